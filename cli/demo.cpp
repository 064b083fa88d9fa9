// psub demo: the whole engine on one model (the cow by default): the stats table, shape at
// equal face counts against Catmull-Clark, the stencil tables and timed frames on the CPU and
// Vulkan, the paper's verdicts, and optionally both refined meshes as OBJ.
#include "commands.h"

#include "analyze.h"
#include "evaluators.h"

#include "psub/catmark.h"
#include "psub/evaluator.h"
#include "psub/output.h"
#include "psub/rules.h"
#include "psub/stencils.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <span>

namespace psub::cli {
namespace {

struct Shape {
    double volume = 0, diagonal = 0;
};

// Signed volume (fan-triangulated faces, divergence theorem) and bounding-box diagonal.
Shape measureShape(const Faces& faces, std::span<const double> p) {
    Shape shape;
    for (Index f = 0; f < faces.faceCount(); ++f) {
        const auto c = faces.face(f);
        const double* a = &p[3 * c[0]];
        for (std::size_t i = 1; i + 1 < c.size(); ++i) {
            const double* b = &p[3 * c[i]];
            const double* d = &p[3 * c[i + 1]];
            shape.volume += (a[0] * (b[1] * d[2] - b[2] * d[1]) - a[1] * (b[0] * d[2] - b[2] * d[0]) +
                             a[2] * (b[0] * d[1] - b[1] * d[0])) / 6;
        }
    }
    double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
    for (std::size_t i = 0; i < p.size(); ++i) {
        lo[i % 3] = std::min(lo[i % 3], p[i]);
        hi[i % 3] = std::max(hi[i % 3], p[i]);
    }
    for (int axis = 0; axis < 3; ++axis) shape.diagonal += (hi[axis] - lo[axis]) * (hi[axis] - lo[axis]);
    shape.diagonal = std::sqrt(shape.diagonal);
    return shape;
}

// For each Catmull-Clark level with a P-S level of the same face count: volume and size.
void printShapes(const Loaded& loaded, const Hierarchy& hierarchy,
                 const std::vector<std::vector<double>>& positions) {
    if (loaded.ccProblem) return;  // printStats said so
    int ccLevels = 0;
    while (hierarchy.levels.size() > std::size_t(2 * ccLevels + (hierarchy.preprocessed ? 2 : 1))) ++ccLevels;
    const std::vector<CatmarkLevel> cc = refineCatmark(loaded.mesh.faces, loaded.mesh.positions, ccLevels);
    const Shape input = measureShape(loaded.mesh.faces, loaded.mesh.positions);
    std::printf("\nShape at equal face counts (input volume %.4g, box diagonal %.4g):\n", input.volume,
                input.diagonal);
    std::printf("%10s  %-14s %12s %10s   %-8s %12s %10s   %s\n", "faces", "P-S", "volume", "diagonal",
                "CC", "volume", "diagonal", "P-S/CC volume");
    for (int k = 1; k <= ccLevels; ++k)
        for (std::size_t j = 1; j < hierarchy.levels.size(); ++j) {
            if (hierarchy.levels[j].faces.faceCount() != cc[k].counts.faces) continue;
            const Shape ps = measureShape(hierarchy.levels[j].faces, positions[j]);
            const Shape c = measureShape(cc[k].faces, cc[k].positions);
            const std::string label = "level " + std::to_string(j - (hierarchy.preprocessed ? 1 : 0));
            std::printf("%10u  %-14s %12.4g %10.4g   level %-2d %12.4g %10.4g   %.3f\n",
                        cc[k].faces.faceCount(), label.c_str(), ps.volume, ps.diagonal, k, c.volume,
                        c.diagonal, ps.volume / c.volume);
        }
    std::printf("A P-S/CC volume below 1 means P-S shrinks the model more than Catmull-Clark "
                "(docs/scheme.md, \"The paper's claims\").\n");
}

// Frame `frame` of the demo's animation: a wave along x lifts the rest pose in y.
void writeWaveFrame(const std::vector<double>& rest, int frame, std::vector<float>& control) {
    for (std::size_t v = 0; v < rest.size() / 3; ++v)
        for (int axis = 0; axis < 3; ++axis)
            control[3 * v + axis] =
                float(rest[3 * v + axis] + (axis == 1 ? 0.05 * std::sin(rest[3 * v] + 0.3 * frame) : 0));
}

// The engine's real path: tables built once, then frames of animated control points on one
// backend (makeEvaluator). Sorted host milliseconds of 25 frames; `out` holds the last frame.
std::vector<double> timeWaveFrames(Evaluator& evaluator, const std::vector<double>& rest, std::vector<float>& control,
                                   std::vector<float>& out) {
    std::vector<double> frameMs;
    for (int frame = 0; frame < 25; ++frame) {
        writeWaveFrame(rest, frame, control);
        const auto start = Clock::now();
        evaluator.evaluate(control, out);
        frameMs.push_back(msSince(start));
    }
    std::sort(frameMs.begin(), frameMs.end());
    return frameMs;
}

template <class Reference>
double largestDifference(const std::vector<float>& out, const Reference& reference) {
    double worst = 0;
    for (std::size_t i = 0; i < out.size(); ++i) worst = std::max(worst, std::abs(double(out[i]) - double(reference[i])));
    return worst;
}

// The demo's Vulkan lines: the per-level and the tiled tables on the Vulkan backend, the same
// frames as the CPU lines, and the largest difference to the CPU backend's result of the same
// form (the tiled one in its drawing order); or why they are not there.
void printVulkanFrames(const Refinement& r, const Loaded& loaded) {
    try {
        for (TableForm form : {TableForm::PerLevel, TableForm::Tiled}) {
            const std::unique_ptr<Evaluator> gpu = makeEvaluator(Backend::Vulkan, tablesOf(r), form, nullptr);
            std::vector<float> control(loaded.mesh.positions.size()), out(3 * std::size_t(gpu->refinedCount())),
                cpuOut(out.size());
            const std::vector<double> frameMs = timeWaveFrames(*gpu, loaded.mesh.positions, control, out);
            const StageTimes stages = gpu->lastTimes();
            makeEvaluator(Backend::Cpu, tablesOf(r), form, nullptr)->evaluate(control, cpuOut);
            std::printf("  %-10s  median %7.3f ms  min %7.3f ms  (last frame: upload %.3f, submit to fence %.3f, "
                        "read back %.3f ms; %s)  max |vulkan - cpu| = %.2g\n",
                        form == TableForm::Tiled ? "vulkan tiled" : "vulkan", frameMs[frameMs.size() / 2],
                        frameMs.front(), stages.uploadMs, stages.evaluateMs + stages.normalsMs, stages.readbackMs,
                        gpu->device().c_str(), largestDifference(out, cpuOut));
        }
    } catch (const std::runtime_error& e) {  // VulkanError, or psub built without Vulkan
        std::printf("  %-10s  unavailable: %s\n", "vulkan", e.what());
    }
}

void printTablesAndFrames(const Loaded& loaded, int levels, const std::vector<double>& rulePositions) {
    RefineOptions options;
    options.levels = levels;
    options.factorized = true;
    options.tiled = true;
    const Refinement r = refine(loaded.mesh, loaded.checked.connectivity, options);
    const double refined = r.perLevel.refinedCount();
    std::printf("\nStencil tables (built once; topology %.1f ms):\n", r.topologyMs);
    std::printf("  per-level   %10llu rows %11llu indices %9.1f MiB %6.1f B/vertex  built in %.1f ms\n",
                (unsigned long long)r.perLevel.destinations.size(), (unsigned long long)r.perLevel.indices.size(),
                double(r.perLevel.bytes()) / 1048576, double(r.perLevel.bytes()) / refined, r.perLevelMs);
    std::printf("  factorized  %10u rows %11llu entries %9.1f MiB %6.1f B/vertex  built in %.1f ms\n",
                r.factorized.rowCount(), (unsigned long long)r.factorized.indices.size(),
                double(r.factorized.bytes()) / 1048576, double(r.factorized.bytes()) / refined, r.factorizedMs);
    const double fallbackShare = double(r.tiled.refinedCount - r.tiled.fallbackBegin) / refined;
    std::printf("  tiled       %10zu tiles, %5.1f%% of the points from fallback rows %9.1f MiB %6.1f B/vertex  "
                "built in %.1f ms\n",
                r.tiled.tileCount(), 100 * fallbackShare, double(r.tiled.bytes()) / 1048576,
                double(r.tiled.bytes()) / refined, r.tiledMs);

    std::printf("\nPer frame (a wave animates the %u control points; float xyz, all cores):\n",
                r.perLevel.controlCount);
    std::vector<float> control(loaded.mesh.positions.size()), out(3 * std::size_t(r.perLevel.refinedCount())),
        canonical(out.size());
    for (TableForm form : {TableForm::PerLevel, TableForm::Factorized, TableForm::Tiled}) {
        const std::unique_ptr<Evaluator> evaluator = makeEvaluator(Backend::Cpu, tablesOf(r), form, nullptr);
        const std::vector<double> frameMs = timeWaveFrames(*evaluator, loaded.mesh.positions, control, out);
        // The rest pose once more, against the readable rule path (the tiled form's drawing
        // order put back into the canonical order first, outside the timed frames).
        std::copy(loaded.mesh.positions.begin(), loaded.mesh.positions.end(), control.begin());
        evaluator->evaluate(control, out);
        if (form == TableForm::Tiled) toCanonical<float>(r.tiled, out, canonical, 3);
        std::printf("  %-10s  median %7.3f ms  min %7.3f ms  (%s)  max |table - rules| = %.2g\n",
                    form == TableForm::PerLevel ? "per-level" : form == TableForm::Factorized ? "factorized" : "tiled",
                    frameMs[frameMs.size() / 2], frameMs.front(), evaluator->device().c_str(),
                    largestDifference(form == TableForm::Tiled ? canonical : out, rulePositions));
    }
    printVulkanFrames(r, loaded);
}

void writeDemoMeshes(const DemoOptions& options, const std::string& model, const Loaded& loaded,
                     const Hierarchy& hierarchy, const std::vector<double>& positions) {
    const std::string stem = std::filesystem::path(model).stem().string();
    const int ccLevels = std::max(1, options.levels / 2);
    const std::string psPath = options.outputDir + "/" + stem + "_ps" + std::to_string(options.levels) + ".obj";
    requireFinite(positions, model, "refined");
    if (loaded.ccProblem) {
        writeOutput(psPath, formatObj(hierarchy.finest().faces, positions, header(model, "P-S demo")));
        std::printf("\nWrote %s (Catmull-Clark is unavailable for this mesh)\n", psPath.c_str());
        return;
    }
    const std::vector<CatmarkLevel> cc = refineCatmark(loaded.mesh.faces, loaded.mesh.positions, ccLevels);
    requireFinite(cc.back().positions, model, "Catmull-Clark refined");
    const std::string ccPath = options.outputDir + "/" + stem + "_cc" + std::to_string(ccLevels) + ".obj";
    // Both or neither: a failure on the second leaves the first unwritten too.
    writeOutputs({{psPath, formatObj(hierarchy.finest().faces, positions, header(model, "P-S demo"))},
                  {ccPath, formatObj(cc.back().faces, cc.back().positions, header(model, "Catmull-Clark demo"))}});
    std::printf("\nWrote %s and %s\n", psPath.c_str(), ccPath.c_str());
}

}  // namespace

int runDemo(const DemoOptions& options) {
    const std::string model = options.model.empty() ? dataDir() + "/cow.obj" : options.model;
    const auto start = Clock::now();
    const Loaded loaded = load(model);
    checkCoordinateRange(loaded.mesh, Precision::Float);  // it also times the float evaluators
    // The header after a successful load: bad input gives only its one error line.
    std::printf("PSub demo: the P-S subdivision scheme (Liu, Yang, Guan) on %s\n\n", model.c_str());
    const Faces& faces = loaded.mesh.faces;
    const bool preprocess = needsPreprocessing(faces, loaded.checked.connectivity, Preprocess::Auto);
    std::printf("Loaded and checked in %.1f ms. %s\n\n", msSince(start),
                preprocess ? "Not all quads, so the paired method turns it into quads first."
                           : "Already P-S input (quads, triangles only on the boundary).");
    std::vector<double> levelMs{0.0};
    const Hierarchy hierarchy = refineTopology(faces, loaded.checked.connectivity, preprocess,
                                               options.levels,
                                               [&](int, double seconds) { levelMs.push_back(seconds * 1e3); });
    printStats(loaded, hierarchy, levelMs, hierarchy.finest().faces.faceCount());

    const auto positionsStart = Clock::now();
    std::vector<std::vector<double>> positions{loaded.mesh.positions};
    for (std::size_t k = 1; k < hierarchy.levels.size(); ++k)
        positions.push_back(refineLevelPositions(hierarchy, k, positions.back()));
    std::printf("\nP-S positions of every level by the readable rule path: %.1f ms\n",
                msSince(positionsStart));
    printShapes(loaded, hierarchy, positions);
    printTablesAndFrames(loaded, options.levels, positions.back());
    if (!options.outputDir.empty()) writeDemoMeshes(options, model, loaded, hierarchy, positions.back());
    printVerdicts(loaded.mesh, loaded.checked.connectivity, options.levels);
    std::printf("\nNext:\n"
                "  psub subdivide %s -o out.obj --levels %d      # refined mesh as OBJ\n"
                "  psub subdivide %s -o cc.obj --levels %d --scheme cc\n"
                "  psub stats %s --levels 6\n"
                "  psub play %s --levels %d --frames 300        # animated, timed per stage\n"
                "  psub figure5 -o pictures/                    # the paper's Figure 5 and Table I as PNG\n"
                "  psub --help\n",
                model.c_str(), options.levels, model.c_str(), std::max(1, options.levels / 2),
                model.c_str(), model.c_str(), options.levels);
    return 0;
}

}  // namespace psub::cli
