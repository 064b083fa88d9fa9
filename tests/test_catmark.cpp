// Catmull-Clark through OpenSubdiv: documented counts and a hand-computed vertex point.
#include "psub/catmark.h"
#include "psub/evaluator.h"
#include "psub/stencils.h"
#include "test_support.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <utility>

namespace psub {
namespace {

using test::load;

TEST(Catmark, CubeCountsMatchOpenSubdivDocumentation) {
    const auto cube = load(test::dataPath("cube.obj"));
    const auto levels = refineCatmark(cube.mesh.faces, cube.mesh.positions, 3);
    ASSERT_EQ(levels.size(), 4u);
    const std::uint64_t vertices[] = {8, 26, 98, 386}, edges[] = {12, 48, 192, 768},
                        faces[] = {6, 24, 96, 384};
    for (int k = 0; k <= 3; ++k) {
        EXPECT_EQ(levels[k].counts.vertices, vertices[k]) << "level " << k;
        EXPECT_EQ(levels[k].counts.edges, edges[k]) << "level " << k;
        EXPECT_EQ(levels[k].counts.faces, faces[k]) << "level " << k;
        EXPECT_EQ(levels[k].positions.size(), 3 * vertices[k]);
    }
}

TEST(Catmark, TorusCountsQuadrupleEachLevel) {
    const auto torus = load(test::testDataPath("osd-shapes/catmark_torus.obj"));
    const auto levels = refineCatmark(torus.mesh.faces, torus.mesh.positions, 3, false);
    for (int k = 0; k <= 3; ++k) {
        const std::uint64_t scale = std::uint64_t(1) << (2 * k);
        EXPECT_EQ(levels[k].counts.faces, 32 * scale);
        EXPECT_EQ(levels[k].counts.vertices, 32 * scale);
        EXPECT_EQ(levels[k].counts.edges, 64 * scale);
        EXPECT_TRUE(levels[k].positions.empty());
    }
}

TEST(Catmark, CubeCornerVertexPointIsFiveNinths) {
    // Valence 3 corner P = (1,1,1): (Q + 2R + (n-3)P)/n with face-point mean Q = (1,1,1)/3 and
    // edge-midpoint mean R = (2,2,2)/3 gives (5/9)(1,1,1).
    const auto cube = load(test::dataPath("cube.obj"));
    const auto levels = refineCatmark(cube.mesh.faces, cube.mesh.positions, 1);
    int found = 0;
    const std::vector<double>& p = levels[1].positions;
    for (std::size_t v = 0; v < p.size() / 3; ++v)
        found += std::abs(p[3 * v] - 5.0 / 9) < 1e-6 && std::abs(p[3 * v + 1] - 5.0 / 9) < 1e-6 &&
                 std::abs(p[3 * v + 2] - 5.0 / 9) < 1e-6;
    EXPECT_EQ(found, 1);
}

TEST(Catmark, TwoPSStepsGiveOneCatmullClarkStepsFaceCount) {
    for (const char* name : {"cube.obj", "cow.obj", "spot_control_mesh.obj"}) {
        SCOPED_TRACE(name);
        const auto loaded = load(test::dataPath(name));
        const auto cc = refineCatmark(loaded.mesh.faces, {}, 2, false);
        const Hierarchy ps = test::refine(loaded, 4, Preprocess::Always);
        // The paired method and one P-S step reach Catmull-Clark level 1; two more, level 2.
        EXPECT_EQ(ps.levels[2].faces.faceCount(), cc[1].counts.faces);
        EXPECT_EQ(ps.levels[4].faces.faceCount(), cc[2].counts.faces);
    }
}

TEST(Catmark, BoundaryIsInterpolatedEdgeOnly) {
    // VTX_BOUNDARY_EDGE_ONLY: the flat grid's corner stays put, the grid stays flat.
    const auto grid = load(test::dataPath("grid4x4.obj"));
    const auto levels = refineCatmark(grid.mesh.faces, grid.mesh.positions, 2);
    for (std::size_t v = 0; v < levels[2].positions.size() / 3; ++v)
        EXPECT_EQ(levels[2].positions[3 * v + 2], 0.0);
}

// A mesh's directed boundary edges as their two end positions.
std::vector<std::array<double, 6>> boundaryEdges(const Faces& faces, const std::vector<double>& p) {
    const Connectivity c = buildConnectivity(faces);
    std::vector<std::array<double, 6>> edges;
    for (Index h = 0; h < faces.verts.size(); ++h) {
        if (c.twin[h] != kNoIndex) continue;
        const Index a = faces.verts[h], b = faces.verts[c.next[h]];
        edges.push_back({p[3 * a], p[3 * a + 1], p[3 * a + 2], p[3 * b], p[3 * b + 1], p[3 * b + 2]});
    }
    return edges;
}

// Edges of `actual` with no edge of `expected` within `tolerance` (every coordinate).
std::size_t unmatchedEdges(const std::vector<std::array<double, 6>>& actual,
                           const std::vector<std::array<double, 6>>& expected, double tolerance) {
    std::size_t unmatched = 0;
    for (const auto& edge : actual) {
        bool found = false;
        for (const auto& other : expected) {
            bool same = true;
            for (int i = 0; i < 6; ++i) same = same && std::abs(edge[i] - other[i]) <= tolerance;
            found = found || same;
        }
        unmatched += !found;
    }
    return unmatched;
}

// P-S positions and faces after `levels` steps through the engine's tables (CPU, double).
std::pair<Faces, std::vector<double>> psThroughTables(const test::Loaded& loaded, int levels, Boundary boundary) {
    RefineOptions options;
    options.levels = levels;
    options.boundary = boundary;
    const Refinement r = refine(loaded.mesh, loaded.checked.connectivity, options);
    CpuEvaluator<double> evaluator(r.perLevel, r.factorized, r.surface, TableForm::PerLevel);
    std::vector<double> positions(3 * std::size_t(evaluator.refinedCount()));
    evaluator.evaluate(loaded.mesh.positions, positions);
    Faces faces;
    faces.vertexCount = r.surface.vertexCount;
    faces.offsets = r.surface.faceOffsets;
    faces.verts = r.surface.faceVerts;
    return {faces, positions};
}

TEST(Catmark, SmoothBoundaryAfter2kPSStepsIsCatmullClarksBoundaryAfterK) {
    const std::vector<std::string> models = test::manifoldModelsWithBoundary();
    ASSERT_GE(models.size(), 5u);
    for (const std::string& path : models)
        for (int k : {1, 2}) {
            SCOPED_TRACE(path + " k " + std::to_string(k));
            const auto loaded = load(path);
            const auto cc = refineCatmark(loaded.mesh.faces, loaded.mesh.positions, k).back();
            const auto [faces, positions] = psThroughTables(loaded, 2 * k, Boundary::Smooth);
            const auto ps = boundaryEdges(faces, positions), expected = boundaryEdges(cc.faces, cc.positions);
            ASSERT_EQ(ps.size(), expected.size());
            EXPECT_EQ(unmatchedEdges(ps, expected, 1e-12), 0u);
            // The paper's boundary is not Catmull-Clark's (so the check above can fail).
            const auto [paperFaces, paperPositions] = psThroughTables(loaded, 2 * k, Boundary::Paper);
            const auto paper = boundaryEdges(paperFaces, paperPositions);
            EXPECT_NE(paper.size(), expected.size());
        }
}

TEST(Catmark, SmoothBoundaryAfterOddStepsIsAlreadyCatmullClarksPolyline) {
    // The split comes first in each pair, so after 2k - 1 steps the boundary is CC's after k.
    const auto grid = load(test::dataPath("grid4x4.obj"));
    const auto cc = refineCatmark(grid.mesh.faces, grid.mesh.positions, 2).back();
    const auto [faces, positions] = psThroughTables(grid, 3, Boundary::Smooth);
    EXPECT_EQ(unmatchedEdges(boundaryEdges(faces, positions), boundaryEdges(cc.faces, cc.positions), 1e-12), 0u);
}

}  // namespace
}  // namespace psub

namespace psub {
namespace {

// The playback stencils give refineCatmark's finest faces and positions (float rounding), on a
// closed mesh, one with a boundary and one with triangles; 0 levels is the identity.
TEST(CatmarkStencils, EqualRefineCatmarkOnTheFinestLevel) {
    for (const char* name : {"cube.obj", "grid4x4.obj", "cow.obj"}) {
        const test::Loaded loaded = test::load(test::dataPath(name));
        for (int levels : {0, 1, 2}) {
            const CatmarkStencils stencils(loaded.mesh.faces, levels);
            const std::vector<CatmarkLevel> reference = refineCatmark(loaded.mesh.faces, loaded.mesh.positions, levels);
            const CatmarkLevel& finest = reference.back();
            ASSERT_EQ(stencils.refinedCount(), finest.faces.vertexCount) << name << " " << levels;
            EXPECT_EQ(stencils.finestFaces().offsets, finest.faces.offsets) << name << " " << levels;
            EXPECT_EQ(stencils.finestFaces().verts, finest.faces.verts) << name << " " << levels;
            const std::vector<float> control(loaded.mesh.positions.begin(), loaded.mesh.positions.end());
            std::vector<float> refined(3 * std::size_t(stencils.refinedCount()), -1.0f);
            stencils.evaluate(control, refined);
            double worst = 0;
            for (std::size_t i = 0; i < refined.size(); ++i)
                worst = std::max(worst, std::abs(double(refined[i]) - finest.positions[i]));
            // Float stencils against double: the cow's coordinates reach 6 (ulp 4.8e-7);
            // a few roundings per level, 2 levels, stay below 1e-4.
            EXPECT_LT(worst, 1e-4) << name << " " << levels;
        }
    }
}

}  // namespace
}  // namespace psub
