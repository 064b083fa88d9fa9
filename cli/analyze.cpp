// psub analyze, psub compare and the demo's verdict table, over psub/analysis.h.
#include "analyze.h"
#include "commands.h"
#include "json.h"
#include "numbers.h"

#include "psub/analysis.h"
#include "psub/catmark.h"
#include "psub/evaluator.h"
#include "psub/stencils.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

namespace psub::cli {
namespace {

std::vector<Rules> rulesOf(const std::string& name) {
    if (name == "paper") return {Rules::Paper};
    if (name == "robust") return {Rules::Robust};
    if (name == "shape") return {Rules::Shape};
    if (name == "all") return {Rules::Paper, Rules::Robust, Rules::Shape};
    return {Rules::Paper, Rules::Robust};
}

std::string eigenvalueText(std::complex<double> value) {
    char text[48];
    if (value.imag() == 0)
        std::snprintf(text, sizeof text, "%.6f", value.real());
    else
        std::snprintf(text, sizeof text, "%.4f%+.4fi", value.real(), value.imag());
    return text;
}

Json jsonRecord(const ValenceReport& r) {
    Json eigenvalues = Json::array();
    for (const auto& value : r.eigenvalues) eigenvalues.push_back({value.real(), value.imag()});
    return {{"n", r.valence}, {"rules", rulesName(r.rules)}, {"eigenvalues", eigenvalues},
            {"c1_necessary", r.c1Necessary}, {"characteristic_map_injective", r.characteristicMapInjective},
            {"cc_lambda1", r.ccLambda1}, {"cc_lambda1_closed_form", r.ccLambda1ClosedForm}, {"lambda1", r.lambda1},
            {"lambda3_over_lambda1_squared", r.lambda3OverLambda1Squared},
            {"spectral_gap", r.spectralGap}, {"matrix_size", r.matrixSize},
            {"ring_windings", r.ringWindings}, {"annulus_faces", r.annulusFaces},
            {"folded_annulus_faces", r.foldedAnnulusFaces}, {"normal_spread_degrees", r.normalSpreadDegrees}};
}

const char* yesNo(bool value) { return value ? "yes" : "no"; }

// Refuses what would not fit comfortably: the refined P-S mesh's face count in closed form.
void guardCompare(const Mesh& mesh, const Connectivity& connectivity, int levels, Boundary boundary) {
    const bool preprocess = needsPreprocessing(mesh.faces, connectivity, Preprocess::Auto, mesh.source);
    const Counts finest = countsAfterSteps(countMesh(mesh.faces, connectivity), levels + (preprocess ? 1 : 0),
                                           boundary, preprocess);
    if (finest.faces > 20'000'000)
        throw InputError(mesh.source.path + ": " + std::to_string(levels) + " P-S steps would give " +
                         std::to_string(finest.faces) + " faces; psub compare stops at 20 million (use fewer --levels)");
}

Fidelity compareLoaded(const Mesh& mesh, const Connectivity& connectivity, int levels, Rules rules, int samples,
                       Boundary boundary = Boundary::Paper) {
    guardCompare(mesh, connectivity, levels, boundary);
    return compareWithCatmark(mesh, connectivity, levels, rules, samples, boundary);
}

// psub analyze --boundary-aspect MODEL: the boundary triangles per level, paper beside smooth.
int runBoundaryAspect(const AnalyzeOptions& options) {
    CheckedMesh checked;
    const Mesh mesh = loadChecked(options.boundaryModel, checked);
    checkCoordinateRange(mesh, Precision::Double);
    if (checked.connectivity.boundaryEdgeCount == 0)
        throw InputError(options.boundaryModel + ": the mesh has no boundary edge, so no boundary triangles");
    const bool preprocess = needsPreprocessing(mesh.faces, checked.connectivity, Preprocess::Auto, mesh.source);
    const Counts finest = countsAfterSteps(countMesh(mesh.faces, checked.connectivity),
                                           options.boundaryLevels + (preprocess ? 1 : 0), Boundary::Smooth, preprocess);
    if (finest.faces > 4'000'000)
        throw InputError(options.boundaryModel + ": " + std::to_string(options.boundaryLevels) + " steps would give " +
                         std::to_string(finest.faces) + " faces; this report keeps every level and stops at 4 million");
    const auto paper = boundaryAspectByLevel(mesh, checked.connectivity, options.boundaryLevels, Boundary::Paper);
    const auto smooth = boundaryAspectByLevel(mesh, checked.connectivity, options.boundaryLevels, Boundary::Smooth);
    if (options.json) {
        std::printf("[\n");
        for (std::size_t k = 0; k < paper.size(); ++k)
            for (const auto& [name, a] : {std::pair{"paper", paper[k]}, std::pair{"smooth", smooth[k]}})
                std::printf("%s%s", k == 0 && std::string(name) == "paper" ? "" : ",\n",
                            jsonText(Json{{"level", k + 1}, {"boundary", name}, {"triangles", a.triangles},
                                          {"worst_aspect", a.worst}, {"median_aspect", a.median}})
                                .c_str());
        std::printf("\n]\n");
        return 0;
    }
    std::printf("%s: triangles along the boundary after each P-S step; aspect = longest edge / height on it\n"
                "(equilateral 1.155). paper: docs/scheme.md, the boundary is never refined. smooth (--boundary smooth,\n"
                "beyond the paper): boundary edges split every second step, cubic B-spline rules.\n\n",
                options.boundaryModel.c_str());
    std::printf("%5s  %10s %12s %12s  %10s %12s %12s\n", "level", "paper: tri", "worst", "median", "smooth: tri", "worst",
                "median");
    for (std::size_t k = 0; k < paper.size(); ++k)
        std::printf("%5zu  %10llu %12.4g %12.4g  %10llu %12.4g %12.4g\n", k + 1, (unsigned long long)paper[k].triangles,
                    paper[k].worst, paper[k].median, (unsigned long long)smooth[k].triangles, smooth[k].worst,
                    smooth[k].median);
    return 0;
}

// psub analyze --optimize-shape: Rules::Shape's weights searched per valence (3 first: the
// test meshes of the others have valence-3 vertices), as a table and as rules.cpp's array.
int runOptimizeShape(const AnalyzeOptions& options) {
    std::vector<Index> valences;
    for (Index n : parseValences(options.valences))
        if (n >= 3 && n != 4) valences.push_back(n);
    if (valences.empty() || valences.front() != 3)
        throw InputError("--optimize-shape: the valences must start at 3 (the others' test meshes have valence-3 corners)");
    ShapeSearchOptions search;
    search.minimumGap = options.minimumGap;
    search.maximumNormalSpread = options.maximumSpread;
    std::printf("| n | c | d | e | lambda1 | gap (paper) | volume ratio (paper) | Hausdorff / diagonal (paper) | "
                "normal spread deg (paper) |\n|---|---|---|---|---|---|---|---|---|\n");
    std::vector<ShapeCandidate> chosen;
    VertexWeights valence3 = quadVertexWeights(3, Rules::Paper);
    ValenceOptions paperCheck;
    for (Index n : valences) {
        const ShapeCandidate best = optimizeShapeWeights(n, valence3, search);
        if (n == 3) valence3 = best.weights;
        // The paper's rules measured the same way (its valence-3 corners too).
        paperCheck.centreWeights = quadVertexWeights(n, Rules::Paper);
        const ValenceReport paper = analyzeValence(n, Rules::Paper, paperCheck);
        const Mesh test = trapezohedron(n);
        const CheckedMesh checked = checkMesh(test);
        const Fidelity f = compareWithCatmark(test, checked.connectivity, search.psSteps, Rules::Paper, search.samplesPerEdge);
        std::printf("| %u | %.4f | %.6f | %.6f | %.6f | %.4f (%.4f) | %.4f (%.4f) | %.4f (%.4f) | %.2f (%.2f) |\n", n,
                    best.weights.centre, best.weights.edge, best.weights.diagonal, best.lambda1, best.spectralGap,
                    paper.spectralGap, best.volumeRatio, f.ps.volume / f.cc.volume, best.hausdorff,
                    f.hausdorff() / f.cc.diagonal(), best.normalSpreadDegrees, paper.normalSpreadDegrees.back());
        std::fflush(stdout);
        chosen.push_back(best);
    }
    std::printf("\nrules.cpp (c, d, e per valence; valence 4 keeps the regular rule):\n");
    for (const ShapeCandidate& best : chosen)
        std::printf("    {%u, {%.17g, %.17g, %.17g}},\n", best.valence, best.weights.centre, best.weights.edge,
                    best.weights.diagonal);
    return 0;
}

// psub analyze --shape-tradeoff: beyond the vertex weights at n = 3 (docs/shape-rules.md, 4):
// per least gap the best candidate, then the paper's rules, Rules::Shape's vertex weights alone
// (its centroids' rule) and its corner rule, measured the same way.
int runShapeTradeoff() {
    TradeoffOptions search;
    for (int k = 0; k <= 34; ++k) search.faceCorners.push_back(0.10 + 0.025 * k);  // alpha 0.10 .. 0.95
    for (int k = 0; k <= 8; ++k) search.neighbourCentres.push_back(k / 32.0);      // beta 0 .. 1/4
    search.centreSteps = 50;
    search.shareSteps = 4;
    const std::vector<double> gaps{0.0, 0.02, 0.05, 0.08, 0.10, 0.12, 0.13, 0.135, 0.138, 0.139, 0.14, 0.16};
    const std::vector<ExtendedCandidate> best = shapeTradeoff(gaps, search);
    std::printf("| least gap | alpha | beta | c | d | e | lambda1 | gap | cube volume ratio | Hausdorff / diagonal | "
                "normal spread deg | corner spread deg |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    const auto row = [](const std::string& label, const ExtendedCandidate& b) {
        std::printf("| %s | %.3f | %.5f | %.2f | %.6f | %.6f | %.6f | %.4f | %.4f | %.4f | %.2f | %.2f |%s\n", label.c_str(),
                    b.rule.faceCorner, b.rule.neighbourCentre, b.rule.centre.centre, b.rule.centre.edge,
                    b.rule.centre.diagonal, b.lambda1, b.spectralGap, b.volumeRatio, b.hausdorff, b.normalSpreadDegrees,
                    b.cornerSpreadDegrees, b.c1 ? "" : " not C1");
    };
    for (std::size_t k = 0; k < best.size(); ++k) {
        char label[16];
        std::snprintf(label, sizeof label, "%.3f", gaps[k]);
        row(label, best[k]);
    }
    for (Rules rules : {Rules::Paper, Rules::Shape}) {
        ExtendedShapeRule rule;
        rule.centre = quadVertexWeights(3, rules);
        row(rules == Rules::Paper ? "(paper)" : "(vertex weights only)", measureExtendedRule(rule, search));
    }
    // What --rules shape gives an input corner.
    row("(shape: corner rule)", measureExtendedRule(extendedRuleOf(shapeCornerRule()), search));
    return 0;
}

}  // namespace

std::vector<Index> parseValences(const std::string& text) {
    std::vector<Index> out;
    const auto bad = [&](const std::string& why) {
        return InputError("--valence '" + text + "': " + why + " (examples: 2..16, 5, 2,3,8..10)");
    };
    const auto number = [&](const std::string& part) {
        if (part.empty() || part.find_first_not_of("0123456789") != std::string::npos)
            throw bad("'" + part + "' is not a valence");
        long long n = 0;  // decimal, as every numeric option (numbers.h): 010 is ten
        if (!parseInteger(part, 2, 64, n).empty()) throw bad("valences run from 2 to 64");
        return Index(n);
    };
    std::size_t begin = 0;
    while (begin <= text.size()) {
        const std::size_t comma = std::min(text.find(',', begin), text.size());
        const std::string part = text.substr(begin, comma - begin);
        const std::size_t dots = part.find("..");
        if (dots == std::string::npos) {
            out.push_back(number(part));
        } else {
            const Index lo = number(part.substr(0, dots)), hi = number(part.substr(dots + 2));
            if (lo > hi) throw bad("a range must go up");
            for (Index n = lo; n <= hi; ++n) out.push_back(n);
        }
        begin = comma + 1;
    }
    return out;
}

int runAnalyze(const AnalyzeOptions& options) {
    if (!options.boundaryModel.empty()) return runBoundaryAspect(options);
    if (options.optimizeShape) return runOptimizeShape(options);
    if (options.shapeTradeoff) return runShapeTradeoff();
    const std::vector<Index> valences = parseValences(options.valences);
    ValenceOptions valenceOptions;
    valenceOptions.characteristicRings = options.rings;
    valenceOptions.tangentLevels = options.levels;
    if (options.json) std::printf("[\n");
    else {
        std::printf("Smoothness of P-S at an interior vertex of valence n surrounded by quads, from the engine's own\n"
                    "stencil tables: the two-step subdivision matrix on 3 rings (1 + 12n vertices; one P-S step turns\n"
                    "the grid by 45 degrees, two are self-similar). C1 needs lambda0 = 1 > lambda1 = lambda2 (real)\n"
                    "> |lambda3| and an injective characteristic map (%d control rings each wind once; no face of the\n"
                    "outer annulus folds). Normal spread: largest angle between two face normals within 2 rings of\n"
                    "the vertex, on a bumpy neighbourhood, after 0 and %d two-step levels (tends to 0 where C1 holds).\n"
                    "CC lambda1: Catmull-Clark's, from OpenSubdiv's stencils (closed form agrees to 1e-12).\n\n",
                    options.rings, options.levels);
        std::printf("%3s  %-6s  %-62s  %-4s  %-4s  %9s  %-17s  %9s\n", "n", "rules",
                    "leading eigenvalues of the two-step matrix (by modulus)", "C1", "map", "l3/l1^2",
                    "normal spread deg", "CC l1");
    }
    bool first = true;
    for (Index n : valences)
        for (Rules rules : rulesOf(options.rules)) {
            const ValenceReport r = analyzeValence(n, rules, valenceOptions);
            if (options.json) {
                std::printf("%s%s", first ? "" : ",\n", jsonText(jsonRecord(r)).c_str());
                first = false;
                continue;
            }
            std::string values;
            for (const auto& value : r.eigenvalues) {
                if (!values.empty()) values += ' ';
                values += eigenvalueText(value);
            }
            char spread[40];
            std::snprintf(spread, sizeof spread, "%.3g -> %.3g", r.normalSpreadDegrees.front(), r.normalSpreadDegrees.back());
            std::printf("%3u  %-6s  %-62s  %-4s  %-4s  %9.4f  %-17s  %9.6f\n", n, rulesName(rules), values.c_str(),
                        yesNo(r.c1Necessary), yesNo(r.characteristicMapInjective), r.lambda3OverLambda1Squared, spread,
                        r.ccLambda1);
        }
    if (options.json) std::printf("\n]\n");
    else
        std::printf("\nl3/l1^2 = 1: bounded curvature; > 1: curvature grows without bound at the vertex; < 1: a flat spot.\n"
                    "Robust rules (beyond the paper) differ only at valence 2: c, d, e = 0, 1/3, 1/6. Shape rules (beyond\n"
                    "the paper) also change c, d, e at valence 3 and 5..16 to keep the shape (docs/shape-rules.md).\n");
    return 0;
}

// psub compare on a mesh OpenSubdiv cannot refine: the P-S measures alone, with the reason.
int comparePsOnly(const CompareOptions& options, const Mesh& mesh, const Connectivity& connectivity, Rules rules,
                  const std::string& problem) {
    guardCompare(mesh, connectivity, options.levels, options.boundary);
    RefineOptions refineOptions;
    refineOptions.levels = options.levels;
    refineOptions.rules = rules;
    refineOptions.boundary = options.boundary;
    const Refinement r = refine(mesh, connectivity, refineOptions);
    CpuEvaluator<double> evaluator(r.perLevel, r.factorized, r.surface, TableForm::PerLevel);
    std::vector<double> ps(3 * std::size_t(evaluator.refinedCount()));
    evaluator.evaluate(mesh.positions, ps);
    requireFinite(ps, options.input, "refined");
    Faces psFaces;
    psFaces.vertexCount = r.surface.vertexCount;
    psFaces.offsets = r.surface.faceOffsets;
    psFaces.verts = r.surface.faceVerts;
    const MeshMeasures input = measureMesh(mesh.faces, mesh.positions), refined = measureMesh(psFaces, ps);
    std::fflush(stdout);
    std::fprintf(stderr, "psub: warning: %s; Catmull-Clark is unavailable, so compare measures P-S only\n",
                 problem.c_str());
    if (options.json) {
        const Json json = {{"input", options.input}, {"rules", rulesName(rules)},
                           {"boundary", boundaryName(options.boundary)}, {"ps_steps", options.levels},
                           {"ps_faces", psFaces.faceCount()}, {"cc", nullptr}, {"cc_unavailable", problem},
                           {"input_volume", input.volume}, {"ps_volume", refined.volume},
                           {"input_area", input.area}, {"ps_area", refined.area}};
        std::printf("%s\n", jsonText(json).c_str());
        return 0;
    }
    std::printf("%s: P-S %d steps (%s rules); Catmull-Clark unavailable for this mesh\n\n", options.input.c_str(),
                options.levels, rulesName(rules));
    std::printf("%-14s %14s %14s\n", "", "input", "P-S");
    std::printf("%-14s %14u %14u\n", "faces", mesh.faces.faceCount(), psFaces.faceCount());
    std::printf("%-14s %14.6g %14.6g\n", "volume", input.volume, refined.volume);
    std::printf("%-14s %14.6g %14.6g\n", "area", input.area, refined.area);
    std::printf("%-14s %14.6g %14.6g\n", "box diagonal", input.diagonal(), refined.diagonal());
    return 0;
}

int runCompare(const CompareOptions& options) {
    if (options.levels % 2 != 0) throw InputError("--levels must be even: P-S after 2k steps against Catmull-Clark after k");
    CheckedMesh checked;
    const Mesh mesh = loadChecked(options.input, checked);
    checkCoordinateRange(mesh, Precision::Double);
    const Rules rules = options.rules == "robust" ? Rules::Robust : options.rules == "shape" ? Rules::Shape : Rules::Paper;
    if (const auto problem = catmarkProblem(mesh)) {
        if (!options.plot.empty()) throw InputError(*problem + "; Catmull-Clark is unavailable, so there is no --plot");
        return comparePsOnly(options, mesh, checked.connectivity, rules, *problem);
    }
    const Fidelity f = compareLoaded(mesh, checked.connectivity, options.levels, rules, options.samples, options.boundary);
    const double diagonal = f.cc.diagonal();
    const auto maxOf = [](const std::vector<double>& v) {
        double m = 0;
        for (double d : v) m = std::max(m, d);
        return m;
    };
    const auto meanOf = [](const std::vector<double>& v) {
        double s = 0;
        for (double d : v) s += d;
        return v.empty() ? 0.0 : s / double(v.size());
    };
    const auto medianOf = [](std::vector<double> v) {
        if (v.empty()) return 0.0;
        std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(v.size() / 2), v.end());
        return v[v.size() / 2];
    };
    if (options.json) {
        const auto measures = [&](const MeshMeasures& m) {
            return Json{{"volume", m.volume}, {"area", m.area}, {"box_min", {m.lo[0], m.lo[1], m.lo[2]}},
                        {"box_max", {m.hi[0], m.hi[1], m.hi[2]}}, {"box_diagonal", m.diagonal()}};
        };
        const Json json = {{"input", options.input}, {"rules", rulesName(rules)},
                           {"boundary", boundaryName(options.boundary)}, {"ps_steps", f.psSteps},
                           {"cc_levels", f.ccLevels}, {"ps_faces", f.psFaces}, {"cc_faces", f.ccFaces},
                           {"input_measures", measures(f.input)}, {"ps", measures(f.ps)}, {"cc", measures(f.cc)},
                           {"hausdorff", f.hausdorff()}, {"ps_to_cc_max", maxOf(f.psToCc)},
                           {"ps_to_cc_mean", meanOf(f.psToCc)}, {"cc_to_ps_max", maxOf(f.ccToPs)},
                           {"cc_to_ps_mean", meanOf(f.ccToPs)},
                           {"samples_each_way", {f.psToCc.size(), f.ccToPs.size()}},
                           {"ev_count", f.evNormalSpreads.size()},
                           {"ev_normal_spread_max", maxOf(f.evNormalSpreads)},
                           {"ev_normal_spread_median", medianOf(f.evNormalSpreads)}};
        std::printf("%s\n", jsonText(json).c_str());
    } else {
        std::printf("%s: P-S %d steps (%s rules, %s boundary) against Catmull-Clark %d level%s (OpenSubdiv)\n\n",
                    options.input.c_str(), f.psSteps, rulesName(rules), boundaryName(options.boundary), f.ccLevels,
                    f.ccLevels == 1 ? "" : "s");
        std::printf("%-14s %14s %14s %14s %10s\n", "", "input", "P-S", "Catmull-Clark", "P-S/CC");
        std::printf("%-14s %14u %14u %14u %10.3f\n", "faces", mesh.faces.faceCount(), f.psFaces, f.ccFaces,
                    double(f.psFaces) / double(f.ccFaces));
        const auto row = [](const char* name, double input, double ps, double cc) {
            std::printf("%-14s %14.6g %14.6g %14.6g %10.4f\n", name, input, ps, cc, cc != 0 ? ps / cc : 0.0);
        };
        row("volume", f.input.volume, f.ps.volume, f.cc.volume);
        row("area", f.input.area, f.ps.area, f.cc.area);
        row("box diagonal", f.input.diagonal(), f.ps.diagonal(), f.cc.diagonal());
        const char* axes = "xyz";
        for (std::size_t a = 0; a < 3; ++a) {
            const std::string lo = std::string("box min ") + axes[a], hi = std::string("box max ") + axes[a];
            row(lo.c_str(), f.input.lo[a], f.ps.lo[a], f.cc.lo[a]);
            row(hi.c_str(), f.input.hi[a], f.ps.hi[a], f.cc.hi[a]);
        }
        std::printf("\nDistance between the surfaces (%zu and %zu points sampled on the faces, nearest point on the\n"
                    "other mesh's triangles), also as a fraction of Catmull-Clark's box diagonal:\n",
                    f.psToCc.size(), f.ccToPs.size());
        std::printf("  P-S to Catmull-Clark   max %.6g (%.4g)  mean %.6g (%.4g)\n", maxOf(f.psToCc), maxOf(f.psToCc) / diagonal,
                    meanOf(f.psToCc), meanOf(f.psToCc) / diagonal);
        std::printf("  Catmull-Clark to P-S   max %.6g (%.4g)  mean %.6g (%.4g)\n", maxOf(f.ccToPs), maxOf(f.ccToPs) / diagonal,
                    meanOf(f.ccToPs), meanOf(f.ccToPs) / diagonal);
        std::printf("  Hausdorff (two-sided)  %.6g (%.4g)\n", f.hausdorff(), f.hausdorff() / diagonal);
        std::printf("\nNormal spread around the %zu interior vertices of valence != 4 (the input's extraordinary\n"
                    "vertices, the paired method's centroids): max %.3g deg, median %.3g deg\n",
                    f.evNormalSpreads.size(), maxOf(f.evNormalSpreads), medianOf(f.evNormalSpreads));
    }
    if (!options.plot.empty()) {
        writeFidelityPlot(options.plot, f, std::filesystem::path(options.input).filename().string());
        if (!options.json) std::printf("\nPlot: %s\n", options.plot.c_str());
    }
    return 0;
}

void printVerdicts(const Mesh& mesh, const Connectivity& connectivity, int levels) {
    std::printf("\nThe paper's claims, checked (psub analyze and psub compare give the details):\n");
    std::printf("  %-48s %-58s %s\n", "claim", "measured", "holds?");
    const auto verdict = [](const std::string& claim, const std::string& measured, const char* holds) {
        std::printf("  %-48s %-58s %s\n", claim.c_str(), measured.c_str(), holds);
    };
    char text[160];

    // Smoothness from the two-step matrices.
    ValenceOptions quick;
    quick.characteristicRings = 6;
    const ValenceReport regular = analyzeValence(4, Rules::Paper, quick);
    std::snprintf(text, sizeof text, "eigenvalues 1, %.3g, %.3g, %.3g; l3 = l1^2", regular.eigenvalues[1].real(),
                  regular.eigenvalues[2].real(), regular.eigenvalues[3].real());
    verdict("C2 at regular vertices (necessary conditions)", text,
            regular.c1Necessary && std::abs(regular.lambda3OverLambda1Squared - 1) < 1e-9 ? "yes" : "no");
    bool allHold = true;
    double lowest = 1, highest = 0;
    for (Index n = 3; n <= 8; ++n) {
        const ValenceReport r = analyzeValence(n, Rules::Paper, quick);
        allHold = allHold && r.c1Necessary && r.characteristicMapInjective;
        lowest = std::min(lowest, r.lambda1);
        highest = std::max(highest, r.lambda1);
    }
    std::snprintf(text, sizeof text, "l1 = l2 from %.4f to %.4f > |l3|; maps injective", lowest, highest);
    verdict("C1 at extraordinary vertices, valence 3..8", text, allHold ? "yes" : "no");
    const ValenceReport two = analyzeValence(2, Rules::Paper, quick), twoRobust = analyzeValence(2, Rules::Robust, quick);
    std::snprintf(text, sizeof text, "l1 %.4f != l2 %.4f; normals %.0f deg apart", two.eigenvalues[1].real(),
                  two.eigenvalues[2].real(), two.normalSpreadDegrees.back());
    verdict("C1 at valence 2 (paper rules)", text, two.c1Necessary && two.characteristicMapInjective ? "yes" : "no");
    std::snprintf(text, sizeof text, "l1 = l2 = %.4f > |l3| = %.4f; map injective", twoRobust.lambda1,
                  std::abs(twoRobust.eigenvalues[3]));
    verdict("C1 at valence 2 (--rules robust, beyond paper)", text,
            twoRobust.c1Necessary && twoRobust.characteristicMapInjective ? "yes" : "no");

    // Shape and face counts: this model, and the bundled cube (built here) where it shows most.
    Mesh cube;
    cube.positions = {-1, -1, -1, 1, -1, -1, 1, 1, -1, -1, 1, -1, -1, -1, 1, 1, -1, 1, 1, 1, 1, -1, 1, 1};
    cube.faces.vertexCount = 8;
    for (const auto& quad : {std::array<Index, 4>{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4}, {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7}})
        cube.faces.addFace(quad);
    const Connectivity cubeConnectivity = buildConnectivity(cube.faces);
    const int steps = std::max(2, levels - levels % 2);
    const std::string name = mesh.source.path.empty() ? "model" : std::filesystem::path(mesh.source.path).filename().string();
    struct Subject {
        std::string label;
        const Mesh* model;
        const Connectivity* links;
    };
    const Subject subjects[2] = {{name, &mesh, &connectivity}, {"cube", &cube, &cubeConnectivity}};
    const bool ccUnavailable = catmarkProblem(mesh).has_value();
    if (ccUnavailable)
        verdict("keeps the shape, 2 P-S steps = 1 CC step: " + name, "Catmull-Clark unavailable for this mesh", "-");
    for (const auto& [label, model, links] : subjects) {
        if (ccUnavailable && model == &mesh) continue;
        const Fidelity f = compareLoaded(*model, *links, steps, Rules::Paper, 0);
        const double ratio = f.ps.volume / f.cc.volume;
        std::snprintf(text, sizeof text, "volume x%.3f, area x%.3f (P-S %d steps / CC %d)", ratio, f.ps.area / f.cc.area,
                      steps, steps / 2);
        verdict("keeps the shape (like CC): " + label, text, std::abs(1 - ratio) <= 0.02 ? "yes (within 2%)" : "no (shrinks)");
    }
    {
        const Fidelity paper = compareLoaded(cube, cubeConnectivity, steps, Rules::Paper, 0);
        const Fidelity shaped = compareLoaded(cube, cubeConnectivity, steps, Rules::Shape, 0);
        const double ratio = shaped.ps.volume / shaped.cc.volume;
        const ValenceReport corner = analyzeValence(3, Rules::Shape, quick);
        const bool c1 = corner.c1Necessary && corner.characteristicMapInjective;
        std::snprintf(text, sizeof text, "volume x%.3f (paper x%.3f); n = 3: %s, gap %.3f", ratio,
                      paper.ps.volume / paper.cc.volume, c1 ? "C1" : "not C1", corner.spectralGap);
        verdict("cube, --rules shape (beyond the paper)", text, ratio >= 0.25 && c1 ? "closer, C1 kept" : "no");
    }
    for (const auto& [label, model, links] : {subjects[1], subjects[0]}) {
        if (ccUnavailable && model == &mesh) continue;
        const bool preprocess = needsPreprocessing(model->faces, *links, Preprocess::Auto);
        const Counts input = countMesh(model->faces, *links);
        // The paired method is a topological step like the others, so it counts as one.
        const Counts after = countsAfterSteps(input, steps);
        const std::vector<CatmarkLevel> cc = refineCatmark(model->faces, {}, steps / 2, false);
        std::snprintf(text, sizeof text, "%llu -> %llu faces in %d steps%s; CC %d levels: %llu",
                      (unsigned long long)input.faces, (unsigned long long)after.faces, steps,
                      preprocess ? " (1st: paired)" : "", steps / 2, (unsigned long long)cc.back().counts.faces);
        const double factor = double(after.faces) / double(cc.back().counts.faces);
        char holds[48];
        std::snprintf(holds, sizeof holds, factor == 1 ? "yes" : "no: x%.3g CC's", factor);
        verdict("2 P-S steps = 1 CC step in faces: " + label, text, holds);
    }
}

}  // namespace psub::cli
