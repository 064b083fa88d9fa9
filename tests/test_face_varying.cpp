// Face-varying texture coordinates (docs/face-varying.md): OBJ vt input and checks, the
// channel's levels and tables, no smear across seams, the affine and hand-computed cases, the
// rule path, the Vulkan evaluator, and `psub subdivide` with UVs.
#include "psub/evaluator.h"
#include "psub/rules.h"
#include "psub/stencils.h"
#include "psub/topology.h"
#if PSUB_HAVE_VULKAN
#include "vulkan_test_support.h"
#endif

#include "test_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <numbers>
#include <numeric>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <sys/wait.h>
#include <unistd.h>

namespace psub {
namespace {

using test::inputErrorOf;

// A mesh with UVs: faces over positions, and per face the value of each corner.
Mesh withUv(Mesh mesh, std::vector<double> values, std::initializer_list<std::initializer_list<Index>> corners) {
    mesh.uv.values = std::move(values);
    for (auto face : corners) mesh.uv.corners.insert(mesh.uv.corners.end(), face.begin(), face.end());
    return mesh;
}

// The unit cube, each face its own UV island: face i is the square [2i, 2i+1] x [0, 1].
Mesh cubeSixIslands() {
    Mesh mesh = test::makeMesh({0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0, 0, 1, 1, 0, 1, 1, 1, 1, 0, 1, 1},
                               {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4}, {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7}});
    const double square[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    for (Index f = 0; f < 6; ++f)
        for (Index c = 0; c < 4; ++c) {
            mesh.uv.values.push_back(2.0 * f + square[c][0]);
            mesh.uv.values.push_back(square[c][1]);
            mesh.uv.corners.push_back(4 * f + c);
        }
    return mesh;
}

// An open cylinder of `around` x `rings` quads with one seam: u = j / around, the column
// j = around repeating column 0's positions with u = 1.
Mesh cylinderOneSeam(Index around = 8, Index rings = 3) {
    Mesh mesh;
    for (Index r = 0; r <= rings; ++r)
        for (Index j = 0; j < around; ++j) {
            const double angle = 2 * M_PI * j / around;
            mesh.positions.insert(mesh.positions.end(), {std::cos(angle), std::sin(angle), double(r)});
        }
    for (Index r = 0; r <= rings; ++r)
        for (Index j = 0; j <= around; ++j) mesh.uv.values.insert(mesh.uv.values.end(), {double(j) / around, double(r) / rings});
    mesh.faces.vertexCount = Index(mesh.positions.size() / 3);
    const auto vertex = [&](Index r, Index j) { return r * around + j % around; };
    const auto value = [&](Index r, Index j) { return r * (around + 1) + j; };
    for (Index r = 0; r < rings; ++r)
        for (Index j = 0; j < around; ++j) {
            const Index face[4] = {vertex(r, j), vertex(r, j + 1), vertex(r + 1, j + 1), vertex(r + 1, j)};
            mesh.faces.addFace(face);
            mesh.uv.corners.insert(mesh.uv.corners.end(), {value(r, j), value(r, j + 1), value(r + 1, j + 1), value(r + 1, j)});
        }
    return mesh;
}

// The affine map the grid's UVs are of its positions.
void affineUv(double x, double y, double& u, double& v) {
    u = 0.3 * x - 0.7 * y + 0.25;
    v = 0.9 * x + 0.2 * y - 1.5;
}

// A planar n x n grid, irregularly spaced (every second quad split into two triangles when
// `triangles`, so that interior valences vary): UVs an affine map of the positions,
// one value per vertex.
Mesh affineGrid(bool triangles) {
    const Index n = 5;
    Mesh mesh;
    for (Index i = 0; i <= n; ++i)
        for (Index j = 0; j <= n; ++j) {
            const double x = j + 0.13 * std::sin(3.0 * i + j), y = i + 0.11 * std::cos(i + 2.0 * j);
            mesh.positions.insert(mesh.positions.end(), {x, y, 0.0});
            double u, v;
            affineUv(x, y, u, v);
            mesh.uv.values.insert(mesh.uv.values.end(), {u, v});
        }
    mesh.faces.vertexCount = Index(mesh.positions.size() / 3);
    const auto at = [&](Index i, Index j) { return i * (n + 1) + j; };
    for (Index i = 0; i < n; ++i)
        for (Index j = 0; j < n; ++j) {
            const Index a = at(i, j), b = at(i, j + 1), c = at(i + 1, j + 1), d = at(i + 1, j);
            if (triangles && (i + j) % 2 == 0) {
                const Index t1[3] = {a, b, c}, t2[3] = {a, c, d};
                mesh.faces.addFace(t1);
                mesh.faces.addFace(t2);
            } else {
                const Index q[4] = {a, b, c, d};
                mesh.faces.addFace(q);
            }
        }
    mesh.uv.corners = mesh.faces.verts;
    return mesh;
}

struct Case {
    std::string name;
    Mesh mesh;
};

std::vector<Case> handCases() {
    return {{"cube", cubeSixIslands()}, {"cylinder", cylinderOneSeam()}, {"grid", affineGrid(false)},
            {"triangles", affineGrid(true)}, {"spot", readObj(test::dataPath("spot_control_mesh_uv.obj"))}};
}

struct Refined {
    Refinement r;
    std::vector<double> positions, uv;
};

Refined refineWithUv(const Mesh& mesh, int levels, Preprocess preprocess, UvLinear linear, Rules rules = Rules::Paper) {
    const CheckedMesh checked = checkMesh(mesh);
    RefineOptions options;
    options.levels = levels;
    options.rules = rules;
    options.preprocess = preprocess;
    options.uvLinear = linear;
    Refined out{refine(mesh, checked.connectivity, options), {}, {}};
    CpuEvaluator<double> evaluator(out.r.perLevel, out.r.factorized, out.r.surface, TableForm::PerLevel);
    out.positions.resize(3 * std::size_t(evaluator.refinedCount()));
    evaluator.evaluate(mesh.positions, out.positions);
    out.uv.resize(2 * std::size_t(out.r.uv.valueCount()));
    evaluateFaceVarying<double>(out.r.uv, mesh.uv.values, out.uv);
    return out;
}

// Island of each input value: faces joined through edges whose two faces name the same values
// at both ends (union-find over faces); a value takes the island of the faces naming it.
std::vector<int> valueIslands(const Mesh& mesh) {
    const CheckedMesh checked = checkMesh(mesh);
    const Connectivity& c = checked.connectivity;
    std::vector<Index> parent(mesh.faces.faceCount());
    std::iota(parent.begin(), parent.end(), 0);
    const std::function<Index(Index)> root = [&](Index f) { return parent[f] == f ? f : parent[f] = root(parent[f]); };
    for (Index h = 0; h < c.twin.size(); ++h) {
        const Index t = c.twin[h];
        if (t == kNoIndex) continue;
        if (mesh.uv.corners[h] == mesh.uv.corners[c.next[t]] && mesh.uv.corners[c.next[h]] == mesh.uv.corners[t])
            parent[root(c.faceOf[h])] = root(c.faceOf[t]);
    }
    std::vector<int> island(mesh.uv.valueCount(), -1);
    for (Index h = 0; h < mesh.uv.corners.size(); ++h) {
        int& own = island[mesh.uv.corners[h]];
        const int face = int(root(c.faceOf[h]));
        EXPECT_TRUE(own == -1 || own == face) << "value " << mesh.uv.corners[h] << " named by two islands";
        own = face;
    }
    return island;
}

// The islands each refined value draws on: its row's sources' islands, level by level.
std::vector<std::set<int>> refinedIslands(const FaceVaryingTable& table, const std::vector<int>& control) {
    std::vector<std::set<int>> current(control.size());
    for (std::size_t v = 0; v < control.size(); ++v)
        if (control[v] >= 0) current[v].insert(control[v]);
    const PerLevelTable& t = table.perLevel;
    for (const StencilLevel& level : t.levels) {
        std::vector<std::set<int>> next(level.destinationCount);
        for (std::uint64_t g = level.groupBegin; g < level.groupEnd; ++g) {
            const RowGroup& group = t.groups[g];
            for (std::uint64_t r = 0; r < group.rowCount; ++r)
                for (std::uint32_t j = 0; j < group.width; ++j) {
                    const std::set<int>& from = current[t.indices[group.indexBegin + r * group.width + j]];
                    next[t.destinations[group.rowBegin + r]].insert(from.begin(), from.end());
                }
        }
        current = std::move(next);
    }
    return current;
}

// No smear: every refined value used by a face draws on one island, and all corners of a face
// on the same one.
void expectNoSmear(const Mesh& mesh, const FaceVaryingTable& table, const std::string& what) {
    const std::vector<std::set<int>> islands = refinedIslands(table, valueIslands(mesh));
    for (std::size_t f = 0; f + 1 < table.faceOffsets.size(); ++f) {
        const std::set<int>& first = islands[table.faceValues[table.faceOffsets[f]]];
        ASSERT_EQ(first.size(), 1u) << what << ": face " << f << " corner 0 draws on " << first.size() << " islands";
        for (std::uint32_t c = table.faceOffsets[f]; c < table.faceOffsets[f + 1]; ++c)
            ASSERT_EQ(islands[table.faceValues[c]], first) << what << ": face " << f << " mixes islands";
    }
}

// The channel's faces are the surface's, each as it is or split along its a-b diagonal into
// [a, b, F(f)] then [b, a, F(g)] (docs/face-varying.md); each value belongs to one vertex.
void expectFacesFollowSurface(const Refinement& r, const std::string& what) {
    const FaceVaryingTable& uv = r.uv;
    const SurfaceTable& s = r.surface;
    std::size_t u = 0;
    for (std::size_t f = 0; f + 1 < s.faceOffsets.size(); ++f) {
        ASSERT_LT(u + 1, uv.faceOffsets.size()) << what;
        const std::vector<std::uint32_t> face(s.faceVerts.begin() + s.faceOffsets[f], s.faceVerts.begin() + s.faceOffsets[f + 1]);
        const std::vector<std::uint32_t> mine(uv.faceVerts.begin() + uv.faceOffsets[u], uv.faceVerts.begin() + uv.faceOffsets[u + 1]);
        if (mine == face) {
            ++u;
            continue;
        }
        ASSERT_EQ(face.size(), 4u) << what << ": surface face " << f;
        ASSERT_EQ(mine, (std::vector<std::uint32_t>{face[0], face[2], face[3]})) << what << ": surface face " << f;
        const std::vector<std::uint32_t> other(uv.faceVerts.begin() + uv.faceOffsets[u + 1], uv.faceVerts.begin() + uv.faceOffsets[u + 2]);
        ASSERT_EQ(other, (std::vector<std::uint32_t>{face[2], face[0], face[1]})) << what << ": surface face " << f;
        u += 2;
    }
    EXPECT_EQ(u + 1, uv.faceOffsets.size()) << what;
    std::vector<std::uint32_t> vertexOf(uv.valueCount(), ~0u);
    for (std::size_t c = 0; c < uv.faceValues.size(); ++c) {
        std::uint32_t& v = vertexOf[uv.faceValues[c]];
        ASSERT_TRUE(v == ~0u || v == uv.faceVerts[c]) << what << ": value " << uv.faceValues[c] << " at two vertices";
        v = uv.faceVerts[c];
    }
}

// The rule path (stencils/rules.cpp, never the table builder): each level's values from the
// parent's with psPositions / pairedPositions over the face-varying mesh (values padded to
// xyz), then each seam triangle's point replaced by its diagonal's midpoint.
std::vector<double> rulePathUv(const Mesh& mesh, int levels, Preprocess mode, UvLinear linear, Rules rules = Rules::Paper) {
    const CheckedMesh checked = checkMesh(mesh);
    const bool preprocess = needsPreprocessing(mesh.faces, checked.connectivity, mode);
    const Hierarchy h = refineTopology(mesh.faces, checked.connectivity, preprocess, levels);
    FaceVaryingLevel level = faceVaryingBase(mesh, checked.connectivity);
    const std::vector<char> corners = inputCorners(level.faces, level.connectivity, rules);
    std::vector<double> xyz;
    for (std::size_t v = 0; v < mesh.uv.valueCount(); ++v) xyz.insert(xyz.end(), {mesh.uv.values[2 * v], mesh.uv.values[2 * v + 1], 0.0});
    for (std::size_t k = 1; k < h.levels.size(); ++k) {
        const bool paired = (preprocess && k == 1) || linear == UvLinear::All;
        // Rules::Shape's corners: those of the channel's base level, numbered first at every level.
        std::vector<double> next = paired ? pairedPositions(level.faces, xyz)
                                          : psPositions(level.faces, level.connectivity, xyz, rules, false, &corners);
        for (Index f = 0; f < level.faces.faceCount(); ++f) {
            if (!level.split[f]) continue;
            const Index a = level.faces.face(f)[0], b = level.faces.face(f)[1];
            for (int axis = 0; axis < 3; ++axis)
                next[3 * (level.faces.vertexCount + f) + std::size_t(axis)] = (xyz[3 * a + std::size_t(axis)] + xyz[3 * b + std::size_t(axis)]) / 2;
        }
        xyz = std::move(next);
        level = refineFaceVarying(level, h.levels[k - 1]);
    }
    std::vector<double> uv;
    for (std::size_t v = 0; v < xyz.size() / 3; ++v) uv.insert(uv.end(), {xyz[3 * v], xyz[3 * v + 1]});
    return uv;
}

// ---------------------------------------------------------------------------------------
// OBJ input

TEST(FaceVaryingObj, ReadsVtAndCornerIndices) {
    const Mesh mesh = parseObj("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0.5 0.25 7\nvt 1 0\nvt 1 1\nvt 0\n"
                               "f 1/1/1 2/2/1 3/-2/1 4/-1\n", "in.obj");
    ASSERT_FALSE(mesh.uv.empty());
    EXPECT_EQ(mesh.uv.width, 2u);
    EXPECT_EQ(mesh.uv.values, (std::vector<double>{0.5, 0.25, 1, 0, 1, 1, 0, 0}));
    EXPECT_EQ(mesh.uv.corners, (std::vector<Index>{0, 1, 2, 3}));
    // The four vt statements are lines 5 to 8 (after four v lines); vt 4's "0" has v = 0.
    EXPECT_EQ(mesh.uv.valueLine, (std::vector<std::uint32_t>{5, 6, 7, 8}));
}

TEST(FaceVaryingObj, FacesWithoutVtKeepNoChannel) {
    const Mesh mesh = parseObj("v 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nf 1 2 3\nf 1//1 3//1 2//1\n", "in.obj");
    EXPECT_TRUE(mesh.uv.empty());
    EXPECT_TRUE(mesh.uv.values.empty());
}

TEST(FaceVaryingObj, SomeFacesWithoutVtDropTheChannelWithAWarning) {
    std::vector<std::string> warnings;
    const Mesh mesh = parseObj("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\n"
                               "f 1/1 2/2 3/3\nf 1 3 4\n", "in.obj", &warnings);
    EXPECT_TRUE(mesh.uv.empty());
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_NE(warnings[0].find("in.obj:9: face 2 lacks a texture coordinate"), std::string::npos) << warnings[0];
    // A face where only some corners name one counts as a face without them.
    warnings.clear();
    const Mesh mixed = parseObj("v 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nf 1/1 2/1 3\n", "in.obj", &warnings);
    EXPECT_TRUE(mixed.uv.empty());
    EXPECT_EQ(mixed.faces.faceCount(), 1u);
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_NE(warnings[0].find("in.obj:5: face 1 lacks a texture coordinate"), std::string::npos) << warnings[0];
}

TEST(FaceVaryingObj, VtIndicesWithoutAnyVtStatementKeepNoChannel) {
    std::vector<std::string> warnings;
    const Mesh mesh = parseObj("v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1/1 2/2 3/3\n", "in.obj", &warnings);
    EXPECT_TRUE(mesh.uv.empty());
    EXPECT_EQ(mesh.faces.faceCount(), 1u);
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_NE(warnings[0].find("in.obj: faces name texture coordinates but the file has no vt statement"), std::string::npos);
}

TEST(FaceVaryingObj, BadVtIsAnErrorNamingFileAndLine) {
    const std::string head = "v 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\n";
    const auto error = [&](const std::string& tail) { return inputErrorOf([&] { parseObj(head + tail, "in.obj"); }); };
    // `head` is 6 lines with 3 vt: the tail is line 7, and a vt there is texture coordinate 4.
    EXPECT_NE(error("f 1/1 2/2 3/4\n").find("in.obj:7: face 1: texture-coordinate index 4 is out of range (the file has 3"), std::string::npos);
    EXPECT_NE(error("f 1/1 2/2 3/0\n").find("in.obj:7: face 1: texture-coordinate index 0"), std::string::npos);
    EXPECT_NE(error("f 1/1 2/2 3/-4\n").find("in.obj:7: face 1: relative texture-coordinate index -4"), std::string::npos);
    EXPECT_NE(error("f 1/1 2/2 3/x\n").find("in.obj:7: face 1: bad texture-coordinate reference 'x'"), std::string::npos);
    EXPECT_NE(error("vt 0 abc\n").find("in.obj:7: texture coordinate 4: expected a number, got 'abc'"), std::string::npos);
    EXPECT_NE(error("vt 0 nan\n").find("in.obj:7: texture coordinate 4: v is not finite"), std::string::npos);
    EXPECT_NE(error("vt inf 0\n").find("in.obj:7: texture coordinate 4: u is not finite"), std::string::npos);
    EXPECT_NE(error("vt 0 1e999\n").find("in.obj:7: texture coordinate 4: number out of range"), std::string::npos);
    EXPECT_NE(error("vt 0 0 0 0\n").find("in.obj:7: texture coordinate 4: unexpected '0' after 3 numbers"), std::string::npos);
    EXPECT_NE(error("vt\n").find("in.obj:7: texture coordinate 4: expected u [v [w]]"), std::string::npos);
}

TEST(FaceVaryingObj, CheckFaceVaryingValidatesInMemoryMeshes) {
    Mesh mesh = withUv(test::makeMesh({0, 0, 0, 1, 0, 0, 1, 1, 0}, {{0, 1, 2}}), {0, 0, 1, 0, 1, 1}, {{0, 1, 2}});
    EXPECT_NO_THROW(checkMesh(mesh));
    // Messages count from 1: corner value 3 is index 4 of 3 values; values[3] is the second
    // value's v; in `shared` the second value is named at vertices 1 and 3 (0-based), i.e. 2 and 4.
    Mesh outOfRange = mesh;
    outOfRange.uv.corners[2] = 3;
    EXPECT_NE(inputErrorOf([&] { checkMesh(outOfRange); }).find("face 1: texture-coordinate index 4 is out of range (3"), std::string::npos);
    Mesh missing = mesh;
    missing.uv.corners.pop_back();
    EXPECT_NE(inputErrorOf([&] { checkMesh(missing); }).find("2 texture-coordinate indices for 3 face corners"), std::string::npos);
    Mesh notFinite = mesh;
    notFinite.uv.values[3] = NAN;
    EXPECT_NE(inputErrorOf([&] { checkMesh(notFinite); }).find("texture coordinate 2 is not finite"), std::string::npos);
    Mesh shared = withUv(test::makeMesh({0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0}, {{0, 1, 2}, {0, 2, 3}}), {0, 0, 1, 0, 1, 1},
                         {{0, 1, 2}, {0, 2, 1}});
    EXPECT_NE(inputErrorOf([&] { checkMesh(shared); }).find("face 2: texture coordinate 2 is named at vertex 4 and at vertex 2"),
              std::string::npos);
}

// A value named at two vertices (an OBJ `vt` reused across vertices) gets one copy per further
// vertex, appended: the channel then checks, keeps the numbers per corner, and keeps the line.
TEST(FaceVaryingObj, AValueNamedAtTwoVerticesIsCopied) {
    const std::string text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\n"
                             "f 1/1 2/2 3/3\nf 1/1 3/3 4/2\n";
    Mesh mesh = parseObj(text, "shared.obj");
    ASSERT_EQ(mesh.uv.valueCount(), 4u);  // vt 2 copied for vertex 4
    EXPECT_NO_THROW(checkMesh(mesh));
    const std::vector<Index> corners{0, 1, 2, 0, 2, 3};
    EXPECT_EQ(mesh.uv.corners, corners);
    // The copy (value 3) is vt 2 = (1, 0), read on line 6.
    EXPECT_EQ(mesh.uv.values[6], 1.0);
    EXPECT_EQ(mesh.uv.values[7], 0.0);
    ASSERT_EQ(mesh.uv.valueLine.size(), 4u);
    EXPECT_EQ(mesh.uv.valueLine[3], 6u);
}

// ---------------------------------------------------------------------------------------
// The channel's tables

// Without seams (values one per vertex) the channel's rows are the position rows exactly.
TEST(FaceVarying, WithoutSeamsTheRowsAreThePositionRows) {
    for (const std::string& path : {test::dataPath("cube.obj"), test::dataPath("grid4x4.obj"), test::dataPath("spot_control_mesh.obj"),
                                    test::testDataPath("triangle.obj"), test::testDataPath("osd-shapes/catmark_val2_interior.obj")}) {
        Mesh mesh = readObj(path);
        mesh.uv.corners = mesh.faces.verts;
        for (std::size_t v = 0; v < mesh.faces.vertexCount; ++v)
            mesh.uv.values.insert(mesh.uv.values.end(), {mesh.positions[3 * v], mesh.positions[3 * v + 1]});
        for (int levels : {1, 2, 3}) {
            const Refined r = refineWithUv(mesh, levels, Preprocess::Auto, UvLinear::Boundaries);
            const PerLevelTable& a = r.r.perLevel;
            PerLevelTable b = r.r.uv.perLevel;
            vertexRowsFromFacePoints(b);  // refine() rewrites the positions' table, not the channel's
            ASSERT_EQ(a.levels.size(), b.levels.size()) << path;
            EXPECT_EQ(a.destinations, b.destinations) << path << " " << levels;
            EXPECT_EQ(a.indices, b.indices) << path << " " << levels;
            ASSERT_EQ(a.groups.size(), b.groups.size()) << path;
            for (std::size_t g = 0; g < a.groups.size(); ++g) {
                EXPECT_EQ(a.groups[g].kind, b.groups[g].kind);
                EXPECT_EQ(a.groups[g].rowCount, b.groups[g].rowCount);
                EXPECT_EQ(a.groups[g].centre, b.groups[g].centre);
            }
            EXPECT_EQ(r.r.uv.faceOffsets, r.r.surface.faceOffsets) << path;
            EXPECT_EQ(r.r.uv.faceVerts, r.r.surface.faceVerts) << path;
            EXPECT_EQ(r.r.uv.faceValues, r.r.surface.faceVerts) << path;
        }
    }
}

// The rules reproduce affine functions: UVs that are an affine map of the positions stay the
// same affine map of the refined positions, quads and (preprocessed) triangles, every parity.
TEST(FaceVarying, AffineUvsFollowTheRefinedPositions) {
    for (bool triangles : {false, true})
        for (Preprocess preprocess : {Preprocess::Auto, Preprocess::Always})
            for (int levels : {1, 2, 3, 4, 5}) {
                const Mesh mesh = affineGrid(triangles);
                const Refined r = refineWithUv(mesh, levels, preprocess, UvLinear::Boundaries);
                // Tolerance 1e-12: coordinates and UVs are at most about 5, so it is some 2000
                // units of 2^-53 * 5 = 5.6e-16, room for rounding over up to 5 steps of averaging
                // (exact arithmetic gives 0).
                ASSERT_EQ(r.r.uv.valueCount(), r.r.surface.vertexCount);
                for (std::size_t v = 0; v < r.r.surface.vertexCount; ++v) {
                    double u, w;
                    affineUv(r.positions[3 * v], r.positions[3 * v + 1], u, w);
                    ASSERT_NEAR(r.uv[2 * v], u, 1e-12) << "triangles " << triangles << " levels " << levels << " vertex " << v;
                    ASSERT_NEAR(r.uv[2 * v + 1], w, 1e-12);
                }
            }
}

// Every case, odd and even levels, preprocessed or not, both choices: faces follow the surface,
// no face mixes islands, the table equals the rule path and buildFaceVaryingTable.
TEST(FaceVarying, EveryCaseEveryLevelNoSmearAndRulePath) {
    for (const Case& c : handCases())
        for (UvLinear linear : {UvLinear::Boundaries, UvLinear::All})
            for (Preprocess preprocess : {Preprocess::Auto, Preprocess::Always})
                for (int levels : {0, 1, 2, 3, 4}) {
                    const std::string what = c.name + " " + uvLinearName(linear) + " levels " + std::to_string(levels) +
                                             (preprocess == Preprocess::Always ? " preprocessed" : "");
                    const Refined r = refineWithUv(c.mesh, levels, preprocess, linear);
                    expectFacesFollowSurface(r.r, what);
                    expectNoSmear(c.mesh, r.r.uv, what);
                    const std::vector<double> expected = rulePathUv(c.mesh, levels, preprocess, linear);
                    ASSERT_EQ(expected.size(), r.uv.size()) << what;
                    // Tolerance 1e-12: the same sums in another order (tables against the rules),
                    // UVs of size up to about 11 (the cube's islands), over up to 4 steps.
                    for (std::size_t i = 0; i < expected.size(); ++i) ASSERT_NEAR(r.uv[i], expected[i], 1e-12) << what << " value " << i / 2;
                    const CheckedMesh checked = checkMesh(c.mesh);
                    const Hierarchy h = refineTopology(c.mesh.faces, checked.connectivity, r.r.preprocessed, levels);
                    const FaceVaryingTable built = buildFaceVaryingTable(h, c.mesh, linear);
                    EXPECT_EQ(built.perLevel.indices, r.r.uv.perLevel.indices) << what;
                    EXPECT_EQ(built.faceValues, r.r.uv.faceValues) << what;
                }
}

// Rules::Shape in the channel: the corner rule wherever the channel's own mesh has an input
// corner (Spot's UV islands have interior values of valence 3), the table against the rule path.
TEST(FaceVarying, ShapeRulesEqualTheRulePath) {
    // Three quads around one interior vertex of valence 3, UVs = x, y: one island, so the
    // channel has the corner too (the hand cases' valence-3 values all lie on seams).
    std::string fan = "v 0 0 0\nvt 0 0\n";
    for (int k = 0; k < 6; ++k) {
        const double a = std::numbers::pi / 3 * k;
        fan += "v " + std::to_string(std::cos(a)) + " " + std::to_string(std::sin(a)) + " 0.25\n";
        fan += "vt " + std::to_string(std::cos(a)) + " " + std::to_string(std::sin(a)) + "\n";
    }
    fan += "f 1/1 2/2 3/3 4/4\nf 1/1 4/4 5/5 6/6\nf 1/1 6/6 7/7 2/2\n";
    std::vector<Case> cases = handCases();
    cases.push_back({"fan", parseObj(fan, "fan.obj")});
    bool anyCorner = false;
    for (const Case& c : cases)
        for (Preprocess preprocess : {Preprocess::Auto, Preprocess::Always})
            for (int levels : {1, 2, 3}) {
                const std::string what = c.name + " levels " + std::to_string(levels) +
                                         (preprocess == Preprocess::Always ? " preprocessed" : "");
                const Refined r = refineWithUv(c.mesh, levels, preprocess, UvLinear::Boundaries, Rules::Shape);
                for (const RowGroup& g : r.r.uv.perLevel.groups) anyCorner = anyCorner || g.kind == RowKind::VertexCorner;
                const std::vector<double> expected = rulePathUv(c.mesh, levels, preprocess, UvLinear::Boundaries, Rules::Shape);
                ASSERT_EQ(expected.size(), r.uv.size()) << what;
                // Tolerance 1e-12: as in EveryCaseEveryLevelNoSmearAndRulePath.
                for (std::size_t i = 0; i < expected.size(); ++i) ASSERT_NEAR(r.uv[i], expected[i], 1e-12) << what << " value " << i / 2;
            }
    EXPECT_TRUE(anyCorner);  // the corner rows were exercised
}

// The seams really split faces (the split is exercised), and the cylinder's seam keeps u = 0
// and u = 1 apart: no refined face spans more than half the texture.
TEST(FaceVarying, SeamsSplitFacesAndNoFaceSpansTheCylinderSeam) {
    const Mesh mesh = cylinderOneSeam();
    for (int levels : {1, 2, 3, 4}) {
        const Refined r = refineWithUv(mesh, levels, Preprocess::Auto, UvLinear::Boundaries);
        const std::size_t faces = r.r.uv.faceOffsets.size() - 1, surfaceFaces = r.r.surface.faceOffsets.size() - 1;
        // After odd steps the faces straddle the seam's edges (3 input edges, each two seam
        // edges two steps later): one extra face per seam edge; after even steps none.
        EXPECT_EQ(faces - surfaceFaces, levels % 2 == 1 ? std::size_t(3) << (levels / 2) : 0u) << levels;
        for (std::size_t f = 0; f < faces; ++f) {
            double lo = 2, hi = -1;
            for (std::uint32_t c = r.r.uv.faceOffsets[f]; c < r.r.uv.faceOffsets[f + 1]; ++c) {
                lo = std::min(lo, r.uv[2 * r.r.uv.faceValues[c]]);
                hi = std::max(hi, r.uv[2 * r.r.uv.faceValues[c]]);
            }
            // Bound 0.5: a column of the cylinder is 1/8 wide in u; a face smeared across the
            // seam would reach from near 0 to near 1.
            ASSERT_LT(hi - lo, 0.5) << "levels " << levels << " face " << f;
        }
    }
}

// Seam polylines are kept with "boundaries": a value on the cylinder's seam keeps u exactly 0
// or 1 at every level; interior values move by the P-S rules.
TEST(FaceVarying, SeamValuesStayOnTheSeam) {
    const Mesh mesh = cylinderOneSeam();
    const Refined r = refineWithUv(mesh, 4, Preprocess::Auto, UvLinear::Boundaries);
    std::size_t onSeam = 0;
    for (std::size_t c = 0; c < r.r.uv.faceVerts.size(); ++c) {
        const std::uint32_t v = r.r.uv.faceVerts[c];
        const double y = r.positions[3 * v + 1], x = r.positions[3 * v];
        if (std::abs(y) < 1e-12 && x > 0) {  // on the seam's plane: the seam vertices
            const double u = r.uv[2 * r.r.uv.faceValues[c]];
            EXPECT_TRUE(u == 0.0 || u == 1.0) << u;
            ++onSeam;
        }
    }
    EXPECT_GT(onSeam, 0u);
}

// Hand case, one step: two unit quads side by side, f0 = [0,1,4,3] with values 0..3 =
// (0,0) (1,0) (1,1) (0,1), f1 = [1,2,5,4] with values 4..7 = (2,0) (3,0) (3,1) (2,1): edge
// 1-4 is a seam. Step 1: values 0..7 kept (all on boundaries), 8 = F(f0) = (0.5,0.5), 9 =
// F(f1) = (2.5,0.5); the face of edge 1-4 is split: [1,2,8] (f0's side, positions 1,4,F0)
// then [7,4,9] (f1's side, positions 4,1,F1). Step 2: the seam triangle [1,2,8] gets the seam
// point (1,0) + (1,1) / 2 = (1,0.5), not its centroid (5/6,1/2); the triangle [0,1,8] (a
// boundary triangle) its centroid (0.5, 1/6); value 8, interior with four triangles around
// (n = 4, m = 0: f = 1/3, g = 1/6), stays (1/3)(0.5,0.5) + (1/6)(2,2) = (0.5,0.5).
TEST(FaceVarying, HandComputedSeamStep) {
    const Mesh mesh = withUv(test::makeMesh({0, 0, 0, 1, 0, 0, 2, 0, 0, 0, 1, 0, 1, 1, 0, 2, 1, 0}, {{0, 1, 4, 3}, {1, 2, 5, 4}}),
                             {0, 0, 1, 0, 1, 1, 0, 1, 2, 0, 3, 0, 3, 1, 2, 1}, {{0, 1, 2, 3}, {4, 5, 6, 7}});
    const Refined one = refineWithUv(mesh, 1, Preprocess::Never, UvLinear::Boundaries);
    ASSERT_EQ(one.r.uv.valueCount(), 10u);
    EXPECT_EQ(std::vector<double>(one.uv.begin(), one.uv.begin() + 16), mesh.uv.values);
    EXPECT_EQ(std::vector<double>(one.uv.begin() + 16, one.uv.end()), (std::vector<double>{0.5, 0.5, 2.5, 0.5}));
    // Faces: edge 0-1 [0,1,8], edge 1-4 split [1,2,8] [7,4,9], ...
    EXPECT_EQ(std::vector<std::uint32_t>(one.r.uv.faceValues.begin(), one.r.uv.faceValues.begin() + 9),
              (std::vector<std::uint32_t>{0, 1, 8, 1, 2, 8, 7, 4, 9}));
    EXPECT_EQ(std::vector<std::uint32_t>(one.r.uv.faceVerts.begin() + 3, one.r.uv.faceVerts.begin() + 9),
              (std::vector<std::uint32_t>{1, 4, 6, 4, 1, 7}));
    const Refined two = refineWithUv(mesh, 2, Preprocess::Never, UvLinear::Boundaries);
    // Step 2 as derived above; [7,4,9]'s seam point is (7 + 4) / 2 = ((2,1) + (2,0)) / 2 = (2,0.5).
    // Tolerance 1e-15: sixths and halves of small numbers, a few units of 2^-53 at most.
    ASSERT_EQ(two.r.uv.valueCount(), 10u + 8u);  // 10 values + 8 face-varying faces (7 faces, one split)
    EXPECT_NEAR(two.uv[2 * 8], 0.5, 1e-15);
    EXPECT_NEAR(two.uv[2 * 8 + 1], 0.5, 1e-15);
    EXPECT_NEAR(two.uv[2 * 10], 0.5, 1e-15);  // F of [0,1,8]
    EXPECT_NEAR(two.uv[2 * 10 + 1], 1.0 / 6, 1e-15);
    EXPECT_NEAR(two.uv[2 * 11], 1.0, 1e-15);  // seam point of [1,2,8]
    EXPECT_NEAR(two.uv[2 * 11 + 1], 0.5, 1e-15);
    EXPECT_NEAR(two.uv[2 * 12], 2.0, 1e-15);  // seam point of [7,4,9]
    EXPECT_NEAR(two.uv[2 * 12 + 1], 0.5, 1e-15);
}

// "all" is linear everywhere: the cube's island squares stay flat squares (every value is an
// average of its island's corners), and an interior vertex keeps its value.
TEST(FaceVarying, LinearAllKeepsEveryValue) {
    const Mesh mesh = affineGrid(false);
    const Refined r = refineWithUv(mesh, 3, Preprocess::Auto, UvLinear::All);
    for (std::size_t i = 0; i < mesh.uv.values.size(); ++i) EXPECT_EQ(r.uv[i], mesh.uv.values[i]);
    const Refined smooth = refineWithUv(mesh, 3, Preprocess::Auto, UvLinear::Boundaries);
    bool moved = false;
    for (std::size_t i = 0; i < mesh.uv.values.size(); ++i) moved = moved || smooth.uv[i] != mesh.uv.values[i];
    EXPECT_TRUE(moved) << "interior values move by the P-S rules with 'boundaries'";
}

TEST(FaceVarying, SmoothBoundaryLeavesTheChannelEmpty) {
    const Mesh mesh = cylinderOneSeam();
    const CheckedMesh checked = checkMesh(mesh);
    RefineOptions options;
    options.boundary = Boundary::Smooth;
    EXPECT_TRUE(refine(mesh, checked.connectivity, options).uv.empty());
    options.boundary = Boundary::Paper;
    EXPECT_FALSE(refine(mesh, checked.connectivity, options).uv.empty());
}

// The tiled form's textured faces (TiledTable::uvFace..., docs/face-varying.md): per corner of
// every refined face drawn from the tiled form, its position (tiled evaluator, drawing order)
// and UV (the channel's values, evaluated once per level) are those of the same corner of the
// same face of the per-level channel (its canonical vertex through TiledTable::canonical): the
// faces are the channel's faces, each once, split seam faces included, with no face mixing
// islands; ordered by their first drawn corner. Seam models, odd and even levels.
TEST(FaceVaryingTiled, DrawingOrderCornersHaveThePerLevelPositionsAndUvs) {
    const std::vector<Case> cases = {{"cube", cubeSixIslands()}, {"cylinder", cylinderOneSeam(12, 8)},
                                     {"spot", readObj(test::dataPath("spot_control_mesh_uv.obj"))}};
    for (const Case& c : cases) {
        std::size_t tiles = 0;
        for (int levels : {1, 2, 3, 4, 5}) {
            const std::string what = c.name + " levels " + std::to_string(levels);
            const CheckedMesh checked = checkMesh(c.mesh);
            RefineOptions options;
            options.levels = levels;
            options.tiled = true;
            const Refinement r = refine(c.mesh, checked.connectivity, options);
            const TiledTable& t = r.tiled;
            tiles += t.tileCount();
            CpuEvaluator<double> perLevel(r.perLevel, r.factorized, r.surface, TableForm::PerLevel), tiled(t);
            std::vector<double> canonical(3 * std::size_t(perLevel.refinedCount())), drawing(canonical.size());
            perLevel.evaluate(c.mesh.positions, canonical);
            tiled.evaluate(c.mesh.positions, drawing);
            // The per-level channel's faces, as (canonical vertex, value) per corner: the same value
            // is the same UV (the values are evaluated once, from the one per-level channel).
            std::map<std::vector<std::uint32_t>, int> faces;
            for (std::size_t f = 0; f + 1 < r.uv.faceOffsets.size(); ++f) {
                std::vector<std::uint32_t> key;
                for (std::uint32_t k = r.uv.faceOffsets[f]; k < r.uv.faceOffsets[f + 1]; ++k)
                    key.insert(key.end(), {r.uv.faceVerts[k], r.uv.faceValues[k]});
                ++faces[key];
            }
            ASSERT_EQ(t.uvFaceOffsets.size(), r.uv.faceOffsets.size()) << what;
            ASSERT_EQ(t.uvFaceValues.size(), t.uvFaceVerts.size()) << what;
            const double scale = test::boundingDiagonal(canonical);
            std::uint32_t lastFirst = 0;
            for (std::size_t f = 0; f + 1 < t.uvFaceOffsets.size(); ++f) {
                std::vector<std::uint32_t> key;
                std::uint32_t first = ~0u;
                for (std::uint32_t k = t.uvFaceOffsets[f]; k < t.uvFaceOffsets[f + 1]; ++k) {
                    const std::uint32_t p = t.uvFaceVerts[k], v = t.canonical[p];
                    first = std::min(first, p);
                    key.insert(key.end(), {v, t.uvFaceValues[k]});
                    // Tolerance 1e-12 of the diagonal: the same sums in another order (tiles against rows).
                    for (std::size_t axis = 0; axis < 3; ++axis) {
                        ASSERT_NEAR(drawing[3 * p + axis], canonical[3 * v + axis], 1e-12 * scale) << what << " face " << f;
                    }
                }
                ASSERT_GE(first, lastFirst) << what << ": faces not ordered by their first drawn corner";
                lastFirst = first;
                const auto found = faces.find(key);
                ASSERT_TRUE(found != faces.end() && found->second > 0)
                    << what << ": tiled face " << f << " is no face of the per-level channel (or is there twice)";
                --found->second;
            }
            // Every per-level face was met once (the counts match and none went below zero).
            for (const auto& [key, left] : faces) ASSERT_EQ(left, 0) << what;
            // The UVs read through the tiled faces are the per-level corners' values: no face mixes islands.
            FaceVaryingTable drawn = r.uv;
            drawn.faceOffsets = t.uvFaceOffsets, drawn.faceVerts = t.uvFaceVerts, drawn.faceValues = t.uvFaceValues;
            expectNoSmear(c.mesh, drawn, what + " (tiled faces)");
        }
        // Tiles exist at some level, so drawing positions differ from canonical ones somewhere
        // (the cube's 8 valence-3 corners leave no regular tile up to 5 steps: all fallback).
        if (c.name != "cube") {
            EXPECT_GT(tiles, 0u) << c.name;
        }
    }
}

#if PSUB_HAVE_VULKAN
// The Vulkan evaluator on the channel's per-level table (width 2) agrees with the CPU.
TEST(FaceVaryingVulkan, AgreesWithTheCpu) {
    std::unique_ptr<VulkanContext> context;
    test::makeContextOrSkip(context, VulkanOptions{});
    if (!context) return;
    const Mesh mesh = readObj(test::dataPath("spot_control_mesh_uv.obj"));
    const Refined r = refineWithUv(mesh, 4, Preprocess::Auto, UvLinear::Boundaries);
    static const SurfaceTable noSurface;
    static const FactorizedTable noFactorized;
    VulkanEvaluator gpu(*context, r.r.uv.perLevel, noFactorized, noSurface, TableForm::PerLevel, 2);
    const std::vector<float> in(mesh.uv.values.begin(), mesh.uv.values.end());
    std::vector<float> out(2 * std::size_t(gpu.refinedCount()));
    gpu.evaluate(in, out);
    ASSERT_EQ(out.size(), r.uv.size());
    // UVs in [0, 1], float on the device against double: 6e-8 per rounding over 4 steps, 1e-5.
    for (std::size_t i = 0; i < out.size(); ++i) ASSERT_NEAR(double(out[i]), r.uv[i], 1e-5) << "value " << i / 2;
}
#endif

// ---------------------------------------------------------------------------------------
// psub subdivide with UVs

struct PsubRun {
    int status;
    std::string err;
};

PsubRun runPsub(const std::string& args, const std::filesystem::path& dir) {
    const std::string errPath = (dir / "stderr.txt").string();
    const int raw = std::system((std::string(PSUB_EXE) + " " + args + " >/dev/null 2>" + errPath).c_str());
    std::ifstream in(errPath);
    std::stringstream text;
    text << in.rdbuf();
    return {WIFEXITED(raw) ? WEXITSTATUS(raw) : -1, text.str()};
}

std::filesystem::path freshDir(const std::string& name) {
    const auto dir = std::filesystem::temp_directory_path() / ("psub_fvar_" + name + "_" + std::to_string(::getpid()));
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    return dir;
}

TEST(FaceVaryingCli, SubdivideWritesVtAndFacesThatReadBack) {
    const auto dir = freshDir("write");
    const std::string in = test::dataPath("spot_control_mesh_uv.obj"), out = (dir / "out.obj").string();
    for (const char* linear : {"boundaries", "all"}) {
        const PsubRun run = runPsub("subdivide " + in + " -o " + out + " --levels 3 --uv-linear " + linear, dir);
        ASSERT_EQ(run.status, 0) << run.err;
        const Mesh written = readObj(out);
        const Refined r = refineWithUv(readObj(in), 3, Preprocess::Auto,
                                       std::string(linear) == "all" ? UvLinear::All : UvLinear::Boundaries);
        ASSERT_FALSE(written.uv.empty());
        EXPECT_EQ(written.positions, r.positions);
        EXPECT_EQ(written.uv.values, r.uv);
        EXPECT_EQ(written.faces.verts, r.r.uv.faceVerts);
        EXPECT_EQ(written.faces.offsets, r.r.uv.faceOffsets);
        EXPECT_EQ(written.uv.corners, r.r.uv.faceValues);
        EXPECT_NO_THROW(checkMesh(written));
    }
    std::filesystem::remove_all(dir);
}

TEST(FaceVaryingCli, BadVtIndexIsExitOneWithNoOutput) {
    const auto dir = freshDir("bad");
    const std::string in = (dir / "bad.obj").string(), out = (dir / "out.obj").string();
    std::ofstream(in) << "v 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nf 1/1 2/1 3/2\n";
    const PsubRun run = runPsub("subdivide " + in + " -o " + out, dir);
    EXPECT_EQ(run.status, 1);
    EXPECT_NE(run.err.find(in + ":5: face 1: texture-coordinate index 2 is out of range"), std::string::npos) << run.err;
    EXPECT_FALSE(std::filesystem::exists(out));
    std::filesystem::remove_all(dir);
}

TEST(FaceVaryingCli, SmoothBoundaryWithUvsIsAUsageError) {
    const auto dir = freshDir("smooth");
    const std::string out = (dir / "out.obj").string();
    const PsubRun run = runPsub("subdivide " + test::dataPath("spot_control_mesh_uv.obj") + " -o " + out + " --boundary smooth", dir);
    EXPECT_EQ(run.status, 2);
    EXPECT_NE(run.err.find("--boundary smooth does not refine texture coordinates"), std::string::npos) << run.err;
    EXPECT_FALSE(std::filesystem::exists(out));
    const PsubRun bad = runPsub("subdivide " + test::dataPath("cube.obj") + " -o " + out + " --uv-linear some", dir);
    EXPECT_EQ(bad.status, 2);
    std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace psub
