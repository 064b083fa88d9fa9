// Class 4 of the hostile inputs: broken input that was accepted silently. OBJ `v` lines take
// 3, 4 (w), 6 or 7 (colour) numbers and nothing else, so a continuation that runs a face into a
// `v` line is an error, not a vanished face; glTF byte offsets must be non-negative, a glb
// must be version 2 and the `scene` must exist.
#include "test_support.h"

#include "psub/topology.h"

namespace psub::test {
namespace {

using HostileInput = HostileTest;

std::string messageOf(const std::string& text) {
    try {
        parseObj(text, "t.obj");
    } catch (const InputError& e) {
        return e.what();
    }
    return "(no error)";
}

TEST_F(HostileInput, TrailingJunkOnAVertexLineIsRefusedNamingFileAndLine) {
    write("junk.obj", "v 0 0 0\nv 1 0 0 abc\nv 0 1 0\nf 1 2 3\n");
    refused("subdivide junk.obj -o out.obj --levels 1", 1, {"junk.obj:2: vertex 2", "unexpected 'abc' after the coordinates"});
}

TEST_F(HostileInput, AContinuationThatRunsAFaceIntoAVertexLineIsRefused) {
    // Before: "v 0 0 1 \\" + "f 1 2 3" read as one vertex and the face was gone.
    write("cont.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1 \\\nf 1 2 3\nf 1 3 4\n");
    refused("subdivide cont.obj -o out.obj --levels 1", 1, {"cont.obj:4: vertex 4", "unexpected 'f'"});
}

TEST(HostileInputObj, ContinuedFaceKeepsEveryCornerAndLaterLineNumbers) {
    const Mesh mesh = parseObj("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 \\\n  3 4\nf 1 \\\n 3 \\\n 4\n", "t.obj");
    ASSERT_EQ(mesh.faces.faceCount(), 2u);
    EXPECT_EQ(mesh.faces.faceSize(0), 4u);
    EXPECT_EQ(mesh.faces.faceSize(1), 3u);
    EXPECT_EQ(mesh.source.faceLine, (std::vector<std::uint32_t>{5, 7}));
    EXPECT_TRUE(contains(messageOf("v 0 0 0\nf 1 \\\n 2 \\\n 3\nv 1 x 0\n"), "t.obj:5: vertex 2")) << "line after continuations";
}

TEST(HostileInputObj, FourSixAndSevenNumberVertexLinesStayAccepted) {
    const Mesh mesh = parseObj("v 1 2 3 1.0\nv 4 5 6 0.5 0.25 1\nv 7 8 9 0.1 0.2 0.3 1\nf 1 2 3\n", "t.obj");
    EXPECT_EQ(mesh.positions, (std::vector<double>{1, 2, 3, 4, 5, 6, 7, 8, 9}));
}

TEST(HostileInputObj, OtherNumberCountsAndJunkAfterNumbersAreRefused) {
    EXPECT_TRUE(contains(messageOf("v 1 2 3 4 5\n"), "t.obj:1: vertex 1: 5 numbers")) << messageOf("v 1 2 3 4 5\n");
    EXPECT_TRUE(contains(messageOf("v 1 2 3 4 5 6 7 8\n"), "t.obj:1: vertex 1: unexpected '8' after 7 numbers"));
    EXPECT_TRUE(contains(messageOf("v 1 2\n"), "t.obj:1: vertex 1: expected 3 numbers, got 2"));
    EXPECT_TRUE(contains(messageOf("v 1 2 3 1 # comment\nv 1 2 3 0.5 0.5 0.5 x\n"), "t.obj:2: vertex 2: unexpected 'x'"));
    EXPECT_TRUE(contains(messageOf("v 1 2 3 4w\n"), "t.obj:1: vertex 1: unexpected '4w'"));
}

// --- glTF ---------------------------------------------------------------------------------

class HostileGltf : public HostileTest {
protected:
    void SetUp() override {
        HostileTest::SetUp();
        write("tet.bin", tetBin());
    }
    static std::string buffer() { return "\"uri\": \"tet.bin\", "; }
};

TEST_F(HostileGltf, TheFixturePlays) {
    write("tet.gltf", tetGltf(buffer()));
    EXPECT_EQ(psub("play tet.gltf --levels 1 --frames 2").status, 0);
    write("tet.glb", glb(tetGltf(""), tetBin()));
    EXPECT_EQ(psub("play tet.glb --levels 1 --frames 2").status, 0);
}

TEST_F(HostileGltf, NegativeAccessorByteOffsetIsRefused) {
    write("neg.gltf", tetGltf(buffer(), "-12"));
    refused("play neg.gltf --levels 1 --frames 2", 1, {"neg.gltf: accessor 0: byteOffset -12 is not a non-negative integer"});
}

TEST_F(HostileGltf, NegativeBufferViewByteOffsetIsRefused) {
    write("neg.gltf", tetGltf(buffer(), "0", "-4"));
    refused("play neg.gltf --levels 1 --frames 2", 1, {"neg.gltf: buffer view 0: byteOffset -4"});
}

TEST_F(HostileGltf, NonIntegerByteOffsetIsRefused) {
    write("frac.gltf", tetGltf(buffer(), "0.5"));
    refused("play frac.gltf --levels 1 --frames 2", 1, {"frac.gltf: accessor 0: byteOffset 0.5"});
}

TEST_F(HostileGltf, NegativeSparseByteOffsetIsRefused) {
    std::string gltf = tetGltf(buffer());
    gltf.replace(gltf.find("\"min\""), 0,
                 "\"sparse\": {\"count\": 1, \"indices\": {\"bufferView\": 1, \"byteOffset\": -2, \"componentType\": 5123},"
                 " \"values\": {\"bufferView\": 0}}, ");
    write("sparse.gltf", gltf);
    refused("play sparse.gltf --levels 1 --frames 2", 1, {"sparse.gltf: accessor 0 sparse indices: byteOffset -2"});
}

TEST_F(HostileGltf, GlbHeaderVersionOneIsRefused) {
    write("v1.glb", glb(tetGltf(""), tetBin(), 1));
    refused("play v1.glb --levels 1 --frames 2", 1, {"v1.glb: glb header: version 1, expected 2"});
}

TEST_F(HostileGltf, ASceneIndexThatDoesNotExistIsRefused) {
    write("scene.gltf", tetGltf(buffer(), "0", "0", "3"));
    refused("play scene.gltf --levels 1 --frames 2", 1, {"scene.gltf: scene 3 does not exist (the file has 1 scenes)"});
    write("negative.gltf", tetGltf(buffer(), "0", "0", "-1"));
    refused("play negative.gltf --levels 1 --frames 2", 1, {"negative.gltf: scene -1 does not exist"});
}

}  // namespace
}  // namespace psub::test
