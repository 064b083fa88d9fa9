// The shape optimiser: per valence, the centre weights (c, d, e) whose P-S surface comes closest
// to Catmull-Clark's while the necessary C1 conditions hold with a stated spectral gap.
#include "local_detail.h"

#include "psub/analysis.h"
#include "psub/catmark.h"
#include "psub/evaluator.h"
#include "psub/stencils.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace psub {
namespace {

double gapOf(const LocalMatrix& matrix) {
    const std::vector<std::complex<double>> ev = eigenvalues(matrix);
    return ev[1].real() - std::abs(ev[3]);
}

// The weights c, and `share` of 1 - c on the n diagonals, the rest on the n edge neighbours.
VertexWeights weightsOf(Index n, double c, double share) {
    const double nd = n;
    return {c, (1 - c) * (1 - share) / nd, (1 - c) * share / nd};
}

// trapezohedron(n) refined once, Catmull-Clark's surface beside it; candidates only change weights.
struct TestMesh {
    Index valence;
    Mesh mesh;
    Refinement refinement;
    Faces psFaces;
    CatmarkLevel cc;
    double ccVolume = 0, ccDiagonal = 0;

    TestMesh(Index n, const ShapeSearchOptions& options) : valence(n), mesh(trapezohedron(n)) {
        const CheckedMesh checked = checkMesh(mesh);
        RefineOptions refineOptions;
        refineOptions.levels = options.psSteps;
        refineOptions.vertexRowsFromFacePoints = false;  // measure() sets the vertex rows' weights
        refinement = refine(mesh, checked.connectivity, refineOptions);
        psFaces.vertexCount = refinement.surface.vertexCount;
        psFaces.offsets = refinement.surface.faceOffsets;
        psFaces.verts = refinement.surface.faceVerts;
        cc = refineCatmark(mesh.faces, mesh.positions, options.psSteps / 2).back();
        const MeshMeasures measures = measureMesh(cc.faces, cc.positions);
        ccVolume = measures.volume;
        ccDiagonal = measures.diagonal();
    }

    // Volume ratio and relative Hausdorff distance with `weights` at the poles (all vertices
    // at n = 3) and `valence3` at the valence-3 vertices.
    void measure(VertexWeights weights, VertexWeights valence3, int samplesPerEdge, ShapeCandidate& out) {
        if (valence != 3) detail::setQuadVertexWeights(refinement.perLevel, 3, valence3);
        detail::setQuadVertexWeights(refinement.perLevel, valence, weights);
        CpuEvaluator<double> evaluator(refinement.perLevel, refinement.factorized, refinement.surface,
                                       TableForm::PerLevel, 3, 1);
        std::vector<double> ps(3 * std::size_t(evaluator.refinedCount()));
        evaluator.evaluate(mesh.positions, ps);
        out.volumeRatio = measureMesh(psFaces, ps).volume / ccVolume;
        double worst = 0;
        for (double d : surfaceDistances(psFaces, ps, cc.faces, cc.positions, samplesPerEdge)) worst = std::max(worst, d);
        for (double d : surfaceDistances(cc.faces, cc.positions, psFaces, ps, samplesPerEdge)) worst = std::max(worst, d);
        out.hausdorff = worst / ccDiagonal;
    }
};

}  // namespace

Mesh trapezohedron(Index n) {
    if (n < 3) throw std::invalid_argument("trapezohedron: n >= 3");
    Mesh out;
    const double pole = std::sqrt(3.0), height = 1 / std::sqrt(3.0), radius = std::sqrt(8.0 / 3);
    out.positions = {0, 0, pole, 0, 0, -pole};
    for (Index k = 0; k < 2 * n; ++k) {  // even k: upper ring, odd k: lower ring
        const double angle = std::numbers::pi * k / n;
        out.positions.insert(out.positions.end(),
                             {radius * std::cos(angle), radius * std::sin(angle), k % 2 ? -height : height});
    }
    out.faces.vertexCount = 2 + 2 * n;
    const auto ring = [n](Index k) { return 2 + k % (2 * n); };
    for (Index i = 0; i < n; ++i) {
        const Index a = 2 * i;
        out.faces.addFace(std::array<Index, 4>{0, ring(a), ring(a + 1), ring(a + 2)});
        out.faces.addFace(std::array<Index, 4>{1, ring(a + 3), ring(a + 2), ring(a + 1)});
    }
    return out;
}

double paperSpectralGap(Index valence) { return gapOf(psTwoStepMatrix(valence, Rules::Paper)); }

ShapeCandidate optimizeShapeWeights(Index valence, VertexWeights valence3, const ShapeSearchOptions& options) {
    if (valence < 3 || valence == 4) throw std::invalid_argument("optimizeShapeWeights: valence 3 or more, not 4");
    const double minimumGap = std::min(options.minimumGap, paperSpectralGap(valence));
    TestMesh test(valence, options);
    std::vector<ShapeCandidate> feasible;
    const auto tryWeights = [&](double c, double share) {
        if (c < 0 || c >= 1 || share < -1e-9 || share > 1 + 1e-9) return;
        share = std::clamp(share, 0.0, 1.0);
        ShapeCandidate candidate;
        candidate.valence = valence;
        candidate.weights = weightsOf(valence, c, share);
        const LocalMatrix matrix = psTwoStepMatrix(valence, candidate.weights);
        const std::vector<std::complex<double>> ev = eigenvalues(matrix);
        candidate.lambda1 = ev[1].real();
        candidate.spectralGap = ev[1].real() - std::abs(ev[3]);
        if (candidate.spectralGap < minimumGap) return;
        test.measure(candidate.weights, valence3, options.samplesPerEdge, candidate);
        feasible.push_back(candidate);
    };
    // Coarse grid: c in steps of 1/50, the diagonals' share in tenths; then a finer grid around the best.
    for (int i = 0; i < 50; ++i)
        for (int j = 0; j <= 10; ++j) tryWeights(i / 50.0, j / 10.0);
    if (feasible.empty()) throw std::runtime_error("optimizeShapeWeights: no candidate meets the gap at valence " + std::to_string(valence));
    const auto better = [](const ShapeCandidate& a, const ShapeCandidate& b) { return a.objective() < b.objective(); };
    const ShapeCandidate coarse = *std::min_element(feasible.begin(), feasible.end(), better);
    // The coarse point's share, back on its grid of tenths (the weights carry rounding).
    const double share = std::round(coarse.weights.diagonal / (1 - coarse.weights.centre) * valence * 10) / 10;
    for (int i = -5; i <= 5; ++i)
        for (int j = -5; j <= 5; ++j) tryWeights(coarse.weights.centre + i * 0.004, share + j * 0.02);
    std::sort(feasible.begin(), feasible.end(), better);
    ValenceOptions check;
    for (ShapeCandidate& candidate : feasible) {
        check.centreWeights = candidate.weights;
        const ValenceReport report = analyzeValence(valence, Rules::Paper, check);
        candidate.normalSpreadDegrees = report.normalSpreadDegrees.back();
        candidate.c1 = report.c1Necessary && report.characteristicMapInjective &&
                       candidate.normalSpreadDegrees <= options.maximumNormalSpread;
        if (candidate.c1) return candidate;
    }
    throw std::runtime_error("optimizeShapeWeights: no candidate passes the C1 checks at valence " + std::to_string(valence));
}

}  // namespace psub
