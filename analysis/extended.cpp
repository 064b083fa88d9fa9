// Beyond the vertex weights: refinement with an ExtendedShapeRule (F-vertex and edge-neighbour
// weights next to an extraordinary vertex, applied to the paper's table) and the search that
// gives the trade-off of the cube's volume against the C1 margin at valence 3. The engine carries
// one point of it as Rules::Shape's corner rule, with its own row kinds (psub/rules.h).
#include "local_detail.h"

#include "psub/analysis.h"
#include "psub/catmark.h"
#include "psub/stencils.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace psub {
namespace {

// Positions of the finest level: `rows` (finest -> control) applied to `control`.
std::vector<double> applyRows(const detail::SparseRowsD& rows, std::span<const double> control) {
    std::vector<double> out(3 * (rows.offsets.size() - 1), 0.0);
    for (std::size_t r = 0; r + 1 < rows.offsets.size(); ++r)
        for (std::uint64_t e = rows.offsets[r]; e < rows.offsets[r + 1]; ++e)
            for (std::size_t axis = 0; axis < 3; ++axis)
                out[3 * r + axis] += rows.weights[e] * control[3 * std::size_t(rows.indices[e]) + axis];
    return out;
}

// A closed all-quad mesh's P-S hierarchy and the paper's table, built once per mesh.
struct QuadRefinement {
    Hierarchy hierarchy;
    PerLevelTable table;

    QuadRefinement(const Mesh& mesh, int psSteps) {
        for (Index f = 0; f < mesh.faces.faceCount(); ++f)
            if (mesh.faces.face(f).size() != 4) throw std::invalid_argument("refineExtended: the mesh must be all quads");
        hierarchy = refineTopology(mesh.faces, buildConnectivity(mesh.faces), false, psSteps);
        table = buildPerLevelTable(hierarchy, Rules::Paper);
    }
    ExtendedRefinement apply(const Mesh& mesh, const ExtendedShapeRule& rule) const {
        return {hierarchy.finest().faces, applyRows(detail::composePerLevel(table, &rule), mesh.positions)};
    }
};

// The local two-step matrix's table, built once; candidates only change weights.
struct LocalTable {
    LocalMesh local;
    PerLevelTable table;
    std::vector<GridKey> fine;

    explicit LocalTable(Index n) : local(makeLocalMesh(n, 5)) {
        const Hierarchy hierarchy = refineTopology(local.mesh.faces, buildConnectivity(local.mesh.faces), false, 2);
        table = buildPerLevelTable(hierarchy, Rules::Paper);
        fine = detail::refineKeysTwoSteps(int(n), hierarchy.levels[0].faces, local.keys, hierarchy.levels[1].faces);
    }
    LocalMatrix matrix(const ExtendedShapeRule& rule) const {
        return detail::extractMatrix(int(local.valence), 3, local.keys, fine, detail::composePerLevel(table, &rule),
                                     "P-S two-step matrix");
    }
};

// Largest angle (degrees) between the normals of two quads around a vertex of valence 3, over
// all such vertices of `faces`.
double cornerSpread(const Faces& faces, std::span<const double> p) {
    std::vector<std::vector<std::array<double, 3>>> normals(faces.vertexCount);
    for (Index f = 0; f < faces.faceCount(); ++f) {
        const auto q = faces.face(f);
        const auto at = [&](std::size_t k, std::size_t axis) { return p[3 * std::size_t(q[k]) + axis]; };
        std::array<double, 3> d0{}, d1{};
        for (std::size_t axis = 0; axis < 3; ++axis) d0[axis] = at(2, axis) - at(0, axis), d1[axis] = at(3, axis) - at(1, axis);
        std::array<double, 3> normal{d0[1] * d1[2] - d0[2] * d1[1], d0[2] * d1[0] - d0[0] * d1[2], d0[0] * d1[1] - d0[1] * d1[0]};
        const double length = std::hypot(normal[0], normal[1], normal[2]);
        for (double& x : normal) x /= length;
        for (Index v : q) normals[v].push_back(normal);
    }
    double worst = 0;
    for (const auto& around : normals) {
        if (around.size() != 3) continue;
        for (std::size_t a = 0; a < around.size(); ++a)
            for (std::size_t b = a + 1; b < around.size(); ++b) {
                const double dot = around[a][0] * around[b][0] + around[a][1] * around[b][1] + around[a][2] * around[b][2];
                worst = std::max(worst, std::acos(std::clamp(dot, -1.0, 1.0)) * 180 / std::numbers::pi);
            }
    }
    return worst;
}

}  // namespace

ExtendedShapeRule extendedRuleOf(const CornerRule& corner) {
    ExtendedShapeRule rule;
    rule.valence = corner.valence;
    rule.centre = corner.centre;
    rule.faceCorner = corner.faceCorner;
    rule.neighbourCentre = corner.neighbour;
    return rule;
}

ExtendedRefinement refineExtended(const Mesh& mesh, int psSteps, const ExtendedShapeRule& rule) {
    return QuadRefinement(mesh, psSteps).apply(mesh, rule);
}

ExtendedCandidate measureExtendedRule(const ExtendedShapeRule& rule, const TradeoffOptions& options) {
    if (rule.valence != 3) throw std::invalid_argument("measureExtendedRule: valence 3 (the cube's corners)");
    ExtendedCandidate out;
    out.rule = rule;
    ValenceOptions check;
    check.extendedRule = rule;
    const ValenceReport report = analyzeValence(3, Rules::Paper, check);
    out.lambda1 = report.lambda1;
    out.spectralGap = report.spectralGap;
    out.normalSpreadDegrees = report.normalSpreadDegrees.back();
    out.c1 = report.c1Necessary && report.characteristicMapInjective;
    const Mesh cube = trapezohedron(3);
    const CatmarkLevel cc = refineCatmark(cube.faces, cube.positions, options.psSteps / 2).back();
    const MeshMeasures ccMeasures = measureMesh(cc.faces, cc.positions);
    const ExtendedRefinement ps = refineExtended(cube, options.psSteps, rule);
    out.volumeRatio = measureMesh(ps.faces, ps.positions).volume / ccMeasures.volume;
    double worst = 0;
    for (double d : surfaceDistances(ps.faces, ps.positions, cc.faces, cc.positions, options.samplesPerEdge))
        worst = std::max(worst, d);
    for (double d : surfaceDistances(cc.faces, cc.positions, ps.faces, ps.positions, options.samplesPerEdge))
        worst = std::max(worst, d);
    out.hausdorff = worst / ccMeasures.diagonal();
    const ExtendedRefinement fine = refineExtended(cube, options.cornerSteps, rule);
    out.cornerSpreadDegrees = cornerSpread(fine.faces, fine.positions);
    return out;
}

std::vector<ExtendedCandidate> shapeTradeoff(std::span<const double> leastGaps, const TradeoffOptions& options) {
    if (leastGaps.empty() || options.centreSteps < 1 || options.shareSteps < 1 || options.psSteps < 2 ||
        options.psSteps % 2 != 0 || options.cornerSteps < 1)
        throw std::invalid_argument("shapeTradeoff: gaps, centreSteps and shareSteps >= 1, psSteps even >= 2");
    const Mesh cube = trapezohedron(3);
    const QuadRefinement refinement(cube, options.psSteps);
    const CatmarkLevel cc = refineCatmark(cube.faces, cube.positions, options.psSteps / 2).back();
    const MeshMeasures ccMeasures = measureMesh(cc.faces, cc.positions);
    const LocalTable local(3);
    const double leastOfAll = *std::min_element(leastGaps.begin(), leastGaps.end());
    const std::vector<double> alphas = options.faceCorners.empty() ? std::vector<double>{0.25} : options.faceCorners;
    const std::vector<double> betas = options.neighbourCentres.empty() ? std::vector<double>{0.125} : options.neighbourCentres;

    std::vector<ExtendedCandidate> feasible;
    for (double alpha : alphas)
        for (double beta : betas)
            for (int i = 0; i < options.centreSteps; ++i)
                for (int j = 0; j <= options.shareSteps; ++j) {
                    ExtendedCandidate candidate;
                    ExtendedShapeRule& rule = candidate.rule;
                    const double c = double(i) / options.centreSteps, share = double(j) / options.shareSteps;
                    rule.centre = {c, (1 - c) * (1 - share) / 3, (1 - c) * share / 3};
                    rule.faceCorner = alpha;
                    rule.neighbourCentre = beta;
                    const std::vector<std::complex<double>> ev = eigenvalues(local.matrix(rule));
                    const bool pair = std::abs(ev[1].imag()) < 1e-8 && std::abs(ev[2].imag()) < 1e-8 &&
                                      std::abs(ev[1].real() - ev[2].real()) < 1e-8 && std::abs(ev[0] - 1.0) < 1e-8;
                    candidate.lambda1 = ev[1].real();
                    candidate.spectralGap = ev[1].real() - std::abs(ev[3]);
                    if (!pair || candidate.lambda1 >= 1 || candidate.spectralGap < leastOfAll) continue;
                    const ExtendedRefinement ps = refinement.apply(cube, rule);
                    candidate.volumeRatio = measureMesh(ps.faces, ps.positions).volume / ccMeasures.volume;
                    feasible.push_back(candidate);
                }
    const auto better = [](const ExtendedCandidate& a, const ExtendedCandidate& b) {
        return std::abs(a.volumeRatio - 1) < std::abs(b.volumeRatio - 1);
    };
    std::sort(feasible.begin(), feasible.end(), better);
    std::vector<char> checked(feasible.size(), 0);
    std::vector<ExtendedCandidate> out;
    for (double gap : leastGaps) {
        std::size_t k = 0;
        for (; k < feasible.size(); ++k) {
            ExtendedCandidate& candidate = feasible[k];
            if (candidate.spectralGap < gap) continue;
            if (!checked[k]) {
                checked[k] = 1;
                candidate = measureExtendedRule(candidate.rule, options);
            }
            if (candidate.c1) break;
        }
        if (k == feasible.size())
            throw std::runtime_error("shapeTradeoff: no candidate passes the C1 checks with a gap of " + std::to_string(gap));
        out.push_back(feasible[k]);
    }
    return out;
}

}  // namespace psub
