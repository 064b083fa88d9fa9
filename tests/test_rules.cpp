// The geometric rules of docs/scheme.md with hand-computed values, plus invariants (weights, affinity).
#include "psub/rules.h"
#include "test_support.h"

#include <gtest/gtest.h>

#include <cmath>

namespace psub {
namespace {

using test::load;
using test::makeMesh;

std::vector<double> refineLoaded(const test::Loaded& loaded, int steps,
                                 Preprocess mode = Preprocess::Auto) {
    return refinePositions(test::refine(loaded, steps, mode), loaded.mesh.positions);
}

// Tolerance 1e-14: the expected points are short rational sums of coordinates below 10, each
// rounding by a unit of 2^-52 relative (2.2e-16).
void expectPoint(const std::vector<double>& positions, Index v, double x, double y, double z) {
    EXPECT_NEAR(positions[3 * v + 0], x, 1e-14) << "vertex " << v;
    EXPECT_NEAR(positions[3 * v + 1], y, 1e-14) << "vertex " << v;
    EXPECT_NEAR(positions[3 * v + 2], z, 1e-14) << "vertex " << v;
}

TEST(Rules, RegularInteriorWeightsAreQuarterEighthSixteenth) {
    const VertexWeights w = quadVertexWeights(4);
    // c = (n - 3) / n, d = 2 / n^2, e = 1 / n^2 at n = 4.
    EXPECT_DOUBLE_EQ(w.centre, 1.0 / 4);
    EXPECT_DOUBLE_EQ(w.edge, 1.0 / 8);
    EXPECT_DOUBLE_EQ(w.diagonal, 1.0 / 16);
}

TEST(Rules, ValenceTwoHasThePapersNegativeCentreWeight) {
    const VertexWeights w = quadVertexWeights(2);
    // c = (n - 3) / n, d = 2 / n^2, e = 1 / n^2 at n = 2: -1/2, 2/4, 1/4.
    EXPECT_DOUBLE_EQ(w.centre, -0.5);
    EXPECT_DOUBLE_EQ(w.edge, 0.5);
    EXPECT_DOUBLE_EQ(w.diagonal, 0.25);
}

TEST(Rules, WeightsSumToOne) {
    for (Index n = 2; n <= 64; ++n) {
        const VertexWeights q = quadVertexWeights(n);
        EXPECT_NEAR(q.centre + n * q.edge + n * q.diagonal, 1.0, 1e-15) << "n " << n;
        for (Index m = 0; m < n; ++m) {
            const VertexWeights w = mixedVertexWeights(n, m);
            EXPECT_NEAR(w.centre + n * w.edge + m * w.diagonal, 1.0, 1e-15) << n << "," << m;
            EXPECT_DOUBLE_EQ(w.edge, w.centre / 2);
            EXPECT_DOUBLE_EQ(w.diagonal, w.centre / 4);
        }
    }
}

TEST(Rules, CubeCornerAfterOneStepIsOneNinth) {
    const auto cube = load(test::dataPath("cube.obj"));
    const std::vector<double> p = refineLoaded(cube, 1);
    // 8 V-vertices and 6 F-vertices. At a corner P, valence 3: c = 0, d = 2/9, e = 1/9; its
    // edge neighbours sum to P, its diagonal ones to -P: P' = 2/9 P - 1/9 P = P / 9.
    ASSERT_EQ(p.size(), 3u * 14);
    for (Index v = 0; v < 8; ++v)
        for (int axis = 0; axis < 3; ++axis)
            EXPECT_NEAR(p[3 * v + axis], cube.mesh.positions[3 * v + axis] / 9, 1e-15);
}

TEST(Rules, FaceVertexIsTheFaceCentre) {
    const auto cube = load(test::dataPath("cube.obj"));
    const std::vector<double> p = refineLoaded(cube, 1);
    for (Index f = 0; f < 6; ++f) {
        double centre[3] = {0, 0, 0};
        for (Index v : cube.mesh.faces.face(f))
            for (int axis = 0; axis < 3; ++axis) centre[axis] += cube.mesh.positions[3 * v + axis] / 4;
        expectPoint(p, 8 + f, centre[0], centre[1], centre[2]);
        // The cube's faces centre on the axes at distance 1.
        EXPECT_NEAR(std::abs(centre[0]) + std::abs(centre[1]) + std::abs(centre[2]), 1.0, 1e-15);
    }
}

TEST(Rules, CubeCornerAfterTwoStepsIsNineteenEightyFirsts) {
    const auto cube = load(test::dataPath("cube.obj"));
    const std::vector<double> p = refineLoaded(cube, 2);
    // 14 vertices and one F-vertex for each of the 12 quads of step 1 (one per cube edge). At
    // the corner, still valence 3: edge neighbours are the 3 face centres (sum P), diagonal ones
    // the 3 neighbouring corners at Q / 9 (sum P / 9): P'' = 2/9 P + 1/9 P / 9 = 19/81 P.
    ASSERT_EQ(p.size(), 3u * 26);
    for (Index v = 0; v < 8; ++v)
        for (int axis = 0; axis < 3; ++axis)
            EXPECT_NEAR(p[3 * v + axis], cube.mesh.positions[3 * v + axis] * 19 / 81, 1e-15);
}

TEST(Rules, MixedRuleOnHandMadeFan) {
    // P = (0,0,1) with neighbours Q0..Q3 on the unit circle, two boundary triangles
    // [P,Q0,Q1], [P,Q1,Q2] and two quads [P,Q2,D2,Q3], [P,Q3,D3,Q0].
    // n = 4, m = 2: f = 1/(1+2+1/2) = 2/7, g = 1/7, h = 1/14.
    // P' = 2/7 P + 1/7 (sum Q = 0) + 1/14 (D2 + D3 = (0,-2,0)) = (0, -1/7, 2/7).
    auto mesh = makeMesh({0, 0, 1, 1, 0, 0, 0, 1, 0, -1, 0, 0, 0, -1, 0, -1, -1, 0, 1, -1, 0},
                         {{0, 1, 2}, {0, 2, 3}, {0, 3, 5, 4}, {0, 4, 6, 1}});
    const CheckedMesh checked = checkMesh(mesh);
    ASSERT_EQ(checked.connectivity.kind[0], VertexKind::Interior);
    ASSERT_FALSE(needsPreprocessing(mesh.faces, checked.connectivity, Preprocess::Auto));
    const std::vector<double> p = psPositions(mesh.faces, checked.connectivity, mesh.positions);
    expectPoint(p, 0, 0, -1.0 / 7, 2.0 / 7);
    for (Index v = 1; v < 7; ++v)  // boundary vertices are retained
        expectPoint(p, v, mesh.positions[3 * v], mesh.positions[3 * v + 1], mesh.positions[3 * v + 2]);
    expectPoint(p, 7, 1.0 / 3, 1.0 / 3, 1.0 / 3);      // F of [P,Q0,Q1]
    expectPoint(p, 9, -0.5, -0.5, 0.25);               // F of [P,Q2,D2,Q3]
}

TEST(Rules, MixedRuleOnPreprocessedTriangle) {
    // The paired method puts B = centroid in the triangle: three boundary triangles around B.
    // One P-S step: B has n = 3, m = 0: f = 1/(1+3/2) = 2/5, g = 1/5, so
    // B' = 2/5 B + 1/5 (A + C + D); the corners are retained; F-vertices are thirds.
    auto mesh = makeMesh({0, 0, 0, 3, 0, 0, 0, 6, 3}, {{0, 1, 2}});
    Mesh loadedMesh = mesh;
    const test::Loaded loaded{loadedMesh, checkMesh(loadedMesh)};
    const std::vector<double> p = refineLoaded(loaded, 1, Preprocess::Always);
    ASSERT_EQ(p.size(), 3u * 7);  // 3 corners + B, then 3 triangle points
    expectPoint(p, 0, 0, 0, 0);
    expectPoint(p, 1, 3, 0, 0);
    expectPoint(p, 2, 0, 6, 3);
    const double b[3] = {1, 2, 1};
    expectPoint(p, 3, 0.4 * b[0] + 0.2 * 3, 0.4 * b[1] + 0.2 * 6, 0.4 * b[2] + 0.2 * 3);
    // Triangle [A, C, B] (edge 0->1 of the input) has centre ((0+3+1)/3, (0+0+2)/3, (0+0+1)/3).
    expectPoint(p, 4, 4.0 / 3, 2.0 / 3, 1.0 / 3);
}

TEST(Rules, FlatGridStaysFlatWithBoundaryBitIdentical) {
    const auto grid = load(test::dataPath("grid4x4.obj"));
    const Hierarchy h = test::refine(grid, 5);
    const std::vector<double> p = refinePositions(h, grid.mesh.positions);
    for (std::size_t v = 0; v < p.size() / 3; ++v) EXPECT_EQ(p[3 * v + 2], 0.0);
    for (Index v = 0; v < 25; ++v)
        if (grid.checked.connectivity.kind[v] == VertexKind::Boundary) {
            for (int axis = 0; axis < 3; ++axis)
                EXPECT_EQ(p[3 * v + axis], grid.mesh.positions[3 * v + axis]) << "vertex " << v;
        }
}

TEST(Rules, TiltedGridStaysOnItsPlaneWithBoundaryBitIdentical) {
    auto grid = load(test::dataPath("grid4x4.obj"));
    // Tilt onto the plane x + 2y + 3z = 1 by setting z = (1 - x - 2y) / 3.
    for (std::size_t v = 0; v < grid.mesh.positions.size() / 3; ++v) {
        double* q = &grid.mesh.positions[3 * v];
        q[2] = (1 - q[0] - 2 * q[1]) / 3;
    }
    const Hierarchy h = test::refine(grid, 5);
    const std::vector<double> p = refinePositions(h, grid.mesh.positions);
    for (std::size_t v = 0; v < p.size() / 3; ++v)
        EXPECT_NEAR(p[3 * v] + 2 * p[3 * v + 1] + 3 * p[3 * v + 2], 1.0, 1e-12);
    for (Index v = 0; v < 25; ++v)
        if (grid.checked.connectivity.kind[v] == VertexKind::Boundary) {
            for (int axis = 0; axis < 3; ++axis)
                EXPECT_EQ(p[3 * v + axis], grid.mesh.positions[3 * v + axis]);
        }
}

TEST(Rules, AffineMapCommutesWithRefinement) {
    const double a[3][3] = {{0.8, -0.3, 0.2}, {0.1, 1.3, -0.4}, {0.5, 0.2, 0.9}};
    const double t[3] = {2.5, -1.0, 0.75};
    auto apply = [&](std::vector<double> p) {
        for (std::size_t v = 0; v < p.size() / 3; ++v) {
            const double x[3] = {p[3 * v], p[3 * v + 1], p[3 * v + 2]};
            for (int i = 0; i < 3; ++i) p[3 * v + i] = a[i][0] * x[0] + a[i][1] * x[1] + a[i][2] * x[2] + t[i];
        }
        return p;
    };
    for (const char* name : {"spot_control_mesh.obj", "grid4x4.obj"}) {
        SCOPED_TRACE(name);
        auto loaded = load(test::dataPath(name));
        const std::vector<double> refinedThenMapped = apply(refineLoaded(loaded, 3));
        loaded.mesh.positions = apply(loaded.mesh.positions);
        const std::vector<double> mappedThenRefined = refineLoaded(loaded, 3);
        ASSERT_EQ(refinedThenMapped.size(), mappedThenRefined.size());
        for (std::size_t i = 0; i < mappedThenRefined.size(); ++i)
            EXPECT_NEAR(refinedThenMapped[i], mappedThenRefined[i], 1e-12);
    }
}

TEST(Rules, NonManifoldAndUnusedVerticesAreCarriedUnchanged) {
    const auto cow = load(test::dataPath("cow.obj"));
    const std::vector<double> cowRefined = refineLoaded(cow, 2);
    for (int axis = 0; axis < 3; ++axis)
        EXPECT_EQ(cowRefined[3 * 253 + axis], cow.mesh.positions[3 * 253 + axis]);

    const auto shape = load(test::testDataPath("osd-shapes/catmark_nonman_verts.obj"));
    const std::vector<double> refined = refineLoaded(shape, 3);
    Index checked = 0;
    for (Index v = 0; v < shape.mesh.faces.vertexCount; ++v) {
        const VertexKind kind = shape.checked.connectivity.kind[v];
        if (kind != VertexKind::Unused && kind != VertexKind::NonManifold) continue;
        ++checked;
        for (int axis = 0; axis < 3; ++axis)
            EXPECT_EQ(refined[3 * v + axis], shape.mesh.positions[3 * v + axis]) << "vertex " << v;
    }
    EXPECT_EQ(checked, 5u);  // 4 pinch vertices and 1 unused vertex
}

TEST(Rules, PairedMethodKeepsOldVerticesAndAddsCentroids) {
    const auto spot = load(test::dataPath("spot_control_mesh.obj"));
    const std::vector<double> p = pairedPositions(spot.mesh.faces, spot.mesh.positions);
    const Index vertexCount = spot.mesh.faces.vertexCount;
    ASSERT_EQ(p.size(), 3u * (vertexCount + spot.mesh.faces.faceCount()));
    for (Index i = 0; i < 3 * vertexCount; ++i) EXPECT_EQ(p[i], spot.mesh.positions[i]);
    for (Index f = 0; f < spot.mesh.faces.faceCount(); ++f) {
        double centre[3] = {0, 0, 0};
        for (Index v : spot.mesh.faces.face(f))
            for (int axis = 0; axis < 3; ++axis) centre[axis] += spot.mesh.positions[3 * v + axis];
        for (int axis = 0; axis < 3; ++axis)
            EXPECT_NEAR(p[3 * (vertexCount + f) + axis], centre[axis] / spot.mesh.faces.faceSize(f), 1e-15);
    }
}

}  // namespace
}  // namespace psub
