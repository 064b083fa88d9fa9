// The tiled form on Vulkan (both tile kernels, shaders/tile.comp and tile_unrolled.comp, and the
// tiled table's per-level rows) against the CPU tiled evaluator, both in the tiled drawing
// order: every model with both boundary modes and two rule sets, a torus at every double-step
// count and several widths (bit for bit where the arithmetic is the CPU's), tiles cut into
// partial blocks, split dispatches under small bindings, staging, the storage-buffer reads, the
// refusals. Validation layer on; no device fails unless PSUB_ALLOW_NO_VULKAN=1.
#include "psub/evaluator.h"
#include "psub/stencils.h"
#include "tiled_options.h"
#include "vulkan_test_support.h"

#include <gtest/gtest.h>

#include <array>
#include <iterator>
#include <cmath>
#include <cstdlib>
#include <set>
#include <string>
#include <tuple>
#include <vector>

namespace psub {
namespace {

using VulkanTiled = test::ValidatedVulkanTest;

// Both tile kernels, whichever the device would pick (lavapipe: the unrolled one), the
// workgroup kernel with blocks of at most 16 and of at most 32 a side (a GPU's choice where
// its shared memory holds the wider blocks' grids; lavapipe's does).
struct KernelChoice {
    TileKernel kernel;
    std::uint32_t block;
};
constexpr KernelChoice kTileKernels[] = {
    {TileKernel::Workgroup, 16}, {TileKernel::Workgroup, 32}, {TileKernel::Unrolled, 0}};

// The kernels a test runs: all three; under the sanitizers the two a device picks by default
// (blocks of 16 differ from 32 only in sizes: the plain build covers them, and the sanitizers
// meet them in NormalsInTheTileKernelAreTheCpuTilePassBits).
std::vector<KernelChoice> testedKernels() {
    std::vector<KernelChoice> kernels(std::begin(kTileKernels), std::end(kTileKernels));
    if (test::kSanitized) kernels.erase(kernels.begin());
    return kernels;
}

VulkanEvaluatorOptions withKernel(KernelChoice choice, VulkanEvaluatorOptions options = {}) {
    options.tileKernel = choice.kernel;
    options.tileBlock = choice.block;
    return options;
}

std::string kernelName(KernelChoice choice) {
    return choice.kernel == TileKernel::Workgroup ? "workgroup kernel, blocks of " + std::to_string(choice.block)
                                                  : std::string("unrolled kernel");
}

// The workgroup kernel's widest block (docs/tiled.md, "On Vulkan"): per tile, the largest
// multiple of 2^t that divides its lattice side L and is at most `limit`.
std::uint32_t widestBlock(const TiledTable& tiled, std::uint32_t limit) {
    std::uint32_t widest = 0;
    const std::uint32_t step = 1u << tiled.doubleSteps;
    for (std::size_t k = 0; k < tiled.tileCount(); ++k)
        for (std::uint32_t M = step; M <= std::min(limit, tiled.lattice(k)); M += step)
            if (tiled.lattice(k) % M == 0) widest = std::max(widest, M);
    return widest;
}

struct Tiled {
    test::Loaded loaded;
    Refinement r;
};

Tiled tiledFor(test::Loaded loaded, int steps, Boundary boundary = Boundary::Paper, Rules rules = Rules::Paper,
               TileSides sides = TileSides::Cheapest) {
    Tiled t{std::move(loaded), {}};
    t.r = refine(t.loaded.mesh, t.loaded.checked.connectivity, test::tiledOptions(steps, boundary, rules, sides));
    return t;
}

using test::animate;

double largestDifference(const std::vector<float>& a, const std::vector<float>& b) {
    if (a.size() != b.size()) return INFINITY;
    double worst = 0;
    for (std::size_t i = 0; i < a.size(); ++i) {
        const double d = std::abs(double(a[i]) - double(b[i]));
        if (!(d <= worst)) worst = std::isnan(d) ? INFINITY : d;
    }
    return worst;
}

// Two changing frames through the Vulkan and the CPU tiled evaluators: positions and normals
// (with `width` >= 3) within `tolerance` (relative to the model's size for positions). A point
// the device did not write keeps the previous frame's value and fails the second frame.
void compareWithCpu(VulkanContext& context, const Tiled& t, std::uint32_t width, double tolerance,
                    const VulkanEvaluatorOptions& options = {}) {
    CpuEvaluator<float> cpu(t.r.tiled, width, 2);
    VulkanEvaluator gpu(context, t.r.tiled, width, options);
    ASSERT_EQ(gpu.refinedCount(), cpu.refinedCount());
    EXPECT_EQ(&gpu.surface(), &t.r.tiled.surface);
    const double scale = std::max(1.0, test::boundingDiagonal(t.loaded.mesh.positions));
    std::vector<float> expected(std::size_t(cpu.refinedCount()) * width), actual(expected.size());
    std::vector<float> expectedNormals(3 * std::size_t(cpu.refinedCount())), actualNormals(expectedNormals.size());
    for (int frame = 0; frame < 2; ++frame) {
        SCOPED_TRACE("width " + std::to_string(width) + " frame " + std::to_string(frame));
        const std::vector<float> control = animate(t.loaded.mesh.positions, width, frame);
        cpu.evaluate(control, expected);
        if (width >= 3) {
            // Where both split the normals (the tiles' inner points' in the tile pass), the CPU's
            // split ones; otherwise normals() of the CPU's positions.
            if (gpu.normalsInTilePass()) {
                EXPECT_TRUE(cpu.normalsInTilePass());
                cpu.evaluate(control, expected, expectedNormals);
            } else {
                cpu.normals(expected, expectedNormals);
            }
            gpu.evaluate(control, actual, actualNormals);
            EXPECT_LE(largestDifference(actualNormals, expectedNormals), tolerance == 0 ? 0.0 : 1e-5);
        } else {
            gpu.evaluate(control, actual);
        }
        EXPECT_LE(largestDifference(actual, expected), tolerance * scale);
    }
}

TEST_F(VulkanTiled, EqualsTheCpuTiledEvaluatorOnEveryModel) {
    std::size_t tiles[2][2] = {};  // [boundary][rules]: tiles met, so the tile kernel is covered
    for (const std::string& path : test::allValidModels())
        for (Boundary boundary : {Boundary::Paper, Boundary::Smooth})
            for (Rules rules : {Rules::Paper, Rules::Shape})
                for (int steps : {2, 5}) {
                    SCOPED_TRACE(path + " steps " + std::to_string(steps) + " " + boundaryName(boundary) + " " +
                                 rulesName(rules));
                    // Every regular block a tile at 2 steps (small tiles and blocks), the cost
                    // model's tiles at 5.
                    const Tiled t = tiledFor(test::load(path), steps, boundary, rules,
                                             steps == 2 ? TileSides::Every : TileSides::Cheapest);
                    tiles[int(boundary)][rules == Rules::Shape] += t.r.tiled.tileCount();
                    compareWithCpu(context(), t, 3, 1e-6);
                }
    for (int boundary = 0; boundary < 2; ++boundary)
        for (int rules = 0; rules < 2; ++rules) EXPECT_GT(tiles[boundary][rules], 0u) << boundary << rules;
}

// The tiled form without tiles (TileSides::None: psub play's third candidate on several CPU
// threads): every point the fallback's rows, on the device as on the CPU, on a torus the tiles
// would cover whole and on Spot, both boundary modes, positions and normals.
TEST_F(VulkanTiled, WithoutTilesEqualsTheCpu) {
    for (const std::string& path : {std::string(), test::dataPath("spot_control_mesh.obj")})
        for (Boundary boundary : {Boundary::Paper, Boundary::Smooth}) {
            SCOPED_TRACE((path.empty() ? "torus" : path) + " " + boundaryName(boundary));
            const Tiled t = tiledFor(path.empty() ? test::loadTorus(24, 16) : test::load(path), path.empty() ? 4 : 6,
                                     boundary, Rules::Paper, TileSides::None);
            ASSERT_EQ(t.r.tiled.tileCount(), 0u);
            compareWithCpu(context(), t, 3, 1e-6);
        }
}

// Every finest point of a torus is a tile's, at t = 1, 2 and 3 double steps (odd steps: the
// base level one higher, reached by per-level rows), one to seven values per vertex (four per
// pass of the kernel). The tile kernel does the CPU's operations in the CPU's order: the same
// bits at widths 3 and 4; at other widths the CPU's generic per-level rows add in another order
// (test_vulkan.cpp), so those are equal only where there are no such rows (even steps). Under
// the sanitizers steps 3, 4 and 6 (one per t), each with two of the widths, every width once or more.
TEST_F(VulkanTiled, TorusAtEveryDoubleStepCountAndWidthIsTheCpusBits) {
    constexpr std::array<std::uint32_t, 4> kWidths = {1, 3, 4, 7};
    const test::Loaded torus = test::loadTorus(24, 24);
    std::uint32_t doubleSteps = 0;
    for (int steps = 2; steps <= 6; ++steps) {
        if (test::kSanitized && steps != 3 && steps != 4 && steps != 6) continue;
        SCOPED_TRACE("steps " + std::to_string(steps));
        const Tiled t = tiledFor(torus, steps);
        ASSERT_GT(t.r.tiled.tileCount(), 0u);
        ASSERT_EQ(t.r.tiled.fallbackBegin, t.r.tiled.refinedCount);
        doubleSteps = std::max(doubleSteps, t.r.tiled.doubleSteps);
        for (KernelChoice kernel : testedKernels()) {
            EXPECT_EQ(VulkanEvaluator(context(), t.r.tiled, 3, withKernel(kernel)).tileBlockSide(),
                      kernel.kernel == TileKernel::Unrolled ? 16u : widestBlock(t.r.tiled, kernel.block))
                << kernelName(kernel);
            for (std::size_t w = 0; w < kWidths.size(); ++w) {
                if (test::kSanitized && w != std::size_t(steps) % 4 && w != std::size_t(steps + 2) % 4) continue;
                const std::uint32_t width = kWidths[w];
                SCOPED_TRACE(kernelName(kernel) + std::string(" width ") + std::to_string(width));
                compareWithCpu(context(), t, width, width == 3 || width == 4 || steps % 2 == 0 ? 0.0 : 1e-6,
                               withKernel(kernel));
            }
        }
    }
    EXPECT_EQ(doubleSteps, 3u);
}

// The normals split as the CPU splits them (shaders/tile_normals.comp for the tiles' inner
// points, listed faces and vertices for the rest): the CPU tile pass's bits, on a torus all
// tiles, and on one whose odd step count leaves strips of fallback points (listed too). The
// listed passes' tables are sized by their lists (64 bytes a listed face or vertex: its face
// normal and corners, or its 8 words), not by the surface: the device holds under 80 bytes a
// point besides them (positions and normals take 32), where the whole surface's tables would
// add 64 more.
TEST_F(VulkanTiled, NormalsOfTheTilesInnerPointsAreTheCpuTilePassBits) {
    for (const auto& [n, m, steps] : {std::tuple{24, 24, 4}, std::tuple{48, 32, 3}}) {
        SCOPED_TRACE(std::to_string(n) + " x " + std::to_string(m) + " steps " + std::to_string(steps));
        const Tiled t = tiledFor(test::loadTorus(n, m), steps);
        ASSERT_GT(t.r.tiled.tileCount(), 0u);
        EXPECT_EQ(t.r.tiled.fallbackBegin == t.r.tiled.refinedCount, steps % 2 == 0);
        const TileNormalSets sets = tileNormalSets(t.r.tiled);
        const std::uint64_t listed = sets.restFaces.size() + sets.ringFaces.size() + sets.restVertices.size();
        for (KernelChoice kernel : testedKernels()) {
            SCOPED_TRACE(kernelName(kernel));
            const VulkanEvaluator gpu(context(), t.r.tiled, 3, withKernel(kernel));
            EXPECT_TRUE(gpu.normalsInTilePass());
            EXPECT_LT(gpu.deviceBytes(), 80 * std::uint64_t(t.r.tiled.refinedCount) + 64 * listed);
            compareWithCpu(context(), t, 3, 0.0, withKernel(kernel));
        }
    }
}

// The normals in the workgroup tile kernel (VulkanEvaluatorOptions::fusedTileNormals): the
// kernel writes the inner points' normals from its last fine grid, the CPU tile pass's bits, at
// t = 3 and at t = 1 and 2 (a window one level-B cell wider, read clamped to the tile's grid),
// on tori all tiles and one with fallback strips (blocks of 16: lavapipe's shared memory holds
// those grids, not those of 32); frames without normals after frames with them, and the normals
// of uploaded positions (no tile kernel then: the tile_normals.comp pass), the same.
TEST_F(VulkanTiled, NormalsInTheTileKernelAreTheCpuTilePassBits) {
    VulkanEvaluatorOptions fused = withKernel({TileKernel::Workgroup, 16});
    fused.fusedTileNormals = true;
    std::set<std::uint32_t> doubleSteps;
    for (const auto& [n, m, steps] :
         {std::tuple{24, 24, 6}, std::tuple{48, 32, 7}, std::tuple{24, 24, 4}, std::tuple{48, 32, 3}, std::tuple{24, 24, 2}}) {
        // Under the sanitizers one torus per double-step count (fallback strips at t = 1).
        if (test::kSanitized && (steps == 7 || steps == 2)) continue;
        SCOPED_TRACE(std::to_string(n) + " x " + std::to_string(m) + " steps " + std::to_string(steps));
        const Tiled t = tiledFor(test::loadTorus(n, m), steps);
        ASSERT_GT(t.r.tiled.tileCount(), 0u);
        doubleSteps.insert(t.r.tiled.doubleSteps);
        VulkanEvaluator gpu(context(), t.r.tiled, 3, fused);
        EXPECT_TRUE(gpu.normalsInTilePass());
        EXPECT_TRUE(gpu.normalsInTileKernel());
        VulkanEvaluatorOptions separate = fused;
        separate.fusedTileNormals = false;
        EXPECT_FALSE(VulkanEvaluator(context(), t.r.tiled, 3, separate).normalsInTileKernel());
        compareWithCpu(context(), t, 3, 0.0, fused);
        CpuEvaluator<float> cpu(t.r.tiled, 3, 2);
        const std::size_t values = 3 * std::size_t(cpu.refinedCount());
        std::vector<float> expected(values), expectedNormals(values), actual(values), actualNormals(values);
        const std::vector<float> control = animate(t.loaded.mesh.positions, 3, 3);
        cpu.evaluate(control, expected, expectedNormals);
        gpu.evaluate(control, actual, actualNormals);
        EXPECT_EQ(largestDifference(actualNormals, expectedNormals), 0.0);
        std::fill(actual.begin(), actual.end(), NAN);
        gpu.evaluate(control, actual);  // positions alone: the plain tile kernel
        EXPECT_EQ(largestDifference(actual, expected), 0.0);
        std::fill(actualNormals.begin(), actualNormals.end(), NAN);
        gpu.normals(expected, actualNormals);  // uploaded positions: the separate pass
        EXPECT_EQ(largestDifference(actualNormals, expectedNormals), 0.0);
    }
    EXPECT_EQ(doubleSteps, (std::set<std::uint32_t>{1, 2, 3}));
}

// The workgroup tile kernel with 64 and 1024 invocations a workgroup (tileThreads; the other
// tests run the defaults, 256 for blocks of 16 and 512 for 32): the same bits, at t = 1, 2 and 3,
// both block sides, widths 4 and 7 (two passes over the grids), with the normals in the kernel
// and without.
TEST_F(VulkanTiled, AnyWorkgroupSizeGivesTheSameBits) {
    const test::Loaded torus = test::loadTorus(24, 24);
    for (int steps : {2, 4, 6}) {
        if (test::kSanitized && steps != 6) continue;
        const Tiled t = tiledFor(torus, steps);
        ASSERT_EQ(t.r.tiled.fallbackBegin, t.r.tiled.refinedCount);
        for (std::uint32_t threads : {64u, 1024u})
            for (std::uint32_t block : {16u, 32u}) {
                if (test::kSanitized && threads != 64) continue;  // the same host code at any size
                SCOPED_TRACE("steps " + std::to_string(steps) + ", " + std::to_string(threads) + " invocations, blocks of " +
                             std::to_string(block));
                VulkanEvaluatorOptions options = withKernel({TileKernel::Workgroup, block});
                options.tileThreads = threads;
                for (bool fused : {false, true}) {
                    options.fusedTileNormals = fused;
                    EXPECT_EQ(VulkanEvaluator(context(), t.r.tiled, 4, options).tileThreads(), threads);
                    for (std::uint32_t width : {4u, 7u}) compareWithCpu(context(), t, width, 0.0, options);
                    // Lavapipe's shared memory holds the kept grid of blocks of 16 (of 32 on the smaller lattices).
                    const bool inKernel = VulkanEvaluator(context(), t.r.tiled, 3, options).normalsInTileKernel();
                    if (!fused || block == 16) {
                        EXPECT_EQ(inKernel, fused);
                    }
                }
            }
    }
    const Tiled t = tiledFor(torus, 6);
    EXPECT_EQ(VulkanEvaluator(context(), t.r.tiled, 3, withKernel({TileKernel::Workgroup, 16})).tileThreads(), 256u);
    EXPECT_EQ(VulkanEvaluator(context(), t.r.tiled, 3, withKernel({TileKernel::Workgroup, 32})).tileThreads(), 512u);
    EXPECT_EQ(VulkanEvaluator(context(), t.r.tiled, 3, withKernel({TileKernel::Unrolled, 0})).tileThreads(), 0u);
    VulkanEvaluatorOptions odd;
    odd.tileThreads = 96;
    EXPECT_THROW(VulkanEvaluator(context(), t.r.tiled, 3, odd), std::invalid_argument);
}

// A tile side that is no power of two, at t = 2 on a 30 x 30 torus: four tiles of 15 faces,
// lattices of 60 (the workgroup kernel: five blocks of 12 a side; the unrolled one: three of
// 16 and one cut to 12, its window clamped to the tile's grid).
TEST_F(VulkanTiled, TilesOfAnySideAreTheCpusBits) {
    const Tiled t = tiledFor(test::loadTorus(30, 30), 4);
    ASSERT_EQ(std::set<std::uint32_t>(t.r.tiled.side.begin(), t.r.tiled.side.end()), (std::set<std::uint32_t>{15}));
    for (KernelChoice kernel : testedKernels())
        for (std::uint32_t width : {3u, 4u}) {
            SCOPED_TRACE(kernelName(kernel));
            compareWithCpu(context(), t, width, 0.0, withKernel(kernel));
        }
}

TEST_F(VulkanTiled, SmallBindingsSplitTheTilesIntoDispatchesWithTheSameResults) {
    // Bindings a third of the refined vertex buffer (its windows; the least the evaluator
    // allows). At one value per vertex the gathered grids (over 4/3 bytes per point here: the
    // tiles' halos; asserted below) then exceed one binding, so the tiles are split into
    // dispatches; at width 3 the vertex buffers are split into windows instead.
    // Six tiles of 8 x 8 faces, no fallback (tiles on every regular block: the cost model would
    // give most of this small torus to the rows).
    const Tiled t = tiledFor(test::loadTorus(24, 16), 2, Boundary::Paper, Rules::Paper, TileSides::Every);
    ASSERT_GT(t.r.tiled.tileCount(), 0u);
    ASSERT_EQ(t.r.tiled.fallbackBegin, t.r.tiled.refinedCount);
    for (std::uint32_t width : {1u, 3u})
        for (Staging staging : {Staging::Auto, Staging::Always, Staging::Results}) {
            if (test::kSanitized && staging == Staging::Results) continue;  // Vulkan.StagingCopies... has it
            SCOPED_TRACE(width);
            const std::uint64_t stride = width == 3 ? 4 : width;
            const VulkanEvaluatorOptions small{staging, std::uint64_t(t.r.tiled.refinedCount) * stride * 4 / 3 + 1024};
            for (KernelChoice kernel : testedKernels()) {
                SCOPED_TRACE(kernelName(kernel));
                compareWithCpu(context(), t, width, 0.0, withKernel(kernel, small));
            }
            VulkanEvaluator whole(context(), t.r.tiled, width), split(context(), t.r.tiled, width, small);
            EXPECT_EQ(whole.dispatchCount(), 1u);
            if (width == 1) {
                EXPECT_GT(split.dispatchCount(), 1u);
            }
        }
    const Tiled spot = tiledFor(test::load(test::dataPath("spot_control_mesh.obj")), 5);
    ASSERT_GT(spot.r.tiled.tileCount(), 0u);
    compareWithCpu(context(), spot, 3, 1e-6, {Staging::Auto, std::uint64_t(spot.r.tiled.refinedCount) * 4 * 4 / 3 + 1024});
}

TEST_F(VulkanTiled, StorageBufferReadsGiveTheSameResults) {
    const char* before = std::getenv("PSUB_VULKAN_TEXELS");
    const std::string saved = before ? before : "";
    ::setenv("PSUB_VULKAN_TEXELS", "0", 1);
    const Tiled t = tiledFor(test::loadTorus(40, 24), 5);
    for (KernelChoice kernel : testedKernels()) {
        SCOPED_TRACE(kernelName(kernel));
        compareWithCpu(context(), t, 3, 0.0, withKernel(kernel));
        compareWithCpu(context(), t, 5, 1e-6, withKernel(kernel));
    }
    const Tiled spot = tiledFor(test::load(test::dataPath("spot_control_mesh.obj")), 4);
    compareWithCpu(context(), spot, 3, 1e-6);
    if (before) ::setenv("PSUB_VULKAN_TEXELS", saved.c_str(), 1);
    else ::unsetenv("PSUB_VULKAN_TEXELS");
}

TEST_F(VulkanTiled, TheOtherConstructorRefusesTheTiledForm) {
    const Tiled t = tiledFor(test::load(test::dataPath("cube.obj")), 2);
    EXPECT_THROW(VulkanEvaluator(context(), t.r.perLevel, t.r.factorized, t.r.surface, TableForm::Tiled),
                 std::invalid_argument);
    EXPECT_THROW(VulkanEvaluator(context(), t.r.tiled, 0), std::invalid_argument);
    EXPECT_THROW(VulkanEvaluator(context(), t.r.tiled, 3, withKernel({TileKernel::Workgroup, 8})), std::invalid_argument);
}

}  // namespace
}  // namespace psub
