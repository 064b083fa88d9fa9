// Tests of vertexRowsFromFacePoints (psub/stencils.h): a regular vertex row rewritten as the mean
// of the four new face points around it, and an extraordinary one as its centre and its face
// points, give the rules' values (hand-computed, and within rounding of the rows as built on
// every model), read only points their level writes, and are applied by refine() to every table
// an evaluator runs.
#include "psub/evaluator.h"
#include "psub/stencils.h"
#include "test_support.h"
#include "tiled_options.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace psub {
namespace {

std::vector<double> evaluated(const PerLevelTable& table, const std::vector<double>& control) {
    const FactorizedTable none;
    const SurfaceTable surface;
    CpuEvaluator<double> evaluator(table, none, surface, TableForm::PerLevel, 3, 1);
    std::vector<double> out(3 * std::size_t(table.refinedCount()));
    evaluator.evaluate(control, out);
    return out;
}

std::uint64_t rowsOfKind(const PerLevelTable& table, RowKind kind, std::uint32_t n = ~0u) {
    std::uint64_t rows = 0;
    for (const RowGroup& g : table.groups)
        if (g.kind == kind && (n == ~0u || g.n == n)) rows += g.rowCount;
    return rows;
}

// Each level's rows that read the level itself (readsOwnLevel) come after its other groups. A
// VertexFromFacePoints row reads 4 points the level's face rows write; a VertexFromCentreAndFacePoints
// row of valence n its centre, a point of the parent level, then n such face points.
void expectFacePointRowsReadFacePoints(const PerLevelTable& table) {
    for (const StencilLevel& level : table.levels) {
        std::vector<char> facePoint(level.destinationCount, 0);
        bool seen = false;
        for (std::uint64_t g = level.groupBegin; g < level.groupEnd; ++g) {
            const RowGroup& group = table.groups[g];
            if (group.kind == RowKind::FaceQuad)
                for (std::uint64_t r = 0; r < group.rowCount; ++r) facePoint[table.destinations[group.rowBegin + r]] = 1;
            if (!readsOwnLevel(group.kind)) {
                ASSERT_FALSE(seen) << "a group after the level's face-point rows";
                continue;
            }
            seen = true;
            const bool centre = group.kind == RowKind::VertexFromCentreAndFacePoints;
            ASSERT_EQ(group.width, centre ? group.n + 1 : 4u);
            for (std::uint64_t r = 0; r < group.rowCount; ++r) {
                const std::uint32_t* row = table.indices.data() + group.indexBegin + r * group.width;
                if (centre) {
                    ASSERT_LT(row[0], level.sourceCount);
                }
                for (std::uint32_t j = centre ? 1 : 0; j < group.width; ++j)
                    ASSERT_TRUE(facePoint[row[j]]) << "reads point " << row[j];
            }
        }
    }
}

// A flat 4 x 4 grid whose centre is lifted by 16: after one step (by the rules, 1/4, 1/8, 1/16)
// the centre's point has z = 4, its four edge neighbours' 2, its four diagonals' 1, the four
// face points around the centre 4 (16 / 4), every other point 0. The rewritten rows (the nine
// interior vertices) give exactly these values.
TEST(FacePoints, ALiftedGridCentreIsHandComputed) {
    const test::Loaded loaded = test::load(test::dataPath("grid4x4.obj"));
    PerLevelTable table = buildPerLevelTable(test::refine(loaded, 1));
    ASSERT_EQ(vertexRowsFromFacePoints(table), 9u);  // the 3 x 3 interior vertices
    EXPECT_EQ(rowsOfKind(table, RowKind::VertexQuad), 0u);
    expectFacePointRowsReadFacePoints(table);
    std::vector<double> control = loaded.mesh.positions;
    const auto at = [&](const std::vector<double>& p, std::size_t v, int axis) { return p[3 * v + std::size_t(axis)]; };
    std::size_t centre = 0;
    for (std::size_t v = 0; v < 25; ++v)
        if (at(control, v, 0) == 2 && at(control, v, 1) == 2) centre = v;
    control[3 * centre + 2] = 16;
    const std::vector<double> out = evaluated(table, control);
    const Faces& faces = loaded.mesh.faces;
    for (std::size_t v = 0; v < 25; ++v) {
        const double dx = std::abs(at(control, v, 0) - 2), dy = std::abs(at(control, v, 1) - 2);
        const double expected = dx + dy == 0 ? 4 : dx + dy == 1 ? 2 : dx == 1 && dy == 1 ? 1 : 0;
        EXPECT_EQ(at(out, v, 2), expected) << "vertex " << v;
        EXPECT_EQ(at(out, v, 0), at(control, v, 0)) << "vertex " << v;  // a flat, even grid: x and y kept
    }
    for (Index f = 0; f < faces.faceCount(); ++f) {
        const auto corners = faces.face(f);
        const bool touchesCentre = std::find(corners.begin(), corners.end(), Index(centre)) != corners.end();
        EXPECT_EQ(at(out, 25 + std::size_t(f), 2), touchesCentre ? 4.0 : 0.0) << "face " << f;
    }
}

// The cube (every vertex of valence 3) with its corner (1, 1, 1) lifted by 9: after one step by
// the paper's rules (c, d, e = 0, 2/9, 1/9) each corner's point is its place / 9 plus, in z, 2 for
// the lifted corner's three edge neighbours and 1 for its three diagonals (the lifted corner's
// own weight is 0); each face point the centroid of its face (+9/4 in z around the lifted corner).
// Every corner's row reads its centre and its three face points: -1/3 P + 4/9 of their sum.
TEST(FacePoints, ALiftedCubeCornerIsHandComputed) {
    const test::Loaded loaded = test::load(test::dataPath("cube.obj"));
    PerLevelTable table = buildPerLevelTable(test::refine(loaded, 1));
    ASSERT_EQ(vertexRowsFromFacePoints(table), 8u);
    EXPECT_EQ(rowsOfKind(table, RowKind::VertexQuad), 0u);
    EXPECT_EQ(rowsOfKind(table, RowKind::VertexFromCentreAndFacePoints, 3), 8u);
    expectFacePointRowsReadFacePoints(table);
    for (const RowGroup& g : table.groups) {
        if (g.kind == RowKind::VertexFromCentreAndFacePoints) {
            EXPECT_DOUBLE_EQ(g.centre, -1.0 / 3);
            EXPECT_DOUBLE_EQ(g.edge, 4.0 / 9);
        }
    }
    std::vector<double> control = loaded.mesh.positions;
    ASSERT_EQ(control[3 * 6], 1.0);  // vertex 6 is (1, 1, 1)
    ASSERT_EQ(control[3 * 6 + 1], 1.0);
    ASSERT_EQ(control[3 * 6 + 2], 1.0);
    control[3 * 6 + 2] += 9;
    const std::vector<double> out = evaluated(table, control);
    for (std::size_t v = 0; v < 8; ++v) {
        const double* place = loaded.mesh.positions.data() + 3 * v;
        const int differ = (place[0] != 1) + (place[1] != 1) + (place[2] != 1);  // from (1, 1, 1)
        const double lift = differ == 1 ? 2 : differ == 2 ? 1 : 0;
        for (int axis = 0; axis < 3; ++axis)
            EXPECT_NEAR(out[3 * v + std::size_t(axis)], place[axis] / 9 + (axis == 2 ? lift : 0), 1e-14) << "vertex " << v;
    }
    const Faces& faces = loaded.mesh.faces;
    for (Index f = 0; f < faces.faceCount(); ++f) {
        double centroid[3] = {0, 0, 0};
        bool lifted = false;
        for (Index v : faces.face(f)) {
            for (int axis = 0; axis < 3; ++axis) centroid[axis] += loaded.mesh.positions[3 * std::size_t(v) + std::size_t(axis)] / 4;
            lifted = lifted || v == 6;
        }
        for (int axis = 0; axis < 3; ++axis)
            EXPECT_NEAR(out[3 * (8 + std::size_t(f)) + std::size_t(axis)], centroid[axis] + (axis == 2 && lifted ? 2.25 : 0), 1e-14)
                << "face " << f;
    }
}

// A row is rewritten only where the table's own face rows are the vertex's four faces: a row
// whose diagonal names another point, or whose point has a face row too few, is kept as it is.
TEST(FacePoints, ARowTheFaceRowsDoNotMatchIsKept) {
    const test::Loaded loaded = test::load(test::dataPath("grid4x4.obj"));
    const PerLevelTable built = buildPerLevelTable(test::refine(loaded, 1));
    std::uint64_t group = built.groups.size();
    for (std::uint64_t g = 0; g < built.groups.size(); ++g)
        if (built.groups[g].kind == RowKind::VertexQuad && built.groups[g].n == 4) group = g;
    ASSERT_LT(group, built.groups.size());
    const RowGroup& vertices = built.groups[group];
    ASSERT_EQ(vertices.rowCount, 9u);
    {
        PerLevelTable table = built;
        std::uint32_t* row = table.indices.data() + vertices.indexBegin;  // the first row
        std::swap(row[5], row[1]);  // a diagonal and an edge neighbour change places
        EXPECT_EQ(vertexRowsFromFacePoints(table), 8u);
        EXPECT_EQ(rowsOfKind(table, RowKind::VertexQuad, 4), 1u);
    }
    {
        PerLevelTable table = built;
        const std::uint32_t centre = table.indices[vertices.indexBegin + 4 * vertices.width];  // the middle row's P
        bool changed = false;  // one face row around it names another of its corners instead
        for (const RowGroup& g : table.groups)
            for (std::uint64_t r = 0; g.kind == RowKind::FaceQuad && r < g.rowCount && !changed; ++r) {
                std::uint32_t* corners = table.indices.data() + g.indexBegin + r * g.width;
                for (int j = 0; j < 4 && !changed; ++j)
                    if (corners[j] == centre) corners[j] = corners[(j + 1) % 4], changed = true;
            }
        ASSERT_TRUE(changed);
        EXPECT_LT(vertexRowsFromFacePoints(table), 9u);
        bool centreKept = false;
        for (const RowGroup& g : table.groups)
            for (std::uint64_t r = 0; g.kind == RowKind::VertexQuad && r < g.rowCount; ++r)
                centreKept = centreKept || table.indices[g.indexBegin + r * g.width] == centre;
        EXPECT_TRUE(centreKept);
    }
}

// The rows of quads' vertices of valence 2 to 16 but 4, as built.
std::uint64_t extraordinaryQuadRows(const PerLevelTable& table) {
    std::uint64_t rows = 0;
    for (const RowGroup& g : table.groups)
        if (g.kind == RowKind::VertexQuad && g.n != 4 && g.n >= 2 && g.n <= 16 && g.m == g.n) rows += g.rowCount;
    return rows;
}

// On every model, both boundary modes and both rule sets, 3 steps: the rewritten table gives the
// rows as built within double rounding; with the paper's rules every quads' vertex row of
// valence up to 16 is rewritten; with Rules::Shape those beside a face with a corner rule are kept.
TEST(FacePoints, EveryModelGivesTheRowsAsBuiltWithinRounding) {
    std::uint64_t kept = 0, extraordinary = 0;
    for (const std::string& path : test::allValidModels())
        for (Boundary boundary : {Boundary::Paper, Boundary::Smooth})
            for (Rules rules : {Rules::Paper, Rules::Shape}) {
                SCOPED_TRACE(path + " " + boundaryName(boundary) + " " + rulesName(rules));
                const test::Loaded loaded = test::load(path);
                const PerLevelTable built = buildPerLevelTable(test::refine(loaded, 3, Preprocess::Auto, boundary), rules);
                PerLevelTable rewritten = built;
                const std::uint64_t count = vertexRowsFromFacePoints(rewritten);
                const std::uint64_t valence4 = rowsOfKind(built, RowKind::VertexQuad, 4);
                const std::uint64_t regular = rowsOfKind(rewritten, RowKind::VertexFromFacePoints),
                                    others = rowsOfKind(rewritten, RowKind::VertexFromCentreAndFacePoints);
                if (rules == Rules::Paper) {
                    EXPECT_EQ(regular, valence4);
                    EXPECT_EQ(others, extraordinaryQuadRows(built));
                }
                EXPECT_LE(regular, valence4);
                EXPECT_LE(others, extraordinaryQuadRows(built));
                kept += valence4 - regular;
                extraordinary += others;
                EXPECT_EQ(regular + others, count);
                EXPECT_EQ(rewritten.destinations.size(), built.destinations.size());
                expectFacePointRowsReadFacePoints(rewritten);
                const std::vector<double> expected = evaluated(built, loaded.mesh.positions),
                                          actual = evaluated(rewritten, loaded.mesh.positions);
                const double scale = std::max(1.0, test::boundingDiagonal(loaded.mesh.positions));
                ASSERT_EQ(actual.size(), expected.size());
                for (std::size_t i = 0; i < expected.size(); ++i)
                    ASSERT_NEAR(actual[i], expected[i], 1e-12 * scale) << "value " << i;
            }
    EXPECT_GT(kept, 0u);  // Rules::Shape kept some
    EXPECT_GT(extraordinary, 0u);
}

// Every table refine() hands an evaluator has been rewritten, the tiled form's lean rows too
// (whose levels past B have only some face rows: a vertex row whose faces are not all there is
// kept); the factorized table is composed from the rows as built.
TEST(FacePoints, RefineRewritesTheTablesItReturns) {
    const test::Loaded torus = test::loadTorus(40, 24);
    for (bool perLevel : {true, false}) {
        SCOPED_TRACE(perLevel ? "full build" : "lean build");
        RefineOptions options = test::tiledOptions(5, Boundary::Paper, Rules::Paper, TileSides::Every);
        options.perLevel = perLevel;
        const Refinement r = refine(torus.mesh, torus.checked.connectivity, options);
        ASSERT_GT(r.tiled.tileCount(), 0u);
        EXPECT_GT(rowsOfKind(r.tiled.rows, RowKind::VertexFromFacePoints), 0u);
        expectFacePointRowsReadFacePoints(r.tiled.rows);
        if (perLevel) {
            EXPECT_EQ(rowsOfKind(r.perLevel, RowKind::VertexQuad), 0u);
            expectFacePointRowsReadFacePoints(r.perLevel);
        }
    }
    RefineOptions options{3, Preprocess::Auto, true, {}};
    const Refinement r = refine(torus.mesh, torus.checked.connectivity, options);
    EXPECT_EQ(r.factorized.rowCount(), r.perLevel.refinedCount());
    EXPECT_THROW(buildFactorizedTable(r.perLevel), std::invalid_argument);
    PerLevelTable again = r.perLevel;
    EXPECT_THROW(vertexRowsFromFacePoints(again), std::invalid_argument);
    options.vertexRowsFromFacePoints = false;
    EXPECT_EQ(rowsOfKind(refine(torus.mesh, torus.checked.connectivity, options).perLevel, RowKind::VertexFromFacePoints), 0u);
}

}  // namespace
}  // namespace psub
