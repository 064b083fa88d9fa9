// psub play, run as a program: every frame's refined positions equal refining that frame's
// deformed control points from scratch (--verify, relative 1e-5) on the CPU and with Vulkan
// (validation layer on, no message allowed), for procedural animations and for a glTF clip
// written here; the JSON report's stable fields; rendered frames; bad input.
#include "gltf_models.h"
#include "test_support.h"

#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

namespace psub {
namespace {

namespace fs = std::filesystem;

using Outcome = test::PsubRun;
using test::contains;
using test::noVulkanAllowed;
using test::readFile;

// Runs psub with the Vulkan validation layer on. Under the sanitizers, drawing leaves Mesa
// lavapipe's process-wide draw state to LeakSanitizer (112 bytes, never freed; see
// tests/test_render.cpp): the leak check is off for runs that draw.
Outcome psub(const std::string& args) {
    test::PsubHow how;
    how.environment = std::string(contains(args, "--render") ? test::kNoLeakCheck : "") + " PSUB_VULKAN_VALIDATION=1";
    return test::runPsub(args, how);
}

// Runs `psub play ARGS --json`, on the CPU or with Vulkan.
Outcome play(const std::string& args, bool vulkan) {
    return psub("play " + args + " --json" + (vulkan ? " --backend vulkan" : ""));
}

// Whether psub finds a Vulkan device (asked once): the message when it does not.
const std::string& vulkanProblem() {
    static const std::string problem = [] {
        const Outcome r = psub("play '" + test::dataPath("cube.obj") + "' --frames 1 --backend vulkan");
        return r.status == 0 ? std::string() : r.err.empty() ? std::string("psub play failed") : r.err;
    }();
    return problem;
}

void expectVerified(const Outcome& r, int frames) {
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_TRUE(contains(r.out, "\"verified_frames\": " + std::to_string(frames))) << r.out;
    EXPECT_FALSE(contains(r.err, "Validation")) << r.err;
    EXPECT_TRUE(contains(r.out, "\"vulkan_validation_messages\": 0") || !contains(r.out, "vulkan_validation_messages"))
        << r.out;
}

// Parameter: Vulkan. Without a device the Vulkan cases fail, unless PSUB_ALLOW_NO_VULKAN=1.
class Play : public ::testing::TestWithParam<bool> {
protected:
    void SetUp() override {
        if (!GetParam() || vulkanProblem().empty()) return;
        if (noVulkanAllowed()) GTEST_SKIP() << "no Vulkan device (allowed by PSUB_ALLOW_NO_VULKAN=1): " << vulkanProblem();
        FAIL() << "no Vulkan device: " << vulkanProblem() << " (set PSUB_ALLOW_NO_VULKAN=1 to skip)";
    }
};

TEST_P(Play, ProceduralFramesEqualRefiningEachFrameFromScratch) {
    for (const char* anim : {"wave", "twist", "bend"}) {
        SCOPED_TRACE(anim);
        expectVerified(play("'" + test::dataPath("spot_control_mesh.obj") + "' --levels 3 --frames 30 --verify --anim " +
                                anim,
                            GetParam()),
                       30);
    }
    // Triangles (the paired method first) and a boundary, with the beyond-the-paper options.
    expectVerified(play("'" + test::testDataPath("suzanne.obj") +
                            "' --levels 2 --frames 30 --verify --anim twist --boundary smooth --rules robust",
                        GetParam()),
                   30);
}

TEST_P(Play, GltfClipFramesEqualRefiningEachFrameFromScratch) {
    const std::string path = testing::TempDir() + "/psub-play-cylinder-" + std::to_string(::getpid()) + ".gltf";
    ASSERT_TRUE(test::writeGltf(test::makeCylinder().builder.model, path));
    const Outcome r = play("'" + path + "' --anim bend --levels 3 --frames 30 --verify", GetParam());
    expectVerified(r, 30);
    EXPECT_TRUE(contains(r.out, "\"animation\": \"glTF clip 'bend'\"")) << r.out;
    // The cage: 40 welded vertices, 64 triangles, 104 edges (40 around, 32 along, 32
    // diagonal); the paired method makes one face per edge, each P-S step doubles: 832.
    EXPECT_TRUE(contains(r.out, "\"refined_faces\": 832,")) << r.out;
    fs::remove(path);
}

TEST_P(Play, GltfWithoutClipsPlaysTheWaveOnItsPose) {
    const std::string path = testing::TempDir() + "/psub-play-still-" + std::to_string(::getpid()) + ".gltf";
    tinygltf::Model model = test::makeCylinder().builder.model;
    model.animations.clear();
    ASSERT_TRUE(test::writeGltf(model, path));
    const Outcome r = play("'" + path + "' --levels 2 --frames 10 --verify", GetParam());
    expectVerified(r, 10);
    EXPECT_TRUE(contains(r.out, "\"animation\": \"wave (procedural)\"")) << r.out;
    const Outcome missing = play("'" + path + "' --anim Walk --frames 1", GetParam());
    EXPECT_EQ(missing.status, 1);
    EXPECT_TRUE(contains(missing.err, "clips: none")) << missing.err;
    fs::remove(path);
}

TEST_P(Play, JsonHasTheStableFields) {
    const Outcome r = play("'" + test::dataPath("cube.obj") + "' --levels 4 --frames 5", GetParam());
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(r.out.front(), '{');
    for (const char* field : {"\"refined_faces\": 96", "\"frames\": 5", "\"fps\": ", "\"stages\": {"})
        EXPECT_TRUE(contains(r.out, field)) << field << " in " << r.out;
    EXPECT_TRUE(contains(r.out, GetParam() ? "\"backend\": \"vulkan\"" : "\"backend\": \"cpu\"")) << r.out;
    EXPECT_TRUE(contains(r.out, "\"host_threads\": ")) << r.out;
    // lavapipe evaluates on the CPU's cores: the CPU-side stages leave them to it.
    if (GetParam() && contains(r.out, "llvmpipe")) {
        EXPECT_TRUE(contains(r.out, "\"host_threads\": 1,")) << r.out;
    }
    for (const char* stage : {"deform", "upload", "evaluate", "normals", "render", "readback"})
        EXPECT_TRUE(contains(r.out, "\"" + std::string(stage) + "\": {\"median_ms\": ")) << stage;
    EXPECT_TRUE(contains(r.out, "\"p95_ms\": ") && contains(r.out, "\"max_ms\": "));
}

INSTANTIATE_TEST_SUITE_P(Backends, Play, ::testing::Values(false, true),
                         [](const ::testing::TestParamInfo<bool>& backend) { return backend.param ? "Vulkan" : "Cpu"; });

TEST(PlayRender, WritesOnePictureAFrameAndTimesTheDraw) {
    const std::string dir = testing::TempDir() + "/psub-play-frames-" + std::to_string(::getpid());
    fs::remove_all(dir);
    const Outcome r = psub("play '" + test::dataPath("cube.obj") + "' --levels 3 --frames 3 --json --size 64x48 --msaa 1 --render '" +
                       dir + "'");
    if (r.status != 0 && !vulkanProblem().empty() && noVulkanAllowed())
        GTEST_SKIP() << "no Vulkan device (allowed by PSUB_ALLOW_NO_VULKAN=1): " << r.err;
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_TRUE(contains(r.out, "\"render\": {\"width\": 64, \"height\": 48}")) << r.out;
    EXPECT_FALSE(contains(r.out, "\"render\": {\"median_ms\": 0, \"p95_ms\": 0, \"max_ms\": 0}")) << r.out;
    for (const char* name : {"frame_0000.png", "frame_0001.png", "frame_0002.png"})
        EXPECT_EQ(readFile(dir + "/" + name).substr(1, 3), "PNG") << name;
    EXPECT_FALSE(fs::exists(dir + "/frame_0003.png"));
    fs::remove_all(dir);
}

TEST(PlayBundled, TheGlbExamplePlaysItsClips) {
    for (const char* clip : {"bend", "step", "cubic"}) {
        const Outcome r = psub("play '" + test::dataPath("two_bone_cylinder.glb") + "' --levels 3 --frames 10 --verify --json --anim " + clip);
        ASSERT_EQ(r.status, 0) << r.err;
        EXPECT_TRUE(contains(r.out, "\"verified_frames\": 10")) << r.out;
    }
}

TEST(PlayErrors, BadInputAndUsage) {
    const std::string cube = "'" + test::dataPath("cube.obj") + "'";
    EXPECT_EQ(psub("play /nonexistent.obj").status, 1);
    const Outcome unknown = psub("play " + cube + " --anim Walk --frames 1");
    EXPECT_EQ(unknown.status, 1);
    EXPECT_TRUE(contains(unknown.err, "Walk")) << unknown.err;
    EXPECT_EQ(psub("play " + cube + " --frames 0").status, 2);
    EXPECT_EQ(psub("play " + cube + " --size 12").status, 2);
    EXPECT_EQ(psub("play " + cube + " --backend gpu").status, 2);
    EXPECT_EQ(psub("play " + cube + " --msaa 3").status, 2);
    EXPECT_EQ(psub("play " + cube + " --levels 40").status, 2);
    const Outcome big = psub("play " + cube + " --levels 30 --frames 1");
    EXPECT_EQ(big.status, 1);
    EXPECT_TRUE(contains(big.err, "refined faces")) << big.err;
    EXPECT_EQ(psub("play --help").status, 0);
}

}  // namespace
}  // namespace psub
