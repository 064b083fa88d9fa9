// psub view, run as a program under Xvfb (xvfb-run -a) with lavapipe and the validation layer
// on (any message fails): the start frame's screenshot equals psub render's picture; `+` doubles
// the logged face count; `s` draws both schemes; a resize during playback; 300 frames of a glTF
// clip without resident-memory growth; bad model, no display, bad script. Without Xvfb or a
// device these fail, unless PSUB_ALLOW_NO_VULKAN=1.
#include "psub/image.h"
#include "view_test_support.h"

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

using test::expectClean;
using test::logField;
using test::logLines;
using test::view;
using test::viewScript;
using test::viewTemp;

std::string q(const std::string& path) { return test::quoted(path); }

// `prefix psub args` with the validation layer on.
Outcome run(const std::string& prefix, const std::string& args) { return test::runValidated(prefix, args); }

class View : public test::WindowTest {};

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
    EXPECT_GT(drawnPixels(a, 0, a.width), a.width * a.height / 20) << "the model is drawn";
    std::string why;
    EXPECT_TRUE(test::closeEnough(a, b, why)) << why;
}

TEST_F(View, StartFrameWithoutHudMatchesPsubRender) {
    const std::string model = test::dataPath("spot_control_mesh.obj"), shot = viewTemp("start.png"), still = viewTemp("render.png");
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
    const std::string model = test::dataPath("spot_control_mesh.obj"), shot = viewTemp("tiled.png"), still = viewTemp("still.png"),
                      log = viewTemp("tiled.jsonl");
    const std::string common = q(model) + " --levels 8 --anim twist --size 320x240 --no-hud --frames 1 --log " + q(log);
    const Outcome r = view(common + " --form tiled --screenshot " + q(shot));
    expectClean(r);
    std::vector<std::string> lines = logLines(log);
    ASSERT_EQ(lines.size(), 1u);
    EXPECT_TRUE(contains(lines[0], "\"ps_form\": \"tiled\"")) << lines[0];
    EXPECT_EQ(logField(lines[0], "refined_faces"), 93696);
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
    const std::string log = viewTemp("plus.jsonl");
    const Outcome r = view(q(test::dataPath("cube.obj")) + " --levels 3 --size 320x240 --frames 40 --script '" +
                           viewScript("plus.txt", "# one level up\n2 key +\n") + "' --log '" + log + "'");
    expectClean(r);
    const std::vector<std::string> lines = logLines(log);
    ASSERT_EQ(lines.size(), 40u);
    EXPECT_EQ(logField(lines[0], "level"), 3);
    const double before = logField(lines[0], "refined_faces");
    EXPECT_EQ(before, 6 * 8);
    EXPECT_EQ(logField(lines.back(), "level"), 4) << "the level-4 tables were built within 38 frames";
    EXPECT_EQ(logField(lines.back(), "refined_faces"), 2 * before);
    for (const std::string& line : lines) EXPECT_EQ(logField(line, "validation_messages"), 0);
    fs::remove(log);
}

TEST_F(View, SchemeKeyDrawsBothSchemesSideBySide) {
    const std::string log = viewTemp("both.jsonl"), shot = viewTemp("both.png");
    const Outcome r = view(q(test::dataPath("cube.obj")) + " --levels 4 --size 400x200 --no-hud --frames 3 --script '" +
                           viewScript("both.txt", "0 key s\n0 key s\n") + "' --log '" + log + "' --screenshot '" + shot + "'");
    expectClean(r);
    const std::vector<std::string> lines = logLines(log);
    ASSERT_EQ(lines.size(), 3u);
    EXPECT_TRUE(contains(lines[0], "\"scheme\": \"both\"")) << lines[0];
    EXPECT_TRUE(contains(lines[0], "\"drawn\": [\"ps\", \"cc\"]")) << lines[0];
    EXPECT_EQ(logField(lines[0], "ps_faces"), 6 * 16);
    EXPECT_EQ(logField(lines[0], "cc_faces"), 6 * 16) << "Catmull-Clark at 2 levels";
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
    const std::string start = viewTemp("cam0.png"), moved = viewTemp("cam1.png"), framed = viewTemp("cam2.png");
    const std::string base =
        q(test::dataPath("spot_control_mesh.obj")) + " --levels 2 --form per-level --size 240x180 --no-hud --paused --frames 3";
    const std::string moves = "1 drag left 40 -20\n1 scroll 2\n1 drag right 15 10\n";
    expectClean(view(base + " --screenshot " + q(start)));
    expectClean(view(base + " --script " + q(viewScript("cam1.txt", moves)) + " --screenshot " + q(moved)));
    expectClean(view(base + " --script " + q(viewScript("cam2.txt", moves + "2 key f\n")) + " --screenshot " + q(framed)));
    const Image a = readPng(start), b = readPng(moved), c = readPng(framed);
    EXPECT_NE(a.rgba, b.rgba) << "the camera moved";
    EXPECT_GT(drawnPixels(b, 0, b.width), drawnPixels(a, 0, a.width)) << "zoomed in: the model covers more pixels";
    EXPECT_EQ(a.rgba, c.rgba) << "f restores the start camera";
    for (const std::string& path : {start, moved, framed}) fs::remove(path);
}

// w, space, b and r change what the log reports; b and r pressed together are both applied
// (the second waits for the first build).
TEST_F(View, KeysCycleWireframePlaybackBoundaryAndRules) {
    const std::string log = viewTemp("keys.jsonl");
    const Outcome r = view(q(test::dataPath("grid4x4.obj")) + " --levels 2 --size 240x180 --frames 40 --script " +
                           q(viewScript("keys.txt", "1 key w\n2 key w\n3 key w\n4 key space\n5 key b\n5 key r\n")) +
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
    EXPECT_GT(logField(lines.back(), "ps_faces"), logField(lines[0], "ps_faces")) << "smooth splits the boundary edges";
    fs::remove(log);
}

TEST_F(View, ResizeDuringPlaybackRedrawsAtTheNewSize) {
    const std::string log = viewTemp("resize.jsonl"), shot = viewTemp("resize.png");
    const Outcome r = view(q(test::dataPath("spot_control_mesh.obj")) + " --levels 2 --size 320x240 --frames 10 "
                           "--script '" + viewScript("resize.txt", "5 resize 400 300\n") + "' --log '" + log +
                           "' --screenshot '" + shot + "'");
    expectClean(r);
    const std::vector<std::string> lines = logLines(log);
    ASSERT_EQ(lines.size(), 10u);
    for (std::size_t i = 0; i < lines.size(); ++i) {
        EXPECT_EQ(logField(lines[i], "width"), i < 5 ? 320 : 400) << lines[i];
        EXPECT_EQ(logField(lines[i], "height"), i < 5 ? 240 : 300) << lines[i];
        EXPECT_EQ(logField(lines[i], "validation_messages"), 0);
    }
    const Image image = readPng(shot);
    EXPECT_EQ(image.width, 400u);
    EXPECT_EQ(image.height, 300u);
    fs::remove(log);
    fs::remove(shot);
}

TEST_F(View, ThreeHundredFramesOfAGltfClipKeepResidentMemory) {
    const std::string log = viewTemp("life.jsonl");
    const Outcome r = view(q(test::dataPath("two_bone_cylinder.glb")) + " --levels 3 --size 320x240 --no-vsync "
                           "--frames 300 --log '" + log + "'");
    expectClean(r);
    const std::vector<std::string> lines = logLines(log);
    ASSERT_EQ(lines.size(), 300u);
    const double at100 = logField(lines[99], "rss_kib"), at300 = logField(lines[299], "rss_kib");
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
    const std::string bad = viewTemp("bad.obj");
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

    const std::string keys = viewScript("badkey.txt", "0 key s\n3 key q\n");
    r = view(q(test::dataPath("cube.obj")) + " --frames 5 --script '" + keys + "'");
    EXPECT_EQ(r.status, 1);
    EXPECT_TRUE(contains(r.err, keys + ":2: unknown key 'q'")) << r.err;

    r = view(q(test::dataPath("cube.obj")) + " --screenshot x.png");
    EXPECT_EQ(r.status, 2) << "--screenshot without --frames is a usage error: " << r.err;
}

}  // namespace
}  // namespace psub
