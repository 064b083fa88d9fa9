// Early glTF 2.0 files (COLLADA2GLTF, e.g. Cesium's RiggedFigure) name a skin's joints the
// glTF 1.0 way, "jointNames" matched to the nodes' "jointName", without the required "joints":
// readGltf takes the joints from those names (with a warning) in .gltf and .glb files, and an
// unmatched name, or a skin with neither, is an InputError naming the file, the skin and the name.
#include "test_support.h"

#include "psub/animation.h"

#include <gtest/gtest.h>

#include <cstring>

namespace {

using namespace psub;

// A tetrahedron skinned to joint 0 of its skin with weight 1; the skin's jointNames are
// `jointNames` (JSON); node 1 ("a") moves by (10, 0, 0), node 2 ("b") by (0, 20, 0).
std::string skinnedBin() {
    const float positions[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
    const std::uint16_t indices[12] = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
    const std::uint8_t joints[16] = {};
    const float weights[16] = {1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0};
    std::string bytes(152, '\0');
    std::memcpy(bytes.data(), positions, 48);
    std::memcpy(bytes.data() + 48, indices, 24);
    std::memcpy(bytes.data() + 72, joints, 16);
    std::memcpy(bytes.data() + 88, weights, 64);
    return bytes;
}

std::string skinnedJson(const std::string& skin, const std::string& buffer = "") {
    return "{\"asset\": {\"version\": \"2.0\"}, \"scene\": 0, \"scenes\": [{\"nodes\": [0, 1, 2]}],\n"
           "\"nodes\": [{\"mesh\": 0, \"skin\": 0}, {\"jointName\": \"a\", \"translation\": [10, 0, 0]},"
           " {\"jointName\": \"b\", \"translation\": [0, 20, 0]}],\n"
           "\"skins\": [" + skin + "],\n"
           "\"meshes\": [{\"primitives\": [{\"attributes\": {\"POSITION\": 0, \"JOINTS_0\": 2, \"WEIGHTS_0\": 3},"
           " \"indices\": 1}]}],\n"
           "\"accessors\": [{\"bufferView\": 0, \"componentType\": 5126, \"count\": 4, \"type\": \"VEC3\","
           " \"min\": [0, 0, 0], \"max\": [1, 1, 1]},\n"
           " {\"bufferView\": 1, \"componentType\": 5123, \"count\": 12, \"type\": \"SCALAR\"},\n"
           " {\"bufferView\": 2, \"componentType\": 5121, \"count\": 4, \"type\": \"VEC4\"},\n"
           " {\"bufferView\": 3, \"componentType\": 5126, \"count\": 4, \"type\": \"VEC4\"}],\n"
           "\"bufferViews\": [{\"buffer\": 0, \"byteOffset\": 0, \"byteLength\": 48},"
           " {\"buffer\": 0, \"byteOffset\": 48, \"byteLength\": 24},"
           " {\"buffer\": 0, \"byteOffset\": 72, \"byteLength\": 16},"
           " {\"buffer\": 0, \"byteOffset\": 88, \"byteLength\": 64}],\n"
           "\"buffers\": [{" + buffer + "\"byteLength\": 152}]}\n";
}

class LegacyJoints : public ::testing::Test {
protected:
    std::string write(const std::string& name, const std::string& bytes) {
        test::writeFile(scratch_ / name, bytes);
        return (scratch_ / name).string();
    }
    // The static pose's first vertex.
    static std::array<float, 3> firstVertex(const GltfAsset& asset) {
        GltfPlayer player(asset);
        std::vector<float> posed(3 * player.vertexCount());
        player.staticPose(posed);
        return {posed[0], posed[1], posed[2]};
    }
    test::ScratchDir scratch_;
};

// jointNames ["b", "a"]: joint 0 is node 2, so the vertex at the origin moves to (0, 20, 0).
TEST_F(LegacyJoints, JointsComeFromJointNamesInGlbAndGltf) {
    const std::string skin = "{\"jointNames\": [\"b\", \"a\"], \"bindShapeMatrix\": "
                             "[1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]}";
    write("skinned.bin", skinnedBin());
    const std::string files[] = {write("legacy.glb", test::glb(skinnedJson(skin), skinnedBin())),
                                 write("legacy.gltf", skinnedJson(skin, "\"uri\": \"skinned.bin\", "))};
    for (const std::string& file : files) {
        const GltfAsset asset = readGltf(file);
        ASSERT_TRUE(asset.skin) << file;
        EXPECT_EQ(asset.skin->jointNodes, (std::vector<std::uint32_t>{2, 1})) << file;
        EXPECT_EQ(firstVertex(asset), (std::array<float, 3>{0, 20, 0})) << file;
        ASSERT_EQ(asset.warnings.size(), 1u) << file;
        EXPECT_EQ(asset.warnings[0], file + ": skin 0: no \"joints\"; took them from the legacy \"jointNames\" (glTF 1.0 style)");
    }
}

// The same file with "joints" loads as before, without a warning (and "joints" wins).
TEST_F(LegacyJoints, JointsWhenPresentAreUsedAsIs) {
    const std::string file = write("modern.glb", test::glb(skinnedJson("{\"joints\": [1, 2], \"jointNames\": [\"b\", \"a\"]}"), skinnedBin()));
    const GltfAsset asset = readGltf(file);
    EXPECT_EQ(firstVertex(asset), (std::array<float, 3>{10, 0, 0}));
    EXPECT_TRUE(asset.warnings.empty());
}

TEST_F(LegacyJoints, NonIdentityBindShapeMatrixIsNamedInTheWarning) {
    const std::string file = write("bind.glb", test::glb(skinnedJson("{\"jointNames\": [\"a\"], \"bindShapeMatrix\": "
                                                                    "[2, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]}"),
                                                        skinnedBin()));
    const GltfAsset asset = readGltf(file);
    ASSERT_EQ(asset.warnings.size(), 1u);
    EXPECT_TRUE(test::contains(asset.warnings[0], "\"bindShapeMatrix\" is not the identity and is ignored")) << asset.warnings[0];
}

// psub stats: exit 1, one line naming the file, the skin and what is wrong; nothing on stdout.
TEST_F(LegacyJoints, UnmatchedOrMissingJointsAreNamed) {
    const struct {
        std::string skin, message;
    } cases[] = {
        {"{\"jointNames\": [\"a\", \"nowhere\"]}",
         "skin 0: has no \"joints\" (required by glTF 2.0), and its legacy \"jointNames\" entry \"nowhere\" matches no "
         "node's \"jointName\""},
        {"{\"name\": \"bare\"}", "skin 0: has no \"joints\" (required by glTF 2.0)"},
    };
    for (const auto& c : cases) {
        const std::string file = write("bad.glb", test::glb(skinnedJson(c.skin), skinnedBin()));
        const test::PsubRun run = test::runPsub("stats " + test::quoted(file) + " --levels 1");
        EXPECT_EQ(run.status, 1) << run.err;
        EXPECT_EQ(test::oneLine(run), "psub: error: " + file + ": " + c.message);
        EXPECT_TRUE(run.out.empty()) << run.out;
    }
}

// psub stats and psub play (--verify) run on the legacy file end to end.
TEST_F(LegacyJoints, StatsAndPlayAcceptTheFile) {
    const std::string file = write("legacy.glb", test::glb(skinnedJson("{\"jointNames\": [\"a\", \"b\"]}"), skinnedBin()));
    const test::PsubRun stats = test::runPsub("stats " + test::quoted(file) + " --levels 2");
    EXPECT_EQ(stats.status, 0) << stats.err;
    EXPECT_TRUE(test::contains(stats.err, "legacy \"jointNames\"")) << stats.err;
    const test::PsubRun play = test::runPsub("play " + test::quoted(file) + " --levels 2 --frames 3 --verify");
    EXPECT_EQ(play.status, 0) << play.err;
    EXPECT_TRUE(test::contains(play.out, "Verified: all 3 frames")) << play.out;
}

}  // namespace
