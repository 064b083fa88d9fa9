// psub view, run as a program under Xvfb (xvfb-run -a) with lavapipe and the validation layer
// on (any message fails): the start frame's screenshot equals psub render's picture; `+` doubles
// the logged face count; `s` draws both schemes; a resize during playback; 300 frames of a glTF
// clip without resident-memory growth; bad model, no display, bad script. Without Xvfb or a
// device these fail, unless PSUB_ALLOW_NO_VULKAN=1.
#include "psub/image.h"
#include "test_support.h"

#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

namespace psub {
namespace {

namespace fs = std::filesystem;

using Outcome = test::PsubRun;
using test::contains;
using test::readFile;

std::string temp(const std::string& name) {
    return testing::TempDir() + "/psub-view-" + std::to_string(::getpid()) + "-" + name;
}

// Runs `prefix psub args` with the validation layer on; stdout and stderr captured.
Outcome run(const std::string& prefix, const std::string& args) {
    test::PsubHow how;
    how.environment = std::string(test::kNoLeakCheck) + " PSUB_VULKAN_VALIDATION=1";
    how.prefix = prefix;
    return test::runPsub(args, how);
}

// psub view under a fresh Xvfb server.
Outcome view(const std::string& args) { return run("xvfb-run -a -s '-screen 0 1600x1200x24'", "view " + args); }

std::string q(const std::string& path) { return test::quoted(path); }

// Why psub view cannot run here (asked once): empty when it can.
const std::string& windowProblem() {
    static const std::string problem = [] {
        if (std::system("command -v xvfb-run >/dev/null 2>&1") != 0) return std::string("xvfb-run is not installed");
        const Outcome r = view(q(test::dataPath("cube.obj")) + " --levels 1 --frames 1");
        return r.status == 0 ? std::string() : "psub view failed: " + r.err;
    }();
    return problem;
}

class View : public ::testing::Test {
protected:
    void SetUp() override {
        if (windowProblem().empty()) return;
        if (test::noVulkanAllowed()) GTEST_SKIP() << "no window (allowed by PSUB_ALLOW_NO_VULKAN=1): " << windowProblem();
        FAIL() << "no window: " << windowProblem() << " (set PSUB_ALLOW_NO_VULKAN=1 to skip)";
    }
};

void expectClean(const Outcome& r) {
    EXPECT_EQ(r.status, 0) << r.err;
    EXPECT_FALSE(contains(r.err, "alidation")) << r.err;
}

std::string script(const std::string& name, const std::string& text) {
    const std::string path = temp(name);
    std::ofstream(path) << text;
    return path;
}

// The number after "key": in one JSON line (the log's fields are flat or in "stages").
double field(const std::string& line, const std::string& key) {
    const std::size_t at = line.find("\"" + key + "\": ");
    if (at == std::string::npos) {
        ADD_FAILURE() << "no " << key << " in " << line;
        return -1;
    }
    return std::strtod(line.c_str() + at + key.size() + 4, nullptr);
}

std::vector<std::string> logLines(const std::string& path) {
    std::ifstream in(path);
    std::vector<std::string> lines;
    for (std::string line; std::getline(in, line);) lines.push_back(line);
    return lines;
}

// Pixels that differ from the white background in columns [x0, x1).
std::size_t drawnPixels(const Image& image, std::uint32_t x0, std::uint32_t x1) {
    std::size_t count = 0;
    for (std::uint32_t y = 0; y < image.height; ++y)
        for (std::uint32_t x = x0; x < x1; ++x)
            if (!(image.pixel(x, y) == Rgba{255, 255, 255, 255})) ++count;
    return count;
}

// A 320 x 240 picture with the model drawn, and `b` the same but for a few pixels along edges.
void expectSamePicture(const Image& a, const Image& b) {
    ASSERT_EQ(a.width, 320u);
    ASSERT_EQ(a.height, 240u);
    ASSERT_EQ(b.width, a.width);
    ASSERT_EQ(b.height, a.height);
    EXPECT_GT(drawnPixels(a, 0, a.width), a.width * a.height / 20) << "the model is drawn";
    double sum[3] = {0, 0, 0};
    std::size_t off = 0;
    for (std::size_t i = 0; i < a.rgba.size(); i += 4) {
        bool far = false;
        for (int c = 0; c < 3; ++c) {
            const int d = std::abs(int(a.rgba[i + std::size_t(c)]) - int(b.rgba[i + std::size_t(c)]));
            sum[c] += d;
            far = far || d > 16;
        }
        off += far;
    }
    const double pixels = double(a.width) * a.height;
    for (int c = 0; c < 3; ++c) EXPECT_LE(sum[c] / pixels, 2.0) << "channel " << c;
    EXPECT_LE(double(off), 0.01 * pixels);
}

TEST_F(View, StartFrameWithoutHudMatchesPsubRender) {
    const std::string model = test::dataPath("spot_control_mesh.obj"), shot = temp("start.png"), still = temp("render.png");
    // twist is the identity at time 0: the first frame is the rest pose psub render draws.
    const Outcome r = view("'" + model + "' --levels 3 --anim twist --size 320x240 --no-hud --frames 1 --screenshot '" + shot + "'");
    expectClean(r);
    const Outcome rendered = run("", "render '" + model + "' --levels 3 --size 320x240 -o '" + still + "'");
    ASSERT_EQ(rendered.status, 0) << rendered.err;
    const Image a = readPng(shot);
    expectSamePicture(a, readPng(still));
    // With the HUD: text in the top-left corner, where the picture alone is background.
    const Outcome withHud = view(q(model) + " --levels 3 --anim twist --size 320x240 --frames 1 --screenshot " + q(shot));
    expectClean(withHud);
    const Image hud = readPng(shot);
    std::size_t dark = 0, darkBefore = 0;
    for (std::uint32_t y = 0; y < 20; ++y)
        for (std::uint32_t x = 0; x < 150; ++x) {
            dark += hud.pixel(x, y).r < 100;
            darkBefore += a.pixel(x, y).r < 100;
        }
    EXPECT_EQ(darkBefore, 0u);
    EXPECT_GT(dark, 50u) << "HUD text";
    fs::remove(shot);
    fs::remove(still);
}

// --form tiled draws the tiled form (its own vertex order and faces) and logs it; its start
// frame is psub render's (per-level) picture, as the per-level form's is. Spot at 8 steps is two
// thirds tiled. --form per-level logs its form; auto logs the one its timing chose.
TEST_F(View, TiledFormStartFrameMatchesPsubRender) {
    const std::string model = test::dataPath("spot_control_mesh.obj"), shot = temp("tiled.png"), still = temp("still.png"),
                      log = temp("tiled.jsonl");
    const std::string common = q(model) + " --levels 8 --anim twist --size 320x240 --no-hud --frames 1 --log " + q(log);
    const Outcome r = view(common + " --form tiled --screenshot " + q(shot));
    expectClean(r);
    std::vector<std::string> lines = logLines(log);
    ASSERT_EQ(lines.size(), 1u);
    EXPECT_TRUE(contains(lines[0], "\"ps_form\": \"tiled\"")) << lines[0];
    EXPECT_EQ(field(lines[0], "refined_faces"), 93696);
    const Outcome rendered = run("", "render " + q(model) + " --levels 8 --size 320x240 -o " + q(still));
    ASSERT_EQ(rendered.status, 0) << rendered.err;
    expectSamePicture(readPng(shot), readPng(still));
    expectClean(view(common + " --form per-level"));
    lines = logLines(log);
    ASSERT_EQ(lines.size(), 1u);
    EXPECT_TRUE(contains(lines[0], "\"ps_form\": \"per-level\"")) << lines[0];
    expectClean(view(common));
    lines = logLines(log);
    ASSERT_EQ(lines.size(), 1u);
    EXPECT_TRUE(contains(lines[0], "\"ps_form\": \"tiled\"") || contains(lines[0], "\"ps_form\": \"per-level\""))
        << lines[0];
    fs::remove(shot);
    fs::remove(still);
    fs::remove(log);
}

TEST_F(View, PlusDoublesTheLoggedFaceCount) {
    const std::string log = temp("plus.jsonl");
    const Outcome r = view(q(test::dataPath("cube.obj")) + " --levels 3 --size 320x240 --frames 40 --script '" +
                           script("plus.txt", "# one level up\n2 key +\n") + "' --log '" + log + "'");
    expectClean(r);
    const std::vector<std::string> lines = logLines(log);
    ASSERT_EQ(lines.size(), 40u);
    EXPECT_EQ(field(lines[0], "level"), 3);
    const double before = field(lines[0], "refined_faces");
    EXPECT_EQ(before, 6 * 8);
    EXPECT_EQ(field(lines.back(), "level"), 4) << "the level-4 tables were built within 38 frames";
    EXPECT_EQ(field(lines.back(), "refined_faces"), 2 * before);
    for (const std::string& line : lines) EXPECT_EQ(field(line, "validation_messages"), 0);
    fs::remove(log);
}

TEST_F(View, SchemeKeyDrawsBothSchemesSideBySide) {
    const std::string log = temp("both.jsonl"), shot = temp("both.png");
    const Outcome r = view(q(test::dataPath("cube.obj")) + " --levels 4 --size 400x200 --no-hud --frames 3 --script '" +
                           script("both.txt", "0 key s\n0 key s\n") + "' --log '" + log + "' --screenshot '" + shot + "'");
    expectClean(r);
    const std::vector<std::string> lines = logLines(log);
    ASSERT_EQ(lines.size(), 3u);
    EXPECT_TRUE(contains(lines[0], "\"scheme\": \"both\"")) << lines[0];
    EXPECT_TRUE(contains(lines[0], "\"drawn\": [\"ps\", \"cc\"]")) << lines[0];
    EXPECT_EQ(field(lines[0], "ps_faces"), 6 * 16);
    EXPECT_EQ(field(lines[0], "cc_faces"), 6 * 16) << "Catmull-Clark at 2 levels";
    const Image image = readPng(shot);
    ASSERT_EQ(image.width, 400u);
    EXPECT_GT(drawnPixels(image, 0, 200), 300u) << "P-S on the left (the cube shrinks under P-S)";
    EXPECT_GT(drawnPixels(image, 200, 400), 1000u) << "Catmull-Clark on the right";
    fs::remove(log);
    fs::remove(shot);
}

// Dragging (orbit, pan) and the wheel move the camera; `f` frames the model again exactly as
// at the start (paused, so the pose is the same; one form in every run, as the auto choice,
// timed at load, could differ from run to run).
TEST_F(View, MouseMovesTheCameraAndFFramesTheModelAgain) {
    const std::string start = temp("cam0.png"), moved = temp("cam1.png"), framed = temp("cam2.png");
    const std::string base =
        q(test::dataPath("spot_control_mesh.obj")) + " --levels 2 --form per-level --size 240x180 --no-hud --paused --frames 3";
    const std::string moves = "1 drag left 40 -20\n1 scroll 2\n1 drag right 15 10\n";
    expectClean(view(base + " --screenshot " + q(start)));
    expectClean(view(base + " --script " + q(script("cam1.txt", moves)) + " --screenshot " + q(moved)));
    expectClean(view(base + " --script " + q(script("cam2.txt", moves + "2 key f\n")) + " --screenshot " + q(framed)));
    const Image a = readPng(start), b = readPng(moved), c = readPng(framed);
    EXPECT_NE(a.rgba, b.rgba) << "the camera moved";
    EXPECT_GT(drawnPixels(b, 0, b.width), drawnPixels(a, 0, a.width)) << "zoomed in: the model covers more pixels";
    EXPECT_EQ(a.rgba, c.rgba) << "f restores the start camera";
    for (const std::string& path : {start, moved, framed}) fs::remove(path);
}

// w, space, b and r change what the log reports; b and r pressed together are both applied
// (the second waits for the first build).
TEST_F(View, KeysCycleWireframePlaybackBoundaryAndRules) {
    const std::string log = temp("keys.jsonl");
    const Outcome r = view(q(test::dataPath("grid4x4.obj")) + " --levels 2 --size 240x180 --frames 40 --script " +
                           q(script("keys.txt", "1 key w\n2 key w\n3 key w\n4 key space\n5 key b\n5 key r\n")) +
                           " --log " + q(log));
    expectClean(r);
    const std::vector<std::string> lines = logLines(log);
    ASSERT_EQ(lines.size(), 40u);
    EXPECT_TRUE(contains(lines[0], "\"wireframe\": \"none\"")) << lines[0];
    EXPECT_TRUE(contains(lines[1], "\"wireframe\": \"refined\"")) << lines[1];
    EXPECT_TRUE(contains(lines[2], "\"wireframe\": \"control\"")) << lines[2];
    EXPECT_TRUE(contains(lines[3], "\"wireframe\": \"none\"")) << lines[3];
    EXPECT_TRUE(contains(lines[3], "\"playing\": true")) << lines[3];
    EXPECT_TRUE(contains(lines[4], "\"playing\": false")) << lines[4];
    EXPECT_TRUE(contains(lines[0], "\"boundary\": \"paper\", \"rules\": \"paper\"")) << lines[0];
    EXPECT_TRUE(contains(lines.back(), "\"boundary\": \"smooth\", \"rules\": \"robust\"")) << lines.back();
    EXPECT_GT(field(lines.back(), "ps_faces"), field(lines[0], "ps_faces")) << "smooth splits the boundary edges";
    fs::remove(log);
}

TEST_F(View, ResizeDuringPlaybackRedrawsAtTheNewSize) {
    const std::string log = temp("resize.jsonl"), shot = temp("resize.png");
    const Outcome r = view(q(test::dataPath("spot_control_mesh.obj")) + " --levels 2 --size 320x240 --frames 10 "
                           "--script '" + script("resize.txt", "5 resize 400 300\n") + "' --log '" + log +
                           "' --screenshot '" + shot + "'");
    expectClean(r);
    const std::vector<std::string> lines = logLines(log);
    ASSERT_EQ(lines.size(), 10u);
    for (std::size_t i = 0; i < lines.size(); ++i) {
        EXPECT_EQ(field(lines[i], "width"), i < 5 ? 320 : 400) << lines[i];
        EXPECT_EQ(field(lines[i], "height"), i < 5 ? 240 : 300) << lines[i];
        EXPECT_EQ(field(lines[i], "validation_messages"), 0);
    }
    const Image image = readPng(shot);
    EXPECT_EQ(image.width, 400u);
    EXPECT_EQ(image.height, 300u);
    fs::remove(log);
    fs::remove(shot);
}

TEST_F(View, ThreeHundredFramesOfAGltfClipKeepResidentMemory) {
    const std::string log = temp("life.jsonl");
    const Outcome r = view(q(test::dataPath("two_bone_cylinder.glb")) + " --levels 3 --size 320x240 --no-vsync "
                           "--frames 300 --log '" + log + "'");
    expectClean(r);
    const std::vector<std::string> lines = logLines(log);
    ASSERT_EQ(lines.size(), 300u);
    const double at100 = field(lines[99], "rss_kib"), at300 = field(lines[299], "rss_kib");
    EXPECT_GT(at100, 0);
    // Under AddressSanitizer freed blocks wait in its quarantine (256 MiB), so resident memory
    // measures that, not the frame loop: the bound is checked in the plain build only.
    if (!test::kSanitized) {
        EXPECT_LE(std::abs(at300 - at100), 2048) << "resident KiB at frame 100: " << at100 << ", at 300: " << at300;
    }
    EXPECT_TRUE(contains(lines[299], "\"playing\": true"));
    fs::remove(log);
}

TEST_F(View, ErrorsAreClearWithTheDocumentedStatus) {
    const std::string bad = temp("bad.obj");
    std::ofstream(bad) << "v 0 0 0\nv 1 0 0\nf 1 2 7\n";
    Outcome r = view("'" + bad + "' --frames 1");
    EXPECT_EQ(r.status, 1);
    EXPECT_TRUE(contains(r.err, bad)) << r.err;
    fs::remove(bad);

    const std::string cube = q(test::dataPath("cube.obj"));
    r = run("env -u DISPLAY -u WAYLAND_DISPLAY", "view " + cube + " --frames 1");
    EXPECT_EQ(r.status, 1);
    EXPECT_TRUE(contains(r.err, "$DISPLAY")) << r.err;
    EXPECT_TRUE(contains(r.err, "xvfb-run")) << r.err;
    EXPECT_TRUE(contains(r.err, "psub play --render")) << r.err;

    const std::string keys = script("badkey.txt", "0 key s\n3 key q\n");
    r = view(q(test::dataPath("cube.obj")) + " --frames 5 --script '" + keys + "'");
    EXPECT_EQ(r.status, 1);
    EXPECT_TRUE(contains(r.err, keys + ":2: unknown key 'q'")) << r.err;

    r = view(q(test::dataPath("cube.obj")) + " --screenshot x.png");
    EXPECT_EQ(r.status, 2) << "--screenshot without --frames is a usage error: " << r.err;
}

}  // namespace
}  // namespace psub
