// The tiled table form against the rule oracle: the regular masks of docs/tiled.md, every
// model with both boundary modes and both rule sets at 1..5 steps, tiles on a torus,
// watertight borders, threads, widths, normals and the refine facade.
#include "psub/evaluator.h"
#include "psub/rules.h"
#include "psub/stencils.h"
#include "test_support.h"
#include "tiled_options.h"

#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <set>
#include <tuple>

namespace psub {
namespace {

using test::loadTorus;

const auto diagonal = test::boundingDiagonal;

// The tiled evaluator's output for `control`, in canonical order.
template <class T>
std::vector<T> tiledCanonical(const TiledTable& table, const std::vector<double>& control, std::uint32_t width = 3,
                              int threads = 1) {
    CpuEvaluator<T> evaluator(table, width, threads);
    const std::vector<T> in(control.begin(), control.end());
    std::vector<T> drawing(std::size_t(evaluator.refinedCount()) * width), canonical(drawing.size());
    evaluator.evaluate(in, drawing);
    toCanonical<T>(table, drawing, canonical, width);
    return canonical;
}

template <class T>
double maxDifference(const std::vector<T>& actual, const std::vector<double>& expected) {
    EXPECT_EQ(actual.size(), expected.size());
    double worst = 0;
    for (std::size_t i = 0; i < std::min(actual.size(), expected.size()); ++i)
        worst = std::max(worst, std::abs(double(actual[i]) - expected[i]));
    return worst;
}

// Weights of the 2-step rule path at finest vertex `point` of a 12 x 12 torus, for the control
// vertices at grid offsets (dx, dy) from vertex (6, 6); compared with the masks of docs/tiled.md.
void expectMask(int steps, Index point, const std::vector<std::vector<int>>& maskRowsTopDown, int denominator,
                int xFrom, int yTop) {
    const test::Loaded torus = loadTorus(12, 12);
    const Hierarchy h = test::refine(torus, steps);
    for (int dy = -4; dy <= 4; ++dy)
        for (int dx = -4; dx <= 4; ++dx) {
            std::vector<double> control(torus.mesh.positions.size(), 0.0);
            control[3 * std::size_t((6 + dy) * 12 + 6 + dx)] = 1.0;
            const double weight = refinePositions(h, control)[3 * std::size_t(point)];
            const int row = yTop - dy, column = dx - xFrom;
            const bool inside = row >= 0 && row < int(maskRowsTopDown.size()) && column >= 0 &&
                                column < int(maskRowsTopDown[0].size());
            const double expected = inside ? double(maskRowsTopDown[std::size_t(row)][std::size_t(column)]) / denominator : 0.0;
            EXPECT_EQ(weight, expected) << "offset " << dx << ", " << dy;
        }
}

TEST(Tiled, OneStepRegularMasksAreTheRulePaths) {
    const Index centre = 6 * 12 + 6;
    expectMask(1, centre, {{1, 2, 1}, {2, 4, 2}, {1, 2, 1}}, 16, -1, 1);  // V-point of (6, 6)
    expectMask(1, 144 + centre, {{1, 1}, {1, 1}}, 4, 0, 1);                // F-point of face (6, 6)
}

TEST(Tiled, TwoStepRegularMasksAreTheRulePaths) {
    const Index centre = 6 * 12 + 6;
    const test::Loaded torus = loadTorus(12, 12);
    const Index edge = torus.checked.connectivity.edgeOf[4 * centre];  // (6, 6) -> (7, 6)
    expectMask(2, centre,
               {{0, 1, 2, 1, 0}, {1, 16, 30, 16, 1}, {2, 30, 56, 30, 2}, {1, 16, 30, 16, 1}, {0, 1, 2, 1, 0}}, 256, -2, 2);
    expectMask(2, 144 + centre, {{2, 10, 10, 2}, {10, 42, 42, 10}, {10, 42, 42, 10}, {2, 10, 10, 2}}, 256, -1, 2);
    expectMask(2, 144 + 144 + edge, {{4, 28, 28, 4}, {8, 56, 56, 8}, {4, 28, 28, 4}}, 256, -1, 1);
}

// Max difference, in float and double, over every model, both boundary modes, all three rule
// sets, with a tile on every regular block (TileSides::Every: small tiles and many tile
// borders beside the fallback; the cost model's choice is a subset of those blocks).
TEST(Tiled, EqualsTheRulesOnEveryModel) {
    std::vector<std::string> models = test::allValidModels();
    std::size_t tiles[2][3][2] = {};  // [boundary][rules][odd steps]: tiles met, so the tile path is covered
    for (const std::string& path : models)
        for (Boundary boundary : {Boundary::Paper, Boundary::Smooth})
            for (Rules rules : {Rules::Paper, Rules::Robust, Rules::Shape})
                for (int steps = 1; steps <= (path.find("cow") != std::string::npos ? 3 : 5); ++steps) {
                    SCOPED_TRACE(path + " steps " + std::to_string(steps) + " " + boundaryName(boundary) + " " + rulesName(rules));
                    const test::Loaded loaded = test::load(path);
                    const Hierarchy h = test::refine(loaded, steps, Preprocess::Auto, boundary);
                    const TiledTable table = buildTiledTable(h, buildPerLevelTable(h, rules), TileSides::Every);
                    tiles[int(boundary)][int(rules)][steps % 2] += table.tileCount();
                    const std::vector<double> oracle = refinePositions(h, loaded.mesh.positions, rules);
                    // Tolerances relative to the model's size: float, 2^-24 = 6e-8 per rounding over
                    // a few steps' weighted sums (1e-6); double, 1.1e-16 per rounding (1e-12).
                    const double scale = diagonal(loaded.mesh.positions);
                    EXPECT_LE(maxDifference(tiledCanonical<float>(table, loaded.mesh.positions), oracle), 1e-6 * scale);
                    EXPECT_LE(maxDifference(tiledCanonical<double>(table, loaded.mesh.positions), oracle), 1e-12 * scale);
                }
    for (int boundary = 0; boundary < 2; ++boundary)
        for (int rules = 0; rules < 3; ++rules)
            for (int odd = 0; odd < 2; ++odd) EXPECT_GT(tiles[boundary][rules][odd], 0u) << boundary << rules << odd;
}

// On a torus every point is regular: at even steps from two on, the tiles of a 48 x 32 torus
// write every finest point (blocks of 16 faces); at odd steps the base level is the quincunx
// lattice, whose blocks leave strips that the cost model gives to the rows (10% at 3 steps,
// where four tiles of 26 cost it less than thirteen that leave 4%; under 4% from 5 steps).
TEST(Tiled, TilesCoverATorusAndEqualTheRules) {
    const test::Loaded torus = loadTorus(48, 32);
    const double scale = diagonal(torus.mesh.positions);
    for (int steps = 1; steps <= 6; ++steps) {
        SCOPED_TRACE("steps " + std::to_string(steps));
        const Hierarchy h = test::refine(torus, steps);
        const TiledTable table = buildTiledTable(h, buildPerLevelTable(h));
        EXPECT_EQ(table.doubleSteps, std::uint32_t(std::min(3, steps / 2)));
        if (steps >= 2) {
            EXPECT_GT(table.tileCount(), 0u);
        }
        if (steps >= 2 && steps % 2 == 0) {
            EXPECT_EQ(table.fallbackBegin, table.refinedCount);
            EXPECT_EQ(table.rows.levels.back().rowEnd, table.rows.levels.back().rowBegin);  // no fallback rows
        }
        if (steps >= 2 && steps % 2 == 1) {
            EXPECT_LT(table.refinedCount - table.fallbackBegin, table.refinedCount / (steps == 3 ? 8 : 25));
        }
        const std::vector<double> oracle = refinePositions(h, torus.mesh.positions);
        EXPECT_LE(maxDifference(tiledCanonical<float>(table, torus.mesh.positions), oracle), 1e-6 * scale);
        EXPECT_LE(maxDifference(tiledCanonical<double>(table, torus.mesh.positions), oracle), 1e-12 * scale);
    }
}

// A regular region whose side is no multiple of the largest tile side (32 at t = 2) gets the
// tiles its cost model prefers: a 36 x 36 torus four of side 18 (the largest sides' cover
// would leave strips of 4; 24 and 12 cost 6% more), a 30 x 30 one four of 15 (a tile's grid,
// side + 7 vertices, must not wrap around); every finest point still a tile's, the rules'.
TEST(Tiled, TileSidesFollowTheRegularRegion) {
    const std::set<std::uint32_t> sides36{18}, sides30{15};
    for (const auto& [n, sides, tiles] : {std::tuple{36u, sides36, 4u}, std::tuple{30u, sides30, 4u}}) {
        SCOPED_TRACE(n);
        const test::Loaded torus = loadTorus(n, n);
        const Hierarchy h = test::refine(torus, 4);
        const TiledTable table = buildTiledTable(h, buildPerLevelTable(h));
        ASSERT_EQ(table.doubleSteps, 2u);
        EXPECT_EQ(table.fallbackBegin, table.refinedCount);
        EXPECT_EQ(table.tileCount(), tiles);
        EXPECT_EQ(std::set<std::uint32_t>(table.side.begin(), table.side.end()), sides);
        EXPECT_LE(maxDifference(tiledCanonical<float>(table, torus.mesh.positions), refinePositions(h, torus.mesh.positions)),
                  1e-6 * diagonal(torus.mesh.positions));
    }
}

// Every side is tried only where level B has at most 8,192 faces (kEverySideFaces): a 90 x 90
// torus (8,100 faces at t = 2) gets tiles of 30 (three a side, nothing left), a 91 x 91 one
// (8,281) only the listed sides, 32, 24, 16 and 12 (and their halves).
TEST(Tiled, EverySideIsTriedOnlyOnSmallLevels) {
    for (const Index n : {90u, 91u}) {
        SCOPED_TRACE(n);
        const test::Loaded torus = loadTorus(n, n);
        const Hierarchy h = test::refine(torus, 4);
        const TiledTable table = buildTiledTable(h, buildPerLevelTable(h));
        ASSERT_EQ(table.doubleSteps, 2u);
        ASSERT_GT(table.tileCount(), 0u);
        const std::set<std::uint32_t> sides(table.side.begin(), table.side.end());
        if (n == 90) {
            EXPECT_EQ(sides, std::set<std::uint32_t>{30});
            EXPECT_EQ(table.fallbackBegin, table.refinedCount);
        } else {
            for (const std::uint32_t side : sides)
                EXPECT_TRUE(side == 32 || side == 24 || side == 16 || side == 12 || side == 8 || side == 6) << side;
        }
    }
}

// A block whose grid is exactly the regular region is found: the open 14 x 14 grid's interior
// vertices are 13 x 13, the grid of a tile of side 8 at one double step (8 + 2 halo + 1); its
// centre is 7 face hops from the boundary, 6 from the grid's edge (the clearance check that
// turns blocks away before walking them must let it through). Both side choices find it.
TEST(Tiled, ABlockAsLargeAsTheRegularRegionIsFound) {
    const Index m = 14;
    test::Loaded grid;
    grid.mesh.faces.vertexCount = (m + 1) * (m + 1);
    for (Index j = 0; j <= m; ++j)
        for (Index i = 0; i <= m; ++i)
            grid.mesh.positions.insert(grid.mesh.positions.end(), {double(i), double(j), 0.1 * std::sin(double(i * j))});
    for (Index j = 0; j < m; ++j)
        for (Index i = 0; i < m; ++i)
            grid.mesh.faces.addFace(std::vector<Index>{j * (m + 1) + i, j * (m + 1) + i + 1, (j + 1) * (m + 1) + i + 1,
                                                       (j + 1) * (m + 1) + i});
    grid.checked = checkMesh(grid.mesh);
    const Hierarchy h = test::refine(grid, 2);
    const PerLevelTable perLevel = buildPerLevelTable(h);
    for (const TileSides sides : {TileSides::Cheapest, TileSides::Every}) {
        const TiledTable table = buildTiledTable(h, perLevel, sides);
        ASSERT_EQ(table.doubleSteps, 1u);
        ASSERT_GT(table.tileCount(), 0u);
        EXPECT_EQ(table.side[0], 8u);
        EXPECT_LE(maxDifference(tiledCanonical<float>(table, grid.mesh.positions), refinePositions(h, grid.mesh.positions)),
                  1e-6 * diagonal(grid.mesh.positions));
    }
}

// Small regular regions stay with the rows: on Spot at 9 steps (t = 1) the cost model keeps
// only tiles of at least 8 faces a side (smaller ones cost more than their points' rows),
// where every regular block would make thousands of tiles.
TEST(Tiled, SmallRegularRegionsStayWithTheRows) {
    const test::Loaded spot = test::load(test::dataPath("spot_control_mesh.obj"));
    const Hierarchy h = test::refine(spot, 9);
    const PerLevelTable perLevel = buildPerLevelTable(h);
    const TiledTable cheapest = buildTiledTable(h, perLevel), every = buildTiledTable(h, perLevel, TileSides::Every);
    ASSERT_EQ(cheapest.doubleSteps, 1u);
    EXPECT_GT(cheapest.tileCount(), 0u);
    EXPECT_GT(every.tileCount(), 20 * cheapest.tileCount());
    EXPECT_GE(*std::min_element(cheapest.side.begin(), cheapest.side.end()), 8u);
    EXPECT_EQ(*std::min_element(every.side.begin(), every.side.end()), 1u);
    EXPECT_LE(maxDifference(tiledCanonical<float>(cheapest, spot.mesh.positions), refinePositions(h, spot.mesh.positions)),
              1e-6 * diagonal(spot.mesh.positions));
}

// Every finest point is written exactly once: `canonical` is a permutation.
TEST(Tiled, DrawingOrderIsAPermutation) {
    for (const std::string& path : {test::dataPath("grid4x4.obj"), test::dataPath("spot_control_mesh.obj")}) {
        const test::Loaded loaded = test::load(path);
        const Hierarchy h = test::refine(loaded, 4);
        const TiledTable table = buildTiledTable(h, buildPerLevelTable(h));
        std::vector<int> seen(table.refinedCount, 0);
        for (std::uint32_t v : table.canonical) ++seen[v];
        EXPECT_EQ(std::count(seen.begin(), seen.end(), 1), std::ptrdiff_t(table.refinedCount)) << path;
    }
}

// The fallback's points in walk order (docs/tiled.md, "Output order"): on the cow (no tile: all
// fallback) a finest face's corners lie close in drawing order, where in canonical order they
// lie far apart (corners from every level); every level's rows still ascend by destination
// within each group (what the CPU kernel's consecutive-store path relies on), and every group
// of the walk-ordered intermediate levels writes consecutive points (groupLevelPoints), the
// finest level's groups mostly consecutive points (groupFinestInChunks), with tiles too (Spot at 9 steps, TileSides::Every: the fallback's levels after B renumbered); the
// same values, on one thread and on two (each level split in even shares of every group from
// walkFrom on).
TEST(Tiled, TheFallbackIsInWalkOrder) {
    const test::Loaded cow = test::load(test::dataPath("cow.obj"));
    const Hierarchy h = test::refine(cow, 5);
    const PerLevelTable perLevel = buildPerLevelTable(h);
    const TiledTable table = buildTiledTable(h, perLevel);
    ASSERT_EQ(table.tileCount(), 0u);
    ASSERT_EQ(table.fallbackBegin, 0u);
    std::vector<std::uint32_t> drawOf(table.refinedCount);
    for (std::uint32_t p = 0; p < table.refinedCount; ++p) drawOf[table.canonical[p]] = p;
    const Faces& finest = h.levels.back().faces;
    double canonicalSpread = 0, drawingSpread = 0;
    for (Index f = 0; f < finest.faceCount(); ++f) {
        const auto [lo, hi] = std::minmax_element(finest.face(f).begin(), finest.face(f).end());
        canonicalSpread += double(*hi - *lo);
        std::uint32_t least = UINT32_MAX, most = 0;
        for (Index v : finest.face(f)) least = std::min(least, drawOf[v]), most = std::max(most, drawOf[v]);
        drawingSpread += double(most - least);
    }
    EXPECT_LT(drawingSpread * 20, canonicalSpread) << drawingSpread / finest.faceCount() << " against "
                                                  << canonicalSpread / finest.faceCount();
    const test::Loaded spot = test::load(test::dataPath("spot_control_mesh.obj"));
    const Hierarchy spotH = test::refine(spot, 9);
    const TiledTable spotTable = buildTiledTable(spotH, buildPerLevelTable(spotH), TileSides::Every);
    ASSERT_GT(spotTable.tileCount(), 0u);
    ASSERT_LT(spotTable.fallbackBegin, spotTable.refinedCount);
    for (const PerLevelTable* rows : {&table.rows, &spotTable.rows})
        for (const RowGroup& g : rows->groups)
            for (std::uint64_t r = g.rowBegin + 1; r < g.rowBegin + g.rowCount; ++r)
                ASSERT_LT(rows->destinations[r - 1], rows->destinations[r]);
    // The walk-ordered levels before the finest are numbered group by group of the rows that
    // write them: each such group writes consecutive points.
    for (const PerLevelTable* rows : {&table.rows, &spotTable.rows}) {
        std::size_t grouped = 0;
        for (std::size_t k = rows->walkFrom; k + 1 < rows->levels.size(); ++k)
            for (std::uint64_t g = rows->levels[k].groupBegin; g < rows->levels[k].groupEnd; ++g, ++grouped) {
                const RowGroup& group = rows->groups[g];
                ASSERT_EQ(rows->destinations[group.rowBegin + group.rowCount - 1] - rows->destinations[group.rowBegin],
                          group.rowCount - 1)
                    << "level " << k << ", group " << g;
            }
        EXPECT_GT(grouped, 4u);
    }
    // The finest level's fallback points are grouped the same way within chunks of the walk
    // (groupFinestInChunks): most rows of a group write the point after the one the row before
    // wrote (in plain walk order a face point and a vertex point alternate: almost none do).
    for (const PerLevelTable* rows : {&table.rows, &spotTable.rows}) {
        const StencilLevel& finestRows = rows->levels.back();
        std::uint64_t next = 0, total = 0;
        for (std::uint64_t g = finestRows.groupBegin; g < finestRows.groupEnd; ++g) {
            const RowGroup& group = rows->groups[g];
            for (std::uint64_t r = group.rowBegin + 1; r < group.rowBegin + group.rowCount; ++r, ++total)
                next += rows->destinations[r] == rows->destinations[r - 1] + 1;
        }
        EXPECT_GT(next, total * 9 / 10) << next << " of " << total;
    }
    EXPECT_LE(maxDifference(tiledCanonical<float>(spotTable, spot.mesh.positions), refinePositions(spotH, spot.mesh.positions)),
              1e-6 * diagonal(spot.mesh.positions));
    // The CPU evaluator splits the walk-ordered levels in even shares of every group: the same bits.
    EXPECT_EQ(table.rows.walkFrom, 0u);
    EXPECT_EQ(spotTable.rows.walkFrom, 0u);  // with tiles too: every level but the control points
    EXPECT_TRUE(tiledCanonical<float>(table, cow.mesh.positions, 3, 1) == tiledCanonical<float>(table, cow.mesh.positions, 3, 2));
    EXPECT_LE(maxDifference(tiledCanonical<float>(table, cow.mesh.positions), refinePositions(h, cow.mesh.positions)),
              1e-6 * diagonal(cow.mesh.positions));
}

// With tiles, the levels up to B are numbered from level B's ancestors two levels before
// (orderLevelsByWalk): two threads, each with its even half of every group (the CPU evaluator's
// split from walkFrom on), then work on two parts of the surface at each of those levels and
// read few points the other wrote: on Spot at 9 steps 1.9% of the sources, against 3.8% with
// the control-point ancestors (the halves' border through whole control faces) and 11.5% with
// level B numbered by the fallback's walk (its strips between the tiles); both left the rows up
// to B about as slow on two threads as on one.
TEST(Tiled, TwoThreadsReadFewOfEachOthersPointsUpToLevelB) {
    const test::Loaded spot = test::load(test::dataPath("spot_control_mesh.obj"));
    const Hierarchy h = test::refine(spot, 9);
    const TiledTable table = buildTiledTable(h, buildPerLevelTable(h));
    ASSERT_GT(table.tileCount(), 0u);
    ASSERT_GE(table.baseLevel, 3u);
    ASSERT_EQ(table.rows.walkFrom, 0u);
    const PerLevelTable& rows = table.rows;
    std::uint64_t crossed = 0, read = 0;
    std::vector<char> secondHalf;  // per point of level k: written by the second half of its group
    for (std::size_t k = 1; k < table.baseLevel; ++k) {
        const StencilLevel& writers = rows.levels[k - 1];
        secondHalf.assign(writers.destinationCount, 0);
        for (std::uint64_t g = writers.groupBegin; g < writers.groupEnd; ++g) {
            const RowGroup& group = rows.groups[g];
            for (std::uint64_t r = 0; r < group.rowCount; ++r)
                secondHalf[rows.destinations[group.rowBegin + r]] = r >= group.rowCount / 2;
        }
        const StencilLevel& readers = rows.levels[k];
        for (std::uint64_t g = readers.groupBegin; g < readers.groupEnd; ++g) {
            const RowGroup& group = rows.groups[g];
            ASSERT_FALSE(readsOwnLevel(group.kind));  // rewritten after ordering, never here
            for (std::uint64_t r = 0; r < group.rowCount; ++r)
                for (std::uint32_t j = 0; j < group.width; ++j, ++read)
                    crossed += secondHalf[rows.indices[group.indexBegin + r * group.width + j]] != (r >= group.rowCount / 2);
        }
    }
    ASSERT_GT(read, 0u);
    EXPECT_LT(crossed * 100, read * 3) << crossed << " of " << read << " sources read across the halves";
}

// A border point that two tiles compute is bitwise the same in both (and equals what its owner wrote).
TEST(Tiled, SharedBorderPointsAreBitwiseIdentical) {
    for (int steps : {2, 4, 6}) {
        const test::Loaded torus = loadTorus(36, 20);
        const Hierarchy h = test::refine(torus, steps);
        const TiledTable table = buildTiledTable(h, buildPerLevelTable(h));
        ASSERT_GT(table.tileCount(), 1u);
        CpuEvaluator<float> evaluator(table, 3, 1);
        const std::vector<float> control(torus.mesh.positions.begin(), torus.mesh.positions.end());
        std::vector<float> refined(3 * std::size_t(table.refinedCount));
        evaluator.evaluate(control, refined);
        // Level B's points, for evaluateTile.
        std::vector<double> baseDouble(torus.mesh.positions);
        for (std::uint32_t k = 1; k <= table.baseLevel; ++k) baseDouble = refineLevelPositions(h, k, baseDouble);
        ASSERT_EQ(table.baseLevel, 0u);  // a torus: no paired method, so B = 0 at 2, 4 and 6 steps
        std::vector<float> scratch(tileScratchSize(table, 3));
        std::size_t shared = 0;
        for (std::size_t k = 0; k < table.tileCount(); ++k) {
            const std::uint32_t L = table.lattice(k);
            std::vector<float> lattice(3 * std::size_t(L + 1) * (L + 1));
            evaluateTile<float>(table, k, control.data(), 3, nullptr, {}, scratch.data(), lattice.data());
            std::size_t e = table.borderBegin[k];
            for (std::uint32_t y = 0; y <= L; ++y)
                for (std::uint32_t x = 0; x <= L; x += (y == 0 || y == L) ? 1 : L, ++e) {
                    const std::uint32_t position = table.border[e];
                    const std::uint32_t end = k + 1 < table.tileCount() ? table.output[k + 1] : table.fallbackBegin;
                    shared += position < table.output[k] || position >= end;
                    EXPECT_EQ(std::memcmp(&lattice[3 * (std::size_t(y) * (L + 1) + x)], &refined[3 * std::size_t(position)],
                                          3 * sizeof(float)), 0)
                        << "tile " << k << " border point " << x << ", " << y;
                }
        }
        EXPECT_GT(shared, 0u);  // some border points were computed by a tile that does not own them
    }
}

TEST(Tiled, ThreadsGiveBitIdenticalResults) {
    for (const std::string& path : {test::dataPath("cow.obj"), test::dataPath("grid4x4.obj")}) {
        const test::Loaded loaded = test::load(path);
        const Hierarchy h = test::refine(loaded, 4);
        const TiledTable table = buildTiledTable(h, buildPerLevelTable(h));
        EXPECT_EQ(tiledCanonical<float>(table, loaded.mesh.positions, 3, 1),
                  tiledCanonical<float>(table, loaded.mesh.positions, 3, 4)) << path;
    }
    const test::Loaded torus = loadTorus(64, 48);
    const Hierarchy h = test::refine(torus, 4);
    const TiledTable table = buildTiledTable(h, buildPerLevelTable(h));
    EXPECT_EQ(tiledCanonical<float>(table, torus.mesh.positions, 3, 1), tiledCanonical<float>(table, torus.mesh.positions, 3, 3));
}

// The tile kernel is compiled for AVX-512, AVX2 and the x86-64 baseline (any CPU runs one):
// every instruction set this CPU has gives the same bits, positions and the tile pass's
// normals, float and double, at t = 1, 2 and 3 and widths 1, 3, 4 and 7, on a torus (all
// tiles) and Spot (fallback beside its tiles).
TEST(Tiled, EveryInstructionSetGivesTheSameBits) {
    // The choice is process-wide: put back as found however the test ends.
    struct Restore {
        std::string set = tileKernelInstructions();
        ~Restore() { setTileKernelInstructions(set); }
    } restore;
    std::vector<std::string> sets;
    for (const char* set : {"avx512f", "avx2", "baseline"})
        if (setTileKernelInstructions(set)) sets.push_back(set);
    EXPECT_EQ(sets.back(), "baseline");  // every CPU runs the baseline
    if (sets.size() < 2) GTEST_SKIP() << "this CPU has only the baseline instruction set: nothing to compare it with";
    struct Case {
        test::Loaded loaded;
        int levels;
    };
    std::vector<Case> cases;
    for (const int levels : {2, 4, 6}) cases.push_back({loadTorus(24, 16), levels});
    cases.push_back({test::load(test::dataPath("spot_control_mesh.obj")), 5});
    for (const Case& c : cases) {
        const Hierarchy h = test::refine(c.loaded, c.levels);
        const TiledTable table = buildTiledTable(h, buildPerLevelTable(h), TileSides::Every);
        ASSERT_GT(table.tileCount(), 0u);
        for (const std::uint32_t width : {1u, 3u, 4u, 7u}) {
            SCOPED_TRACE("t = " + std::to_string(table.doubleSteps) + ", width " + std::to_string(width));
            const std::vector<float> controlF = test::animate(c.loaded.mesh.positions, width, 1);
            const std::vector<double> controlD(controlF.begin(), controlF.end());
            std::vector<std::vector<float>> positions, normals;
            std::vector<std::vector<double>> positionsD;
            for (const std::string& set : sets) {
                ASSERT_TRUE(setTileKernelInstructions(set));
                EXPECT_EQ(tileKernelInstructions(), set);
                CpuEvaluator<float> evaluator(table, width, 2);
                positions.emplace_back(std::size_t(table.refinedCount) * width);
                normals.emplace_back(width >= 3 ? 3 * std::size_t(table.refinedCount) : 0);
                if (width >= 3) evaluator.evaluate(controlF, positions.back(), normals.back());
                else evaluator.evaluate(controlF, positions.back());
                CpuEvaluator<double> evaluatorD(table, width, 2);
                positionsD.emplace_back(std::size_t(table.refinedCount) * width);
                evaluatorD.evaluate(controlD, positionsD.back());
            }
            for (std::size_t i = 1; i < sets.size(); ++i) {
                EXPECT_EQ(positions[i], positions[0]) << sets[i] << " against " << sets[0];
                EXPECT_EQ(normals[i], normals[0]) << sets[i] << " against " << sets[0];
                EXPECT_EQ(positionsD[i], positionsD[0]) << sets[i] << " against " << sets[0];
            }
        }
    }
    EXPECT_FALSE(setTileKernelInstructions("sse9"));
}

// Tiled evaluators share each thread's scratch (the larger the tables, the larger it grows):
// evaluators of other sizes and widths taking turns on the same threads give each the results
// it gives alone, on 1 and 2 threads.
TEST(Tiled, EvaluatorsTakingTurnsOnAThreadGiveTheirOwnResults) {
    const test::Loaded small = loadTorus(16, 12), large = loadTorus(64, 48);
    const Hierarchy hs = test::refine(small, 2), hl = test::refine(large, 6);
    const TiledTable ts = buildTiledTable(hs, buildPerLevelTable(hs), TileSides::Every);
    const TiledTable tl = buildTiledTable(hl, buildPerLevelTable(hl));
    ASSERT_GT(ts.tileCount(), 0u);
    ASSERT_GT(tl.tileCount(), 0u);
    ASSERT_NE(ts.doubleSteps, tl.doubleSteps);
    // Width 1 at t = 1 needs about half the scratch of width 4 at t = 3.
    const std::vector<float> controlSmall = test::animate(small.mesh.positions, 1, 0);
    const std::vector<float> controlLarge = test::animate(large.mesh.positions, 4, 0);
    for (const int threads : {1, 2}) {
        SCOPED_TRACE(threads);
        CpuEvaluator<float> evaluatorSmall(ts, 1, threads), evaluatorLarge(tl, 4, threads);
        std::vector<float> aloneSmall(ts.refinedCount), aloneLarge(4 * std::size_t(tl.refinedCount));
        evaluatorSmall.evaluate(controlSmall, aloneSmall);
        evaluatorLarge.evaluate(controlLarge, aloneLarge);
        for (int turn = 0; turn < 2; ++turn) {
            std::vector<float> outSmall(aloneSmall.size()), outLarge(aloneLarge.size());
            evaluatorLarge.evaluate(controlLarge, outLarge);
            evaluatorSmall.evaluate(controlSmall, outSmall);
            EXPECT_EQ(outLarge, aloneLarge);
            EXPECT_EQ(outSmall, aloneSmall);
        }
    }
}

// One evaluator over a changing sequence: each frame is refined from its own control points.
TEST(Tiled, EachFrameOfAChangingSequenceIsRefinedFromItsOwnControlPoints) {
    const test::Loaded torus = loadTorus(24, 16);
    const Hierarchy h = test::refine(torus, 4);
    const TiledTable table = buildTiledTable(h, buildPerLevelTable(h));
    CpuEvaluator<double> evaluator(table, 3, 2);
    std::vector<double> drawing(3 * std::size_t(table.refinedCount)), canonical(drawing.size());
    for (int frame = 0; frame < 3; ++frame) {
        std::vector<double> control = torus.mesh.positions;
        for (std::size_t i = 0; i < control.size(); ++i) control[i] += 0.1 * std::sin(double(i) + frame);
        evaluator.evaluate(control, drawing);
        toCanonical<double>(table, drawing, canonical, 3);
        EXPECT_LE(maxDifference(canonical, refinePositions(h, control)), 1e-12) << "frame " << frame;
    }
}

// Widths 1, 4 and 5 carry linear primvars: value c of a point is that of the same linear function.
TEST(Tiled, OtherWidthsCarryLinearPrimvars) {
    const test::Loaded torus = loadTorus(24, 20);
    const test::Loaded grid = test::load(test::dataPath("grid4x4.obj"));
    for (const test::Loaded* loaded : {&torus, &grid}) {
        const Hierarchy h = test::refine(*loaded, 5);
        const TiledTable table = buildTiledTable(h, buildPerLevelTable(h));
        const std::vector<double> oracle = refinePositions(h, loaded->mesh.positions);
        const std::size_t controls = loaded->mesh.positions.size() / 3;
        for (std::uint32_t width : {1u, 4u, 5u}) {
            std::vector<double> control;
            for (std::size_t v = 0; v < controls; ++v)
                for (std::uint32_t c = 0; c < width; ++c) {
                    const double* p = &loaded->mesh.positions[3 * v];
                    control.push_back(p[c % 3] + double(c) * (p[0] - 2 * p[1] + 0.5 * p[2]));
                }
            const std::vector<double> out = tiledCanonical<double>(table, control, width);
            for (std::size_t v = 0; v < oracle.size() / 3; ++v)
                for (std::uint32_t c = 0; c < width; ++c) {
                    const double* p = &oracle[3 * v];
                    ASSERT_NEAR(out[v * width + c], p[c % 3] + double(c) * (p[0] - 2 * p[1] + 0.5 * p[2]), 1e-9)
                        << "width " << width << " vertex " << v;
                }
        }
    }
}

// Normals of the tiled form (drawing order) are today's definition on its own positions.
TEST(Tiled, NormalsAreTheDefinitionOnTheTiledPositions) {
    const test::Loaded torus = loadTorus(32, 24);
    for (const test::Loaded* loaded : {&torus}) {
        for (int steps : {3, 4}) {
            const Hierarchy h = test::refine(*loaded, steps);
            const PerLevelTable perLevel = buildPerLevelTable(h);
            const TiledTable table = buildTiledTable(h, perLevel);
            const SurfaceTable surface = buildSurfaceTable(h.finest().faces);
            CpuEvaluator<float> tiled(table, 3, 2);
            const std::vector<float> control(loaded->mesh.positions.begin(), loaded->mesh.positions.end());
            std::vector<float> drawing(3 * std::size_t(table.refinedCount)), normals(drawing.size());
            tiled.evaluate(control, drawing);
            tiled.normals(drawing, normals);
            std::vector<float> canonical(drawing.size()), canonicalNormals(drawing.size()), expected(drawing.size());
            toCanonical<float>(table, drawing, canonical, 3);
            toCanonical<float>(table, normals, canonicalNormals, 3);
            CpuEvaluator<float> reference(perLevel, FactorizedTable{}, surface, TableForm::PerLevel, 3, 1);
            reference.normals(canonical, expected);
            for (std::size_t i = 0; i < expected.size(); ++i)
                ASSERT_NEAR(canonicalNormals[i], expected[i], 1e-5) << "value " << i;
        }
    }
}

// Normals with the positions (evaluate with a normals span): the same positions as without,
// and normals within float rounding of normals() on them (the tiles' inner points, from the
// lattice) or equal (the rest, over their faces: in one pass for floats of width 3, the tiles'
// ring faces' normals taken from the tile pass, else in two over lists), on every model (most of
// them mostly fallback: normals() after the positions), and on a torus (all tiles: the tile
// pass's normals) at widths 3 and 4, 1 and 3 threads, float and double.
template <class T>
void expectFusedNormals(const TiledTable& table, const std::vector<double>& positions, std::uint32_t width,
                        int threads, double tolerance, bool inTilePass = false) {
    CpuEvaluator<T> evaluator(table, width, threads);
    if (inTilePass) {
        ASSERT_TRUE(evaluator.normalsInTilePass());
        // The rest in one pass (float, 3 values a vertex, from 2^17 faces), else the two passes
        // over lists.
        EXPECT_EQ(evaluator.restNormalsInOnePass(),
                  (std::is_same_v<T, float> && width == 3 && table.surface.faceOffsets.size() - 1 >= (1u << 17)));
    }
    std::vector<T> control;
    for (std::size_t v = 0; v < positions.size() / 3; ++v)
        for (std::uint32_t c = 0; c < width; ++c) control.push_back(T(c < 3 ? positions[3 * v + c] : 0.5 * c));
    const std::size_t count = table.refinedCount;
    std::vector<T> alone(width * count), fused(width * count), normals(3 * count, T(NAN)), expected(3 * count);
    evaluator.evaluate(control, alone);
    evaluator.evaluate(control, fused, normals);
    ASSERT_EQ(fused, alone);
    // The rest in one pass keeps only the ring faces' normals, not one for every face.
    if (inTilePass) {
        EXPECT_EQ(evaluator.holdsFaceNormals(), !evaluator.restNormalsInOnePass());
    }
    evaluator.normals(fused, expected);
    for (std::size_t i = 0; i < expected.size(); ++i)
        ASSERT_NEAR(double(normals[i]), double(expected[i]), tolerance) << "value " << i << " width " << width;
    // The other points (tiles' borders, the fallback's) sum the same face normals in the same
    // order (the tiles write their outer rings' face normals with normals()'s operations): equal.
    std::vector<char> inner(count, 0);
    for (std::size_t k = 0; k < table.tileCount(); ++k)
        std::fill_n(inner.begin() + table.output[k], std::size_t(table.lattice(k) - 1) * (table.lattice(k) - 1), 1);
    for (std::size_t v = 0; v < count; ++v) {
        if (inner[v]) continue;
        for (int c = 0; c < 3; ++c) ASSERT_EQ(normals[3 * v + c], expected[3 * v + c]) << "vertex " << v;
    }
}

TEST(Tiled, NormalsInTheTilePassAreTheDefinition) {
    std::size_t tiles = 0;
    std::vector<std::string> models = test::allValidModels();
    for (const std::string& path : models)
        for (int steps : {2, 3, 5}) {
            if (steps == 5 && path.find("cow") != std::string::npos) continue;
            SCOPED_TRACE(path + " steps " + std::to_string(steps));
            const test::Loaded loaded = test::load(path);
            const Hierarchy h = test::refine(loaded, steps);
            const TiledTable table = buildTiledTable(h, buildPerLevelTable(h));
            tiles += table.tileCount();
            expectFusedNormals<float>(table, loaded.mesh.positions, 3, 2, 1e-5);
        }
    EXPECT_GT(tiles, 0u);
    const test::Loaded torus = loadTorus(32, 24);
    for (int steps : {2, 4, 6}) {
        SCOPED_TRACE("torus steps " + std::to_string(steps));
        const Hierarchy h = test::refine(torus, steps);
        const TiledTable table = buildTiledTable(h, buildPerLevelTable(h));
        ASSERT_GT(table.tileCount(), 0u);
        for (std::uint32_t width : {3u, 4u})
            for (int threads : {1, 3}) expectFusedNormals<float>(table, torus.mesh.positions, width, threads, 1e-5, true);
        expectFusedNormals<double>(table, torus.mesh.positions, 3, 2, 1e-12, true);
    }
    // A rest of 86k vertices (Spot at 9 steps, 187k faces: tiles' borders and the fallback), in
    // one pass, whose stream of faces goes several times round the window.
    const test::Loaded spot = test::load(test::dataPath("spot_control_mesh.obj"));
    const Hierarchy h = test::refine(spot, 9);
    const TiledTable table = buildTiledTable(h, buildPerLevelTable(h));
    for (int threads : {1, 2, 3}) expectFusedNormals<float>(table, spot.mesh.positions, 3, threads, 1e-5, true);
}

// A vertex on a face whose position is not finite gets a normal that is not finite (`psub play`
// checks the normals whole and only faceless vertices' positions on that account): control
// points of NaN, infinities and a float overflow, through every normals path of the tiled form
// (the tile pass with the rest's two passes over lists: a torus of 49k faces; with the rest's
// one pass: Spot at 9 steps; the one pass over every vertex: the cow at 5 steps, no tile; the two
// passes: the cow at 3 steps), one and two threads.
TEST(Tiled, ANonFinitePositionOnAFaceHasANonFiniteNormal) {
    const test::Loaded torus = loadTorus(32, 24), spot = test::load(test::dataPath("spot_control_mesh.obj")),
                       cow = test::load(test::dataPath("cow.obj"));
    enum class Path { TilePassRestListed, TilePassRestOnePass, OnePass, TwoPasses };
    const std::tuple<const test::Loaded*, int, const char*, Path> cases[] = {
        {&torus, 6, "torus", Path::TilePassRestListed},
        {&spot, 9, "Spot", Path::TilePassRestOnePass},
        {&cow, 5, "cow, 5 steps", Path::OnePass},
        {&cow, 3, "cow, 3 steps", Path::TwoPasses}};
    for (const auto& [loaded, steps, name, path] : cases) {
        const Hierarchy h = test::refine(*loaded, steps);
        const TiledTable table = buildTiledTable(h, buildPerLevelTable(h));
        for (int threads : {1, 2}) {
            CpuEvaluator<float> evaluator(table, 3, threads);
            ASSERT_EQ(evaluator.normalsInTilePass(), path == Path::TilePassRestListed || path == Path::TilePassRestOnePass)
                << name;
            ASSERT_EQ(evaluator.restNormalsInOnePass(), path == Path::TilePassRestOnePass) << name;
            ASSERT_EQ(evaluator.normalsInOnePass(), path == Path::OnePass) << name;
            for (const double bad : {double(NAN), double(INFINITY), -double(INFINITY), 3e38}) {
                SCOPED_TRACE(std::string(name) + ", threads " + std::to_string(threads) + ", bad " + std::to_string(bad));
                std::vector<float> control(loaded->mesh.positions.begin(), loaded->mesh.positions.end());
                const std::size_t at = 3 * (control.size() / 6) + 1;  // the middle vertex's y
                control[at] = float(bad);
                if (bad == 3e38) control[at + 3] = float(bad);  // the next one too: sums overflow
                std::vector<float> refined(3 * std::size_t(table.refinedCount)), normals(refined.size());
                evaluator.evaluate(control, refined, normals);
                std::size_t broken = 0;
                for (std::size_t v = 0; v < table.refinedCount; ++v) {
                    const float* p = &refined[3 * v];
                    if (std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2])) continue;
                    ++broken;
                    const float* n = &normals[3 * v];
                    ASSERT_FALSE(std::isfinite(n[0]) && std::isfinite(n[1]) && std::isfinite(n[2])) << "vertex " << v;
                }
                EXPECT_GT(broken, 0u);
            }
        }
    }
}

// refine() builds the finest level's faces only and walks the lattices on level N - 2, kept
// as it goes (level B itself at t = 1, a level of its own at t = 2 and 3): the same table as
// from the whole hierarchy, with both boundary modes (a split boundary renumbers the faces the
// lattices' edge middles come from) and every tile count.
TEST(Tiled, RefineFacadeBuildsTheTiledForm) {
    std::vector<std::string> models = test::manifoldModelsWithBoundary();
    models.resize(std::min<std::size_t>(models.size(), 3));
    models.push_back("");  // a 30 x 20 torus
    std::size_t tiles[2][4] = {};  // [boundary][double steps]
    for (const std::string& path : models)
        for (Boundary boundary : {Boundary::Paper, Boundary::Smooth})
            for (int levels = 2; levels <= (path.empty() ? 6 : 5); ++levels) {
                SCOPED_TRACE((path.empty() ? "torus" : path) + " levels " + std::to_string(levels) + " " + boundaryName(boundary));
                const test::Loaded loaded = path.empty() ? loadTorus(30, 20) : test::load(path);
                const Refinement r = refine(loaded.mesh, loaded.checked.connectivity,
                                            test::tiledOptions(levels, boundary, Rules::Paper, TileSides::Every));
                const Hierarchy h = test::refine(loaded, levels, Preprocess::Auto, boundary);
                TiledTable expected = buildTiledTable(h, buildPerLevelTable(h), TileSides::Every);
                vertexRowsFromFacePoints(expected.rows);  // as refine() leaves its tables
                EXPECT_EQ(r.tiled.doubleSteps, expected.doubleSteps);
                EXPECT_EQ(r.tiled.canonical, expected.canonical);
                EXPECT_EQ(r.tiled.gather, expected.gather);
                EXPECT_EQ(r.tiled.rows.indices, expected.rows.indices);
                EXPECT_EQ(r.tiled.surface.faceVerts, expected.surface.faceVerts);
                tiles[int(boundary)][r.tiled.doubleSteps] += r.tiled.tileCount();
            }
    for (int boundary = 0; boundary < 2; ++boundary)
        for (int t = 1; t <= 3; ++t) EXPECT_GT(tiles[boundary][t], 0u) << boundary << " " << t;
}

// The tiles of two tiled tables: sides, gathers, output ranges and border points.
void expectSameTiles(const TiledTable& a, const TiledTable& b) {
    EXPECT_EQ(a.side, b.side);
    EXPECT_EQ(a.gatherBegin, b.gatherBegin);
    EXPECT_EQ(a.gather, b.gather);
    EXPECT_EQ(a.output, b.output);
    EXPECT_EQ(a.borderBegin, b.borderBegin);
    EXPECT_EQ(a.border, b.border);
}

// Every array of two tiled tables, compared whole.
void expectSameTable(const TiledTable& a, const TiledTable& b) {
    EXPECT_EQ(std::tie(a.controlCount, a.refinedCount, a.baseLevel, a.doubleSteps, a.halo, a.fallbackBegin),
              std::tie(b.controlCount, b.refinedCount, b.baseLevel, b.doubleSteps, b.halo, b.fallbackBegin));
    EXPECT_EQ(a.rows.controlCount, b.rows.controlCount);
    ASSERT_EQ(a.rows.levels.size(), b.rows.levels.size());
    for (std::size_t k = 0; k < a.rows.levels.size(); ++k) {
        const StencilLevel &x = a.rows.levels[k], &y = b.rows.levels[k];
        EXPECT_EQ(std::tie(x.sourceCount, x.destinationCount, x.groupBegin, x.groupEnd, x.rowBegin, x.rowEnd),
                  std::tie(y.sourceCount, y.destinationCount, y.groupBegin, y.groupEnd, y.rowBegin, y.rowEnd)) << "level " << k;
    }
    ASSERT_EQ(a.rows.groups.size(), b.rows.groups.size());
    for (std::size_t g = 0; g < a.rows.groups.size(); ++g) {
        const RowGroup &x = a.rows.groups[g], &y = b.rows.groups[g];
        EXPECT_EQ(std::tie(x.kind, x.n, x.m, x.width, x.rowBegin, x.rowCount, x.indexBegin, x.centre, x.edge, x.diagonal),
                  std::tie(y.kind, y.n, y.m, y.width, y.rowBegin, y.rowCount, y.indexBegin, y.centre, y.edge, y.diagonal))
            << "group " << g;
    }
    EXPECT_EQ(a.rows.destinations, b.rows.destinations);
    EXPECT_EQ(a.rows.indices, b.rows.indices);
    expectSameTiles(a, b);
    EXPECT_EQ(a.canonical, b.canonical);
    EXPECT_EQ(a.surface.faceOffsets, b.surface.faceOffsets);
    EXPECT_EQ(a.surface.faceVerts, b.surface.faceVerts);
    EXPECT_EQ(a.surface.vertexOffsets, b.surface.vertexOffsets);
    EXPECT_EQ(a.surface.vertexFaces, b.surface.vertexFaces);
    EXPECT_EQ(a.uvFaceOffsets, b.uvFaceOffsets);
    EXPECT_EQ(a.uvFaceVerts, b.uvFaceVerts);
    EXPECT_EQ(a.uvFaceValues, b.uvFaceValues);
}

// The lean build (RefineOptions::perLevel = false: the tiled form's rows made only where its
// fallback can need them, docs/tiled.md) makes the very table the full build copies from the
// per-level rows: every model (unused and non-manifold vertices, triangles, boundaries), both
// boundary modes, the paper and shape rules, every tile count, all three side choices (no tiles:
// the paper rules), 0 to 5 steps. Where the tiles cover the mesh (the torus) the lean build
// takes the surface from the tiles' lattices and never makes levels N - 1 and N: the same
// arrays as the full build's faces sorted (expectSameTable).
TEST(Tiled, TheLeanBuildMakesTheFullBuildsTable) {
    std::vector<std::string> models = test::allValidModels();
    models.push_back("");  // a 30 x 20 torus
    std::size_t tiles[2][4] = {};  // [boundary][double steps]
    std::size_t fallbackPoints = 0;
    std::size_t wholeTiled = 0;  // lean builds whose surface is the tiles' own faces (no level N - 1)
    for (const std::string& path : models)
        for (Boundary boundary : {Boundary::Paper, Boundary::Smooth})
            for (Rules rules : {Rules::Paper, Rules::Shape})
                for (TileSides sides : {TileSides::Every, TileSides::Cheapest, TileSides::None})
                    for (int levels = 0; levels <= (path.find("cow") != std::string::npos ? 3 : path.empty() ? 6 : 5); ++levels) {
                        if (sides == TileSides::Cheapest && !path.empty() && rules == Rules::Shape) continue;
                        if (sides == TileSides::None && rules == Rules::Shape) continue;
                        // Under AddressSanitizer (memory errors, not tables) the paper rules with
                        // every side: a third of the builds (the CI's time).
                        if (test::kSanitized && (rules == Rules::Shape || sides != TileSides::Every)) continue;
                        SCOPED_TRACE((path.empty() ? "torus" : path) + " levels " + std::to_string(levels) + " " +
                                     boundaryName(boundary) + " " + rulesName(rules) +
                                     (sides == TileSides::Every      ? " every side"
                                      : sides == TileSides::Cheapest ? " cheapest sides"
                                                                     : " no tiles"));
                        const test::Loaded loaded = path.empty() ? loadTorus(30, 20) : test::load(path);
                        RefineOptions options = test::tiledOptions(levels, boundary, rules, sides);
                        const Refinement full = refine(loaded.mesh, loaded.checked.connectivity, options);
                        options.perLevel = false;
                        const Refinement lean = refine(loaded.mesh, loaded.checked.connectivity, options);
                        expectSameTable(lean.tiled, full.tiled);
                        EXPECT_TRUE(lean.perLevel.levels.empty());
                        EXPECT_TRUE(lean.surface.faceVerts.empty());
                        tiles[int(boundary)][lean.tiled.doubleSteps] += lean.tiled.tileCount();
                        if (lean.tiled.tileCount() > 0) fallbackPoints += lean.tiled.refinedCount - lean.tiled.fallbackBegin;
                        const TiledTable& t = lean.tiled;
                        if (t.tileCount() > 0 && t.fallbackBegin == t.refinedCount && lean.uv.perLevel.levels.empty())
                            ++wholeTiled;
                    }
    for (int boundary = 0; boundary < 2; ++boundary)
        for (int t = 1; t <= 3; ++t) EXPECT_GT(tiles[boundary][t], 0u) << boundary << " " << t;
    EXPECT_GT(fallbackPoints, 0u);  // tiles beside fallback rows, not only all-tile tables
    EXPECT_GT(wholeTiled, 0u);      // and tables all tiles, whose lean build ends on level N - 2
}

// A quad with its corners turned to start at the least: faces compare as sets of cycles.
std::vector<std::array<Index, 4>> cycles(const SurfaceTable& surface) {
    std::vector<std::array<Index, 4>> quads;
    for (std::size_t f = 0; f + 1 < surface.faceOffsets.size(); ++f) {
        const Index* q = surface.faceVerts.data() + surface.faceOffsets[f];
        const std::size_t least = std::size_t(std::min_element(q, q + 4) - q);
        quads.push_back({q[least], q[(least + 1) % 4], q[(least + 2) % 4], q[(least + 3) % 4]});
    }
    std::sort(quads.begin(), quads.end());
    return quads;
}

// The drawing-only build (RefineOptions::canonicalOrder false) places the tiles on level B
// where they cover the mesh (a torus at every double step count): the lean build's tiles,
// drawing positions and level sizes, the same faces (tile after tile instead of by first drawn
// corner), the same positions bit for bit and normals within float rounding, on one thread
// and two; no canonical order (toCanonical refuses), and no level after B made (onLevel
// reports the steps not taken with 0 s). Where tiles do not cover the mesh (Spot, a torus with
// tiles turned off) it is the lean build, canonical order and all.
TEST(Tiled, TheDrawingOnlyBuildPlacesTheTilesOnLevelB) {
    std::size_t drawingOnly[4] = {};  // per double step count
    for (const auto& [nu, nv] : {std::pair<Index, Index>{30, 20}, {48, 32}})
        for (int levels = 2; levels <= 6; ++levels) {
            SCOPED_TRACE("torus " + std::to_string(nu) + " x " + std::to_string(nv) + " levels " + std::to_string(levels));
            const test::Loaded loaded = loadTorus(nu, nv);
            RefineOptions options = test::tiledOptions(levels, Boundary::Paper, Rules::Paper, TileSides::Every);
            options.perLevel = false;
            const Refinement lean = refine(loaded.mesh, loaded.checked.connectivity, options);
            options.canonicalOrder = false;
            std::vector<std::pair<int, double>> reported;
            options.onLevel = [&](int level, double seconds) { reported.emplace_back(level, seconds); };
            const Refinement r = refine(loaded.mesh, loaded.checked.connectivity, options);
            const TiledTable &a = r.tiled, &b = lean.tiled;
            if (b.fallbackBegin != b.refinedCount) {  // tiles leave points to the fallback: the lean build
                EXPECT_EQ(a.canonical.size(), a.refinedCount);
                expectSameTable(a, b);
                continue;
            }
            EXPECT_TRUE(a.canonical.empty());
            EXPECT_EQ(std::tie(a.controlCount, a.refinedCount, a.baseLevel, a.doubleSteps, a.halo, a.fallbackBegin),
                      std::tie(b.controlCount, b.refinedCount, b.baseLevel, b.doubleSteps, b.halo, b.fallbackBegin));
            expectSameTiles(a, b);
            ASSERT_EQ(a.rows.levels.size(), b.rows.levels.size());
            for (std::size_t k = 0; k < a.rows.levels.size(); ++k)
                EXPECT_EQ(std::tie(a.rows.levels[k].sourceCount, a.rows.levels[k].destinationCount),
                          std::tie(b.rows.levels[k].sourceCount, b.rows.levels[k].destinationCount));
            EXPECT_EQ(a.rows.indices, b.rows.indices);
            EXPECT_EQ(a.surface.faceOffsets, b.surface.faceOffsets);
            EXPECT_EQ(cycles(a.surface), cycles(b.surface));
            // Each vertex's faces as buildSurfaceTable lists them (in face order).
            Faces faces;
            faces.vertexCount = a.refinedCount;
            faces.offsets = a.surface.faceOffsets;
            faces.verts = a.surface.faceVerts;
            const SurfaceTable listed = buildSurfaceTable(std::move(faces));
            EXPECT_EQ(a.surface.vertexCount, listed.vertexCount);
            EXPECT_EQ(a.surface.vertexOffsets, listed.vertexOffsets);
            EXPECT_EQ(a.surface.vertexFaces, listed.vertexFaces);
            // Only level B's topology was made: every later step reported as not taken.
            ASSERT_EQ(reported.size(), std::size_t(levels));
            for (int level = 1; level <= levels; ++level) {
                EXPECT_EQ(reported[std::size_t(level - 1)].first, level);
                if (level > int(a.baseLevel)) {
                    EXPECT_EQ(reported[std::size_t(level - 1)].second, 0.0);
                }
            }
            const std::vector<float> control(loaded.mesh.positions.begin(), loaded.mesh.positions.end());
            for (int threads : {1, 2}) {
                CpuEvaluator<float> drawn(a, 3, threads), expected(b, 3, threads);
                std::vector<float> positions(3 * std::size_t(a.refinedCount)), normals(positions.size());
                std::vector<float> expectedPositions(positions.size()), expectedNormals(positions.size());
                drawn.evaluate(control, positions, normals);
                expected.evaluate(control, expectedPositions, expectedNormals);
                EXPECT_EQ(positions, expectedPositions);
                for (std::size_t i = 0; i < normals.size(); ++i) ASSERT_NEAR(normals[i], expectedNormals[i], 1e-6) << i;
                std::vector<float> canonical(positions.size());
                EXPECT_THROW(toCanonical<float>(a, positions, canonical, 3), std::invalid_argument);
            }
            ++drawingOnly[a.doubleSteps];
        }
    for (int t = 1; t <= 3; ++t) EXPECT_GT(drawingOnly[t], 0u) << t;
    // Where the tiles do not cover the mesh: the lean build itself.
    for (const std::string& path : {test::dataPath("spot_control_mesh.obj"), std::string()}) {
        const test::Loaded loaded = path.empty() ? loadTorus(30, 20) : test::load(path);
        RefineOptions options = test::tiledOptions(path.empty() ? 4 : 7, Boundary::Paper, Rules::Paper,
                                                   path.empty() ? TileSides::None : TileSides::Cheapest);
        options.perLevel = false;
        const Refinement lean = refine(loaded.mesh, loaded.checked.connectivity, options);
        options.canonicalOrder = false;
        const Refinement r = refine(loaded.mesh, loaded.checked.connectivity, options);
        EXPECT_EQ(r.tiled.canonical.size(), r.tiled.refinedCount);
        expectSameTable(r.tiled, lean.tiled);
    }
}

// Without tiles (TileSides::None, psub play's third tiled candidate on several threads): the plan's
// double steps and base level kept, no tile, every finest point the fallback's, the same numbers
// as the rules on a torus (which the tiles would cover whole) and on Spot, both boundary modes,
// and the lean build makes the full build's table. Only a table whose tiles write under 90% of
// the points is worth timing without them (Spot, not the torus, nor a table without tiles).
TEST(Tiled, WithoutTilesEveryPointIsTheFallbacksWithTheRulesNumbers) {
    for (const std::string& path : {std::string(), test::dataPath("spot_control_mesh.obj")})
        for (Boundary boundary : {Boundary::Paper, Boundary::Smooth}) {
            const test::Loaded loaded = path.empty() ? loadTorus(48, 32) : test::load(path);
            SCOPED_TRACE((path.empty() ? "torus" : path) + " " + boundaryName(boundary));
            const int steps = path.empty() ? 4 : 7;
            const Hierarchy h = test::refine(loaded, steps, Preprocess::Auto, boundary);
            const PerLevelTable perLevel = buildPerLevelTable(h);
            const TiledTable tiles = buildTiledTable(h, perLevel), none = buildTiledTable(h, perLevel, TileSides::None);
            ASSERT_GT(tiles.tileCount(), 0u);
            EXPECT_EQ(none.tileCount(), 0u);
            EXPECT_EQ(none.fallbackBegin, 0u);
            EXPECT_EQ(none.refinedCount, tiles.refinedCount);
            EXPECT_EQ(none.doubleSteps, tiles.doubleSteps);
            EXPECT_EQ(none.baseLevel, tiles.baseLevel);
            EXPECT_EQ(worthTimingWithoutTiles(tiles), !path.empty());
            EXPECT_FALSE(worthTimingWithoutTiles(none));
            const std::vector<double> oracle = refinePositions(h, loaded.mesh.positions);
            const double scale = diagonal(loaded.mesh.positions);
            EXPECT_LE(maxDifference(tiledCanonical<float>(none, loaded.mesh.positions), oracle), 1e-6 * scale);
            EXPECT_LE(maxDifference(tiledCanonical<double>(none, loaded.mesh.positions, 3, 2), oracle), 1e-12 * scale);
            RefineOptions options = test::tiledOptions(path.empty() ? 4 : 6, boundary, Rules::Paper, TileSides::None);
            const Refinement full = refine(loaded.mesh, loaded.checked.connectivity, options);
            options.perLevel = false;
            const Refinement lean = refine(loaded.mesh, loaded.checked.connectivity, options);
            EXPECT_EQ(lean.tiled.tileCount(), 0u);
            expectSameTable(lean.tiled, full.tiled);
        }
}

// Where the fallback is most of the finest points, the lean build renumbers the levels in walk
// order beside the faces' sort (two threads; docs/tiled.md, "The lean build"); on one thread,
// and in the full build, one after the other. The tables must be the same: the cow and a 4 x 4
// grid (no tile; the grid with the smooth boundary's split edges) and Spot (tiles beside a
// fallback of three quarters), lean and full builds, on 1 and 2 threads.
TEST(Tiled, TheTableIsTheSameOnOneThreadAndTwo) {
    const test::OmpThreadsRestored restore;
    for (const char* name : {"cow.obj", "spot_control_mesh.obj", "grid4x4.obj"})
        for (const bool perLevel : {false, true}) {
            SCOPED_TRACE(std::string(name) + (perLevel ? " full" : " lean"));
            const test::Loaded loaded = test::load(test::dataPath(name));
            RefineOptions options = test::tiledOptions(std::string(name) == "cow.obj" ? 4 : 6, Boundary::Smooth);
            options.perLevel = perLevel;
            omp_set_num_threads(1);
            const Refinement one = refine(loaded.mesh, loaded.checked.connectivity, options);
            omp_set_num_threads(2);
            const Refinement two = refine(loaded.mesh, loaded.checked.connectivity, options);
            omp_set_num_threads(restore.found);
            EXPECT_GE(2 * (one.tiled.refinedCount - one.tiled.fallbackBegin), one.tiled.refinedCount);
            EXPECT_EQ(one.tiled.tileCount() > 0, std::string(name) == "spot_control_mesh.obj");
            expectSameTable(one.tiled, two.tiled);
        }
}

// placeTiles runs on the threads from 65,536 lattice faces, in batches of four tiles a thread:
// a torus the tiles cover whole, past that size and with more tiles than one batch, built lean
// on two threads (its lattices walked, its finest faces made on both) is the full build's table
// (whose faces refine makes) and the lean build's on one thread.
TEST(Tiled, TheLeanBuildOnTwoThreadsMakesTheFullBuildsTable) {
    const test::OmpThreadsRestored restore;
    const test::Loaded torus = loadTorus(96, 96);
    RefineOptions options = test::tiledOptions(4, Boundary::Smooth);
    omp_set_num_threads(2);
    const Refinement full = refine(torus.mesh, torus.checked.connectivity, options);
    options.perLevel = false;
    const Refinement lean = refine(torus.mesh, torus.checked.connectivity, options);
    omp_set_num_threads(1);
    const Refinement leanOnOne = refine(torus.mesh, torus.checked.connectivity, options);
    omp_set_num_threads(restore.found);
    const TiledTable& t = lean.tiled;
    EXPECT_GE(t.surface.faceOffsets.size() - 1, 65536u);
    EXPECT_GT(t.tileCount(), 8u);
    EXPECT_EQ(t.fallbackBegin, t.refinedCount);  // every point a tile's: the faces are the tiles'
    expectSameTable(lean.tiled, full.tiled);
    expectSameTable(leanOnOne.tiled, full.tiled);
}

// Without the per-level table only the tiled form can be built.
TEST(Tiled, OnlyTheTiledFormIsBuiltWithoutThePerLevelTable) {
    const test::Loaded torus = loadTorus(12, 12);
    RefineOptions options;
    options.perLevel = false;
    EXPECT_THROW(refine(torus.mesh, torus.checked.connectivity, options), std::invalid_argument);
    options.tiled = true;
    options.factorized = true;
    EXPECT_THROW(refine(torus.mesh, torus.checked.connectivity, options), std::invalid_argument);
    options.factorized = false;
    EXPECT_NO_THROW(refine(torus.mesh, torus.checked.connectivity, options));
}

// The levels buildTiledTable walks and names the lattices from are checked against the table:
// level N - 1 in place of N - 2, a wrong level B, or the wrong split flag on a boundary model
// (the smooth boundary splits at odd P-S steps) is refused, not turned into a wrong table.
TEST(Tiled, LevelsThatAreNotTheTablesAreRefused) {
    const test::Loaded torus = loadTorus(24, 16);
    const Hierarchy h = test::refine(torus, 4);
    const PerLevelTable perLevel = buildPerLevelTable(h);
    const TiledPlan plan = planTiled(h.levels.size() - 1, h.preprocessed, h.levels[0]);
    ASSERT_EQ(plan.doubleSteps, 2u);
    EXPECT_NO_THROW(buildTiledTable(perLevel, h.levels[plan.baseLevel], h.levels[2], false, h.finest().faces, plan));
    EXPECT_THROW(buildTiledTable(perLevel, h.levels[plan.baseLevel], h.levels[3], false, h.finest().faces, plan),
                 std::invalid_argument);
    EXPECT_THROW(buildTiledTable(perLevel, h.levels[1], h.levels[2], false, h.finest().faces, plan),
                 std::invalid_argument);
    const std::vector<std::string> bounded = test::manifoldModelsWithBoundary();
    ASSERT_FALSE(bounded.empty());
    const test::Loaded open = test::load(bounded.front());
    // Smooth splits at odd P-S steps: the step to level N - 1 is one at 2 or 3 steps.
    for (int steps : {2, 3}) {
        const Hierarchy s = test::refine(open, steps, Preprocess::Auto, Boundary::Smooth);
        const bool split = s.splitsBoundary(s.levels.size() - 2);
        if (!split) continue;
        const PerLevelTable smooth = buildPerLevelTable(s);
        const TiledPlan one = planTiled(s.levels.size() - 1, s.preprocessed, s.levels[s.preprocessed ? 1 : 0]);
        ASSERT_EQ(one.doubleSteps, 1u);
        const Level& coarse = s.levels[s.levels.size() - 3];
        EXPECT_NO_THROW(buildTiledTable(smooth, coarse, coarse, true, s.finest().faces, one));
        EXPECT_THROW(buildTiledTable(smooth, coarse, coarse, false, s.finest().faces, one), std::invalid_argument);
        return;
    }
    FAIL() << "no step count whose step to level N - 1 splits the boundary";
}

TEST(Tiled, TheOtherConstructorRefusesTheTiledForm) {
    const PerLevelTable perLevel;
    const FactorizedTable factorized;
    const SurfaceTable surface;
    EXPECT_THROW(CpuEvaluator<float>(perLevel, factorized, surface, TableForm::Tiled), std::invalid_argument);
}

}  // namespace
}  // namespace psub
