// The output layer (psub/output.h) on its own: atomic replacement, what is written through,
// what is refused, permission bits, links, several files as one, and checked errors.
#include "psub/output.h"
#include "psub/topology.h"

#include "test_support.h"

#include <gtest/gtest.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <unistd.h>

namespace psub {
namespace {

using namespace psub::test;

// The message of the OutputError `action` throws; a test failure when it throws none.
template <class Action>
std::string outputErrorOf(Action&& action) {
    try {
        action();
    } catch (const OutputError& error) {
        return error.what();
    }
    ADD_FAILURE() << "expected an OutputError";
    return "(no error)";
}

mode_t modeOf(const fs::path& path) {
    struct stat info {};
    EXPECT_EQ(::stat(path.c_str(), &info), 0) << path;
    return info.st_mode;
}

TEST(Output, WritesANewFileAndNoTemporary) {
    ScratchDir dir;
    writeOutput((dir / "out.obj").string(), "v 0 0 0\n");
    EXPECT_EQ(readFile(dir / "out.obj"), "v 0 0 0\n");
    EXPECT_EQ(namesIn(dir.path()), std::vector<std::string>{"out.obj"});
}

TEST(Output, NewFileGetsTheUmaskPermissionsNotThePrivateTemporaryOnes) {
    ScratchDir dir;
    const mode_t previous = ::umask(022);
    writeOutput((dir / "out.obj").string(), "x");
    ::umask(previous);
    EXPECT_EQ(modeOf(dir / "out.obj") & 07777, 0644u);
}

TEST(Output, ExistingFileKeepsItsPermissionBits) {
    ScratchDir dir;
    const fs::path file = dir / "out.obj";
    writeFile(file, "old\n");
    ASSERT_EQ(::chmod(file.c_str(), 0640), 0);
    writeOutput(file.string(), "new\n");
    EXPECT_EQ(readFile(file), "new\n");
    EXPECT_EQ(modeOf(file) & 07777, 0640u);
}

TEST(Output, WritesAnEmptyText) {
    ScratchDir dir;
    writeOutput((dir / "empty.obj").string(), "");
    ASSERT_TRUE(fs::exists(dir / "empty.obj"));
    EXPECT_EQ(fs::file_size(dir / "empty.obj"), 0u);
}

TEST(Output, OverwritingReplacesTheWholeFile) {
    ScratchDir dir;
    writeFile(dir / "out.obj", std::string(10000, 'x'));
    writeOutput((dir / "out.obj").string(), "short\n");
    EXPECT_EQ(readFile(dir / "out.obj"), "short\n");
    EXPECT_EQ(namesIn(dir.path()), std::vector<std::string>{"out.obj"});
}

TEST(Output, MissingDirectoryThrowsAndLeavesNothing) {
    ScratchDir dir;
    const fs::path file = dir / "missing" / "out.obj";
    const std::string message = outputErrorOf([&] { writeOutput(file.string(), "v 0 0 0\n"); });
    EXPECT_TRUE(contains(message, file.string())) << message;
    EXPECT_TRUE(namesIn(dir.path()).empty());
}

TEST(Output, ParentThatIsARegularFileThrowsAndLeavesItAlone) {
    ScratchDir dir;
    writeFile(dir / "plain", "not a directory");
    const fs::path file = dir / "plain" / "out.obj";
    const std::string message = outputErrorOf([&] { writeOutput(file.string(), "v 0 0 0\n"); });
    EXPECT_TRUE(contains(message, file.string())) << message;
    EXPECT_EQ(namesIn(dir.path()), std::vector<std::string>{"plain"});
    EXPECT_EQ(readFile(dir / "plain"), "not a directory");
}

TEST(Output, DirectoryIsRefusedAndLeftEmpty) {
    ScratchDir dir;
    fs::create_directory(dir / "taken");
    const std::string message = outputErrorOf([&] { writeOutput((dir / "taken").string(), "v\n"); });
    EXPECT_TRUE(contains(message, (dir / "taken").string() + ": cannot write: it is a directory")) << message;
    EXPECT_EQ(namesIn(dir.path()), std::vector<std::string>{"taken"});
    EXPECT_TRUE(fs::is_empty(dir / "taken"));
}

TEST(Output, NameNearTheLengthLimitStillWorks) {
    // 254 bytes is a legal name (NAME_MAX 255); the temporary beside it must not be longer.
    ScratchDir dir;
    const std::string name = std::string(250, 'n') + ".obj";
    writeOutput((dir / name).string(), "v 0 0 0\n");
    EXPECT_EQ(readFile(dir / name), "v 0 0 0\n");
    EXPECT_EQ(namesIn(dir.path()), std::vector<std::string>{name});
}

TEST(Output, SymlinkIsFollowedAndStaysALink) {
    ScratchDir dir;
    fs::create_directory(dir / "real");
    writeFile(dir / "real" / "target.obj", "old\n");
    ASSERT_EQ(::chmod((dir / "real" / "target.obj").c_str(), 0600), 0);
    fs::create_symlink("real/target.obj", dir / "link.obj");  // relative, from the link's directory
    writeOutput((dir / "link.obj").string(), "new\n");
    EXPECT_TRUE(fs::is_symlink(dir / "link.obj"));
    EXPECT_EQ(fs::read_symlink(dir / "link.obj"), fs::path("real/target.obj"));
    EXPECT_EQ(readFile(dir / "real" / "target.obj"), "new\n");
    EXPECT_EQ(modeOf(dir / "real" / "target.obj") & 07777, 0600u);
    EXPECT_EQ(namesIn(dir / "real"), std::vector<std::string>{"target.obj"});
}

TEST(Output, DanglingSymlinkCreatesItsTarget) {
    ScratchDir dir;
    fs::create_symlink(dir / "new.obj", dir / "link.obj");
    writeOutput((dir / "link.obj").string(), "v\n");
    EXPECT_TRUE(fs::is_symlink(dir / "link.obj"));
    EXPECT_EQ(readFile(dir / "new.obj"), "v\n");
}

TEST(Output, SymlinkLoopIsAnError) {
    ScratchDir dir;
    fs::create_symlink(dir / "b", dir / "a");
    fs::create_symlink(dir / "a", dir / "b");
    const std::string message = outputErrorOf([&] { writeOutput((dir / "a").string(), "v\n"); });
    EXPECT_TRUE(contains(message, (dir / "a").string())) << message;
    EXPECT_EQ(namesIn(dir.path()), (std::vector<std::string>{"a", "b"}));
}

TEST(Output, HardLinkedFileIsRefusedAndBothNamesKeepTheirContent) {
    ScratchDir dir;
    writeFile(dir / "one.obj", "shared\n");
    fs::create_hard_link(dir / "one.obj", dir / "two.obj");
    const std::string message = outputErrorOf([&] { writeOutput((dir / "one.obj").string(), "new\n"); });
    EXPECT_TRUE(contains(message, (dir / "one.obj").string() + ": cannot write: it has 2 hard links")) << message;
    EXPECT_EQ(readFile(dir / "one.obj"), "shared\n");
    EXPECT_EQ(fs::hard_link_count(dir / "two.obj"), 2u);
    EXPECT_EQ(namesIn(dir.path()), (std::vector<std::string>{"one.obj", "two.obj"}));
}

TEST(Output, CharacterDeviceIsWrittenThroughNotReplaced) {
    writeOutput("/dev/null", "v 0 0 0\n");
    EXPECT_TRUE(S_ISCHR(modeOf("/dev/null")));
    checkOutput("/dev/null");
}

TEST(Output, FullDeviceIsAnErrorNamingIt) {
    const std::string message = outputErrorOf([] { writeOutput("/dev/full", "v 0 0 0\n"); });
    EXPECT_TRUE(contains(message, "/dev/full: cannot write: No space left on device")) << message;
    EXPECT_TRUE(S_ISCHR(modeOf("/dev/full")));
}

TEST(Output, NamedPipeIsWrittenThrough) {
    ScratchDir dir;
    const fs::path fifo = dir / "pipe";
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
    // The reader opens first (non-blocking), so the writer's open does not wait.
    const int reader = ::open(fifo.c_str(), O_RDONLY | O_NONBLOCK);
    ASSERT_GE(reader, 0);
    writeOutput(fifo.string(), "through\n");
    char buffer[32] = {};
    EXPECT_EQ(::read(reader, buffer, sizeof buffer), 8);
    ::close(reader);
    EXPECT_EQ(std::string(buffer), "through\n");
    EXPECT_TRUE(S_ISFIFO(modeOf(fifo)));
    EXPECT_EQ(namesIn(dir.path()), std::vector<std::string>{"pipe"});
}

TEST(Output, BlockDeviceIsRefused) {
    std::string device;
    for (const auto& entry : fs::directory_iterator("/dev"))
        if (entry.is_block_file()) {
            device = entry.path().string();
            break;
        }
    if (device.empty()) GTEST_SKIP() << "no block device under /dev on this machine";
    const std::string message = outputErrorOf([&] { writeOutput(device, "x"); });
    EXPECT_TRUE(contains(message, device + ": cannot write: it is a block device")) << message;
    EXPECT_TRUE(contains(outputErrorOf([&] { checkOutput(device); }), "block device"));
}

TEST(Output, SeveralFilesAreWrittenAsOne) {
    ScratchDir dir;
    writeOutputs({{(dir / "a.obj").string(), "a\n"}, {(dir / "b.obj").string(), "b\n"}});
    EXPECT_EQ(readFile(dir / "a.obj"), "a\n");
    EXPECT_EQ(readFile(dir / "b.obj"), "b\n");
    EXPECT_EQ(namesIn(dir.path()), (std::vector<std::string>{"a.obj", "b.obj"}));
}

TEST(Output, WhenALaterFileFailsNoneIsWritten) {
    ScratchDir dir;
    writeFile(dir / "a.obj", "old a\n");
    const fs::path bad = dir / "missing" / "b.obj";
    const std::string message = outputErrorOf(
        [&] { writeOutputs({{(dir / "a.obj").string(), "new a\n"}, {(dir / "c.obj").string(), "c\n"}, {bad.string(), "b\n"}}); });
    EXPECT_TRUE(contains(message, bad.string())) << message;
    EXPECT_EQ(readFile(dir / "a.obj"), "old a\n");
    EXPECT_EQ(namesIn(dir.path()), std::vector<std::string>{"a.obj"});
}

TEST(Output, WhenALaterFileIsRefusedNoneIsWritten) {
    ScratchDir dir;
    fs::create_directory(dir / "b.obj");
    EXPECT_TRUE(contains(
        outputErrorOf([&] { writeOutputs({{(dir / "a.obj").string(), "a\n"}, {(dir / "b.obj").string(), "b\n"}}); }),
        "it is a directory"));
    EXPECT_EQ(namesIn(dir.path()), std::vector<std::string>{"b.obj"});
}

TEST(Output, CheckOutputWritesNothing) {
    ScratchDir dir;
    checkOutput((dir / "later.json").string());
    EXPECT_TRUE(namesIn(dir.path()).empty());
    EXPECT_TRUE(contains(outputErrorOf([&] { checkOutput((dir / "no" / "x.json").string()); }), "/no/x.json"));
    EXPECT_TRUE(contains(outputErrorOf([&] { checkOutput(dir.path().string()); }), "it is a directory"));
}

TEST(Output, MakeOutputDirectoryCreatesParentsAndRefusesAFile) {
    ScratchDir dir;
    makeOutputDirectory((dir / "a" / "b").string());
    EXPECT_TRUE(fs::is_directory(dir / "a" / "b"));
    makeOutputDirectory((dir / "a" / "b").string());  // existing: fine
    writeFile(dir / "file", "keep");
    EXPECT_TRUE(contains(outputErrorOf([&] { makeOutputDirectory((dir / "file").string()); }),
                         (dir / "file").string() + ": cannot create the directory: it exists and is not a directory"));
    EXPECT_TRUE(contains(outputErrorOf([&] { makeOutputDirectory((dir / "file" / "frames").string()); }),
                         (dir / "file" / "frames").string() + ": cannot create the directory"));
    EXPECT_EQ(readFile(dir / "file"), "keep");
}

TEST(Output, EmptyNameIsRefused) {
    EXPECT_TRUE(contains(outputErrorOf([] { writeOutput("", "x"); }), "no file name given"));
}

TEST(Output, WrittenMeshReadsBack) {
    ScratchDir dir;
    Faces faces;
    faces.vertexCount = 4;
    faces.addFace(std::vector<Index>{0, 1, 2});
    faces.addFace(std::vector<Index>{0, 2, 3});
    const std::vector<double> positions = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
    writeOutput((dir / "square.obj").string(), formatObj(faces, positions, "square"));
    const Mesh mesh = readObj((dir / "square.obj").string());
    EXPECT_EQ(mesh.positions, positions);
    EXPECT_EQ(mesh.faces.faceCount(), 2u);
}

}  // namespace
}  // namespace psub
