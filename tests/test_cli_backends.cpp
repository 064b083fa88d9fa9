// `psub demo` and `psub subdivide` on their backends through the one evaluator contract
// (cli/evaluators.h makeEvaluator): the demo's header only after a successful load, its CPU and
// Vulkan frame lines, and subdivide's Vulkan result against its CPU result. No Vulkan device
// fails the Vulkan tests unless PSUB_ALLOW_NO_VULKAN=1.
#include "test_support.h"

#include <cstdlib>
#include <string>

namespace psub::test {
namespace {

const std::string kCube = dataPath("cube.obj");

// The number after `label` on the line of `text` that holds it; NaN when there is none.
double numberAfter(const std::string& text, const std::string& label) {
    const std::size_t at = text.find(label);
    if (at == std::string::npos) return std::nan("");
    return std::strtod(text.c_str() + at + label.size(), nullptr);
}

using CliBackends = HostileTest;

TEST_F(CliBackends, DemoOnBadInputPrintsOnlyTheErrorLine) {
    // Face 1 names vertex 2, and the file has one: refused before any header is printed.
    write("bad.obj", "v 0 0 0\nf 1 2 1\n");
    refused("demo --model bad.obj --levels 1", 1, {"bad.obj"});
}

TEST_F(CliBackends, DemoTimesTheCpuFormsAndComparesBothVulkanForms) {
    const Run run = psub("demo --model " + test::quoted(kCube) + " --levels 2", 300);
    ASSERT_EQ(run.status, 0) << run.err;
    EXPECT_EQ(run.out.find("PSub demo: "), 0u) << run.out;
    // The CPU lines (per-level, factorized, tiled) name their backend as the contract's device()
    // does ("CPU, N threads").
    EXPECT_EQ(countOf(run.out, "(CPU, "), 3) << run.out;
    EXPECT_TRUE(contains(run.out, "% of the points from fallback rows")) << run.out;
    // Tables against the readable rule path in float: coordinates of the cube are within 1, so a
    // float result is within a few units of 2^-24 * 1 = 6e-8 per level; 1e-5 leaves wide margin.
    for (const char* line : {"  per-level   median", "  factorized  median", "  tiled       median"}) {
        const std::size_t at = run.out.find(line);
        ASSERT_NE(at, std::string::npos) << line << "\n" << run.out;
        EXPECT_LT(numberAfter(run.out.substr(at), "max |table - rules| = "), 1e-5) << line << "\n" << run.out;
    }
    if (contains(run.out, "vulkan      unavailable: ") && noVulkanAllowed()) GTEST_SKIP() << run.out;
    // Vulkan and CPU both in float on the same tables, per-level and tiled: the same 1e-5 bound
    // (derived above).
    for (const char* line : {"  vulkan      median", "  vulkan tiled  median"}) {
        const std::size_t at = run.out.find(line);
        ASSERT_NE(at, std::string::npos) << line << "\n" << run.out;
        EXPECT_LT(numberAfter(run.out.substr(at), "max |vulkan - cpu| = "), 1e-5) << line << "\n" << run.out;
    }
}

TEST_F(CliBackends, SubdivideOnVulkanMatchesTheCpu) {
    const Run cpu = psub("subdivide " + test::quoted(kCube) + " -o cpu.obj --levels 2");
    ASSERT_EQ(cpu.status, 0) << cpu.err;
    const Run gpu = psub("subdivide " + test::quoted(kCube) + " -o gpu.obj --levels 2 --backend vulkan");
    if (gpu.status != 0 && noVulkanAllowed()) GTEST_SKIP() << gpu.err;
    ASSERT_EQ(gpu.status, 0) << gpu.err;
    EXPECT_TRUE(contains(gpu.out, "float on Vulkan: ")) << gpu.out;
    const Mesh a = readObj(path("cpu.obj")), b = readObj(path("gpu.obj"));
    ASSERT_EQ(a.positions.size(), b.positions.size());
    EXPECT_EQ(a.faces.verts, b.faces.verts);
    EXPECT_EQ(a.faces.offsets, b.faces.offsets);
    // Double on the CPU, float on Vulkan: the cube's coordinates are within 1, so float rounding
    // (2^-24 = 6e-8 per operation, a few per level, 2 levels) stays far below 1e-5.
    for (std::size_t i = 0; i < a.positions.size(); ++i) EXPECT_NEAR(a.positions[i], b.positions[i], 1e-5) << i;
}

}  // namespace
}  // namespace psub::test
