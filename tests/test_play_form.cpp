// psub play --form, run as a program: each forced CPU table form plays frames equal to the rule
// oracle (--verify; the tiled form's drawing order is mapped back to canonical order), auto
// names its choice and why, and a mesh without regular tiles stays on the per-level rows.
#include "test_support.h"

#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <numbers>
#include <string>

namespace {

namespace fs = std::filesystem;

struct Outcome {
    int status = -1;
    std::string out, err;
};

std::string readFile(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

Outcome psub(const std::string& args) {
    const std::string base = testing::TempDir() + "/psub-play-form-" + std::to_string(::getpid());
    const std::string command =
        "'" PSUB_EXE "' " + args + " >'" + base + ".out' 2>'" + base + ".err' </dev/null";
    const int raw = std::system(command.c_str());
    Outcome run;
    if (raw != -1 && WIFEXITED(raw)) run.status = WEXITSTATUS(raw);
    run.out = readFile(base + ".out");
    run.err = readFile(base + ".err");
    fs::remove(base + ".out");
    fs::remove(base + ".err");
    return run;
}

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

// An n x n quad torus as an OBJ file (every vertex regular: the tiled form tiles it).
std::string writeTorus(int n) {
    const std::string path = testing::TempDir() + "/psub-play-form-torus-" + std::to_string(::getpid()) + ".obj";
    std::ofstream out(path);
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const double u = 2 * std::numbers::pi * i / n, v = 2 * std::numbers::pi * j / n;
            out << "v " << (3 + std::cos(v)) * std::cos(u) << ' ' << (3 + std::cos(v)) * std::sin(u) << ' '
                << std::sin(v) << '\n';
        }
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const int i1 = (i + 1) % n, j1 = (j + 1) % n;
            out << "f " << j * n + i + 1 << ' ' << j * n + i1 + 1 << ' ' << j1 * n + i1 + 1 << ' ' << j1 * n + i + 1
                << '\n';
        }
    return path;
}

TEST(PlayForm, EachForcedFormPlaysTheOracleFrames) {
    const std::string torus = writeTorus(24);
    for (const std::string form : {"tiled", "per-level", "factorized"}) {
        const Outcome run = psub("play '" + torus + "' --levels 3 --frames 3 --anim twist --verify --form " + form);
        EXPECT_EQ(run.status, 0) << form << ": " << run.err;
        EXPECT_TRUE(contains(run.out, "Table form: " + form + " (forced)")) << run.out;
        EXPECT_TRUE(contains(run.out, "Verified: all 3 frames")) << run.out;
    }
    fs::remove(torus);
}

TEST(PlayForm, AutoTimesBothFormsOnATiledMesh) {
    const std::string torus = writeTorus(24);
    const Outcome run = psub("play '" + torus + "' --levels 4 --frames 2 --verify");
    EXPECT_EQ(run.status, 0) << run.err;
    EXPECT_TRUE(contains(run.out, "(auto: 100% of the points tiled; rest pose ")) << run.out;
    EXPECT_TRUE(contains(run.out, "Table form: tiled (auto") || contains(run.out, "Table form: per-level (auto"))
        << run.out;
    // Either choice plays the oracle's frames (the tiled one after the per-level table is dropped).
    EXPECT_TRUE(contains(run.out, "Verified: all 2 frames")) << run.out;
    const Outcome json = psub("play '" + torus + "' --levels 2 --frames 2 --json --form tiled");
    EXPECT_EQ(json.status, 0) << json.err;
    EXPECT_TRUE(contains(json.out, "\"form\":\"tiled\"") || contains(json.out, "\"form\": \"tiled\"")) << json.out;
    fs::remove(torus);
}

// On two CPU threads, where the tiles write under 90% of the points (Spot), auto also times the
// tiled form without tiles (a second lean build); it won on every run measured (Spot at 5 to
// 11 steps, docs/tiled.md "Tiles or none"), and whichever wins plays the oracle's frames. One
// CPU thread does not time it.
TEST(PlayForm, AutoTimesTheTiledFormWithoutTilesOnTwoThreads) {
    const std::string spot = "play '" + psub::test::dataPath("spot_control_mesh.obj") + "' --levels 6 --frames 2 --anim twist --verify";
    ::setenv("OMP_NUM_THREADS", "2", 1);
    const Outcome two = psub(spot);
    ::setenv("OMP_NUM_THREADS", "1", 1);
    const Outcome one = psub(spot);
    ::unsetenv("OMP_NUM_THREADS");
    EXPECT_EQ(two.status, 0) << two.err;
    EXPECT_TRUE(contains(two.out, " ms tiled without tiles, ")) << two.out;
    EXPECT_TRUE(contains(two.out, "Verified: all 2 frames")) << two.out;
    EXPECT_EQ(one.status, 0) << one.err;
    EXPECT_FALSE(contains(one.out, "without tiles")) << one.out;
    EXPECT_TRUE(contains(one.out, "Verified: all 2 frames")) << one.out;
}

// On Vulkan auto times the tiled form without tiles too (where the tiles write under 90% of the
// points), whatever the CPU's threads; whichever wins plays the oracle's frames. No device fails
// the test (a skip only with PSUB_ALLOW_NO_VULKAN=1).
TEST(PlayForm, VulkanAutoTimesTheTiledFormWithoutTiles) {
    ::setenv("OMP_NUM_THREADS", "1", 1);
    const Outcome run = psub("play '" + psub::test::dataPath("spot_control_mesh.obj") +
                             "' --levels 5 --frames 2 --anim twist --verify --backend vulkan");
    ::unsetenv("OMP_NUM_THREADS");
    if (run.status != 0 && contains(run.err, "Vulkan") && psub::test::noVulkanAllowed())
        GTEST_SKIP() << "no Vulkan device (allowed by PSUB_ALLOW_NO_VULKAN=1): " << run.err;
    EXPECT_EQ(run.status, 0) << run.err;
    EXPECT_TRUE(contains(run.out, " ms tiled without tiles")) << run.out;
    EXPECT_TRUE(contains(run.out, "Verified: all 2 frames")) << run.out;
}

// On Vulkan too: the tiled form (a tile kernel) plays the oracle's frames, and auto times both
// forms on the device. No device fails the test (a skip only with PSUB_ALLOW_NO_VULKAN=1).
TEST(PlayForm, VulkanPlaysEachForcedFormAndAutoTimesBoth) {
    const std::string torus = writeTorus(24);
    for (const std::string form : {"tiled", "per-level", "factorized", "auto"}) {
        const Outcome run =
            psub("play '" + torus + "' --levels 4 --frames 3 --anim twist --verify --backend vulkan --form " + form);
        if (run.status != 0 && contains(run.err, "Vulkan") && psub::test::noVulkanAllowed())
            GTEST_SKIP() << "no Vulkan device (allowed by PSUB_ALLOW_NO_VULKAN=1): " << run.err;
        EXPECT_EQ(run.status, 0) << form << ": " << run.err;
        EXPECT_TRUE(contains(run.out, form == "auto" ? "(auto: 100% of the points tiled; rest pose "
                                                     : "Table form: " + form + " (forced)"))
            << run.out;
        EXPECT_TRUE(contains(run.out, "Verified: all 3 frames")) << run.out;
    }
    fs::remove(torus);
}

// On Vulkan auto times the tiled form without tiles too (its fallback in walk order), whatever
// the CPU's threads; whichever wins plays the oracle's frames.
TEST(PlayForm, VulkanAutoTimesTheWalkOrderWithoutTiles) {
    const Outcome run = psub("play '" + psub::test::dataPath("cow.obj") +
                             "' --levels 3 --frames 2 --anim twist --verify --backend vulkan");
    if (run.status != 0 && contains(run.err, "Vulkan") && psub::test::noVulkanAllowed())
        GTEST_SKIP() << "no Vulkan device (allowed by PSUB_ALLOW_NO_VULKAN=1): " << run.err;
    EXPECT_EQ(run.status, 0) << run.err;
    EXPECT_TRUE(contains(run.out, "Table form: per-level (auto: no regular tiles; rest pose with normals ") ||
                contains(run.out, "Table form: tiled (auto: no regular tiles; rest pose with normals "))
        << run.out;
    EXPECT_TRUE(contains(run.out, " ms tiled)")) << run.out;
    EXPECT_TRUE(contains(run.out, "Verified: all 2 frames")) << run.out;
}

// Without a tile, on a mesh small enough for one thread, auto times both forms on the CPU too
// (the tiled one's normals run in one pass over its walk order); whichever wins plays the
// oracle's frames.
TEST(PlayForm, AutoTimesBothFormsWithoutTilesOnOneThread) {
    const Outcome run = psub("play '" + psub::test::dataPath("cube.obj") + "' --levels 3 --frames 2 --verify");
    EXPECT_EQ(run.status, 0) << run.err;
    EXPECT_TRUE(contains(run.out, "Table form: per-level (auto: no regular tiles; rest pose with normals ") ||
                contains(run.out, "Table form: tiled (auto: no regular tiles; rest pose with normals "))
        << run.out;
    EXPECT_TRUE(contains(run.out, " ms per-level, ") && contains(run.out, " ms tiled)")) << run.out;
    EXPECT_TRUE(contains(run.out, "Verified: all 2 frames")) << run.out;
}

// From 2^18 refined faces on the CPU, auto builds and times the tiled form alone (its lean
// build), on one thread and on two: the cow at 5 steps (278,592 faces, no tile) plays it and the
// oracle's frames, and the summary says the per-level rows went untimed.
TEST(PlayForm, AutoTimesTheTiledFormAloneFromTwoToTheEighteenFaces) {
    for (const char* threads : {"1", "2"}) {
        ::setenv("OMP_NUM_THREADS", threads, 1);
        const Outcome run = psub("play '" + psub::test::dataPath("cow.obj") + "' --levels 5 --frames 2 --anim twist --verify");
        ::unsetenv("OMP_NUM_THREADS");
        EXPECT_EQ(run.status, 0) << run.err;
        EXPECT_TRUE(contains(run.out, "Table form: tiled (auto: no regular tiles; rest pose with normals ")) << run.out;
        EXPECT_TRUE(contains(run.out, " ms tiled; per-level untimed from 262144 faces)")) << run.out;
        EXPECT_FALSE(contains(run.out, "ms per-level")) << run.out;
        EXPECT_TRUE(contains(run.out, "Verified: all 2 frames")) << run.out;
    }
    // Below it (the cow at 4 steps, 69,648 faces), both are timed.
    const Outcome below = psub("play '" + psub::test::dataPath("cow.obj") + "' --levels 4 --frames 1");
    EXPECT_EQ(below.status, 0) << below.err;
    EXPECT_TRUE(contains(below.out, " ms per-level, ") && contains(below.out, " ms tiled")) << below.out;
}

// On several CPU threads auto also times the per-level rows ordered by region (one region per
// thread) and, though the cow has no tile, the tiled form (its fallback in walk order,
// docs/tiled.md); whichever wins plays the oracle's frames, and the JSON names the table's
// regions.
TEST(PlayForm, AutoAlsoTimesTheRegionOrderOnSeveralThreads) {
    ::setenv("OMP_NUM_THREADS", "2", 1);  // two threads whatever this machine has
    const std::string cow = psub::test::dataPath("cow.obj");
    const Outcome run = psub("play '" + cow + "' --levels 3 --frames 2 --anim twist --verify");
    const Outcome json = psub("play '" + cow + "' --levels 3 --frames 2 --json");
    ::unsetenv("OMP_NUM_THREADS");
    EXPECT_EQ(run.status, 0) << run.err;
    // "per-level (auto: ...", "tiled (auto: ..." (its fallback in walk order) or, when the region
    // order won, "per-level by 2 regions (auto: ...".
    EXPECT_TRUE(contains(run.out, "Table form: per-level (auto: no regular tiles; rest pose with normals ") ||
                contains(run.out, "Table form: tiled (auto: no regular tiles; rest pose with normals ") ||
                contains(run.out, "Table form: per-level by 2 regions (auto: no regular tiles; rest pose with normals "))
        << run.out;
    EXPECT_TRUE(contains(run.out, " ms tiled, ") && contains(run.out, " ms per-level by 2 regions)")) << run.out;
    EXPECT_TRUE(contains(run.out, "Verified: all 2 frames")) << run.out;
    EXPECT_EQ(json.status, 0) << json.err;
    EXPECT_TRUE(contains(json.out, "\"regions\": 1") || contains(json.out, "\"regions\": 2")) << json.out;
    EXPECT_TRUE(contains(json.out, "\"form\": \"per-level\"") || contains(json.out, "\"form\": \"tiled\"")) << json.out;
}

TEST(PlayForm, AnUnknownFormIsAUsageError) {
    const Outcome run = psub("play '" + psub::test::dataPath("cube.obj") + "' --form fastest");
    EXPECT_EQ(run.status, 2);
    EXPECT_TRUE(contains(run.err, "--form")) << run.err;
}

}  // namespace
