// writeOutputs as one step: when renaming the second file into place fails, the first is put
// back (its old contents, or no file where there was none) and nothing is left behind. The
// failure is made here: this executable defines rename(), which the output layer (linked
// statically) calls, refusing with EACCES to replace the one name a test marks unwritable
// (root may write anywhere, so permission bits cannot make it fail).
#include "psub/output.h"

#include "test_support.h"

#include <gtest/gtest.h>

#include <dlfcn.h>

#include <cerrno>
#include <string>

namespace {

std::string unwritableTarget;  // rename() onto this path fails with EACCES

}  // namespace

extern "C" int rename(const char* from, const char* to) {
    if (!unwritableTarget.empty() && unwritableTarget == to) {
        errno = EACCES;
        return -1;
    }
    using Rename = int (*)(const char*, const char*);
    static const Rename real = reinterpret_cast<Rename>(::dlsym(RTLD_NEXT, "rename"));
    return real(from, to);
}

namespace psub {
namespace {

using namespace psub::test;

class OutputRollback : public ::testing::Test {
protected:
    void TearDown() override { unwritableTarget.clear(); }
    std::string at(const std::string& name) const { return (scratch_ / name).string(); }
    ScratchDir scratch_;
};

TEST_F(OutputRollback, TheInterposedRenameFailsOnlyOnTheMarkedName) {
    writeFile(at("a.obj"), "old a\n");
    unwritableTarget = at("b.obj");
    writeOutput(at("a.obj"), "new a\n");
    EXPECT_EQ(readFile(at("a.obj")), "new a\n");
    EXPECT_THROW(writeOutput(at("b.obj"), "new b\n"), OutputError);
    EXPECT_FALSE(fs::exists(at("b.obj")));
}

TEST_F(OutputRollback, SecondRenameFailingPutsTheFirstFileBack) {
    writeFile(at("a.obj"), "old a\n");
    writeFile(at("b.obj"), "old b\n");
    unwritableTarget = at("b.obj");
    try {
        writeOutputs({{at("a.obj"), "new a\n"}, {at("b.obj"), "new b\n"}});
        ADD_FAILURE() << "writeOutputs did not fail";
    } catch (const OutputError& error) {
        EXPECT_EQ(std::string(error.what()).rfind(at("b.obj") + ": cannot write: ", 0), 0u) << error.what();
        EXPECT_TRUE(contains(error.what(), "Permission denied")) << error.what();
    }
    EXPECT_EQ(readFile(at("a.obj")), "old a\n");
    EXPECT_EQ(readFile(at("b.obj")), "old b\n");
    EXPECT_EQ(fs::hard_link_count(at("a.obj")), 1u);  // the kept link is gone again
    EXPECT_EQ(namesIn(scratch_.path()), (std::vector<std::string>{"a.obj", "b.obj"}));
}

TEST_F(OutputRollback, SecondRenameFailingRemovesANewFirstFile) {
    writeFile(at("b.obj"), "old b\n");
    unwritableTarget = at("b.obj");
    EXPECT_THROW(writeOutputs({{at("a.obj"), "new a\n"}, {at("b.obj"), "new b\n"}}), OutputError);
    EXPECT_EQ(namesIn(scratch_.path()), (std::vector<std::string>{"b.obj"}));
    EXPECT_EQ(readFile(at("b.obj")), "old b\n");
}

TEST_F(OutputRollback, ThirdRenameFailingPutsBothEarlierFilesBack) {
    writeFile(at("a.obj"), "old a\n");
    writeFile(at("c.obj"), "old c\n");
    unwritableTarget = at("c.obj");
    EXPECT_THROW(writeOutputs({{at("a.obj"), "new a\n"}, {at("b.obj"), "new b\n"}, {at("c.obj"), "new c\n"}}),
                 OutputError);
    EXPECT_EQ(namesIn(scratch_.path()), (std::vector<std::string>{"a.obj", "c.obj"}));
    EXPECT_EQ(readFile(at("a.obj")), "old a\n");
    EXPECT_EQ(readFile(at("c.obj")), "old c\n");
}

TEST_F(OutputRollback, SuccessReplacesEveryFileAndLeavesNoKeptCopy) {
    writeFile(at("a.obj"), "old a\n");
    writeFile(at("b.obj"), "old b\n");
    writeOutputs({{at("a.obj"), "new a\n"}, {at("b.obj"), "new b\n"}});
    EXPECT_EQ(readFile(at("a.obj")), "new a\n");
    EXPECT_EQ(readFile(at("b.obj")), "new b\n");
    EXPECT_EQ(fs::hard_link_count(at("a.obj")), 1u);
    EXPECT_EQ(namesIn(scratch_.path()), (std::vector<std::string>{"a.obj", "b.obj"}));
}

}  // namespace
}  // namespace psub
