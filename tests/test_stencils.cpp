// Stencil tables and the CPU evaluator against the rule oracle: every model, both table
// forms, float and double, row ranges, widths, layouts, threads, frames and normals.
#include "psub/evaluator.h"
#include "psub/rules.h"
#include "psub/stencils.h"
#include "psub/tiled.h"
#include "test_support.h"

#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstdint>
#include <memory>
#include <random>
#include <span>
#include <stdexcept>

#include <sys/mman.h>
#include <unistd.h>

namespace psub {
namespace {

using test::load;

struct Refined {
    test::Loaded loaded;
    Hierarchy hierarchy;
    PerLevelTable perLevel;
    FactorizedTable factorized;
    SurfaceTable surface;
};

Refined refineModel(const std::string& path, int steps, Preprocess mode = Preprocess::Auto,
                    Boundary boundary = Boundary::Paper) {
    Refined r{load(path), {}, {}, {}, {}};
    r.hierarchy = test::refine(r.loaded, steps, mode, boundary);
    r.perLevel = buildPerLevelTable(r.hierarchy);
    r.factorized = buildFactorizedTable(r.perLevel);
    r.surface = buildSurfaceTable(r.hierarchy.finest().faces);
    return r;
}

const auto diagonal = test::boundingDiagonal;

template <class T>
std::vector<T> evaluateWith(const Refined& r, TableForm form, const std::vector<double>& control,
                            int threads = 1) {
    CpuEvaluator<T> evaluator(r.perLevel, r.factorized, r.surface, form, 3, threads);
    const std::vector<T> in(control.begin(), control.end());
    std::vector<T> out(std::size_t(evaluator.refinedCount()) * 3);
    evaluator.evaluate(in, out);
    return out;
}

// |a - b| <= tolerance * (bounding-box diagonal of the control points), index by index.
template <class T>
void expectClose(const std::vector<T>& actual, const std::vector<double>& expected, double tolerance,
                 double scale) {
    ASSERT_EQ(actual.size(), expected.size());
    for (std::size_t i = 0; i < expected.size(); ++i)
        ASSERT_NEAR(double(actual[i]), expected[i], tolerance * std::max(1.0, scale)) << "value " << i;
}

TEST(Stencils, BothFormsEqualTheRulesOnEveryModel) {
    for (const std::string& path : test::allValidModels())
        for (int steps : {1, 3}) {
            SCOPED_TRACE(path + " steps " + std::to_string(steps));
            const Refined r = refineModel(path, steps);
            const std::vector<double> oracle = refinePositions(r.hierarchy, r.loaded.mesh.positions);
            const double scale = diagonal(r.loaded.mesh.positions);
            const auto& control = r.loaded.mesh.positions;
            expectClose(evaluateWith<double>(r, TableForm::PerLevel, control), oracle, 1e-12, scale);
            expectClose(evaluateWith<double>(r, TableForm::Factorized, control), oracle, 1e-6, scale);
            expectClose(evaluateWith<float>(r, TableForm::PerLevel, control), oracle, 1e-5, scale);
            expectClose(evaluateWith<float>(r, TableForm::Factorized, control), oracle, 1e-5, scale);
        }
}

TEST(Stencils, SmoothBoundaryTablesEqualTheRulesOnEveryModel) {
    for (const std::string& path : test::allValidModels())
        for (int steps : {1, 2, 4}) {
            SCOPED_TRACE(path + " steps " + std::to_string(steps));
            const Refined r = refineModel(path, steps, Preprocess::Auto, Boundary::Smooth);
            const std::vector<double> oracle = refinePositions(r.hierarchy, r.loaded.mesh.positions);
            const double scale = diagonal(r.loaded.mesh.positions);
            const auto& control = r.loaded.mesh.positions;
            expectClose(evaluateWith<double>(r, TableForm::PerLevel, control), oracle, 1e-12, scale);
            expectClose(evaluateWith<double>(r, TableForm::Factorized, control), oracle, 1e-6, scale);
            expectClose(evaluateWith<float>(r, TableForm::PerLevel, control), oracle, 1e-5, scale);
        }
}

TEST(Stencils, SmoothBoundaryRowsAreTheCubicBSplineCurveRules) {
    // grid4x4, one split step: corner 0 (neighbours 5 and 1) -> (P5 + 6 P0 + P1) / 8; the first
    // edge point (vertex 41, edge 0->1) -> (P0 + P1) / 2; interior rows keep the paper's rules.
    const Refined r = refineModel(test::dataPath("grid4x4.obj"), 1, Preprocess::Auto, Boundary::Smooth);
    const FactorizedTable& t = r.factorized;
    const auto row = [&](std::uint32_t v) {
        std::vector<double> weights(25, 0.0);
        for (std::uint64_t e = t.offsets[v]; e < t.offsets[v + 1]; ++e) weights[t.indices[e]] = t.weights[e];
        return weights;
    };
    std::vector<double> corner(25, 0.0), edgePoint(25, 0.0), middle(25, 0.0);
    corner[0] = 0.75, corner[1] = corner[5] = 0.125;
    edgePoint[0] = edgePoint[1] = 0.5;
    middle[12] = 0.25, middle[7] = middle[11] = middle[13] = middle[17] = 0.125;
    middle[6] = middle[8] = middle[16] = middle[18] = 0.0625;
    for (int v = 0; v < 25; ++v) {
        EXPECT_FLOAT_EQ(float(row(0)[v]), float(corner[v])) << "control " << v;
        EXPECT_FLOAT_EQ(float(row(41)[v]), float(edgePoint[v])) << "control " << v;
        EXPECT_FLOAT_EQ(float(row(12)[v]), float(middle[v])) << "control " << v;
    }
    // The second step of the pair keeps the boundary: the boundary rows are copies.
    const Refined two = refineModel(test::dataPath("grid4x4.obj"), 2, Preprocess::Auto, Boundary::Smooth);
    const StencilLevel& second = two.perLevel.levels[1];
    std::uint64_t curveRows = 0, edgeRows = 0;
    for (std::uint64_t g = second.groupBegin; g < second.groupEnd; ++g) {
        curveRows += two.perLevel.groups[g].kind == RowKind::BoundaryVertex;
        edgeRows += two.perLevel.groups[g].kind == RowKind::BoundaryEdge;
    }
    EXPECT_EQ(curveRows + edgeRows, 0u);
}

TEST(Stencils, PreprocessedQuadMeshAlsoMatches) {
    const Refined r = refineModel(test::dataPath("cube.obj"), 3, Preprocess::Always);
    const std::vector<double> oracle = refinePositions(r.hierarchy, r.loaded.mesh.positions);
    // Per-level rows in double: rounding only (1e-12). Factorized weights are float (2^-24 =
    // 6e-8 relative each, summed over a row of weights adding to 1): 1e-6.
    expectClose(evaluateWith<double>(r, TableForm::PerLevel, r.loaded.mesh.positions), oracle, 1e-12, 1);
    expectClose(evaluateWith<double>(r, TableForm::Factorized, r.loaded.mesh.positions), oracle, 1e-6, 1);
}

TEST(Stencils, CubeCornerRowIsTheHandComputedStencil) {
    // Corner 6 = (1,1,1), valence 3: c = 0, d = 2/9 (vertices 2, 5, 7), e = 1/9 (1, 3, 4).
    const Refined r = refineModel(test::dataPath("cube.obj"), 1);
    const FactorizedTable& t = r.factorized;
    std::vector<double> row(8, 0.0);
    for (std::uint64_t e = t.offsets[6]; e < t.offsets[7]; ++e) row[t.indices[e]] = t.weights[e];
    const double expected[8] = {0, 1.0 / 9, 2.0 / 9, 1.0 / 9, 1.0 / 9, 2.0 / 9, 0, 2.0 / 9};
    // Tolerance 1e-7: the factorized weights are float; 2/9 rounds by at most 2^-24 * 2/9 = 1.3e-8.
    for (int v = 0; v < 8; ++v) EXPECT_NEAR(row[v], expected[v], 1e-7) << "control " << v;
    // The face point of face 0 (1 4 3 2): a quarter of each corner.
    std::vector<double> facePoint(8, 0.0);
    for (std::uint64_t e = t.offsets[8]; e < t.offsets[9]; ++e) facePoint[t.indices[e]] = t.weights[e];
    const double quarter[8] = {0.25, 0.25, 0.25, 0.25, 0, 0, 0, 0};
    for (int v = 0; v < 8; ++v) EXPECT_FLOAT_EQ(float(facePoint[v]), float(quarter[v]));
}

TEST(Stencils, TableSizesEqualClosedFormCounts) {
    for (const std::string& path : test::allValidModels())
      for (Boundary boundary : {Boundary::Paper, Boundary::Smooth}) {
        SCOPED_TRACE(path + " boundary " + boundaryName(boundary));
        const Refined r = refineModel(path, 3, Preprocess::Auto, boundary);
        const Counts input = countMesh(r.loaded.mesh.faces, r.loaded.checked.connectivity);
        const bool pre = r.hierarchy.preprocessed;
        ASSERT_EQ(r.perLevel.levels.size(), r.hierarchy.levels.size() - 1);
        for (std::size_t k = 0; k < r.perLevel.levels.size(); ++k) {
            const StencilLevel& level = r.perLevel.levels[k];
            const Counts parent = countsAfterSteps(input, int(k), boundary, pre),
                         child = countsAfterSteps(input, int(k) + 1, boundary, pre);
            EXPECT_EQ(level.sourceCount, parent.vertices);
            EXPECT_EQ(level.destinationCount, child.vertices);
            EXPECT_EQ(level.rowEnd - level.rowBegin, child.vertices);
            std::uint64_t quadRows = 0, triangleRows = 0;
            for (std::uint64_t g = level.groupBegin; g < level.groupEnd; ++g) {
                quadRows += r.perLevel.groups[g].kind == RowKind::FaceQuad ? r.perLevel.groups[g].rowCount : 0;
                triangleRows += r.perLevel.groups[g].kind == RowKind::FaceTriangle ? r.perLevel.groups[g].rowCount : 0;
            }
            EXPECT_EQ(quadRows, parent.quads);
            EXPECT_EQ(triangleRows, parent.triangles);
        }
        const Counts finest = countsAfterSteps(input, int(r.perLevel.levels.size()), boundary, pre);
        EXPECT_EQ(r.factorized.rowCount(), finest.vertices);
        EXPECT_EQ(r.surface.faceOffsets.size() - 1, finest.faces);
    }
}

TEST(Stencils, EveryLevelWritesEachDestinationOnce) {
    const Refined r = refineModel(test::dataPath("spot_control_mesh.obj"), 3);
    for (const StencilLevel& level : r.perLevel.levels) {
        std::vector<int> written(level.destinationCount, 0);
        for (std::uint64_t row = level.rowBegin; row < level.rowEnd; ++row) ++written[r.perLevel.destinations[row]];
        for (int count : written) ASSERT_EQ(count, 1);
    }
}

// A source with room past its last vertex (the evaluator's own levels) is read 16 bytes a
// vertex without a test; the rows give the same bits as from an exactly sized source, every
// level of the cow at 3 steps, the last vertex included.
TEST(Evaluator, RowsFromAPaddedSourceAreTheSameBits) {
    const Refined r = refineModel(test::dataPath("cow.obj"), 3);
    PerLevelTable facePoints = r.perLevel;  // whose vertex rows read the destination (padded too)
    ASSERT_GT(vertexRowsFromFacePoints(facePoints), 0u);
    const BufferLayout packed{0, 3, 3};
    std::mt19937 random(3);
    std::uniform_real_distribution<float> uniform(-1.0f, 1.0f);
    for (const PerLevelTable* table : std::initializer_list<const PerLevelTable*>{&r.perLevel, &facePoints})
    for (std::size_t k = 0; k < table->levels.size(); ++k) {
        SCOPED_TRACE(table == &facePoints ? "vertex rows from face points" : "as built");
        const StencilLevel& level = table->levels[k];
        std::vector<float> exact(3 * std::size_t(level.sourceCount));
        for (float& x : exact) x = uniform(random);
        std::vector<float> padded(exact);
        padded.push_back(std::nanf(""));  // read into a lane no result uses
        const std::uint64_t rows = level.rowEnd - level.rowBegin;
        std::vector<float> expected(3 * std::size_t(level.destinationCount), -1), actual(expected.size() + 1, -2);
        actual.back() = std::nanf("");
        evaluateLevelRows(*table, k, exact.data(), packed, expected.data(), packed, 0, rows);
        evaluateLevelRows(*table, k, padded.data(), packed, actual.data(), packed, 0, rows, {.sourcePadded = true, .destinationPadded = true});
        ASSERT_TRUE(std::isnan(actual.back()));
        for (std::size_t i = 0; i < expected.size(); ++i)
            ASSERT_EQ(std::bit_cast<std::uint32_t>(actual[i]), std::bit_cast<std::uint32_t>(expected[i]))
                << "level " << k << " value " << i;
    }
}

// A float buffer whose last value ends a page, the page after it unreadable: a read past the
// buffer (a 16-byte load of its last vertex) ends the test with a fault.
class GuardedFloats {
public:
    explicit GuardedFloats(std::size_t count) : count_(count) {
        const std::size_t page = std::size_t(sysconf(_SC_PAGESIZE));
        bytes_ = (count * sizeof(float) + page - 1) / page * page + page;
        void* at = mmap(nullptr, bytes_, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
        if (at == MAP_FAILED) throw std::runtime_error("mmap failed");
        base_ = static_cast<char*>(at);
        if (mprotect(base_ + bytes_ - page, page, PROT_NONE) != 0) throw std::runtime_error("mprotect failed");
    }
    ~GuardedFloats() { munmap(base_, bytes_); }
    GuardedFloats(const GuardedFloats&) = delete;
    GuardedFloats& operator=(const GuardedFloats&) = delete;
    std::span<float> span() const {
        const std::size_t page = std::size_t(sysconf(_SC_PAGESIZE));
        return {reinterpret_cast<float*>(base_ + bytes_ - page) - count_, count_};
    }

private:
    std::size_t count_, bytes_;
    char* base_;
};

// Whether a row of the table's finest level that reads that level (readsOwnLevel) reads its
// last vertex.
bool finestVertexRowsReadTheLastVertex(const PerLevelTable& table) {
    const StencilLevel& level = table.levels.back();
    for (std::uint64_t g = level.groupBegin; g < level.groupEnd; ++g) {
        const RowGroup& group = table.groups[g];
        if (!readsOwnLevel(group.kind)) continue;
        for (std::uint64_t i = 0; i < group.rowCount * group.width; ++i)
            if (table.indices[group.indexBegin + i] == level.destinationCount - 1) return true;
    }
    return false;
}

// The finest level's vertex rows read the output: 16 bytes a vertex unchecked only where none of
// them reads its last vertex (the tiled form's walk order), checked where one does (the
// per-level form's canonical order ends with a face point). Neither reads past the output, on
// one thread or two.
TEST(Evaluator, TheFinestVertexRowsNeverReadPastTheOutput) {
    Refined r = refineModel(test::dataPath("cow.obj"), 3);
    TiledTable tiled = buildTiledTable(r.hierarchy, r.perLevel);
    ASSERT_GT(vertexRowsFromFacePoints(r.perLevel), 0u);
    ASSERT_GT(vertexRowsFromFacePoints(tiled.rows), 0u);
    EXPECT_THROW(buildTiledTable(r.hierarchy, r.perLevel), std::invalid_argument);  // a rewritten table
    ASSERT_TRUE(finestVertexRowsReadTheLastVertex(r.perLevel));
    ASSERT_FALSE(finestVertexRowsReadTheLastVertex(tiled.rows));
    const std::vector<float> control(r.loaded.mesh.positions.begin(), r.loaded.mesh.positions.end());
    for (int threads : {1, 2}) {
        CpuEvaluator<float> perLevel(r.perLevel, r.factorized, r.surface, TableForm::PerLevel, 3, threads);
        CpuEvaluator<float> tiledForm(tiled, 3, threads);
        for (CpuEvaluator<float>* evaluator : {&perLevel, &tiledForm}) {
            const std::size_t count = 3 * std::size_t(evaluator->refinedCount());
            std::vector<float> expected(count);
            evaluator->evaluate(control, expected);
            const GuardedFloats guarded(count);
            evaluator->evaluate(control, guarded.span());
            EXPECT_TRUE(std::equal(expected.begin(), expected.end(), guarded.span().begin())) << threads;
        }
    }
}

// Narrow rows (psub/evaluator.h): a hand-made level of 200 face rows over 70,000 sources, in
// four blocks: one whose sources fit 16-bit offsets, one with a source 69,000 past its
// position's least (wide: read from `indices`), one whose destinations have a gap (scattered:
// read from `destinations`), and a last one of 8 rows. Every row of a fitting block decodes to its
// indices, and the kernel gives the bits it gives without them for every range of rows, whole
// blocks or not.
TEST(Evaluator, NarrowRowsReadTheRowsIndicesAndGiveTheirBits) {
    constexpr std::uint32_t kRows = 200, kSources = 70000;
    PerLevelTable table;
    table.controlCount = kSources;
    table.groups.push_back({RowKind::FaceQuad, 3, 0, 4, 0, kRows, 0, 0.25, 0.25, 0.0});
    std::mt19937 random(11);
    for (std::uint32_t r = 0; r < kRows; ++r) {
        table.destinations.push_back(r < 160 ? r : r + 1);  // a gap in the third block
        for (std::uint32_t j = 0; j < 4; ++j) table.indices.push_back(1000 + 7000 * j + std::uint32_t(random() % 6000));
    }
    table.indices[4 * 70 + 2] = 0, table.indices[4 * 71 + 2] = 69000;  // the second block is wide
    table.levels.push_back({kSources, kRows + 1, 0, 1, 0, kRows});
    const NarrowRows narrow = narrowRows(table);
    ASSERT_EQ(narrow.firstBlock, std::vector<std::uint32_t>{0});
    ASSERT_EQ(narrow.bases.size(), 16u);
    EXPECT_EQ(narrow.bases[4], kWideBlock);
    EXPECT_EQ(narrow.firstDestination, (std::vector<std::uint32_t>{0, 64, kScattered, 193}));
    for (std::uint32_t r = 0; r < kRows; ++r) {
        const std::uint32_t* bases = narrow.bases.data() + 4 * (r / kNarrowBlock);
        if (bases[0] == kWideBlock) continue;
        for (std::uint32_t j = 0; j < 4; ++j)
            EXPECT_EQ(bases[j] + narrow.offsets[4 * r + j], table.indices[4 * r + j]) << r << " " << j;
    }
    // Fitting blocks 0, 2 and 3 (136 rows, 8 bytes each spared), consecutive blocks 0, 1 and 3
    // (136 rows, 4 bytes each), less 20 bytes for each of the four blocks.
    EXPECT_EQ(narrowBytesSaved(table, narrow), 136u * 8 + 136 * 4 - 4 * 20);
    std::vector<float> source(3 * std::size_t(kSources) + 1);
    for (float& x : source) x = std::ldexp(float(random() % 2001) - 1000.0f, -7);
    const BufferLayout packed{0, 3, 3};
    for (const auto& [begin, end] : std::vector<std::pair<std::uint32_t, std::uint32_t>>{{0, kRows}, {0, 1}, {5, 70}, {63, 130}, {129, 199}, {150, 200}}) {
        SCOPED_TRACE(testing::Message() << "rows " << begin << " to " << end);
        std::vector<float> expected(3 * (kRows + 1) + 1, -1), actual(expected.size(), -1);
        evaluateLevelRows(table, 0, source.data(), packed, expected.data(), packed, begin, end);
        evaluateLevelRows(table, 0, source.data(), packed, actual.data(), packed, begin, end,
                          {.sourcePadded = true, .destinationPadded = true, .narrow = &narrow});
        EXPECT_TRUE(std::equal(expected.begin(), expected.end() - 1, actual.begin(), [](float a, float b) {
            return std::bit_cast<std::uint32_t>(a) == std::bit_cast<std::uint32_t>(b);
        }));
    }
}

// The evaluators read narrow rows (float, 3 values a vertex) and give the bits of the rows read
// whole, level by level, on the cow at 5 steps (most of its blocks fit, a few are wide or
// scattered), per-level and tiled, on one thread and two.
TEST(Evaluator, NarrowRowsGiveTheBitsOfTheRowsReadWhole) {
    Refined r = refineModel(test::dataPath("cow.obj"), 5);
    const TiledTable tiled = buildTiledTable(r.hierarchy, r.perLevel);
    ASSERT_EQ(tiled.tileCount(), 0u);  // the cow at 5 steps: rows only
    const std::vector<float> control(r.loaded.mesh.positions.begin(), r.loaded.mesh.positions.end());
    const BufferLayout packed{0, 3, 3};
    for (const PerLevelTable* table : std::initializer_list<const PerLevelTable*>{&r.perLevel, &tiled.rows}) {
        const NarrowRows narrow = narrowRows(*table);
        std::size_t fit = 0, wide = 0;
        for (std::size_t b = 0; b < narrow.firstDestination.size(); ++b) ++(narrow.bases[4 * b] == kWideBlock ? wide : fit);
        EXPECT_GT(fit, 10 * wide);
        std::vector<float> expected(control);
        const std::uint64_t everyGroupSaves = narrowBytesSaved(*table, narrow);
        for (std::size_t k = 0; k < table->levels.size(); ++k) {
            std::vector<float> next(3 * std::size_t(table->levels[k].destinationCount) + 1);
            evaluateLevelRows(*table, k, expected.data(), packed, next.data(), packed, 0,
                              table->levels[k].rowEnd - table->levels[k].rowBegin);
            next.pop_back();
            expected = std::move(next);
        }
        for (int threads : {1, 2}) {
            SCOPED_TRACE(testing::Message() << (table == &tiled.rows ? "tiled" : "per-level") << ", threads " << threads);
            std::unique_ptr<CpuEvaluator<float>> evaluator =
                table == &tiled.rows ? std::make_unique<CpuEvaluator<float>>(tiled, 3, threads)
                                     : std::make_unique<CpuEvaluator<float>>(r.perLevel, r.factorized, r.surface,
                                                                            TableForm::PerLevel, 3, threads);
            std::vector<float> actual(expected.size());
            // Here every four-source group reads the copy: the cow's first level has none, and no
            // finest vertex row reads the last vertex (finestOwnReadsWide), per-level too.
            EXPECT_EQ(evaluator->narrowBytesSaved(), everyGroupSaves);
            evaluator->evaluate(control, actual);
            EXPECT_TRUE(std::equal(expected.begin(), expected.end(), actual.begin(), [](float a, float b) {
                return std::bit_cast<std::uint32_t>(a) == std::bit_cast<std::uint32_t>(b);
            }));
        }
    }
}

// The evaluator copies only the groups whose rows read the copy: not the first level's face rows,
// which read the caller's control points (the cube's: quads, four sources each).
TEST(Evaluator, NarrowRowsCopyOnlyTheGroupsThatReadThem) {
    const Refined r = refineModel(test::dataPath("cube.obj"), 6);
    const NarrowRows every = narrowRows(r.perLevel);
    const RowGroup& first = r.perLevel.groups[r.perLevel.levels[0].groupBegin];
    ASSERT_EQ(first.kind, RowKind::FaceQuad);
    ASSERT_NE(every.firstBlock[r.perLevel.levels[0].groupBegin], kNoNarrowRows);
    std::vector<std::uint8_t> copied(r.perLevel.groups.size(), 1);
    for (std::uint64_t g = r.perLevel.levels[0].groupBegin; g < r.perLevel.levels[0].groupEnd; ++g) copied[g] = 0;
    const CpuEvaluator<float> evaluator(r.perLevel, r.factorized, r.surface, TableForm::PerLevel, 3, 1);
    EXPECT_LT(evaluator.narrowBytesSaved(), narrowBytesSaved(r.perLevel, every));
    EXPECT_EQ(evaluator.narrowBytesSaved(), narrowBytesSaved(r.perLevel, narrowRows(r.perLevel, copied)));
}

// Which groups read the narrow copy: four sources, a diagonal term of +0, the buffer they read
// padded (the parent level's, or for vertex points from face points the level's own; both for a
// valence-3 vertex from its centre, the parent's, and its face points).
TEST(Evaluator, NarrowRowsAreReadByLeanFourSourceRowsOfPaddedBuffers) {
    const RowGroup face{RowKind::FaceQuad, 3, 0, 4, 0, 1, 0, 0.25, 0.25, 0.0};
    RowGroup fromFacePoints = face, negativeZero = face, triangle = face, valence3 = face, fromCentre = face;
    fromFacePoints.kind = RowKind::VertexFromFacePoints;
    fromCentre.kind = RowKind::VertexFromCentreAndFacePoints, fromCentre.centre = -1.0 / 3, fromCentre.edge = 4.0 / 9;
    EXPECT_TRUE(readsNarrowRows(fromCentre, RowReads{.sourcePadded = true, .destinationPadded = true}));
    EXPECT_FALSE(readsNarrowRows(fromCentre, RowReads{.sourcePadded = true}));
    EXPECT_FALSE(readsNarrowRows(fromCentre, RowReads{.destinationPadded = true}));
    negativeZero.diagonal = -0.0;
    triangle.kind = RowKind::FaceTriangle, triangle.n = 2, triangle.width = 3;
    valence3.kind = RowKind::VertexQuad, valence3.m = 3, valence3.width = 7;
    const RowReads parentPadded{.sourcePadded = true}, ownPadded{.destinationPadded = true};
    EXPECT_TRUE(readsNarrowRows(face, parentPadded));
    EXPECT_FALSE(readsNarrowRows(face, ownPadded));
    EXPECT_TRUE(readsNarrowRows(fromFacePoints, ownPadded));
    EXPECT_FALSE(readsNarrowRows(fromFacePoints, parentPadded));
    EXPECT_FALSE(readsNarrowRows(negativeZero, parentPadded));
    EXPECT_FALSE(readsNarrowRows(triangle, parentPadded));
    EXPECT_FALSE(readsNarrowRows(valence3, parentPadded));
}

// The float rows give the bits of their definition, row by row: centre x source + edge x the
// sum of the edge sources + diagonal x the sum of the diagonals, every sum started from 0, in
// that order (RowGroup, psub/tables.h). Sources of +0, -0 and other values, every level of the
// cow at 3 steps, as built and with vertex points from face points: the kernel's rows without
// diagonals skip the additions of 0 (cpu_kernels.cpp, `Lean`), which may change only the sign of
// a zero, and their last addition (diagonal x 0 = +0) makes every zero +0 as the definition's.
TEST(Evaluator, RowsGiveTheDefinitionsBitsWithZerosOfBothSigns) {
    const Refined r = refineModel(test::dataPath("cow.obj"), 3);
    PerLevelTable facePoints = r.perLevel;
    ASSERT_GT(vertexRowsFromFacePoints(facePoints), 0u);
    const BufferLayout packed{0, 3, 3};
    std::mt19937 random(5);
    for (const PerLevelTable* table : std::initializer_list<const PerLevelTable*>{&r.perLevel, &facePoints})
    for (std::size_t k = 0; k < table->levels.size(); ++k) {
        SCOPED_TRACE(table == &facePoints ? "vertex rows from face points" : "as built");
        const StencilLevel& level = table->levels[k];
        std::vector<float> source(3 * std::size_t(level.sourceCount));
        for (float& x : source) {
            const std::uint32_t pick = random() % 4;
            x = pick == 0 ? 0.0f : pick == 1 ? -0.0f : std::ldexp(float(random() % 2001) - 1000.0f, -8);
        }
        std::vector<float> expected(3 * std::size_t(level.destinationCount), -1), actual(expected.size(), -2);
        for (std::uint64_t gi = level.groupBegin; gi < level.groupEnd; ++gi) {
            const RowGroup& g = table->groups[gi];
            // The level's own points, but a VertexFromCentreAndFacePoints row's centre.
            const std::vector<float>& from = readsOwnLevel(g.kind) ? expected : source;
            const std::vector<float>& centreFrom = g.kind == RowKind::VertexFromCentreAndFacePoints ? source : from;
            for (std::uint64_t row = 0; row < g.rowCount; ++row) {
                const std::uint32_t* ix = table->indices.data() + g.indexBegin + row * g.width;
                float* out = expected.data() + 3 * std::size_t(table->destinations[g.rowBegin + row]);
                for (int c = 0; c < 3; ++c) {
                    const auto at = [&](std::uint32_t j) {
                        return (j == 0 ? centreFrom : from)[3 * std::size_t(ix[j]) + std::size_t(c)];
                    };
                    const float acc = 0.0f + float(g.centre) * at(0);
                    float edges = 0.0f, diagonals = 0.0f;
                    for (std::uint32_t j = 1; j <= g.n; ++j) edges = edges + at(j);
                    for (std::uint32_t j = 1 + g.n; j < g.width; ++j) diagonals = diagonals + at(j);
                    out[c] = (acc + float(g.edge) * edges) + float(g.diagonal) * diagonals;
                }
            }
        }
        evaluateLevelRows(*table, k, source.data(), packed, actual.data(), packed, 0, level.rowEnd - level.rowBegin);
        for (std::size_t i = 0; i < expected.size(); ++i)
            ASSERT_EQ(std::bit_cast<std::uint32_t>(actual[i]), std::bit_cast<std::uint32_t>(expected[i]))
                << "level " << k << " value " << i;
    }
}

TEST(Evaluator, RowRangesInPiecesEqualTheWhole) {
    const Refined r = refineModel(test::dataPath("spot_control_mesh.obj"), 2);
    const BufferLayout packed{0, 3, 3};
    const std::vector<double>& control = r.loaded.mesh.positions;
    // Level 0 only (control -> preprocessed): whole, then in uneven pieces.
    const StencilLevel& level = r.perLevel.levels[0];
    const std::uint64_t rows = level.rowEnd - level.rowBegin;
    std::vector<double> whole(3 * std::size_t(level.destinationCount), -1), pieces(whole.size(), -2);
    evaluateLevelRows(r.perLevel, 0, control.data(), packed, whole.data(), packed, 0, rows);
    for (std::uint64_t begin = 0, step = 1; begin < rows; begin += step, step = step * 3 + 1)
        evaluateLevelRows(r.perLevel, 0, control.data(), packed, pieces.data(), packed, begin,
                          std::min(rows, begin + step));
    EXPECT_EQ(whole, pieces);

    const std::uint32_t finest = r.factorized.rowCount();
    std::vector<double> fWhole(3 * std::size_t(finest), -1), fPieces(fWhole.size(), -2);
    evaluateFactorizedRows(r.factorized, control.data(), packed, fWhole.data(), packed, 0, finest);
    for (std::uint32_t begin = 0, step = 1; begin < finest; begin += step, step = step * 2 + 1)
        evaluateFactorizedRows(r.factorized, control.data(), packed, fPieces.data(), packed, begin,
                               std::min(finest, begin + step));
    EXPECT_EQ(fWhole, fPieces);
}

TEST(Evaluator, EveryWidthFromOneToEightCarriesLinearPrimvars) {
    // Component i of each control point is a fixed linear function of its position; refining
    // is affine, so component i of each refined point is the same function of the refined
    // position.
    const Refined r = refineModel(test::dataPath("spot_control_mesh.obj"), 2);
    const std::vector<double> positions = refinePositions(r.hierarchy, r.loaded.mesh.positions);
    auto primvar = [](const double* p, std::uint32_t i) { return (i + 1) * p[0] - 0.5 * i * p[1] + p[2] / (i + 2) + i; };
    for (TableForm form : {TableForm::PerLevel, TableForm::Factorized})
        for (std::uint32_t width = 1; width <= 8; ++width) {
            SCOPED_TRACE("width " + std::to_string(width));
            CpuEvaluator<double> evaluator(r.perLevel, r.factorized, r.surface, form, width, 2);
            std::vector<double> control(std::size_t(evaluator.controlCount()) * width);
            for (std::uint32_t v = 0; v < evaluator.controlCount(); ++v)
                for (std::uint32_t i = 0; i < width; ++i)
                    control[std::size_t(v) * width + i] = primvar(&r.loaded.mesh.positions[3 * v], i);
            std::vector<double> refined(std::size_t(evaluator.refinedCount()) * width);
            evaluator.evaluate(control, refined);
            for (std::uint32_t v = 0; v < evaluator.refinedCount(); ++v)
                for (std::uint32_t i = 0; i < width; ++i)
                    // 1e-5: float factorized weights (6e-8 relative) times primvars up to about 20.
                    ASSERT_NEAR(refined[std::size_t(v) * width + i], primvar(&positions[3 * v], i), 1e-5)
                        << "vertex " << v << " component " << i;
        }
}

TEST(Evaluator, StridedAndOffsetLayoutsReadAndWriteOnlyTheirSlots) {
    const Refined r = refineModel(test::dataPath("cube.obj"), 1);
    const std::vector<double>& control = r.loaded.mesh.positions;
    const BufferLayout packed{0, 3, 3}, in{2, 3, 7}, out{1, 3, 5};
    std::vector<double> source(7 * 8, 1e30);  // garbage around the slots must not leak in
    for (int v = 0; v < 8; ++v)
        for (int i = 0; i < 3; ++i) source[7 * v + 2 + i] = control[3 * v + i];
    const std::uint32_t rows = r.factorized.rowCount();
    std::vector<double> expected(3 * rows), destination(5 * rows, -7.0);
    evaluateFactorizedRows(r.factorized, control.data(), packed, expected.data(), packed, 0, rows);
    evaluateFactorizedRows(r.factorized, source.data(), in, destination.data(), out, 0, rows);
    for (std::uint32_t v = 0; v < rows; ++v) {
        EXPECT_EQ(destination[5 * v], -7.0);
        EXPECT_EQ(destination[5 * v + 4], -7.0);
        for (int i = 0; i < 3; ++i) EXPECT_EQ(destination[5 * v + 1 + i], expected[3 * v + i]);
    }
    std::vector<double> levelDestination(5 * rows, -7.0);
    evaluateLevelRows(r.perLevel, 0, source.data(), in, levelDestination.data(), out, 0, rows);
    for (std::uint32_t v = 0; v < rows; ++v) {
        EXPECT_EQ(levelDestination[5 * v], -7.0);
        // Per-level (double weights) against factorized (float weights) on the cube's unit
        // coordinates: float rounding, 6e-8 per weight, well inside 1e-6.
        for (int i = 0; i < 3; ++i) EXPECT_NEAR(levelDestination[5 * v + 1 + i], expected[3 * v + i], 1e-6);
    }
}

TEST(Evaluator, ThreadsGiveBitIdenticalResults) {
    Refined r = refineModel(test::dataPath("cow.obj"), 3);
    for (TableForm form : {TableForm::PerLevel, TableForm::Factorized}) {
        const auto one = evaluateWith<float>(r, form, r.loaded.mesh.positions, 1);
        for (int threads : {2, 3, 7}) EXPECT_EQ(one, evaluateWith<float>(r, form, r.loaded.mesh.positions, threads));
    }
    // Vertex rows from face points: a second pass per level, after the face points' (a barrier).
    r = refineModel(test::dataPath("cow.obj"), 5);
    ASSERT_GT(vertexRowsFromFacePoints(r.perLevel), 0u);
    const auto one = evaluateWith<float>(r, TableForm::PerLevel, r.loaded.mesh.positions, 1);
    for (int threads : {2, 3, 7}) EXPECT_EQ(one, evaluateWith<float>(r, TableForm::PerLevel, r.loaded.mesh.positions, threads));
}

// Any fractions tile every count exactly: each thread's rows begin where the one before's end.
TEST(Evaluator, RowSharesMeetExactlyWhateverTheFractions) {
    const std::vector<std::vector<double>> boundsSets = {
        {0, 1}, {0, 0.5, 1}, {0, 0.1, 0.35, 1}, {0, 1.0 / 3, 2.0 / 3, 1}, {0, 0.999999, 1}, {0, 0.2, 0.2, 0.9, 1}};
    for (const std::vector<double>& bounds : boundsSets) {
        const std::uint64_t n = bounds.size() - 1;
        for (const std::uint64_t count : {0ull, 1ull, 7ull, 1000ull, 123457ull}) {
            EXPECT_EQ(rowShareStart(count, bounds.data(), 0, n), 0u);
            EXPECT_EQ(rowShareStart(count, bounds.data(), n, n), count);
            for (std::uint64_t t = 0; t < n; ++t) {
                const std::uint64_t begin = rowShareStart(count, bounds.data(), t, n), end = rowShareStart(count, bounds.data(), t + 1, n);
                EXPECT_LE(begin, end) << "thread " << t << " of " << n << ", " << count << " rows";
                // Within a row of the fraction's own share.
                EXPECT_NEAR(double(end - begin), double(count) * (bounds[t + 1] - bounds[t]), 1.0);
            }
        }
    }
}

// The shares move a quarter of the way toward the threads' speeds (hand-computed), settle where
// the threads take equal times, and keep a slow thread's share at least a fifth of an even one.
TEST(Evaluator, RowSharesMoveTowardTheFasterThread) {
    constexpr std::size_t apart = 8;
    std::vector<double> bounds = {0, 0.5, 1}, seconds(2 * apart, 0.0);
    seconds[0] = 1.0, seconds[apart] = 3.0;  // thread 1 three times as slow
    balanceRowShares(bounds, seconds, apart);
    // Speeds 0.5 / 1 and 0.5 / 3 (2/3 in all): 0.75 and 0.25 of it; a quarter of the way there.
    EXPECT_NEAR(bounds[1], 0.75 * 0.5 + 0.25 * 0.75, 1e-12);
    EXPECT_EQ(bounds[0], 0.0);
    EXPECT_EQ(bounds[2], 1.0);
    EXPECT_EQ(seconds, std::vector<double>(2 * apart, 0.0));
    // Frames whose time is each thread's fraction times its cost a row: equal times at 3 to 1.
    const auto frames = [&](double cost0, double cost1, int count) {
        for (int f = 0; f < count; ++f) {
            seconds[0] = (bounds[1] - bounds[0]) * cost0, seconds[apart] = (bounds[2] - bounds[1]) * cost1;
            balanceRowShares(bounds, seconds, apart);
        }
    };
    frames(1, 3, 100);
    EXPECT_NEAR(bounds[1], 0.75, 1e-6);
    frames(1, 1000, 100);
    EXPECT_GE(bounds[2] - bounds[1], 0.2 / 2);
    EXPECT_LT(bounds[2] - bounds[1], 0.25 / 2);
    // A thread that ran no rows leaves the shares as they are.
    const std::vector<double> before = bounds;
    seconds[0] = 1.0, seconds[apart] = 0.0;
    balanceRowShares(bounds, seconds, apart);
    EXPECT_EQ(bounds, before);
    EXPECT_EQ(seconds, std::vector<double>(2 * apart, 0.0));
}

// The evaluator's barrier, many phases in a row: each thread writes its slot, waits, reads every
// slot (each must hold this phase's number: no thread left before all had written, and the
// writes are visible), and waits again before the next write. On two threads, and on more
// threads than this machine has cores, where the waiting threads stop spinning and yield.
TEST(Evaluator, TeamBarrierLetsNoThreadPassBeforeAllArrive) {
    for (const int threads : {2, 7}) {
        const int phases = threads == 2 ? 20000 : 300;
        TeamBarrier barrier;
        std::vector<int> slots(16 * std::size_t(threads), -1);  // a cache line a thread
        std::atomic<int> team{0}, stale{0};
#pragma omp parallel num_threads(threads)
        {
            const std::size_t t = std::size_t(omp_get_thread_num()), n = std::size_t(omp_get_num_threads());
            if (t == 0) team = int(n);
            for (int phase = 0; phase < phases; ++phase) {
                slots[16 * t] = phase;
                barrier.wait();
                for (std::size_t u = 0; u < n; ++u)
                    if (slots[16 * u] != phase) stale.fetch_add(1, std::memory_order_relaxed);
                barrier.wait();
            }
        }
        ASSERT_EQ(team.load(), threads) << "OpenMP gave another team size";
        EXPECT_EQ(stale.load(), 0) << threads << " threads: slots read before their thread reached the barrier";
    }
}

// Shares that move from frame to frame (with the threads' speeds) still give every row once:
// each frame of a changing sequence the same bits as one thread's. The frames alternate between
// the shares the threads' speeds give and shares set far to either side (setRowShares: thread 0
// with a tenth of the rows, then with four fifths, ...), so that a share's start or end that did
// not follow its fractions would leave rows out whichever way this machine's threads run.
// Every way of sharing: by work over a level (the per-level table as built), every group in
// turn (the tiled form's rows, in walk order), the factorized table's one range; and the normals
// (every other frame), whose one pass (the tiled form's drawing order) and two passes (fewer
// than 2^17 faces) take the rows' shares.
TEST(Evaluator, SharesThatMoveBetweenFramesGiveTheSameBits) {
    const Refined r = refineModel(test::dataPath("cow.obj"), 5), small = refineModel(test::dataPath("cow.obj"), 3);
    const TiledTable tiled = buildTiledTable(r.hierarchy, r.perLevel);
    ASSERT_LT(tiled.rows.walkFrom, tiled.rows.levels.size());
    const auto frames = [](const Refined& model, CpuEvaluator<float>& one, CpuEvaluator<float>& three, const char* form) {
        std::vector<float> control(model.loaded.mesh.positions.size());
        std::vector<float> expected(3 * std::size_t(one.refinedCount())), got(expected.size());
        std::vector<float> expectedNormals(expected.size()), gotNormals(expected.size());
        const double firstShares[] = {0.1, 0.8, 0.35, 0.6};
        int skewed = 0;
        for (int frame = 0; frame < 20; ++frame) {
            for (std::size_t i = 0; i < control.size(); ++i)
                control[i] = float(model.loaded.mesh.positions[i] + 0.01 * std::sin(double(i) + frame));
            const std::size_t team = three.rowShares().size() - (three.rowShares().empty() ? 0 : 1);
            if (frame % 4 >= 2 && team >= 2) {  // thread 0 takes `first`, the others the rest evenly
                // Each of the four, with normals and without, over the ten frames.
                const double first = firstShares[std::size_t(frame / 4 + frame) % 4];
                ++skewed;
                std::vector<double> bounds(team + 1, 1.0);
                bounds[0] = 0;
                for (std::size_t t = 1; t < team; ++t) bounds[t] = first + (1 - first) * double(t - 1) / double(team - 1);
                three.setRowShares(bounds);
                ASSERT_TRUE(std::equal(bounds.begin(), bounds.end(), three.rowShares().begin()));
            }
            if (frame % 2 == 0) {
                one.evaluate(control, expected);
                three.evaluate(control, got);
            } else {
                one.evaluate(control, expected, expectedNormals);
                three.evaluate(control, got, gotNormals);
                ASSERT_EQ(expectedNormals, gotNormals) << form << ", frame " << frame;
            }
            ASSERT_EQ(expected, got) << form << ", frame " << frame;
        }
        EXPECT_EQ(skewed, 10) << form << ": a team of one has no shares to move";
    };
    CpuEvaluator<float> one(r.perLevel, r.factorized, r.surface, TableForm::PerLevel, 3, 1);
    CpuEvaluator<float> three(r.perLevel, r.factorized, r.surface, TableForm::PerLevel, 3, 3);
    frames(r, one, three, "per-level");
    CpuEvaluator<float> tiledOne(tiled, 3, 1), tiledThree(tiled, 3, 3);
    ASSERT_TRUE(tiledThree.normalsInOnePass());
    frames(r, tiledOne, tiledThree, "tiled");
    CpuEvaluator<float> factorizedOne(r.perLevel, r.factorized, r.surface, TableForm::Factorized, 3, 1);
    CpuEvaluator<float> factorizedThree(r.perLevel, r.factorized, r.surface, TableForm::Factorized, 3, 3);
    frames(r, factorizedOne, factorizedThree, "factorized");
    CpuEvaluator<float> smallOne(small.perLevel, small.factorized, small.surface, TableForm::PerLevel, 3, 1);
    CpuEvaluator<float> smallThree(small.perLevel, small.factorized, small.surface, TableForm::PerLevel, 3, 3);
    ASSERT_FALSE(smallThree.normalsInOnePass());
    frames(small, smallOne, smallThree, "per-level, two passes of normals");
}

TEST(Evaluator, SetRowSharesTakesOnlyAscendingFractionsFromZeroToOne) {
    const Refined r = refineModel(test::dataPath("cube.obj"), 2);
    CpuEvaluator<float> evaluator(r.perLevel, r.factorized, r.surface, TableForm::PerLevel, 3, 2);
    EXPECT_TRUE(evaluator.rowShares().empty());
    for (const std::vector<double>& bad : std::vector<std::vector<double>>{
             {}, {0}, {0.1, 1}, {0, 0.9}, {0, 0.7, 0.3, 1}, {0, std::nan(""), 1}})
        EXPECT_THROW(evaluator.setRowShares(bad), std::invalid_argument) << bad.size() << " fractions";
    const std::vector<double> good = {0, 0, 0.5, 1};  // an empty share is a share
    evaluator.setRowShares(good);
    EXPECT_TRUE(std::equal(good.begin(), good.end(), evaluator.rowShares().begin(), evaluator.rowShares().end()));
}

TEST(Evaluator, EachFrameOfAChangingSequenceIsRefinedFromItsOwnControlPoints) {
    const Refined r = refineModel(test::dataPath("spot_control_mesh.obj"), 3);
    const double scale = diagonal(r.loaded.mesh.positions);
    for (TableForm form : {TableForm::PerLevel, TableForm::Factorized}) {
        CpuEvaluator<float> evaluator(r.perLevel, r.factorized, r.surface, form, 3, 2);
        std::vector<float> control(r.loaded.mesh.positions.size()), refined(3 * std::size_t(evaluator.refinedCount()));
        for (int frame = 0; frame < 5; ++frame) {
            std::vector<double> frameControl = r.loaded.mesh.positions;
            for (std::size_t v = 0; v < frameControl.size() / 3; ++v)  // a twisting wave
                frameControl[3 * v + 1] += 0.1 * std::sin(frameControl[3 * v] * 3 + frame);
            std::copy(frameControl.begin(), frameControl.end(), control.begin());
            evaluator.evaluate(control, refined);
            expectClose(refined, refinePositions(r.hierarchy, frameControl), 1e-5, scale);
        }
    }
}

TEST(Evaluator, FlatGridNormalsPointUp) {
    const Refined r = refineModel(test::dataPath("grid4x4.obj"), 3);
    CpuEvaluator<float> evaluator(r.perLevel, r.factorized, r.surface, TableForm::PerLevel, 3, 2);
    const std::vector<float> control(r.loaded.mesh.positions.begin(), r.loaded.mesh.positions.end());
    std::vector<float> refined(3 * std::size_t(evaluator.refinedCount())), normals(refined.size());
    evaluator.evaluate(control, refined);
    evaluator.normals(refined, normals);
    for (std::size_t v = 0; v < normals.size() / 3; ++v) {
        EXPECT_FLOAT_EQ(normals[3 * v + 2], 1.0f);
        EXPECT_FLOAT_EQ(normals[3 * v], 0.0f);
    }
}

TEST(Evaluator, ClosedSurfaceNormalsPointOutward) {
    const Refined r = refineModel(test::dataPath("cube.obj"), 4);
    CpuEvaluator<double> evaluator(r.perLevel, r.factorized, r.surface, TableForm::Factorized, 3, 2);
    std::vector<double> refined(3 * std::size_t(evaluator.refinedCount())), normals(refined.size());
    evaluator.evaluate(r.loaded.mesh.positions, refined);
    evaluator.normals(refined, normals);
    for (std::size_t v = 0; v < normals.size() / 3; ++v) {
        const double dot = normals[3 * v] * refined[3 * v] + normals[3 * v + 1] * refined[3 * v + 1] +
                           normals[3 * v + 2] * refined[3 * v + 2];
        const double length = std::hypot(normals[3 * v], normals[3 * v + 1], normals[3 * v + 2]);
        EXPECT_GT(dot, 0) << "vertex " << v;
        EXPECT_NEAR(length, 1.0, 1e-12);
    }
}

// The definition, value by value in float: each row is (0 + c P) + e (0 + edge sum) +
// d (0 + diagonal sum), summed in index order.
void referenceLevel(const PerLevelTable& table, std::size_t k, const float* source, BufferLayout sl,
                    float* destination, BufferLayout dl) {
    const StencilLevel& level = table.levels[k];
    for (std::uint64_t gi = level.groupBegin; gi < level.groupEnd; ++gi) {
        const RowGroup& g = table.groups[gi];
        const bool facePoints = readsOwnLevel(g.kind);  // reads the level's own points
        const bool parentCentre = g.kind == RowKind::VertexFromCentreAndFacePoints;  // but its centre
        const float* from = facePoints ? destination : source;
        const BufferLayout fl = facePoints ? dl : sl;
        for (std::uint64_t r = 0; r < g.rowCount; ++r) {
            const std::uint32_t* ix = table.indices.data() + g.indexBegin + r * g.width;
            float* out = destination + std::size_t(table.destinations[g.rowBegin + r]) * dl.stride + dl.offset;
            for (int i = 0; i < 3; ++i) {
                auto at = [&](std::uint32_t j) {
                    if (j == 0 && parentCentre) return source[std::size_t(ix[j]) * sl.stride + sl.offset + i];
                    return from[std::size_t(ix[j]) * fl.stride + fl.offset + i];
                };
                float centre = 0, edges = 0, diagonals = 0;
                centre += float(g.centre) * at(0);
                for (std::uint32_t j = 1; j <= g.n; ++j) edges += at(j);
                for (std::uint32_t j = 1 + g.n; j < g.width; ++j) diagonals += at(j);
                out[i] = centre + float(g.edge) * edges + float(g.diagonal) * diagonals;
            }
        }
    }
}

TEST(Evaluator, FloatLevelRowsAreBitIdenticalToTheScalarDefinition) {
    const Refined r = refineModel(test::dataPath("cow.obj"), 3);
    PerLevelTable facePoints = r.perLevel;
    ASSERT_GT(vertexRowsFromFacePoints(facePoints), 0u);
    // The tiled form's rows (the cow: no tile): walk order, the finest level's groups writing
    // runs of consecutive points with gaps (docs/tiled.md, "Output order").
    const TiledTable tiled = buildTiledTable(r.hierarchy, r.perLevel);
    ASSERT_EQ(tiled.tileCount(), 0u);
    std::mt19937 random(7);
    std::uniform_real_distribution<float> uniform(-1.0f, 1.0f);
    for (const PerLevelTable* table : std::initializer_list<const PerLevelTable*>{&r.perLevel, &facePoints, &tiled.rows})
    for (const BufferLayout layout : {BufferLayout{0, 3, 3}, BufferLayout{1, 3, 5}, BufferLayout{2, 3, 5}}) {
        SCOPED_TRACE(table == &facePoints ? "vertex rows from face points" : table == &tiled.rows ? "tiled form's rows" : "as built");
        std::vector<float> source(std::size_t(table->controlCount) * layout.stride);
        for (float& x : source) x = uniform(random);
        for (std::size_t k = 0; k < table->levels.size(); ++k) {
            const StencilLevel& level = table->levels[k];
            std::vector<float> actual(std::size_t(level.destinationCount) * layout.stride, -7.0f), expected = actual;
            const std::uint64_t rows = level.rowEnd - level.rowBegin;
            for (std::uint64_t piece = 0; piece < 3; ++piece)  // ranges ending mid-group
                evaluateLevelRows(*table, k, source.data(), layout, actual.data(), layout, rows * piece / 3,
                                  rows * (piece + 1) / 3);
            referenceLevel(*table, k, source.data(), layout, expected.data(), layout);
            for (std::size_t i = 0; i < actual.size(); ++i)
                ASSERT_EQ(std::bit_cast<std::uint32_t>(actual[i]), std::bit_cast<std::uint32_t>(expected[i]))
                    << "level " << k << ", value " << i << ", stride " << layout.stride;
            source = std::move(actual);
        }
    }
}

// Newell's normal of a polygon (twice its area along its normal), in corner order.
template <class T>
void newell(const SurfaceTable& s, std::size_t f, const std::vector<T>& p, std::size_t stride, T n[3]) {
    n[0] = n[1] = n[2] = 0;
    for (std::uint32_t c = s.faceOffsets[f], end = s.faceOffsets[f + 1]; c < end; ++c) {
        const T* a = &p[s.faceVerts[c] * stride];
        const T* b = &p[s.faceVerts[c + 1 == end ? s.faceOffsets[f] : c + 1] * stride];
        n[0] += (a[1] - b[1]) * (a[2] + b[2]);
        n[1] += (a[2] - b[2]) * (a[0] + b[0]);
        n[2] += (a[0] - b[0]) * (a[1] + b[1]);
    }
}

// Normals by the definition, in float: Newell's normal per face (for a quad computed as the
// cross product of its diagonals, (p2 - p0) x (p3 - p1), which it equals: checked below),
// summed per vertex in table order, normalised.
std::vector<float> referenceNormals(const SurfaceTable& s, const std::vector<float>& p, std::size_t stride) {
    std::vector<float> faceNormals(3 * (s.faceOffsets.size() - 1)), out(3 * std::size_t(s.vertexCount));
    for (std::size_t f = 0; f + 1 < s.faceOffsets.size(); ++f) {
        float n[3] = {0, 0, 0};
        if (s.faceOffsets[f + 1] - s.faceOffsets[f] == 4) {
            const float* p0 = &p[s.faceVerts[s.faceOffsets[f]] * stride];
            const float* p1 = &p[s.faceVerts[s.faceOffsets[f] + 1] * stride];
            const float* p2 = &p[s.faceVerts[s.faceOffsets[f] + 2] * stride];
            const float* p3 = &p[s.faceVerts[s.faceOffsets[f] + 3] * stride];
            const float a[3] = {p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]};
            const float b[3] = {p3[0] - p1[0], p3[1] - p1[1], p3[2] - p1[2]};
            n[0] = a[1] * b[2] - a[2] * b[1];
            n[1] = a[2] * b[0] - a[0] * b[2];
            n[2] = a[0] * b[1] - a[1] * b[0];
        } else {
            newell(s, f, p, stride, n);
        }
        std::copy(n, n + 3, &faceNormals[3 * f]);
    }
    for (std::uint32_t v = 0; v < s.vertexCount; ++v) {
        float n[3] = {0, 0, 0};
        for (std::uint32_t i = s.vertexOffsets[v]; i < s.vertexOffsets[v + 1]; ++i)
            for (int axis = 0; axis < 3; ++axis) n[axis] += faceNormals[3 * s.vertexFaces[i] + axis];
        const float length = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        const float scale = length > 0 ? 1 / length : 0;
        for (int axis = 0; axis < 3; ++axis) out[3 * v + axis] = n[axis] * scale;
    }
    return out;
}

// A quad's diagonals' cross product is its Newell normal (exact arithmetic; here in double on
// random, non-planar quads far from the origin, where only rounding separates them).
TEST(Evaluator, AQuadsDiagonalCrossProductIsItsNewellNormal) {
    const Refined r = refineModel(test::dataPath("cow.obj"), 2);
    std::mt19937 random(5);
    std::uniform_real_distribution<double> uniform(-1.0, 1.0);
    std::vector<double> p(3 * std::size_t(r.surface.vertexCount));
    for (std::size_t i = 0; i < p.size(); ++i) p[i] = uniform(random) + (i % 3 == 0 ? 100.0 : 0.0);
    for (std::size_t f = 0; f + 1 < r.surface.faceOffsets.size(); ++f) {
        ASSERT_EQ(r.surface.faceOffsets[f + 1] - r.surface.faceOffsets[f], 4u);
        double n[3];
        newell(r.surface, f, p, 3, n);
        const double* q[4];
        for (int c = 0; c < 4; ++c) q[c] = &p[3 * std::size_t(r.surface.faceVerts[r.surface.faceOffsets[f] + c])];
        const double a[3] = {q[2][0] - q[0][0], q[2][1] - q[0][1], q[2][2] - q[0][2]};
        const double b[3] = {q[3][0] - q[1][0], q[3][1] - q[1][1], q[3][2] - q[1][2]};
        const double cross[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
        for (int axis = 0; axis < 3; ++axis) ASSERT_NEAR(cross[axis], n[axis], 1e-10) << "face " << f;
    }
}

TEST(Evaluator, FloatNormalsAreBitIdenticalToTheDefinition) {
    const Refined r = refineModel(test::dataPath("cow.obj"), 2);
    // The refined surface (all quads) and the control mesh (triangles and quads).
    const SurfaceTable control = buildSurfaceTable(r.hierarchy.levels.front().faces);
    for (const bool refined : {true, false}) {
        const SurfaceTable& surface = refined ? r.surface : control;
        for (const std::uint32_t width : {3u, 4u}) {
            std::mt19937 random(11);
            std::uniform_real_distribution<float> uniform(-1.0f, 1.0f);
            std::vector<float> positions(std::size_t(surface.vertexCount) * width);
            for (float& x : positions) x = uniform(random);
            const std::vector<float> expected = referenceNormals(surface, positions, width);
            for (const int threads : {1, 2}) {
                CpuEvaluator<float> evaluator(r.perLevel, r.factorized, surface, TableForm::PerLevel, width, threads);
                std::vector<float> normals(expected.size(), -7.0f);
                evaluator.normals(positions, normals);
                for (std::size_t i = 0; i < normals.size(); ++i)
                    ASSERT_EQ(std::bit_cast<std::uint32_t>(normals[i]), std::bit_cast<std::uint32_t>(expected[i]))
                        << (refined ? "refined" : "control") << " surface, width " << width << ", threads "
                        << threads << ", value " << i;
            }
        }
    }
    // The tiled form's evaluator (its surface in drawing order; its passes prefetch nothing).
    const TiledTable tiled = buildTiledTable(r.hierarchy, r.perLevel);
    for (const std::uint32_t width : {3u, 4u}) {
        std::mt19937 random(13);
        std::uniform_real_distribution<float> uniform(-1.0f, 1.0f);
        std::vector<float> positions(std::size_t(tiled.surface.vertexCount) * width);
        for (float& x : positions) x = uniform(random);
        const std::vector<float> expected = referenceNormals(tiled.surface, positions, width);
        for (const int threads : {1, 2}) {
            CpuEvaluator<float> evaluator(tiled, width, threads);
            std::vector<float> normals(expected.size(), -7.0f);
            evaluator.normals(positions, normals);
            for (std::size_t i = 0; i < normals.size(); ++i)
                ASSERT_EQ(std::bit_cast<std::uint32_t>(normals[i]), std::bit_cast<std::uint32_t>(expected[i]))
                    << "tiled form, width " << width << ", threads " << threads << ", value " << i;
        }
    }
}

// A grid of n x n quads (vertices (n + 1)^2, row by row) whose faces are numbered row by row,
// with the first and last faces' numbers swapped, or at random; with `unused` > 0 the vertices
// from row n / 2 on are numbered `unused` higher, after as many vertices that no face has.
enum class FaceNumbers { Rows, TwoSwapped, Random };
SurfaceTable gridSurface(std::uint32_t n, FaceNumbers numbers, std::uint32_t unused = 0) {
    std::vector<std::uint32_t> number(std::size_t(n) * n);
    for (std::uint32_t f = 0; f < number.size(); ++f) number[f] = f;
    if (numbers == FaceNumbers::TwoSwapped) std::swap(number.front(), number.back());
    if (numbers == FaceNumbers::Random) std::shuffle(number.begin(), number.end(), std::mt19937(3));
    std::vector<std::array<Index, 4>> quads(number.size());
    const auto at = [n, unused](std::uint32_t x, std::uint32_t y) {
        return Index(y * (n + 1) + x + (y >= n / 2 ? unused : 0));
    };
    for (std::uint32_t j = 0; j < n; ++j)
        for (std::uint32_t i = 0; i < n; ++i)
            quads[number[j * n + i]] = {at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)};
    Faces faces;
    faces.vertexCount = Index((n + 1) * (n + 1) + unused);
    for (const auto& quad : quads) faces.addFace(quad);
    return buildSurfaceTable(std::move(faces));
}

// normals() in one pass (a window of face normals) gives the bits of the definition at 1 to 3
// threads, twice in a row (the window reused): on the tiled form's drawing order of the cow and
// on a grid numbered row by row (its last vertex's face the last face), both with 16-bit
// corners, and on grids whose middle row of faces has corners 20,000 vertices apart (unused
// vertices between; 16-bit corners up to 62,370), 22,000 and 70,000 (the surface's corners). The cow's canonical order, the grid with its first and
// last faces' numbers swapped and one numbered at random keep the two passes (a block of vertices
// there reads faces too far apart), as does a smaller grid.
TEST(Evaluator, NormalsInOnePassAreBitIdenticalToTheDefinition) {
    // At least 2^17 faces each (below, the two passes are faster: cpu_evaluator.cpp).
    const Hierarchy h = test::refine(load(test::dataPath("cow.obj")), 6);
    const PerLevelTable perLevel = buildPerLevelTable(h);
    const TiledTable tiled = buildTiledTable(h, perLevel);
    ASSERT_EQ(tiled.tileCount(), 0u);
    const SurfaceTable canonical = buildSurfaceTable(h.finest().faces), small = gridSurface(362, FaceNumbers::Rows),
                       rows = gridSurface(725, FaceNumbers::Rows), swapped = gridSurface(725, FaceNumbers::TwoSwapped),
                       shuffled = gridSurface(725, FaceNumbers::Random),
                       apart = gridSurface(725, FaceNumbers::Rows, 70000),
                       nearlyApart = gridSurface(725, FaceNumbers::Rows, 20000),
                       justApart = gridSurface(725, FaceNumbers::Rows, 22000);
    ASSERT_GE(canonical.faceOffsets.size() - 1, std::size_t(1) << 17);
    ASSERT_LT(small.faceOffsets.size() - 1, std::size_t(1) << 17);
    ASSERT_GE(rows.faceOffsets.size() - 1, std::size_t(1) << 17);
    const std::pair<const SurfaceTable*, const char*> surfaces[] = {
        {&tiled.surface, "cow, drawing order"}, {&canonical, "cow, canonical order"}, {&rows, "grid"},
        {&apart, "grid with unused vertices in the middle"},
        {&nearlyApart, "grid with 20,000 unused vertices in the middle"},
        {&justApart, "grid with 22,000 unused vertices in the middle"},
        {&small, "grid of fewer than 2^17 faces"}, {&swapped, "grid, two faces swapped"},
        {&shuffled, "grid, numbered at random"}};
    for (const auto& [surface, name] : surfaces) {
        std::mt19937 random(17);
        std::uniform_real_distribution<float> uniform(-1.0f, 1.0f);
        std::vector<float> positions(3 * std::size_t(surface->vertexCount));
        for (float& x : positions) x = uniform(random);
        const std::vector<float> expected = referenceNormals(*surface, positions, 3);
        for (const int threads : {1, 2, 3}) {
            std::unique_ptr<CpuEvaluator<float>> evaluator =
                surface == &tiled.surface
                    ? std::make_unique<CpuEvaluator<float>>(tiled, 3, threads)
                    : std::make_unique<CpuEvaluator<float>>(perLevel, FactorizedTable{}, *surface, TableForm::PerLevel, 3, threads);
            const bool onePass = surface == &tiled.surface || surface == &rows || surface == &apart ||
                                 surface == &nearlyApart || surface == &justApart;
            EXPECT_EQ(evaluator->normalsInOnePass(), onePass) << name;
            // Narrow corners are offsets in floats (3 per vertex) within 16 bits: runs of faces
            // spanning at most 21,845 vertices (the gap of 20,000 plus a row and a run: 20,790).
            EXPECT_EQ(evaluator->normalsReadNarrowCorners(),
                      surface == &tiled.surface || surface == &rows || surface == &nearlyApart)
                << name;
            EXPECT_EQ(evaluator->holdsFaceNormals(), !onePass) << name;  // from construction
            for (const int call : {1, 2}) {
                std::vector<float> normals(expected.size(), -7.0f);
                evaluator->normals(positions, normals);
                for (std::size_t i = 0; i < normals.size(); ++i)
                    ASSERT_EQ(std::bit_cast<std::uint32_t>(normals[i]), std::bit_cast<std::uint32_t>(expected[i]))
                        << name << ", call " << call << ", threads " << threads << ", value " << i;
                // A normal per face only for the two passes (the one pass keeps none).
                EXPECT_EQ(evaluator->holdsFaceNormals(), !onePass) << name;
            }
        }
    }
}

TEST(Evaluator, RefineFacadeBuildsWhatTheEvaluatorNeeds) {
    const auto cow = load(test::dataPath("cow.obj"));
    const Refinement refinement = refine(cow.mesh, cow.checked.connectivity, {2, Preprocess::Auto, true, {}});
    EXPECT_TRUE(refinement.preprocessed);
    EXPECT_EQ(refinement.perLevel.levels.size(), 3u);  // the cow has triangles: preprocessing + 2 steps
    EXPECT_EQ(refinement.factorized.rowCount(), refinement.perLevel.refinedCount());
    EXPECT_THROW(refine(cow.mesh, cow.checked.connectivity, {2, Preprocess::Never, false, {}}), InputError);
}

}  // namespace
}  // namespace psub
