// Beyond the vertex weights (the analysis's search): the F-vertex weight alpha and the
// edge-neighbour weight beta next to an extraordinary vertex. With alpha = 1/4 and beta = 1/8
// the extended analysis is today's; a hand-derived entry; alpha moves lambda1; the experimental
// refinement agrees with the engine's; one point of the n = 3 trade-off curve recomputed.
#include "psub/analysis.h"
#include "psub/catmark.h"
#include "psub/rules.h"
#include "test_support.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

namespace psub {
namespace {

ExtendedShapeRule ruleOf(Index n, VertexWeights centre, double alpha, double beta) {
    ExtendedShapeRule rule;
    rule.valence = n;
    rule.centre = centre;
    rule.faceCorner = alpha;
    rule.neighbourCentre = beta;
    return rule;
}

TEST(ShapeExtended, QuarterAndEighthGiveTodaysTwoStepMatrix) {
    for (Index n : {3u, 5u, 7u}) {
        SCOPED_TRACE("valence " + std::to_string(n));
        for (Rules rules : {Rules::Paper, Rules::Shape}) {
            const VertexWeights w = quadVertexWeights(n, rules);
            const LocalMatrix today = psTwoStepMatrix(n, w, 4);
            const LocalMatrix extended = psTwoStepMatrix(ruleOf(n, w, 0.25, 0.125), 4);
            ASSERT_EQ(today.size(), extended.size());
            for (std::size_t k = 0; k < today.weights.size(); ++k) ASSERT_NEAR(today.weights[k], extended.weights[k], 1e-15);
            ValenceOptions options;
            options.extendedRule = ruleOf(n, w, 0.25, 0.125);
            ValenceOptions weightsOnly;  // the vertex weights alone (Rules::Shape adds its corner rule at n = 3)
            weightsOnly.centreWeights = w;
            const ValenceReport a = analyzeValence(n, Rules::Paper, weightsOnly), b = analyzeValence(n, rules, options);
            EXPECT_NEAR(a.lambda1, b.lambda1, 1e-12);
            EXPECT_NEAR(a.spectralGap, b.spectralGap, 1e-12);
            EXPECT_EQ(a.c1Necessary, b.c1Necessary);
            EXPECT_EQ(a.characteristicMapInjective, b.characteristicMapInjective);
        }
    }
}

// By hand: two steps carry P to the new centre P'' = c P' + d (sum of P''s edge neighbours) +
// e (sum of its diagonals). P''s edge neighbours are the F-vertices of the n faces around P,
// each alpha of P; its diagonals are the V-vertices of P's old edge neighbours, regular
// vertices with P as an edge neighbour, each beta of P; P' holds c of P. So
//     S(P, P) = c^2 + n d alpha + n e beta,
// which for alpha = 1/4, beta = 1/8 is today's c^2 + n d / 4 + n e / 8.
TEST(ShapeExtended, HandDerivedCentreEntry) {
    const Index n = 3;
    const VertexWeights w{0.5, 0.1, 0.5 / 3 - 0.1};
    for (double alpha : {0.25, 0.4, 0.55})
        for (double beta : {0.0, 0.05, 0.125, 0.2}) {
            const LocalMatrix m = psTwoStepMatrix(ruleOf(n, w, alpha, beta));
            EXPECT_NEAR(m.at(0, 0), w.centre * w.centre + n * w.edge * alpha + n * w.diagonal * beta, 1e-14)
                << "alpha " << alpha << " beta " << beta;
            for (std::size_t r = 0; r < m.size(); ++r) {  // affine invariance: every row sums to 1
                double sum = 0;
                for (std::size_t c = 0; c < m.size(); ++c) sum += m.at(r, c);
                EXPECT_NEAR(sum, 1.0, 1e-13);
            }
        }
}

// The vertex weights leave lambda1 where the paper has it; alpha and beta move it.
TEST(ShapeExtended, FaceAndNeighbourWeightsMoveLambda1) {
    const VertexWeights w = quadVertexWeights(3, Rules::Shape);
    const double paper = analyzeValence(3, Rules::Paper).lambda1;
    ValenceOptions options;
    options.extendedRule = ruleOf(3, w, 0.25, 0.125);
    EXPECT_NEAR(analyzeValence(3, Rules::Paper, options).lambda1, paper, 1e-12);
    options.extendedRule = ruleOf(3, w, 0.35, 0.125);
    const double alphaMoved = analyzeValence(3, Rules::Paper, options).lambda1;
    options.extendedRule = ruleOf(3, w, 0.25, 0.0625);
    const double betaMoved = analyzeValence(3, Rules::Paper, options).lambda1;
    EXPECT_GT(std::abs(alphaMoved - paper), 1e-3);
    EXPECT_GT(std::abs(betaMoved - paper), 1e-3);
}

// The experimental refinement (the rule applied while composing the paper's table) is the
// engine's (its own row kinds, tables and CPU evaluator through compareWithCatmark): with
// alpha = 1/4, beta = 1/8 and the paper's weights for Rules::Paper, and with Rules::Shape's
// corner rule (psub/rules.h) for Rules::Shape.
TEST(ShapeExtended, RefinementMatchesTheEngineForBothRuleSets) {
    const Mesh cube = trapezohedron(3);
    const Connectivity connectivity = buildConnectivity(cube.faces);
    for (Rules rules : {Rules::Paper, Rules::Shape}) {
        const ExtendedShapeRule rule = rules == Rules::Paper ? ruleOf(3, quadVertexWeights(3, rules), 0.25, 0.125)
                                                             : extendedRuleOf(shapeCornerRule());
        const ExtendedRefinement ps = refineExtended(cube, 4, rule);
        const Fidelity engine = compareWithCatmark(cube, connectivity, 4, rules, 0);
        EXPECT_EQ(ps.faces.faceCount(), engine.psFaces);
        EXPECT_NEAR(measureMesh(ps.faces, ps.positions).volume, engine.ps.volume, 1e-9);
        EXPECT_NEAR(measureMesh(ps.faces, ps.positions).area, engine.ps.area, 1e-9);
    }
    const VertexWeights paper = quadVertexWeights(3, Rules::Paper);
    const Mesh triangle = test::makeMesh({0, 0, 0, 1, 0, 0, 0, 1, 0}, {{0, 1, 2}});
    EXPECT_THROW(refineExtended(triangle, 2, ruleOf(3, paper, 0.25, 0.125)), std::invalid_argument);
}

// One point of the trade-off curve (docs/shape-rules.md, section 4, least gap 0.12), recomputed:
// alpha = 0.525, beta = 0, (c, d, e) = (0.8, 0, 0.2 / 3) keeps C1 with a gap above 0.12 and
// the cube past half of Catmull-Clark's volume.
TEST(ShapeExtended, TradeoffPointAtGap012KeepsC1AndHalfTheVolume) {
    const ExtendedCandidate point = measureExtendedRule(ruleOf(3, {0.8, 0.0, 0.2 / 3}, 0.525, 0.0));
    EXPECT_TRUE(point.c1);
    EXPECT_GE(point.spectralGap, 0.12);
    // Regression values: the least-gap 0.12 row of docs/shape-rules.md section 4's table, measured
    // with `psub analyze --shape-tradeoff`; each tolerance is one unit in the last digit kept there.
    EXPECT_NEAR(point.spectralGap, 0.1216, 1e-4);
    EXPECT_NEAR(point.lambda1, 0.371106, 1e-6);
    EXPECT_GE(point.volumeRatio, 0.5);
    EXPECT_NEAR(point.volumeRatio, 0.5652, 1e-4);
    EXPECT_NEAR(point.hausdorff, 0.0787, 1e-4);
    EXPECT_NEAR(point.cornerSpreadDegrees, 17.66, 0.01);
    // The same measure for the paper's rules reproduces psub compare's cube after 10 steps (6.2
    // degrees at the corners) and the volume ratio of 4 steps.
    const ExtendedCandidate paper = measureExtendedRule(ruleOf(3, quadVertexWeights(3, Rules::Paper), 0.25, 0.125));
    EXPECT_TRUE(paper.c1);
    // Regression values: the "(paper)" row of the same table (0.0325 also section 3's cube).
    EXPECT_NEAR(paper.cornerSpreadDegrees, 6.21, 0.01);
    EXPECT_NEAR(paper.volumeRatio, 0.0325, 1e-4);
}

// The search with alpha = 1/4 and beta = 1/8 fixed is the vertex-weight family: lambda1 stays the
// paper's and the cube stays below half of Catmull-Clark's volume with a gap of 0.12.
TEST(ShapeExtended, VertexWeightsAloneStayBelowHalfAtGap012) {
    TradeoffOptions options;
    options.faceCorners = {0.25};
    options.neighbourCentres = {0.125};
    const std::vector<double> gaps{0.12};
    const std::vector<ExtendedCandidate> best = shapeTradeoff(gaps, options);
    ASSERT_EQ(best.size(), 1u);
    EXPECT_TRUE(best[0].c1);
    EXPECT_GE(best[0].spectralGap, 0.12);
    EXPECT_NEAR(best[0].lambda1, analyzeValence(3, Rules::Paper).lambda1, 1e-9);
    EXPECT_LT(best[0].volumeRatio, 0.5);
    EXPECT_GT(best[0].volumeRatio, 0.25);
}

}  // namespace
}  // namespace psub
