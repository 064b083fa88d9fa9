// Hostile-input leftovers (issue 14): the main input of every command must be a regular file.
// A FIFO (which would block the open, or be read as a stream), a directory or a device is
// refused at once with one line naming the file and what it is (exit 1), nothing written. And
// `psub render` at a size the device cannot allocate: one line saying so, exit 1, no PNG.
#include "test_support.h"

#include <sys/stat.h>

namespace psub::test {
namespace {

class HostileLeftovers : public HostileTest {
protected:
    // Every command that reads a mesh, on `input`: refused within 30 s (a blocked open would
    // time out with status 124), exit 1, the message naming the input and `kind`.
    void expectEveryCommandRefuses(const std::string& input, const std::string& kind) {
        const std::string named = input + ": is " + kind + ", not a regular file";
        for (const std::string& command :
             {"subdivide " + input + " -o out.obj --levels 1", "subdivide " + input + " -o out.obj --scheme cc",
              "stats " + input + " --levels 1", "compare " + input + " --levels 2",
              "analyze --boundary-aspect " + input, "play " + input + " --frames 1 --levels 1",
              "render " + input + " -o out.png --levels 1"}) {
            SCOPED_TRACE(command);
            refused(command, 1, {named}, 30);
        }
    }
};

TEST_F(HostileLeftovers, AFifoAsTheMainInputIsRefusedWithoutBlocking) {
    ASSERT_EQ(::mkfifo(path("pipe.obj").c_str(), 0600), 0);
    expectEveryCommandRefuses("pipe.obj", "a named pipe (FIFO)");
}

TEST_F(HostileLeftovers, AFifoNamedLikeGltfIsRefusedByPlay) {
    ASSERT_EQ(::mkfifo(path("pipe.gltf").c_str(), 0600), 0);
    ASSERT_EQ(::mkfifo(path("pipe.glb").c_str(), 0600), 0);
    refused("play pipe.gltf --frames 1 --levels 1", 1, {"pipe.gltf: is a named pipe (FIFO), not a regular file"}, 30);
    refused("play pipe.glb --frames 1 --levels 1", 1, {"pipe.glb: is a named pipe (FIFO), not a regular file"}, 30);
}

TEST_F(HostileLeftovers, AFifoWithAWriterIsStillRefusedNotReadAsAStream) {
    ASSERT_EQ(::mkfifo(path("fed.obj").c_str(), 0600), 0);
    // A writer (given up after 30 s) offers a valid cube through the FIFO.
    writeFile(root_ / "cube.obj", cubeObj("1"));
    PsubHow how;
    how.shellFirst = "(timeout 30 cat " + quoted(root_ / "cube.obj") + " >fed.obj 2>/dev/null &)";
    how.environment = kNoLeakCheck;
    how.directory = work_;
    how.timeoutSeconds = 30;
    const PsubRun run = runPsub("subdivide fed.obj -o out.obj --levels 1", how);
    EXPECT_EQ(run.status, 1) << run.err;
    EXPECT_EQ(oneLine(run), "psub: error: fed.obj: is a named pipe (FIFO), not a regular file (psub reads input only from files)");
    EXPECT_FALSE(fs::exists(work_ / "out.obj"));
}

TEST_F(HostileLeftovers, DemoOnAFifoModelStopsBeforeWritingAnything) {
    ASSERT_EQ(::mkfifo(path("pipe.obj").c_str(), 0600), 0);
    fs::create_directory(work_ / "demo");
    const PsubRun run = psub("demo --model pipe.obj --levels 1 --output-dir demo", 30);
    EXPECT_EQ(run.status, 1) << run.err;
    EXPECT_EQ(oneLine(run), "psub: error: pipe.obj: is a named pipe (FIFO), not a regular file (psub reads input only from files)");
    EXPECT_TRUE(namesIn(work_ / "demo").empty());
}

TEST_F(HostileLeftovers, ADirectoryAsTheMainInputIsRefused) {
    fs::create_directory(work_ / "dir.obj");
    expectEveryCommandRefuses("dir.obj", "a directory");
}

TEST_F(HostileLeftovers, ACharacterDeviceAsTheMainInputIsRefusedNotReadForever) {
    expectEveryCommandRefuses("/dev/zero", "a character device");
}

TEST_F(HostileLeftovers, ARenderTooBigForTheDeviceIsNamedAndWritesNothing) {
    if (kSanitized) GTEST_SKIP() << "AddressSanitizer reserves more address space than the limit this test sets";
    // 16384 x 16384 (the largest --size) with 4 samples: a 4 GiB color image, beyond a 4 GB
    // address-space limit, so the device (lavapipe allocates from the process) cannot allocate it.
    write("cube.obj", cubeObj("1"));
    PsubHow how;
    how.shellFirst = "ulimit -v 4000000";
    how.directory = work_;
    how.timeoutSeconds = 120;
    const auto before = snapshot();
    const PsubRun run = runPsub("render cube.obj -o big.png --levels 1 --size 16384x16384 --msaa 4", how);
    if (run.status == 1 && contains(run.err, "no Vulkan") && noVulkanAllowed())
        GTEST_SKIP() << "no Vulkan device (allowed by PSUB_ALLOW_NO_VULKAN=1): " << run.err;
    EXPECT_EQ(run.status, 1) << run.err;
    EXPECT_EQ(linesOf(run.err).size(), 1u) << run.err;
    EXPECT_EQ(run.err.rfind("psub: error: render: a 16384x16384 image with 4 sample(s) per pixel needs ", 0), 0u)
        << run.err;
    EXPECT_TRUE(contains(run.err, "use a smaller --size or --msaa 1")) << run.err;
    EXPECT_EQ(run.out, "");
    EXPECT_EQ(snapshot(), before) << "a file was written";
}

}  // namespace
}  // namespace psub::test
