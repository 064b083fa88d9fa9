// Connectivity, classification, the topological step and closed-form counts.
#include "test_support.h"

#include <gtest/gtest.h>

#include <algorithm>

namespace psub {
namespace {

using test::load;
using test::makeMesh;

std::vector<Index> faceOf(const Faces& faces, Index f) {
    return {faces.face(f).begin(), faces.face(f).end()};
}

TEST(Topology, CubeConnectivityPairsEveryHalfedgeWithItsReverse) {
    const auto cube = load(test::dataPath("cube.obj"));
    const Connectivity& c = cube.checked.connectivity;
    const Faces& faces = cube.mesh.faces;
    // A closed cube: 12 edges, 3 at each of the 8 corners.
    EXPECT_EQ(c.edgeCount(), 12u);
    EXPECT_EQ(c.boundaryEdgeCount, 0u);
    for (Index h = 0; h < faces.verts.size(); ++h) {
        ASSERT_NE(c.twin[h], kNoIndex);
        EXPECT_EQ(c.twin[c.twin[h]], h);
        EXPECT_EQ(faces.verts[c.twin[h]], faces.verts[c.next[h]]);
        EXPECT_EQ(c.edgeOf[h], c.edgeOf[c.twin[h]]);
    }
    for (Index v = 0; v < 8; ++v) {
        EXPECT_EQ(c.valence[v], 3u);
        EXPECT_EQ(c.kind[v], VertexKind::Interior);
        EXPECT_EQ(c.outgoingOf(v).size(), 3u);
    }
}

TEST(Topology, EdgesAreNumberedInFirstAppearanceOrder) {
    const auto cube = load(test::dataPath("cube.obj"));
    const Connectivity& c = cube.checked.connectivity;
    for (Index e = 1; e < c.edgeCount(); ++e) EXPECT_LT(c.edgeHalfedge[e - 1], c.edgeHalfedge[e]);
    for (Index h = 0; h < cube.mesh.faces.verts.size(); ++h) EXPECT_LE(c.edgeHalfedge[c.edgeOf[h]], h);
}

TEST(Topology, GridClassifiesCornersEdgesAndInteriorAsRegular) {
    const auto grid = load(test::dataPath("grid4x4.obj"));
    const Connectivity& c = grid.checked.connectivity;
    // 4 x 4 quads: 5 x 5 = 25 vertices, 4 boundary edges a side, 25 - 3 x 3 interior = 16
    // boundary vertices of which 4 corners (valence 2); all regular for their kind.
    EXPECT_EQ(c.boundaryEdgeCount, 16u);
    const VertexClasses classes = classifyVertices(c);
    EXPECT_EQ(classes.regular, 25u);
    EXPECT_EQ(classes.extraordinary, 0u);
    EXPECT_EQ(classes.boundary, 16u);
    Index corners = 0;
    for (Index v = 0; v < 25; ++v) corners += c.valence[v] == 2;
    EXPECT_EQ(corners, 4u);
}

TEST(Topology, CubeVerticesAreExtraordinary) {
    const auto cube = load(test::dataPath("cube.obj"));
    EXPECT_EQ(classifyVertices(cube.checked.connectivity).extraordinary, 8u);  // valence 3, not 4
}

TEST(Topology, BowtieCentreIsNonManifoldAndCountsAsExtraordinary) {
    const auto bowtie = load(test::testDataPath("bowtie.obj"));
    const Connectivity& c = bowtie.checked.connectivity;
    EXPECT_EQ(c.kind[0], VertexKind::NonManifold);
    // Two triangles at vertex 0, two edges each; the other 4 vertices are on open edges.
    EXPECT_EQ(c.valence[0], 4u);
    const VertexClasses classes = classifyVertices(c);
    EXPECT_EQ(classes.nonManifold, 1u);
    EXPECT_EQ(classes.boundary, 4u);
}

TEST(Topology, UnusedVertexIsClassifiedUnused) {
    auto mesh = makeMesh({0, 0, 0, 1, 0, 0, 0, 1, 0, 5, 5, 5}, {{0, 1, 2}});
    const CheckedMesh checked = checkMesh(mesh);
    EXPECT_EQ(checked.connectivity.kind[3], VertexKind::Unused);
    EXPECT_EQ(classifyVertices(checked.connectivity).unused, 1u);
    ASSERT_EQ(checked.warnings.size(), 1u);
    EXPECT_NE(checked.warnings[0].find("used by no face"), std::string::npos);
}

TEST(Topology, SingleQuadBecomesFourBoundaryTriangles) {
    const auto mesh = makeMesh({0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0}, {{0, 1, 2, 3}});
    const Connectivity c = buildConnectivity(mesh.faces);
    const Faces child = refineFaces(mesh.faces, c);
    EXPECT_EQ(child.vertexCount, 5u);
    ASSERT_EQ(child.faceCount(), 4u);
    EXPECT_EQ(faceOf(child, 0), (std::vector<Index>{0, 1, 4}));
    EXPECT_EQ(faceOf(child, 1), (std::vector<Index>{1, 2, 4}));
    EXPECT_EQ(faceOf(child, 2), (std::vector<Index>{2, 3, 4}));
    EXPECT_EQ(faceOf(child, 3), (std::vector<Index>{3, 0, 4}));
}

TEST(Topology, InteriorEdgeBecomesQuadAcrossBothFacePoints) {
    // Two quads sharing edge 1-2: face 0 holds 1->2, face 1 holds 2->1.
    const auto mesh = makeMesh({0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 2, 0, 0, 2, 1, 0},
                               {{0, 1, 2, 3}, {1, 4, 5, 2}});
    const Connectivity c = buildConnectivity(mesh.faces);
    const Faces child = refineFaces(mesh.faces, c);
    EXPECT_EQ(child.vertexCount, 8u);
    ASSERT_EQ(child.faceCount(), 7u);
    // Edge 1->2 (face 0) is met second: [1, F(1), 2, F(0)] = [1, 7, 2, 6].
    EXPECT_EQ(faceOf(child, 1), (std::vector<Index>{1, 7, 2, 6}));
    EXPECT_EQ(faceOf(child, 0), (std::vector<Index>{0, 1, 6}));
    // The child is consistently oriented (buildConnectivity would throw otherwise).
    EXPECT_NO_THROW(buildConnectivity(child));
}

TEST(Topology, PreprocessDecision) {
    const auto cube = load(test::dataPath("cube.obj"));
    const auto triangle = load(test::testDataPath("triangle.obj"));
    const auto tetrahedron = load(test::testDataPath("tetrahedron.obj"));
    const auto spot = load(test::dataPath("spot_control_mesh.obj"));
    auto decide = [](const test::Loaded& l, Preprocess mode) {
        return needsPreprocessing(l.mesh.faces, l.checked.connectivity, mode, l.mesh.source);
    };
    EXPECT_FALSE(decide(cube, Preprocess::Auto));
    EXPECT_TRUE(decide(cube, Preprocess::Always));
    EXPECT_FALSE(decide(triangle, Preprocess::Auto));   // boundary triangle: legal
    EXPECT_TRUE(decide(tetrahedron, Preprocess::Auto));  // closed triangles: not legal
    EXPECT_TRUE(decide(spot, Preprocess::Auto));         // pentagons
    EXPECT_FALSE(decide(triangle, Preprocess::Never));
    try {
        decide(spot, Preprocess::Never);
        FAIL() << "--preprocess never on a mesh with pentagons must be an error";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("spot_control_mesh.obj:"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("--preprocess"), std::string::npos) << e.what();
    }
    EXPECT_THROW(decide(tetrahedron, Preprocess::Never), InputError);
}

TEST(Topology, PairedMethodOnClosedMeshGivesOneQuadPerEdge) {
    const auto tetrahedron = load(test::testDataPath("tetrahedron.obj"));
    const Hierarchy h = test::refine(tetrahedron, 0);
    ASSERT_TRUE(h.preprocessed);
    ASSERT_EQ(h.levels.size(), 2u);
    const Faces& quads = h.levels[1].faces;
    EXPECT_EQ(quads.faceCount(), 6u);
    EXPECT_EQ(quads.vertexCount, 8u);
    for (Index f = 0; f < quads.faceCount(); ++f) EXPECT_EQ(quads.faceSize(f), 4u);
}

TEST(Topology, ClosedFormCountsMatchRefinementOnEveryModel) {
    for (const std::string& path : test::allValidModels())
      for (Boundary boundary : {Boundary::Paper, Boundary::Smooth}) {
        SCOPED_TRACE(path + " boundary " + boundaryName(boundary));
        const auto loaded = load(path);
        const Counts input = countMesh(loaded.mesh.faces, loaded.checked.connectivity);
        const Hierarchy h = test::refine(loaded, 4, Preprocess::Always, boundary);
        for (std::size_t k = 0; k < h.levels.size(); ++k) {
            const Counts real = countMesh(h.levels[k].faces, h.levels[k].connectivity);
            const Counts closed = countsAfterSteps(input, int(k), boundary, true);
            EXPECT_EQ(real.vertices, closed.vertices) << "level " << k;
            EXPECT_EQ(real.edges, closed.edges) << "level " << k;
            EXPECT_EQ(real.faces, closed.faces) << "level " << k;
            EXPECT_EQ(real.triangles, closed.triangles) << "level " << k;
            EXPECT_EQ(real.quads, closed.quads) << "level " << k;
            EXPECT_EQ(real.boundaryEdges, closed.boundaryEdges) << "level " << k;
        }
    }
}

TEST(Topology, ClosedQuadMeshDoublesItsFacesEachStep) {
    const auto cube = load(test::dataPath("cube.obj"));
    const Hierarchy h = test::refine(cube, 6);
    for (std::size_t k = 1; k < h.levels.size(); ++k)
        EXPECT_EQ(h.levels[k].faces.faceCount(), 2 * h.levels[k - 1].faces.faceCount());
    EXPECT_EQ(h.finest().faces.faceCount(), 6u * 64u);
}

TEST(Topology, EulerCharacteristicIsPreservedByEveryStep) {
    for (const std::string& path : test::allValidModels()) {
        SCOPED_TRACE(path);
        const auto loaded = load(path);
        const Hierarchy h = test::refine(loaded, 2);
        const auto chi = [](const Level& l) {
            const Counts c = countMesh(l.faces, l.connectivity);
            return std::int64_t(c.vertices) - std::int64_t(c.edges) + std::int64_t(c.faces);
        };
        for (const Level& level : h.levels) EXPECT_EQ(chi(level), chi(h.levels[0]));
    }
}

TEST(Topology, RefinedLevelsAreLegalPSInputAndKeepVertexKinds) {
    for (const std::string& path : test::allValidModels()) {
        SCOPED_TRACE(path);
        const auto loaded = load(path);
        const Hierarchy h = test::refine(loaded, 2);
        for (std::size_t k = 1; k < h.levels.size(); ++k) {
            const Level& level = h.levels[k];
            EXPECT_EQ(firstNonPSFace(level.faces, level.connectivity), kNoIndex);
            const Level& parent = h.levels[k - 1];
            for (Index v = 0; v < parent.faces.vertexCount; ++v)
                EXPECT_EQ(level.connectivity.kind[v], parent.connectivity.kind[v]) << "vertex " << v;
        }
    }
}

TEST(Topology, SmoothBoundarySplitsEveryBoundaryEdgeOnOddStepsOnly) {
    // grid4x4: 25 vertices, 16 quads, 40 edges, 16 on the boundary.
    const auto grid = load(test::dataPath("grid4x4.obj"));
    const Hierarchy h = test::refine(grid, 4, Preprocess::Auto, Boundary::Smooth);
    const Index boundaryEdges[] = {16, 32, 32, 64, 64}, vertices[] = {25, 25 + 16 + 16, 57 + 56, 113 + 112 + 32, 257 + 256};
    for (std::size_t k = 0; k < h.levels.size(); ++k) {
        EXPECT_EQ(h.levels[k].connectivity.boundaryEdgeCount, boundaryEdges[k]) << "level " << k;
        EXPECT_EQ(h.levels[k].faces.vertexCount, vertices[k]) << "level " << k;
    }
    // Step 1, boundary edge 0 (the first met: 0->1 of face 0) is split at vertex 25 + 16 into
    // [0, 41, F0] and [41, 1, F0]; the edge points are boundary vertices of valence 3.
    const Level& one = h.levels[1];
    const Index first[] = {0, 41, 25}, second[] = {41, 1, 25};
    EXPECT_TRUE(std::equal(first, first + 3, one.faces.face(0).begin()));
    EXPECT_TRUE(std::equal(second, second + 3, one.faces.face(1).begin()));
    for (Index v = 41; v < 57; ++v) {
        EXPECT_EQ(one.connectivity.kind[v], VertexKind::Boundary) << "vertex " << v;
        EXPECT_EQ(one.connectivity.valence[v], 3u) << "vertex " << v;
    }
    const BoundaryNeighbours around = boundaryNeighbours(grid.mesh.faces, grid.checked.connectivity, 0);
    EXPECT_EQ(around.previous, 5u);  // the boundary runs 5 -> 0 -> 1 (counter-clockwise)
    EXPECT_EQ(around.next, 1u);
    EXPECT_FALSE(splitsBoundary(Boundary::Paper, 1));
    EXPECT_TRUE(splitsBoundary(Boundary::Smooth, 1));
    EXPECT_FALSE(splitsBoundary(Boundary::Smooth, 2));
    EXPECT_TRUE(splitsBoundary(Boundary::Smooth, 3));
}

TEST(Topology, SmoothBoundaryLevelsAreLegalPSInputWithEulerCharacteristicKept) {
    for (const std::string& path : test::allValidModels()) {
        SCOPED_TRACE(path);
        const auto loaded = load(path);
        const Hierarchy h = test::refine(loaded, 3, Preprocess::Auto, Boundary::Smooth);
        const auto chi = [](const Level& l) {
            const Counts c = countMesh(l.faces, l.connectivity);
            return std::int64_t(c.vertices) - std::int64_t(c.edges) + std::int64_t(c.faces);
        };
        for (std::size_t k = 1; k < h.levels.size(); ++k) {
            EXPECT_EQ(firstNonPSFace(h.levels[k].faces, h.levels[k].connectivity), kNoIndex);
            EXPECT_EQ(chi(h.levels[k]), chi(h.levels[0]));
        }
    }
}

TEST(Topology, ReversedInputStaysReversed) {
    // catmark_lefthanded is clockwise throughout: refining keeps it consistently oriented.
    const auto lefthanded = load(test::testDataPath("osd-shapes/catmark_lefthanded.obj"));
    EXPECT_NO_THROW(test::refine(lefthanded, 3));
}

TEST(Topology, DirectLevelConstructionEqualsGenericBuild) {
    // Both forms of refineLevel: from a parent kept, and from one consumed (freed meanwhile).
    const auto expectLevel = [](const Level& direct, const Faces& generic, const Connectivity& built) {
        ASSERT_EQ(direct.faces.vertexCount, generic.vertexCount);
        ASSERT_EQ(direct.faces.offsets, generic.offsets);
        ASSERT_EQ(direct.faces.verts, generic.verts);
        EXPECT_EQ(direct.connectivity.faceOf, built.faceOf);
        EXPECT_EQ(direct.connectivity.next, built.next);
        EXPECT_EQ(direct.connectivity.twin, built.twin);
        EXPECT_EQ(direct.connectivity.edgeOf, built.edgeOf);
        EXPECT_EQ(direct.connectivity.edgeHalfedge, built.edgeHalfedge);
        EXPECT_EQ(direct.connectivity.outOffsets, built.outOffsets);
        EXPECT_EQ(direct.connectivity.outgoing, built.outgoing);
        EXPECT_EQ(direct.connectivity.valence, built.valence);
        EXPECT_EQ(direct.connectivity.kind, built.kind);
        EXPECT_EQ(direct.connectivity.boundaryEdgeCount, built.boundaryEdgeCount);
    };
    for (const std::string& path : test::allValidModels()) {
        SCOPED_TRACE(path);
        const auto loaded = load(path);
        Level parent{loaded.mesh.faces, loaded.checked.connectivity};
        for (int step = 0; step < 4; ++step) {
            const bool split = step % 2 == 1;  // both kinds of step, each from both kinds of parent
            const Faces generic = refineFaces(parent.faces, parent.connectivity, split);
            const Connectivity built = buildConnectivity(generic);
            const Level direct = refineLevel(parent, split);
            expectLevel(direct, generic, built);
            Level consumed = parent;
            expectLevel(refineLevel(std::move(consumed), split), generic, built);
            EXPECT_TRUE(consumed.faces.verts.empty() && consumed.faces.faceCount() == 0 &&
                        consumed.connectivity.twin.empty() && consumed.connectivity.outgoing.empty());
            parent = direct;
        }
    }
}

}  // namespace
}  // namespace psub
