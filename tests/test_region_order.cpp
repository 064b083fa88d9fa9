// The per-level table ordered by region (orderLevelsByRegion): still a table of the same rows,
// the same bits from the CPU evaluator on any thread count, the tiled form's rows too, and the
// locality it is for.
#include "psub/evaluator.h"
#include "psub/stencils.h"
#include "test_support.h"
#include "tiled_options.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <stdexcept>

namespace psub {
namespace {

PerLevelTable tableOf(const std::string& path, int steps, Boundary boundary = Boundary::Paper,
                      Rules rules = Rules::Paper) {
    const test::Loaded loaded = test::load(path);
    return buildPerLevelTable(test::refine(loaded, steps, Preprocess::Auto, boundary), rules);
}

template <class T>
std::vector<T> evaluated(const PerLevelTable& table, const std::vector<double>& control, int threads) {
    const FactorizedTable none;
    const SurfaceTable surface;
    CpuEvaluator<T> evaluator(table, none, surface, TableForm::PerLevel, 3, threads);
    const std::vector<T> in(control.begin(), control.end());
    std::vector<T> out(3 * std::size_t(table.refinedCount()));
    evaluator.evaluate(in, out);
    return out;
}

// The rows of each level as (kind, n, m, destination's finest-or-not, sources) are a
// permutation of the original's, up to the renumbering: checked through what matters, each
// level writing each of its points once, with sources of the level before.
void expectATable(const PerLevelTable& table) {
    std::uint32_t sourceCount = table.controlCount;
    for (const StencilLevel& level : table.levels) {
        std::vector<int> written(level.destinationCount, 0);
        for (std::uint64_t g = level.groupBegin; g < level.groupEnd; ++g) {
            const RowGroup& group = table.groups[g];
            for (std::uint64_t r = 0; r < group.rowCount; ++r) {
                ++written[table.destinations[group.rowBegin + r]];
                // The level's own points, but a VertexFromCentreAndFacePoints row's centre.
                const std::uint32_t count = readsOwnLevel(group.kind) ? level.destinationCount : sourceCount;
                const std::uint32_t firstCount =
                    group.kind == RowKind::VertexFromCentreAndFacePoints ? sourceCount : count;
                for (std::uint32_t j = 0; j < group.width; ++j)
                    ASSERT_LT(table.indices[group.indexBegin + r * group.width + j], j == 0 ? firstCount : count);
            }
        }
        for (int count : written) ASSERT_EQ(count, 1);
        sourceCount = level.destinationCount;
    }
}

TEST(RegionOrder, GivesTheSameBitsOnEveryModelBoundaryAndRuleSet) {
    for (const std::string& path : test::allValidModels())
        for (Boundary boundary : {Boundary::Paper, Boundary::Smooth})
            for (Rules rules : {Rules::Paper, Rules::Shape})
              for (bool facePoints : {false, true}) {  // as built, and with vertexRowsFromFacePoints
                SCOPED_TRACE(path + (boundary == Boundary::Smooth ? " smooth" : " paper") + " " + rulesName(rules) +
                             (facePoints ? " face points" : ""));
                PerLevelTable table = tableOf(path, 3, boundary, rules);
                if (facePoints) vertexRowsFromFacePoints(table);
                const std::vector<double> control = test::load(path).mesh.positions;
                const std::vector<float> expected = evaluated<float>(table, control, 1);
                const std::vector<double> expectedDouble = evaluated<double>(table, control, 1);
                for (std::uint32_t regions : {2u, 3u}) {
                    PerLevelTable ordered = table;
                    orderLevelsByRegion(ordered, regions);
                    EXPECT_EQ(ordered.regions, regions);
                    expectATable(ordered);
                    ASSERT_EQ(ordered.levels.size(), table.levels.size());
                    for (std::size_t g = 0; g < table.groups.size(); ++g)
                        ASSERT_EQ(ordered.groups[g].rowCount, table.groups[g].rowCount);
                    for (int threads : {1, 2, 3}) {
                        EXPECT_EQ(evaluated<float>(ordered, control, threads), expected) << threads << " threads";
                        EXPECT_EQ(evaluated<double>(ordered, control, threads), expectedDouble) << threads << " threads";
                    }
                }
            }
}

// Meshes big enough for the evaluator to start its threads (it runs small ones on one), with a
// control mesh that moves: the region-ordered table on 2, 3 and 4 threads gives the table's bits.
TEST(RegionOrder, ThreadsOnALargeMeshGiveTheTablesBits) {
    for (const auto& [name, steps] : {std::pair{"spot_control_mesh.obj", 7}, std::pair{"cow.obj", 4}}) {
        SCOPED_TRACE(name);
        const std::string path = test::dataPath(name);
        PerLevelTable table = tableOf(path, steps);
        ASSERT_GT(vertexRowsFromFacePoints(table), 0u);  // as refine() leaves it
        ASSERT_GE(6 * std::uint64_t(table.refinedCount()), 4u * 32768);  // so that 4 threads start
        std::vector<double> control = test::load(path).mesh.positions;
        for (std::size_t i = 0; i < control.size(); ++i) control[i] += 0.01 * std::sin(double(i));
        const std::vector<float> expected = evaluated<float>(table, control, 1);
        for (std::uint32_t regions : {2u, 4u}) {
            PerLevelTable ordered = table;
            orderLevelsByRegion(ordered, regions);
            for (int threads : {1, 2, 3, 4})
                EXPECT_EQ(evaluated<float>(ordered, control, threads), expected) << regions << " regions, " << threads;
        }
    }
}

// What the order is for: with each of two threads taking an even share of every row group (the
// evaluator's split of a region-ordered table), the sources a thread reads at levels 2 .. N are
// mostly points it wrote itself at the level before. The same split of the table as refined
// reads about half from the other thread.
double ownReads(const PerLevelTable& table) {
    std::vector<std::uint8_t> writer(table.controlCount, 2), nextWriter;  // 2: a control point
    std::uint64_t own = 0, all = 0;
    for (const StencilLevel& level : table.levels) {
        nextWriter.assign(level.destinationCount, 2);
        for (std::uint64_t g = level.groupBegin; g < level.groupEnd; ++g) {
            const RowGroup& group = table.groups[g];
            for (std::uint64_t r = 0; r < group.rowCount; ++r) {
                const std::uint8_t thread = r < group.rowCount / 2 ? 0 : 1;  // share(): rows * t / 2
                nextWriter[table.destinations[group.rowBegin + r]] = thread;
                for (std::uint32_t j = 0; j < group.width; ++j) {
                    const std::uint8_t from = writer[table.indices[group.indexBegin + r * group.width + j]];
                    if (from == 2) continue;
                    ++all;
                    own += from == thread;
                }
            }
        }
        writer.swap(nextWriter);
    }
    return double(own) / double(std::max<std::uint64_t>(all, 1));
}

TEST(RegionOrder, EachThreadReadsMostlyWhatItWrote) {
    for (const char* name : {"spot_control_mesh.obj", "cow.obj"}) {
        SCOPED_TRACE(name);
        const PerLevelTable table = tableOf(test::dataPath(name), 6);
        PerLevelTable ordered = table;
        orderLevelsByRegion(ordered, 2);
        const double asRefined = ownReads(table), byRegion = ownReads(ordered);
        std::printf("%s: own reads %.3f as refined, %.3f by region\n", name, asRefined, byRegion);
        EXPECT_GT(byRegion, 0.9);
        EXPECT_LT(asRefined, 0.75);
    }
}

// The tiled form's rows ordered by region up to its level B (which the tiles gather from, so it
// keeps its numbering): the same bits, positions and normals, on 1 to 3 threads; both boundary
// modes, tiles on every regular block (many tile borders beside the fallback).
TEST(RegionOrder, TheTiledFormsRowsUpToLevelBGiveTheSameBits) {
    for (const auto& [name, steps] : {std::pair{"spot_control_mesh.obj", 7}, std::pair{"cow.obj", 6}})
        for (Boundary boundary : {Boundary::Paper, Boundary::Smooth}) {
            SCOPED_TRACE(name + std::string(boundary == Boundary::Smooth ? " smooth" : " paper"));
            const test::Loaded loaded = test::load(test::dataPath(name));
            const Refinement r = refine(loaded.mesh, loaded.checked.connectivity,
                                        test::tiledOptions(steps, boundary, Rules::Paper, TileSides::Every));
            ASSERT_GT(r.tiled.tileCount(), 0u);
            ASSERT_GT(r.tiled.baseLevel, 1u);
            TiledTable ordered = r.tiled;
            orderLevelsByRegion(ordered.rows, 2, ordered.baseLevel);
            EXPECT_EQ(ordered.rows.regionLevels, ordered.baseLevel);
            std::vector<double> moved = loaded.mesh.positions;
            for (std::size_t i = 0; i < moved.size(); ++i) moved[i] += 0.01 * std::cos(double(i));
            const std::vector<float> control(moved.begin(), moved.end());
            const auto frame = [&](const TiledTable& table, int threads) {
                CpuEvaluator<float> evaluator(table, 3, threads);
                std::vector<float> positions(3 * std::size_t(table.refinedCount)), normals(positions.size());
                evaluator.evaluate(control, positions, normals);
                positions.insert(positions.end(), normals.begin(), normals.end());
                return positions;
            };
            const std::vector<float> expected = frame(r.tiled, 1);
            for (int threads : {1, 2, 3}) EXPECT_EQ(frame(ordered, threads), expected) << threads << " threads";
        }
}

TEST(RegionOrder, KeepsTheFinestLevelsNumbersAndRefusesWhatItCannotDo) {
    const PerLevelTable table = tableOf(test::dataPath("cube.obj"), 3);
    PerLevelTable ordered = table;
    EXPECT_THROW(orderLevelsByRegion(ordered, 0), std::invalid_argument);
    orderLevelsByRegion(ordered, 1);  // one region: the table as it is
    EXPECT_EQ(ordered.regions, 1u);
    EXPECT_EQ(ordered.indices, table.indices);
    EXPECT_EQ(ordered.destinations, table.destinations);
    orderLevelsByRegion(ordered, 2);
    EXPECT_THROW(orderLevelsByRegion(ordered, 2), std::invalid_argument);  // ordered already
    // The finest level's rows write the same points (in region order), the control points are
    // the first level's sources as before.
    const StencilLevel& last = table.levels.back();
    std::vector<std::uint32_t> a(table.destinations.begin() + std::ptrdiff_t(last.rowBegin), table.destinations.end()),
        b(ordered.destinations.begin() + std::ptrdiff_t(last.rowBegin), ordered.destinations.end());
    std::sort(a.begin(), a.end());
    std::sort(b.begin(), b.end());
    EXPECT_EQ(a, b);
    PerLevelTable broken = table;
    broken.indices.back() = broken.levels[broken.levels.size() - 2].destinationCount;  // past its level
    EXPECT_THROW(orderLevelsByRegion(broken, 2), std::invalid_argument);
}

}  // namespace
}  // namespace psub
