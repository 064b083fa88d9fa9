// Catmull-Clark through OpenSubdiv: documented counts and a hand-computed vertex point.
#include "psub/catmark.h"
#include "test_support.h"

#include <gtest/gtest.h>

#include <cmath>

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

}  // namespace
}  // namespace psub
