// Class 2 of the hostile inputs: what hung psub. A glTF buffer or image URI naming a FIFO (or
// any file that is not regular: directory, device) is refused by stat before anything opens
// it. Each run has a timeout, so a hang fails the test instead of hanging it.
#include "test_support.h"

#include <sys/stat.h>

namespace psub::test {
namespace {

class HostileHang : public HostileTest {
protected:
    // play on a glTF whose buffer 0 is `uri`; 30 s is far more than a refusal takes.
    Run playWithBuffer(const std::string& uri, int status, std::initializer_list<std::string> needles) {
        write("tet.gltf", tetGltf("\"uri\": \"" + uri + "\", "));
        return refused("play tet.gltf --frames 2 --levels 1", status, needles, 30);
    }
};

TEST_F(HostileHang, TheFixtureWithARegularBufferPlays) {
    write("tet.bin", tetBin());
    write("tet.gltf", tetGltf("\"uri\": \"tet.bin\", "));
    const Run run = psub("play tet.gltf --frames 2 --levels 1", 60);
    EXPECT_EQ(run.status, 0) << run.err;
}

TEST_F(HostileHang, BufferUriNamingAFifoIsRefusedWithoutBlocking) {
    ASSERT_EQ(::mkfifo(path("pipe.bin").c_str(), 0600), 0);
    playWithBuffer("pipe.bin", 1, {"tet.gltf: buffer 0: uri 'pipe.bin'", "named pipe (FIFO), not a regular file"});
}

TEST_F(HostileHang, BufferUriNamingAFifoInPercentEncodingIsRefused) {
    ASSERT_EQ(::mkfifo(path("a pipe.bin").c_str(), 0600), 0);
    playWithBuffer("a%20pipe.bin", 1, {"buffer 0", "named pipe (FIFO)"});
}

TEST_F(HostileHang, ImageUriNamingAFifoIsRefusedWithoutBlocking) {
    write("tet.bin", tetBin());
    ASSERT_EQ(::mkfifo(path("pipe.png").c_str(), 0600), 0);
    write("tet.gltf", tetGltf("\"uri\": \"tet.bin\", ", "0", "0", "0", ", \"images\": [{\"uri\": \"pipe.png\"}]"));
    refused("play tet.gltf --frames 2 --levels 1", 1, {"tet.gltf: image 0: uri 'pipe.png'", "named pipe"}, 30);
}

TEST_F(HostileHang, BufferUriNamingADirectoryIsRefusedNotOutOfMemory) {
    fs::create_directory(work_ / "dir.bin");
    playWithBuffer("dir.bin", 1, {"tet.gltf: buffer 0: uri 'dir.bin'", "is a directory"});
}

TEST_F(HostileHang, BufferUriNamingACharacterDeviceIsRefused) {
    playWithBuffer("/dev/zero", 1, {"tet.gltf: buffer 0: uri '/dev/zero'", "character device"});
}

TEST_F(HostileHang, BufferFileOfTheWrongSizeIsRefusedBeforeReading) {
    write("big.bin", tetBin() + std::string(1 << 20, '\0'));
    playWithBuffer("big.bin", 1, {"tet.gltf: buffer 0: uri 'big.bin'", "1048648 bytes, byteLength says 72"});
}

}  // namespace
}  // namespace psub::test
