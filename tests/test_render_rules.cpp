// `psub render --rules paper|robust|shape` (P-S only) and `psub figure-shape`: the shape rules
// keep more of the cube than the paper's, so they cover more pixels from the same camera.
#include "psub/image.h"

#include "test_support.h"

#include <gtest/gtest.h>

namespace psub {
namespace {

using namespace psub::test;

const Rgba kWhite{255, 255, 255, 255};

// Pixels of `image` in columns [x0, x1) and rows [0, rows) that are not the white background.
std::size_t covered(const Image& image, std::uint32_t x0, std::uint32_t x1, std::uint32_t rows) {
    std::size_t count = 0;
    for (std::uint32_t y = 0; y < rows; ++y)
        for (std::uint32_t x = x0; x < x1; ++x) count += !(image.pixel(x, y) == kWhite);
    return count;
}

class RenderRules : public ::testing::Test {
protected:
    // psub ARGS; a run that found no Vulkan device skips with PSUB_ALLOW_NO_VULKAN=1, else fails.
    PsubRun psub(const std::string& args) {
        const PsubRun run = runPsub(scratch_, args);
        if (run.status == 1 && contains(run.err, "Vulkan") && noVulkanAllowed()) skipped_ = true;
        return run;
    }
    std::string at(const std::string& name) const { return (scratch_ / name).string(); }
    ScratchDir scratch_;
    bool skipped_ = false;
};

TEST_F(RenderRules, ShapeRulesCoverMoreOfThePictureThanThePapersOnTheSameCamera) {
    std::size_t pixels[3] = {0, 0, 0};
    const char* rules[3] = {"paper", "robust", "shape"};
    for (int k = 0; k < 3; ++k) {
        const std::string out = at(std::string(rules[k]) + ".png");
        const PsubRun run = psub("render " + test::quoted(dataPath("cube.obj")) + " -o " + test::quoted(out) +
                                 " --levels 4 --size 160x120 --msaa 1 --rules " + rules[k]);
        if (skipped_) GTEST_SKIP() << "no Vulkan device (allowed by PSUB_ALLOW_NO_VULKAN=1): " << run.err;
        ASSERT_EQ(run.status, 0) << run.err;
        EXPECT_TRUE(contains(run.out, "P-S, 4 steps")) << run.out;
        if (k == 2) {
            EXPECT_TRUE(contains(run.out, "shape rules")) << run.out;
        }
        pixels[k] = covered(readPng(out), 0, 160, 120);
    }
    // The camera frames what is drawn, so compare how much of the frame each fills relative to
    // its box: the shape rules' cube is rounder, not only larger; both must draw something.
    EXPECT_GT(pixels[0], 100u);
    EXPECT_GT(pixels[2], 100u);
    EXPECT_NE(readFile(at("paper.png")), readFile(at("shape.png")));
}

TEST_F(RenderRules, RulesWithCatmullClarkIsAUsageError) {
    const PsubRun run = psub("render " + test::quoted(dataPath("cube.obj")) + " -o " + test::quoted(at("cc.png")) +
                             " --scheme cc --rules shape");
    EXPECT_EQ(run.status, 2);
    EXPECT_TRUE(contains(run.err, "--rules applies to --scheme ps only")) << run.err;
    EXPECT_FALSE(fs::exists(at("cc.png")));
}

TEST_F(RenderRules, UnknownRulesAreAUsageErrorNamingTheOption) {
    const PsubRun run = psub("render " + test::quoted(dataPath("cube.obj")) + " -o " + test::quoted(at("x.png")) + " --rules loop");
    EXPECT_EQ(run.status, 2);
    EXPECT_TRUE(contains(oneLine(run), "--rules")) << run.err;
    EXPECT_FALSE(fs::exists(at("x.png")));
}

TEST_F(RenderRules, FigureShapeDrawsPaperAndShapeBesideCatmullClarkAtEqualFaceCounts) {
    const PsubRun run = psub("figure-shape -o " + test::quoted(at("pictures")) + " --panel-size 160x120");
    if (skipped_) GTEST_SKIP() << "no Vulkan device (allowed by PSUB_ALLOW_NO_VULKAN=1): " << run.err;
    ASSERT_EQ(run.status, 0) << run.err;
    const Image row = readPng(at("pictures/figure_shape_cube.png"));
    EXPECT_EQ(row.width, 3u * 160u);
    EXPECT_GT(row.height, 120u);  // the caption band
    // One camera (framing the input cube): P-S with the paper's rules shrinks the cube far more
    // than Catmull-Clark does; the shape rules keep at least a quarter of Catmull-Clark's volume
    // (tests/test_shape_rules.cpp), so they cover more than the paper's rules.
    const std::size_t paper = covered(row, 0, 160, 120), shape = covered(row, 160, 320, 120),
                      cc = covered(row, 320, 480, 120);
    EXPECT_GT(paper, 50u);  // a floor: the shrunken cube is drawn at all in its 160 x 120 panel
    EXPECT_GT(shape, paper);
    EXPECT_GT(cc, shape);
}

}  // namespace
}  // namespace psub
