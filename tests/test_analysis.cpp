// The analysis layer: robust rules as a table option, local two-step matrices from the
// engine's tables, their eigenvalues against known values, the C1 verdicts at valence 2
// (paper fails, robust passes), Catmull-Clark from OpenSubdiv against its closed form, and the
// fidelity measures against hand-computed values.
#include "psub/analysis.h"
#include "psub/evaluator.h"
#include "psub/output.h"
#include "psub/rules.h"
#include "psub/stencils.h"
#include "test_support.h"

#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>

namespace psub {
namespace {

using test::load;

// ---- Robust rules

TEST(RobustRules, WeightsSumToOneAndDifferFromThePaperOnlyAtValenceTwo) {
    for (Index n = 2; n <= 64; ++n) {
        const VertexWeights paper = quadVertexWeights(n, Rules::Paper), robust = quadVertexWeights(n, Rules::Robust);
        // Tolerance 1e-15: a sum of 2n + 1 weights rounds by a few units of 2^-53 = 1.1e-16.
        EXPECT_NEAR(robust.centre + n * robust.edge + n * robust.diagonal, 1.0, 1e-15) << "n " << n;
        if (n == 2) continue;
        EXPECT_EQ(robust.centre, paper.centre) << "n " << n;
        EXPECT_EQ(robust.edge, paper.edge) << "n " << n;
        EXPECT_EQ(robust.diagonal, paper.diagonal) << "n " << n;
    }
    const VertexWeights two = quadVertexWeights(2, Rules::Robust);
    EXPECT_DOUBLE_EQ(two.centre, 0.0);
    EXPECT_DOUBLE_EQ(two.edge, 1.0 / 3);
    EXPECT_DOUBLE_EQ(two.diagonal, 1.0 / 6);
    EXPECT_STREQ(rulesName(Rules::Paper), "paper");
    EXPECT_STREQ(rulesName(Rules::Robust), "robust");
}

TEST(RobustRules, DefaultTableIsThePapers) {
    const auto model = load(test::testDataPath("osd-shapes/catmark_val2_interior.obj"));
    const Hierarchy h = test::refine(model, 2);
    const PerLevelTable byDefault = buildPerLevelTable(h), paper = buildPerLevelTable(h, Rules::Paper);
    ASSERT_EQ(byDefault.groups.size(), paper.groups.size());
    for (std::size_t g = 0; g < paper.groups.size(); ++g) {
        EXPECT_EQ(byDefault.groups[g].centre, paper.groups[g].centre);
        EXPECT_EQ(byDefault.groups[g].edge, paper.groups[g].edge);
        EXPECT_EQ(byDefault.groups[g].diagonal, paper.groups[g].diagonal);
    }
    EXPECT_EQ(RefineOptions{}.rules, Rules::Paper);
}

TEST(RobustRules, TablesDifferOnlyInTheValenceTwoQuadGroups) {
    const auto model = load(test::testDataPath("osd-shapes/catmark_val2_interior.obj"));
    const Hierarchy h = test::refine(model, 3);
    const PerLevelTable paper = buildPerLevelTable(h, Rules::Paper), robust = buildPerLevelTable(h, Rules::Robust);
    EXPECT_EQ(paper.destinations, robust.destinations);
    EXPECT_EQ(paper.indices, robust.indices);
    ASSERT_EQ(paper.groups.size(), robust.groups.size());
    int valenceTwoGroups = 0;
    for (std::size_t g = 0; g < paper.groups.size(); ++g) {
        const RowGroup &a = paper.groups[g], &b = robust.groups[g];
        const bool valenceTwo = a.kind == RowKind::VertexQuad && a.n == 2;
        valenceTwoGroups += valenceTwo;
        EXPECT_EQ(a.centre != b.centre || a.edge != b.edge || a.diagonal != b.diagonal, valenceTwo) << "group " << g;
        EXPECT_NEAR(b.centre + b.n * b.edge + b.m * b.diagonal, 1.0, 1e-15) << "group " << g;
    }
    EXPECT_GT(valenceTwoGroups, 0);
}

TEST(RobustRules, OneStepMovesOnlyTheValenceTwoInteriorVertices) {
    // The model has pentagons: the paired method first, then one P-S step with each rule set.
    const auto model = load(test::testDataPath("osd-shapes/catmark_val2_interior.obj"));
    const Hierarchy h = test::refine(model, 1);
    ASSERT_TRUE(h.preprocessed);
    const Level& quads = h.levels[1];
    const Connectivity& c = quads.connectivity;
    const std::vector<double> input = refineLevelPositions(h, 1, model.mesh.positions);
    const std::vector<double> paper = psPositions(quads.faces, c, input, Rules::Paper);
    const std::vector<double> robust = psPositions(quads.faces, c, input, Rules::Robust);
    ASSERT_EQ(paper.size(), robust.size());
    int moved = 0;
    for (Index v = 0; v < Index(paper.size() / 3); ++v) {
        bool valenceTwo = v < quads.faces.vertexCount && c.kind[v] == VertexKind::Interior && c.valence[v] == 2;
        if (valenceTwo)
            for (Index half : c.outgoingOf(v)) valenceTwo = valenceTwo && quads.faces.faceSize(c.faceOf[half]) == 4;
        double difference = 0;
        for (int axis = 0; axis < 3; ++axis) difference = std::max(difference, std::abs(paper[3 * v + axis] - robust[3 * v + axis]));
        EXPECT_EQ(difference > 0, valenceTwo) << "vertex " << v;
        moved += valenceTwo;
    }
    EXPECT_GT(moved, 0);
}

TEST(RobustRules, RefineOptionReachesTheEvaluatorAndMatchesTheOracle) {
    const auto model = load(test::testDataPath("osd-shapes/catmark_val2_interior.obj"));
    RefineOptions options;
    options.levels = 3;
    options.rules = Rules::Robust;
    const Refinement r = refine(model.mesh, model.checked.connectivity, options);
    CpuEvaluator<double> evaluator(r.perLevel, r.factorized, r.surface, TableForm::PerLevel, 3, 1);
    std::vector<double> out(3 * std::size_t(evaluator.refinedCount()));
    evaluator.evaluate(model.mesh.positions, out);
    const std::vector<double> oracle = refinePositions(test::refine(model, 3), model.mesh.positions, Rules::Robust);
    ASSERT_EQ(out.size(), oracle.size());
    for (std::size_t i = 0; i < out.size(); ++i) ASSERT_NEAR(out[i], oracle[i], 1e-12) << "value " << i;
}

// ---- Local matrices and eigenvalues

TEST(LocalMesh, IsAValidDiskAroundAnInteriorVertexOfTheValence) {
    for (Index n : {2u, 3u, 4u, 7u}) {
        const LocalMesh local = makeLocalMesh(n, 3, 1.0);
        const CheckedMesh checked = checkMesh(local.mesh);
        EXPECT_EQ(checked.connectivity.valence[0], n);
        EXPECT_EQ(checked.connectivity.kind[0], VertexKind::Interior);
        // Each of the n sectors is a 3 x 3 grid of quads: 9 faces and 4 x 4 = 16 vertices, less
        // the centre and the 3 on the edge it shares with the next sector: 12 of its own.
        EXPECT_EQ(local.mesh.faces.faceCount(), n * 9);
        EXPECT_EQ(local.mesh.faces.vertexCount, 1 + n * 12);
        for (Index v = 1; v < local.mesh.faces.vertexCount; ++v) {
            const bool outer = local.keys[v].ring() == 3;
            EXPECT_EQ(checked.connectivity.kind[v] == VertexKind::Boundary, outer) << "vertex " << v;
            if (!outer) {
                EXPECT_EQ(checked.connectivity.valence[v], 4u) << "vertex " << v;
            }
        }
    }
}

TEST(LocalMatrix, RowsSumToOneAndTheThreeRingBlockIsInvariant) {
    for (Index n : {2u, 3u, 5u, 8u})
        for (Rules rules : {Rules::Paper, Rules::Robust}) {
            const LocalMatrix small = psTwoStepMatrix(n, rules, 3), large = psTwoStepMatrix(n, rules, 5);
            // The centre and per sector (r + 1)^2 - 1 - r vertices for r rings: 12 (r = 3), 30 (r = 5).
            ASSERT_EQ(small.size(), 1 + 12 * n);
            ASSERT_EQ(large.size(), 1 + 30 * n);
            for (std::size_t r = 0; r < small.size(); ++r) {
                double sum = 0;
                for (std::size_t c = 0; c < small.size(); ++c) {
                    sum += small.at(r, c);
                    ASSERT_EQ(small.keys[c], large.keys[c]);
                    ASSERT_NEAR(small.at(r, c), large.at(r, c), 1e-15) << "n " << n << " row " << r;
                }
                for (std::size_t c = small.size(); c < large.size(); ++c) ASSERT_EQ(large.at(r, c), 0.0);
                EXPECT_NEAR(sum, 1.0, 1e-13);
            }
        }
    EXPECT_THROW(psTwoStepMatrix(4, Rules::Paper, 2), std::invalid_argument);
}

TEST(LocalMatrix, CentreRowOfTheRegularVertexIsTwoStepsOfTheRules) {
    // Two steps at a regular vertex by hand: the centre's refined position is the V-rule of the
    // level-1 centre (1/4), its 4 level-1 neighbours (the face points, 1/8 each) and its 4
    // level-1 diagonals (the old edge neighbours' V-points, 1/16 each), all in level-0 terms.
    const LocalMatrix m = psTwoStepMatrix(4, Rules::Paper, 3);
    std::vector<double> expected(m.size(), 0.0);
    const auto column = [&](GridKey key) {
        for (std::size_t c = 0; c < m.size(); ++c)
            if (m.keys[c] == key) return c;
        ADD_FAILURE() << "missing key";
        return std::size_t(0);
    };
    const auto addVertexRule = [&](int s, int i, int j, double weight) {
        // V-rule at (s, i, j), a regular vertex: 1/4 itself, 1/8 its 4 grid neighbours, 1/16 diagonals.
        const auto key = [&](int di, int dj) {
            // Sector coordinates of a regular grid: the centre's 4 sectors tile the plane.
            const int x = (s == 0 ? i : s == 1 ? -j : s == 2 ? -i : j) + di;
            const int y = (s == 0 ? j : s == 1 ? i : s == 2 ? -j : -i) + dj;
            if (x == 0 && y == 0) return GridKey{0, 0, 0};
            if (x > 0 && y >= 0) return y == 0 ? GridKey{3, 0, x} : GridKey{0, x, y};
            if (x <= 0 && y > 0) return x == 0 ? GridKey{0, 0, y} : GridKey{1, y, -x};
            if (x < 0 && y <= 0) return y == 0 ? GridKey{1, 0, -x} : GridKey{2, -x, -y};
            return x == 0 ? GridKey{2, 0, -y} : GridKey{3, -y, x};
        };
        expected[column(key(0, 0))] += weight / 4;
        for (auto [di, dj] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) expected[column(key(di, dj))] += weight / 8;
        for (auto [di, dj] : {std::pair{1, 1}, {-1, 1}, {1, -1}, {-1, -1}}) expected[column(key(di, dj))] += weight / 16;
    };
    // Level 1 around the centre: the centre's V-point, 4 face points, 4 edge neighbours' V-points.
    addVertexRule(0, 0, 0, 1.0 / 4);
    for (int s = 0; s < 4; ++s) {
        addVertexRule(s, 1, 0, 1.0 / 16);
        for (GridKey corner : {GridKey{0, 0, 0}, GridKey{(s + 3) % 4, 0, 1}, GridKey{s, 1, 1}, GridKey{s, 0, 1}})
            expected[column(corner)] += 1.0 / 8 / 4;
    }
    for (std::size_t c = 0; c < m.size(); ++c) EXPECT_NEAR(m.at(0, c), expected[c], 1e-15) << "column " << c;
}

TEST(Eigenvalues, RegularVertexTwoStepsAreOneHalfHalfQuarter) {
    const std::vector<std::complex<double>> ev = eigenvalues(psTwoStepMatrix(4, Rules::Paper));
    // Two P-S steps at valence 4 are one dyadic step of the regular quad spline: halving the
    // parameters scales 1, u, v, uv by 1, 1/2, 1/2, 1/4. Tolerance 1e-10: an iterative eigensolver.
    const double expected[4] = {1, 0.5, 0.5, 0.25};
    for (int k = 0; k < 4; ++k) {
        EXPECT_NEAR(ev[std::size_t(k)].real(), expected[k], 1e-10) << "lambda" << k;
        EXPECT_NEAR(ev[std::size_t(k)].imag(), 0, 1e-10) << "lambda" << k;
    }
}

TEST(Eigenvalues, SubdominantAtValenceThreeAndFive) {
    // Regression values: measured with `psub analyze --valence 3,5` (Eigen's eigensolver on the
    // two-step matrix), 2026-12-02, as listed in docs/shape-rules.md; tolerance 1e-6 = the six
    // digits kept.
    EXPECT_NEAR(eigenvalues(psTwoStepMatrix(3, Rules::Paper))[1].real(), 0.400857, 1e-6);
    EXPECT_NEAR(eigenvalues(psTwoStepMatrix(5, Rules::Paper))[1].real(), 0.560306, 1e-6);
}

TEST(Eigenvalues, CatmullClarkFromOpenSubdivEqualsTheClosedForm) {
    for (Index n = 2; n <= 12; ++n) {
        const std::vector<std::complex<double>> ev = eigenvalues(catmarkOneStepMatrix(n, 1));
        EXPECT_NEAR(ev[0].real(), 1.0, 1e-12) << "n " << n;
        EXPECT_NEAR(ev[1].real(), catmarkSubdominantClosedForm(n), 1e-12) << "n " << n;
    }
    // lambda1 = (5 + cos(2 pi/n) + cos(pi/n) sqrt(2 (9 + cos(2 pi/n)))) / 16: n = 4 gives
    // (5 + 0 + sqrt(1/2) sqrt(18)) / 16 = 8/16; n = 3 gives (4.5 + 0.5 sqrt(17)) / 16 = 0.4100970
    // (tolerance 1e-6: the digits written here).
    EXPECT_NEAR(catmarkSubdominantClosedForm(4), 0.5, 1e-15);
    EXPECT_NEAR(catmarkSubdominantClosedForm(3), 0.410097, 1e-6);
}

TEST(Smoothness, PaperRulesFailAtValenceTwoAndRobustRulesPass) {
    const ValenceReport paper = analyzeValence(2, Rules::Paper);
    EXPECT_FALSE(paper.c1Necessary);
    EXPECT_FALSE(paper.characteristicMapInjective);
    EXPECT_GT(paper.normalSpreadDegrees.back(), 170);  // the two faces fold back to back
    const ValenceReport robust = analyzeValence(2, Rules::Robust);
    EXPECT_TRUE(robust.c1Necessary);
    EXPECT_TRUE(robust.characteristicMapInjective);
    // Regression value: measured with `psub analyze --valence 2 --rules robust`, 2026-12-02
    // (tolerance 1e-10: the eigensolver's).
    EXPECT_NEAR(robust.lambda1, 0.25, 1e-10);
    EXPECT_LT(robust.normalSpreadDegrees.back(), robust.normalSpreadDegrees[1]);
}

TEST(Smoothness, PaperRulesPassAtValenceThreeToEight) {
    for (Index n = 3; n <= 8; ++n) {
        const ValenceReport r = analyzeValence(n, Rules::Paper);
        EXPECT_TRUE(r.c1Necessary) << "n " << n;
        EXPECT_TRUE(r.characteristicMapInjective) << "n " << n;
        EXPECT_EQ(r.foldedFaces, 0u) << "n " << n;
        for (int w : r.ringWindings) EXPECT_EQ(std::abs(w), 1) << "n " << n;
        ASSERT_EQ(r.eigenvalues.size(), 6u);
        for (std::size_t k = 1; k < 6; ++k) EXPECT_LE(std::abs(r.eigenvalues[k]), std::abs(r.eigenvalues[k - 1]) + 1e-12);
        // Normals near the vertex line up: the spread shrinks level after level.
        EXPECT_LT(r.normalSpreadDegrees.back(), r.normalSpreadDegrees.front() / 10) << "n " << n;
        EXPECT_NEAR(r.ccLambda1, r.ccLambda1ClosedForm, 1e-12);
    }
    // Valence 4: lambda3 / lambda1^2 = (1/4) / (1/2)^2 (RegularVertexTwoStepsAreOneHalfHalfQuarter).
    EXPECT_NEAR(analyzeValence(4, Rules::Paper).lambda3OverLambda1Squared, 1.0, 1e-10);
}

// ---- Fidelity

Mesh unitSquare(double z, double shift) {
    return test::makeMesh({shift, shift, z, 1 + shift, shift, z, 1 + shift, 1 + shift, z, shift, 1 + shift, z}, {{0, 1, 2, 3}});
}

TEST(Fidelity, MeasuresOfTheCubeByHand) {
    const auto cube = load(test::dataPath("cube.obj"));
    const MeshMeasures m = measureMesh(cube.mesh.faces, cube.mesh.positions);
    // The cube [-1, 1]^3: volume 2^3, area 6 * 2^2, diagonal sqrt(3 * 2^2).
    EXPECT_NEAR(m.volume, 8, 1e-12);
    EXPECT_NEAR(m.area, 24, 1e-12);
    for (std::size_t a = 0; a < 3; ++a) {
        EXPECT_EQ(m.lo[a], -1);
        EXPECT_EQ(m.hi[a], 1);
    }
    EXPECT_NEAR(m.diagonal(), std::sqrt(12.0), 1e-12);
}

TEST(Fidelity, DistancesBetweenOffsetSquaresAreTheClosedForm) {
    // Points of the square [0,1]^2 at z = 0 against [0.5,1.5]^2 at z = 0.5: the nearest point is
    // the clamp of (x, y) to the other square, so d = sqrt(dx^2 + dy^2 + 0.25).
    const Mesh a = unitSquare(0, 0), b = unitSquare(0.5, 0.5);
    const int m = 6;
    const std::vector<double> d = surfaceDistances(a.faces, a.positions, b.faces, b.positions, m);
    // Fan triangles (0,1,2) and (0,2,3), each sampled on its barycentric grid, in that order.
    const double corners[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    std::size_t k = 0;
    for (int t = 0; t < 2; ++t) {
        const double* p0 = corners[0];
        const double* p1 = corners[t + 1];
        const double* p2 = corners[t + 2];
        for (int i = 0; i <= m; ++i)
            for (int j = 0; i + j <= m; ++j) {
                const double u = double(i) / m, v = double(j) / m, w = 1 - u - v;
                const double x = w * p0[0] + u * p1[0] + v * p2[0], y = w * p0[1] + u * p1[1] + v * p2[1];
                const double dx = std::max(0.0, 0.5 - x), dy = std::max(0.0, 0.5 - y);
                ASSERT_LT(k, d.size());
                EXPECT_NEAR(d[k++], std::sqrt(dx * dx + dy * dy + 0.25), 1e-12) << x << "," << y;
            }
    }
    EXPECT_EQ(k, d.size());
}

TEST(Fidelity, IdenticalMeshesAreAtDistanceZero) {
    const auto spot = load(test::dataPath("spot_control_mesh.obj"));
    const std::vector<double> d = surfaceDistances(spot.mesh.faces, spot.mesh.positions, spot.mesh.faces, spot.mesh.positions, 2);
    for (double distance : d) ASSERT_LT(distance, 1e-12);
}

TEST(Fidelity, CubeShrinksToAFewPercentOfCatmullClarkAtEqualFaces) {
    const auto cube = load(test::dataPath("cube.obj"));
    const Fidelity f = compareWithCatmark(cube.mesh, cube.checked.connectivity, 4);
    // 6 quads; a P-S step doubles the faces, a Catmull-Clark level quadruples them: 6 * 2^4 = 6 * 4^2.
    EXPECT_EQ(f.psFaces, 96u);
    EXPECT_EQ(f.ccFaces, 96u);
    EXPECT_NEAR(f.input.volume, 8, 1e-12);
    EXPECT_GT(f.ps.volume / f.cc.volume, 0.02);  // docs/scheme.md: about 3%
    EXPECT_LT(f.ps.volume / f.cc.volume, 0.05);
    // Regression bound: measured with `psub compare cube.obj --levels 4 --json`, 2026-12-02:
    // Hausdorff 0.629 against a Catmull-Clark box diagonal of 3.04, 0.21 (docs/shape-rules.md's
    // paper column at n = 3 too); half of it kept as the bound.
    EXPECT_GT(f.hausdorff(), 0.1 * f.cc.diagonal());
    EXPECT_GE(f.hausdorff(), f.meanDistance());
    EXPECT_EQ(f.psToCc.size(), 96u * 2 * 6);  // 2 triangles per quad, 6 samples each
    const Fidelity counts = compareWithCatmark(cube.mesh, cube.checked.connectivity, 2, Rules::Paper, 0);
    EXPECT_TRUE(counts.psToCc.empty());
    EXPECT_THROW(compareWithCatmark(cube.mesh, cube.checked.connectivity, 3), std::invalid_argument);
}

using test::readFile;

TEST(Fidelity, PlotIsAPngOfTheAdvertisedSize) {
    const auto cube = load(test::dataPath("cube.obj"));
    const Fidelity f = compareWithCatmark(cube.mesh, cube.checked.connectivity, 2);
    const std::string path = testing::TempDir() + "/psub-fidelity-plot-" + std::to_string(::getpid()) + ".png";
    writeFidelityPlot(path, f, "cube.obj");
    const std::string png = readFile(path);
    std::filesystem::remove(path);
    ASSERT_GT(png.size(), 33u);
    EXPECT_EQ(png.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
    EXPECT_EQ(png.substr(12, 4), "IHDR");
    const auto be32 = [&](std::size_t at) {
        return (unsigned(std::uint8_t(png[at])) << 24) | (unsigned(std::uint8_t(png[at + 1])) << 16) |
               (unsigned(std::uint8_t(png[at + 2])) << 8) | unsigned(std::uint8_t(png[at + 3]));
    };
    // IHDR width and height: the plot's fixed size (analysis/plot.cpp).
    EXPECT_EQ(be32(16), 960u);
    EXPECT_EQ(be32(20), 460u);
    EXPECT_THROW(writeFidelityPlot("/nonexistent-dir/x.png", f, "x"), OutputError);
}

// ---- The commands

TEST(BoundaryAspect, RightTriangleByHand) {
    // Legs 1 and 1: longest edge sqrt 2, height on it 1/sqrt 2, aspect 2.
    const Mesh triangle = test::makeMesh({0, 0, 0, 1, 0, 0, 0, 1, 0}, {{0, 1, 2}});
    const Connectivity c = buildConnectivity(triangle.faces);
    const BoundaryAspect a = boundaryTriangleAspect(triangle.faces, c, triangle.positions);
    EXPECT_EQ(a.triangles, 1u);
    EXPECT_NEAR(a.worst, 2.0, 1e-12);
    EXPECT_NEAR(a.median, 2.0, 1e-12);
}

TEST(BoundaryAspect, PaperBoundaryTrianglesGrowThreeTimesThinnerEachStep) {
    // Paper mode keeps the boundary edge a b and moves the triangle's third point to the
    // centroid (a + b + F) / 3, so the height shrinks by 3 per step: aspect 2 * 3^(k-1) on the grid.
    const auto grid = test::load(test::dataPath("grid4x4.obj"));
    const auto paper = boundaryAspectByLevel(grid.mesh, grid.checked.connectivity, 8, Boundary::Paper);
    ASSERT_EQ(paper.size(), 8u);
    for (std::size_t k = 0; k < paper.size(); ++k) {
        EXPECT_EQ(paper[k].triangles, 16u);
        EXPECT_NEAR(paper[k].worst, 2 * std::pow(3.0, double(k)), 1e-9 * std::pow(3.0, double(k))) << "level " << k + 1;
    }
    // Smooth mode doubles the boundary triangles every second step and slows the thinning
    // (edges halve every two steps while heights still shrink by 3): far thinner than the
    // grid's squares, yet 60 times better than the paper's at the median by level 11.
    const auto smooth = boundaryAspectByLevel(grid.mesh, grid.checked.connectivity, 11, Boundary::Smooth);
    const auto paper11 = boundaryAspectByLevel(grid.mesh, grid.checked.connectivity, 11, Boundary::Paper);
    // Regression value: measured with `psub analyze --boundary-aspect grid4x4.obj
    // --boundary-levels 11`, 2026-12-02: the 16 triangles doubled 6 times in 11 steps.
    EXPECT_EQ(smooth.back().triangles, 16u << 6);
    // Every paper triangle has the same aspect: 2 * 3^10 = 118098 at level 11.
    EXPECT_GT(paper11.back().median, 1e5);
    // Regression bound: measured with the same command, 2026-12-02: median 1885.5 against
    // 118098, 63 times; 50 kept as the bound.
    EXPECT_LT(smooth.back().median, paper11.back().median / 50);
}

using CommandResult = test::PsubRun;
CommandResult psub(const std::string& args) { return test::runPsub(args); }

using test::countOf;

TEST(AnalyzeCommand, JsonHasOneRecordPerValenceAndRulesWithTheStableFields) {
    const CommandResult r = psub("analyze --valence 2,3 --rules both --json");
    ASSERT_EQ(r.status, 0);
    EXPECT_EQ(r.out.front(), '[');
    EXPECT_EQ(countOf(r.out, "{\"n\": "), 4u);
    for (const char* field : {"\"rules\": ", "\"eigenvalues\": [[", "\"c1_necessary\": ",
                              "\"characteristic_map_injective\": ", "\"cc_lambda1\": "})
        EXPECT_EQ(countOf(r.out, field), 4u) << field;
    EXPECT_NE(r.out.find("{\"n\": 2, \"rules\": \"paper\""), std::string::npos);
    EXPECT_NE(r.out.find("{\"n\": 2, \"rules\": \"robust\""), std::string::npos);
    // Paper at valence 2 fails both checks; everything else passes.
    EXPECT_EQ(countOf(r.out, "\"c1_necessary\": false"), 1u);
    EXPECT_EQ(countOf(r.out, "\"characteristic_map_injective\": false"), 1u);
}

TEST(AnalyzeCommand, TableAndUsageErrors) {
    const CommandResult table = psub("analyze --valence 4 --rules paper");
    ASSERT_EQ(table.status, 0);
    // Valence 4: 1, 1/2, 1/2, 1/4 (derived in RegularVertexTwoStepsAreOneHalfHalfQuarter).
    EXPECT_NE(table.out.find("1.000000 0.500000 0.500000 0.250000"), std::string::npos) << table.out;
    EXPECT_EQ(psub("analyze --valence 1").status, 2);
    EXPECT_EQ(psub("analyze --valence 5..3").status, 2);
    EXPECT_EQ(psub("analyze --valence x").status, 2);
    EXPECT_EQ(psub("analyze --rules other").status, 2);
    EXPECT_EQ(psub("analyze --help").status, 0);
}

TEST(AnalyzeCommand, BoundaryAspectReportsBothModesPerLevel) {
    const CommandResult r = psub("analyze --boundary-aspect '" + test::dataPath("grid4x4.obj") + "' --boundary-levels 3 --json");
    ASSERT_EQ(r.status, 0);
    EXPECT_EQ(countOf(r.out, "\"boundary\": \"paper\""), 3u);
    EXPECT_EQ(countOf(r.out, "\"boundary\": \"smooth\""), 3u);
    // The grid's 16 boundary triangles at level 3: aspect 2 * 3^(3-1) (PaperBoundaryTrianglesGrow...).
    EXPECT_NE(r.out.find("{\"level\": 3, \"boundary\": \"paper\", \"triangles\": 16, \"worst_aspect\": 18"), std::string::npos)
        << r.out;
    EXPECT_EQ(psub("analyze --boundary-aspect '" + test::dataPath("cube.obj") + "'").status, 1);  // closed
    EXPECT_EQ(psub("analyze --boundary-aspect /nonexistent.obj").status, 1);
}

TEST(CompareCommand, SmoothBoundaryGivesTheFlatGridCatmullClarksArea) {
    // A flat mesh's area is fixed by its boundary polyline: equal to Catmull-Clark's exactly
    // when the boundaries are equal (smooth), not when the boundary is never refined (paper).
    const auto areas = [&](const std::string& boundary) {
        const CommandResult r = psub("compare '" + test::dataPath("grid4x4.obj") + "' --levels 4 --json --boundary " + boundary);
        EXPECT_EQ(r.status, 0);
        EXPECT_NE(r.out.find("\"boundary\": \"" + boundary + "\""), std::string::npos);
        const auto areaOf = [&](const std::string& key) {
            const std::size_t at = r.out.find("\"area\": ", r.out.find("\"" + key + "\": {"));
            return std::stod(r.out.substr(at + 8));
        };
        return std::pair{areaOf("ps"), areaOf("cc")};
    };
    const auto [smoothPS, smoothCC] = areas("smooth");
    EXPECT_NEAR(smoothPS, smoothCC, 1e-12);
    // Regression value: measured with `psub compare grid4x4.obj --levels 4 --boundary smooth`
    // (OpenSubdiv's 2 levels round the corners off), 2026-12-02; it is a multiple of 2^-4, so
    // exact in double (tolerance 1e-12 for rounding only).
    EXPECT_NEAR(smoothCC, 15.6875, 1e-12);
    const auto [paperPS, paperCC] = areas("paper");
    // The flat 4 x 4 grid of unit quads, its boundary kept: area 16.
    EXPECT_NEAR(paperPS, 16.0, 1e-12);
    EXPECT_EQ(psub("compare '" + test::dataPath("grid4x4.obj") + "' --levels 2 --boundary other").status, 2);
}

TEST(CompareCommand, PrintsTheMeasuresAndWritesThePlot) {
    const std::string plot = testing::TempDir() + "/psub-compare-plot-" + std::to_string(::getpid()) + ".png";
    const CommandResult r = psub("compare '" + test::dataPath("cube.obj") + "' --levels 2 --plot '" + plot + "'");
    ASSERT_EQ(r.status, 0);
    for (const char* needle : {"volume", "area", "box diagonal", "Hausdorff"})
        EXPECT_NE(r.out.find(needle), std::string::npos) << needle;
    EXPECT_EQ(readFile(plot).substr(1, 3), "PNG");
    std::filesystem::remove(plot);
    const CommandResult json = psub("compare '" + test::dataPath("cube.obj") + "' --levels 2 --json");
    ASSERT_EQ(json.status, 0);
    EXPECT_NE(json.out.find("\"hausdorff\": "), std::string::npos);
    EXPECT_EQ(psub("compare '" + test::dataPath("cube.obj") + "' --levels 3").status, 2);
    EXPECT_EQ(psub("compare /nonexistent.obj --levels 2").status, 1);
}

TEST(SubdivideCommand, RobustRulesChangeOnlyTheValenceTwoModelsOutput) {
    const std::string dir = testing::TempDir() + "/psub-analysis-" + std::to_string(::getpid());
    std::filesystem::create_directories(dir);
    const std::string val2 = test::testDataPath("osd-shapes/catmark_val2_interior.obj");
    ASSERT_EQ(psub("subdivide '" + val2 + "' -o '" + dir + "/psub-paper.obj' --levels 2").status, 0);
    ASSERT_EQ(psub("subdivide '" + val2 + "' -o '" + dir + "/psub-robust.obj' --levels 2 --rules robust").status, 0);
    const std::string paper = readFile(dir + "/psub-paper.obj"), robust = readFile(dir + "/psub-robust.obj");
    EXPECT_NE(paper.substr(paper.find("\nv ")), robust.substr(robust.find("\nv ")));
    const std::string cube = test::dataPath("cube.obj");
    ASSERT_EQ(psub("subdivide '" + cube + "' -o '" + dir + "/psub-paper.obj' --levels 2").status, 0);
    ASSERT_EQ(psub("subdivide '" + cube + "' -o '" + dir + "/psub-robust.obj' --levels 2 --rules robust").status, 0);
    const std::string cubePaper = readFile(dir + "/psub-paper.obj"), cubeRobust = readFile(dir + "/psub-robust.obj");
    EXPECT_EQ(cubePaper.substr(cubePaper.find("\nv ")), cubeRobust.substr(cubeRobust.find("\nv ")));
    EXPECT_EQ(psub("subdivide '" + cube + "' -o '" + dir + "/psub-cc.obj' --scheme cc --rules robust").status, 2);
    std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace psub
