// psub view's frame loop, run as a program under Xvfb (xvfb-run -a) with lavapipe and the
// validation layer on (any message fails): two frames in flight (the log's slot alternates, and
// the picture equals the one drawn with one frame in flight, with the CPU and the Vulkan
// evaluator), every renderer (and so every pipeline) any `s` / `w` mode needs is made before
// frame 0 and only a resize makes new ones, and the CPU evaluator's vertices written straight
// into the renderers' mapped buffers (lavapipe's memory is host-cached: "cpu_upload": "direct")
// draw the picture of the copy path (forced by PSUB_VIEW_CPU_UPLOAD=copy). Without Xvfb or a
// device these fail, unless PSUB_ALLOW_NO_VULKAN=1.
#include "psub/image.h"
#include "view_test_support.h"

#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace psub {
namespace {

namespace fs = std::filesystem;

using test::contains;

using test::closeEnough;
using test::expectClean;
using test::logField;
using test::logLines;
using test::view;
using test::viewScript;
using test::viewTemp;

std::string q(const std::string& path) { return test::quoted(path); }

class ViewFrames : public test::WindowTest {};

class FramesInFlight : public ViewFrames, public ::testing::WithParamInterface<const char*> {};

// The animation advances a fixed step per frame (--step), so frame 9 is the same pose in every
// run; the camera moves at frame 3. With two frames in flight the slots alternate, and frame 9's
// picture is the one drawn one frame after the other; frame 8's differs from it (so a frame
// drawn from the wrong slot would show).
TEST_P(FramesInFlight, SlotsAlternateAndThePictureIsTheOneAtATimeOne) {
    const std::string backend = GetParam();
    const std::string base = q(test::dataPath("spot_control_mesh.obj")) + " --levels 2 --anim twist --step 0.07 --size 320x240 "
                             "--no-hud --backend " + backend + " --script " + q(viewScript("fif.txt", "3 drag left 30 -10\n"));
    const std::string two = viewTemp("two.png"), one = viewTemp("one.png"), earlier = viewTemp("earlier.png");
    const std::string twoLog = viewTemp("two.jsonl"), oneLog = viewTemp("one.jsonl");
    expectClean(view(base + " --frames 10 --screenshot " + q(two) + " --log " + q(twoLog)));
    expectClean(view(base + " --frames 10 --frames-in-flight 1 --screenshot " + q(one) + " --log " + q(oneLog)));
    expectClean(view(base + " --frames 9 --screenshot " + q(earlier)));

    const std::vector<std::string> twoLines = logLines(twoLog), oneLines = logLines(oneLog);
    ASSERT_EQ(twoLines.size(), 10u);
    ASSERT_EQ(oneLines.size(), 10u);
    for (std::size_t i = 0; i < twoLines.size(); ++i) {
        EXPECT_EQ(logField(twoLines[i], "frame"), double(i));
        EXPECT_EQ(logField(twoLines[i], "frames_in_flight"), 2) << twoLines[i];
        EXPECT_EQ(logField(twoLines[i], "slot"), double(i % 2)) << twoLines[i];
        EXPECT_EQ(logField(twoLines[i], "validation_messages"), 0);
        EXPECT_EQ(logField(oneLines[i], "frames_in_flight"), 1) << oneLines[i];
        EXPECT_EQ(logField(oneLines[i], "slot"), 0) << oneLines[i];
    }
    const Image a = readPng(two), b = readPng(one), c = readPng(earlier);
    std::string why;
    EXPECT_TRUE(closeEnough(a, b, why)) << backend << ": two in flight vs one: " << why;
    EXPECT_FALSE(closeEnough(a, c, why)) << backend << ": frame 9 and frame 8 should differ: " << why;
    for (const std::string& path : {two, one, earlier, twoLog, oneLog}) fs::remove(path);
}

INSTANTIATE_TEST_SUITE_P(Backends, FramesInFlight, ::testing::Values("cpu", "vulkan"));

// Four rounds of s s s w w w (and a frame without keys, so each round starts in the other
// slot): every mode draws in both slots, yet frame 0 already counts every renderer made until
// the resize (each makes its pipelines once, in its constructor): 2 slots x 2 schemes (P-S,
// Catmull-Clark) x 2 layouts (whole window, side by side), each holding all 3 wireframe modes,
// = 8. On the old behaviour (made on a mode's first use) frame 0 counted 1 and the count grew
// with the keys. A resize then makes the 8 again at the new size.
TEST_F(ViewFrames, SchemeAndWireframeKeysReuseTheirRenderers) {
    std::string keys;
    for (int round = 0; round < 4; ++round) {
        const int start = 1 + 7 * round;
        for (int k = 0; k < 3; ++k) keys += std::to_string(start + k) + " key s\n";
        for (int k = 3; k < 6; ++k) keys += std::to_string(start + k) + " key w\n";
    }
    keys += "30 resize 360 260\n";
    const std::string log = viewTemp("keys.jsonl");
    expectClean(view(q(test::dataPath("cube.obj")) + " --levels 2 --size 320x240 --frames 33 --script " +
                     q(viewScript("keys.txt", keys)) + " --log " + q(log)));
    const std::vector<std::string> lines = logLines(log);
    ASSERT_EQ(lines.size(), 33u);
    EXPECT_TRUE(contains(lines[1], "\"scheme\": \"cc\"")) << lines[1];
    EXPECT_TRUE(contains(lines[2], "\"scheme\": \"both\"")) << lines[2];
    EXPECT_TRUE(contains(lines[5], "\"wireframe\": \"control\"")) << lines[5];
    EXPECT_TRUE(contains(lines[23], "\"scheme\": \"both\"")) << lines[23];
    const double atFrame0 = logField(lines[0], "renderers_created");
    EXPECT_EQ(atFrame0, 8) << "2 slots x 2 schemes x 2 layouts, made before the first frame";
    for (std::size_t i = 1; i < 30; ++i)
        EXPECT_EQ(logField(lines[i], "renderers_created"), atFrame0) << "s or w made a renderer: " << lines[i];
    EXPECT_EQ(logField(lines[29], "width"), 320);
    EXPECT_EQ(logField(lines[30], "width"), 360);
    EXPECT_EQ(logField(lines[32], "renderers_created"), 2 * atFrame0) << "a resize makes them again at the new size";
    for (const std::string& line : lines) EXPECT_EQ(logField(line, "validation_messages"), 0);
    fs::remove(log);
}

// The CPU evaluator writes P-S and the Catmull-Clark side's vertices straight into the
// renderers' mapped buffers when their memory is host-cached (lavapipe's is: the log says
// "direct"); PSUB_VIEW_CPU_UPLOAD=copy forces the copy from host arrays ("copy"). Both draw the
// same bytes, side by side with the refined wireframe and with P-S alone, two frames in flight.
// One form for both runs: the default (auto) times the forms at load and may choose another in
// each run, and the forms' pictures differ in a few pixels (float rounding, the faces' order).
TEST_F(ViewFrames, CpuVerticesWrittenInPlaceDrawTheCopiedPicture) {
    for (const std::string keys : {"", "1 key s\n2 key s\n3 key w\n"}) {
        const std::string base = q(test::dataPath("spot_control_mesh.obj")) +
                                 " --levels 2 --form per-level --anim twist --step 0.07 --size 320x240 --no-hud --frames 6 --script " +
                                 q(viewScript("upload.txt", keys));
        const std::string direct = viewTemp("direct.png"), copy = viewTemp("copy.png");
        const std::string directLog = viewTemp("direct.jsonl"), copyLog = viewTemp("copy.jsonl");
        expectClean(view(base + " --screenshot " + q(direct) + " --log " + q(directLog)));
        expectClean(view(base + " --screenshot " + q(copy) + " --log " + q(copyLog), "PSUB_VIEW_CPU_UPLOAD=copy"));
        const std::vector<std::string> directLines = logLines(directLog), copyLines = logLines(copyLog);
        ASSERT_EQ(directLines.size(), 6u);
        ASSERT_EQ(copyLines.size(), 6u);
        for (std::size_t i = 0; i < 6; ++i) {
            EXPECT_TRUE(contains(directLines[i], "\"cpu_upload\": \"direct\"")) << directLines[i];
            EXPECT_TRUE(contains(copyLines[i], "\"cpu_upload\": \"copy\"")) << copyLines[i];
            for (const std::string* line : {&directLines[i], &copyLines[i]})
                EXPECT_TRUE(contains(*line, "\"ps_form\": \"per-level\"")) << *line;
        }
        if (!keys.empty()) {
            EXPECT_TRUE(contains(directLines[5], "\"scheme\": \"both\"")) << directLines[5];
            EXPECT_TRUE(contains(directLines[5], "\"wireframe\": \"refined\"")) << directLines[5];
        }
        const Image a = readPng(direct), b = readPng(copy);
        EXPECT_EQ(a.width, 320u);
        EXPECT_TRUE(a.rgba == b.rgba) << "keys: " << keys;
        std::size_t background = 0;  // the model is drawn: not all white
        for (std::size_t i = 0; i < a.rgba.size(); i += 4) background += a.rgba[i] == 255 && a.rgba[i + 1] == 255 && a.rgba[i + 2] == 255;
        EXPECT_LT(background, a.rgba.size() / 4 - 1000) << "keys: " << keys;
        for (const std::string& path : {direct, copy, directLog, copyLog}) fs::remove(path);
    }
}

}  // namespace
}  // namespace psub
