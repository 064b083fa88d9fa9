// psub bench: models, matched sizes, PSub's side of each size, and the run as a whole.
// OpenSubdiv's side is in osd.cpp, the machine and bandwidth in machine.cpp, the output in
// report.cpp. See README.md for what is measured and how bytes per frame are counted.
#include "detail.h"

#include "psub/evaluator.h"
#include "psub/stencils.h"
#if PSUB_HAVE_VULKAN
#include "psub/vulkan_evaluator.h"
#endif

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <new>
#include <numbers>

namespace psub::bench {

Mesh makeTorus(int n) {
    if (n < 3) throw std::invalid_argument("makeTorus: n must be at least 3");
    const Index size = Index(n);
    Mesh mesh;
    mesh.faces.vertexCount = size * size;
    mesh.positions.reserve(3 * std::size_t(size) * size);
    const double major = 1.0, minor = 0.4, step = 2 * std::numbers::pi / n;
    for (Index i = 0; i < size; ++i)
        for (Index j = 0; j < size; ++j) {
            const double u = step * i, v = step * j, ring = major + minor * std::cos(v);
            mesh.positions.insert(mesh.positions.end(),
                                  {ring * std::cos(u), ring * std::sin(u), minor * std::sin(v)});
        }
    mesh.faces.verts.reserve(4 * std::size_t(size) * size);
    mesh.faces.offsets.reserve(std::size_t(size) * size + 1);
    auto at = [size](Index i, Index j) { return (i % size) * size + j % size; };
    for (Index i = 0; i < size; ++i)
        for (Index j = 0; j < size; ++j) {
            // Along u, then along v: du x dv points out of the tube.
            const Index corners[4] = {at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)};
            mesh.faces.addFace(corners);
        }
    mesh.source.path = "torus" + std::to_string(n) + " (generated)";
    return mesh;
}

namespace detail {
namespace {

struct Model {
    std::string name, path;
    Mesh mesh;
    Connectivity connectivity;
};

Model loadModel(const std::string& path) {
    Model model;
    model.path = path;
    model.name = std::filesystem::path(path).stem().string();
    std::vector<std::string> warnings;
    model.mesh = readObj(path, &warnings);
    CheckedMesh checked = checkMesh(model.mesh);
    warnings.insert(warnings.end(), checked.warnings.begin(), checked.warnings.end());
    for (const std::string& warning : warnings) std::fprintf(stderr, "psub: warning: %s\n", warning.c_str());
    model.connectivity = std::move(checked.connectivity);
    return model;
}

Model torusModel(int n) {
    Model model;
    model.mesh = makeTorus(n);
    model.name = "torus" + std::to_string(n);
    model.path = "(generated: " + std::to_string(n) + "x" + std::to_string(n) + " quads)";
    model.connectivity = checkMesh(model.mesh).connectivity;
    return model;
}

// "torus:N" names the generated N x N torus.
int torusSize(const std::string& name) {
    const std::string digits = name.substr(6);
    if (digits.empty() || digits.size() > 4 || digits.find_first_not_of("0123456789") != std::string::npos ||
        std::stoi(digits) < 3)
        throw InputError(name + ": a generated torus is named torus:N with N from 3 to 9999");
    return std::stoi(digits);
}

// Build times in ms, each the fastest of its repetitions: refine() with the per-level (and
// factorized) tables, and the tiled form's own lean build (RefineOptions::perLevel = false,
// what a program that evaluates only the tiled form builds; the same table, tests/test_tiled.cpp)
// without the canonical order (RefineOptions::canonicalOrder = false: what a program that
// evaluates and draws it builds; where tiles cover the mesh, no level after B), and with it.
struct BuildMs {
    double topology = 1e300, perLevel = 1e300, factorized = 1e300;
    double tiledTopology = 1e300, tiled = 1e300, tiledWithCanonical = 1e300;
};

// The tiled form's record (psub/tiled.h): table bytes are what evaluating reads (rows, gather
// lists, tile data); bytes per frame add 12 B per vertex of each per-level source and
// destination up to level B, of level B once (the tiles' gathers) and of the finest level.
Record tiledRecord(const Model& model, int levels, int k, const Refinement& refinement, const std::string& evaluator,
                   const BuildMs& build) {
    const TiledTable& tiled = refinement.tiled;
    std::uint64_t levelVertices = 0;
    for (std::size_t l = 0; l < tiled.rows.levels.size(); ++l) {
        const StencilLevel& level = tiled.rows.levels[l];
        if (l < tiled.baseLevel) levelVertices += std::uint64_t(level.sourceCount) + level.destinationCount;
        else if (l == tiled.baseLevel) levelVertices += level.sourceCount;
    }
    Record r;
    r.model = model.name;
    r.scheme = "ps";
    r.levels = levels;
    r.ccLevel = k;
    r.refinedFaces = tiled.surface.faceOffsets.size() - 1;
    r.refinedVertices = tiled.refinedCount;
    r.controlVertices = tiled.controlCount;
    r.evaluator = evaluator + "-tiled";
    r.table = "tiled";
    r.topologyMs = build.tiledTopology;
    r.tableMs = build.tiled;
    r.buildMs = r.topologyMs + r.tableMs;
    r.buildWithCanonicalMs = build.tiledWithCanonical;
    r.tableBytes = tiled.bytes();
    r.tableEntries = tiled.rows.indices.size() + tiled.gather.size();
    r.bytesPerFrame = r.tableBytes + 12 * (levelVertices + tiled.refinedCount);
    return r;
}

// PSub at `levels` P-S steps: refine() with both tables, then per-level and factorized
// evaluators on one thread and on all. Returns the refined shape.
// The fields every PSub record shares: model, size, table form, build times, bytes per frame
// (table + each level's source and destination vertices, 12 B each; factorized: control + finest).
Record psubRecord(const Model& model, int levels, int k, const Refinement& refinement, TableForm form,
                  const std::string& evaluator, const BuildMs& build) {
    const bool isPerLevel = form == TableForm::PerLevel;
    if (form == TableForm::Tiled) return tiledRecord(model, levels, k, refinement, evaluator, build);
    const std::uint64_t controlCount = refinement.perLevel.controlCount, refinedCount = refinement.perLevel.refinedCount();
    std::uint64_t levelVertices = 0;
    for (const StencilLevel& level : refinement.perLevel.levels)
        levelVertices += std::uint64_t(level.sourceCount) + level.destinationCount;
    Record r;
    r.model = model.name;
    r.scheme = "ps";
    r.levels = levels;
    r.ccLevel = k;
    r.refinedFaces = refinement.surface.faceOffsets.size() - 1;
    r.refinedVertices = refinedCount;
    r.controlVertices = controlCount;
    r.evaluator = evaluator + (isPerLevel ? "-perlevel" : "-factorized");
    r.table = isPerLevel ? "per-level" : "factorized";
    r.layoutFloats = 3;
    r.topologyMs = build.topology;
    r.tableMs = build.perLevel + (isPerLevel ? 0 : build.factorized);
    r.buildMs = r.topologyMs + r.tableMs;
    r.tableBytes = isPerLevel ? refinement.perLevel.bytes() : refinement.factorized.bytes();
    r.tableEntries = isPerLevel ? refinement.perLevel.indices.size() : refinement.factorized.indices.size();
    r.bytesPerFrame = r.tableBytes + 12 * (isPerLevel ? levelVertices : controlCount + refinedCount);
    return r;
}

#if PSUB_HAVE_VULKAN
// The Vulkan evaluator on the same tables (lavapipe here: the same 2 cores), timed with the
// results left on the device, then read back once and checked against the CPU's. `untiled`:
// the tiled form without tiles, when built (psub-vulkan-tiled-notiles).
void benchVulkan(const Model& model, int levels, int k, const Refinement& refinement, const BuildMs& build,
                 const std::vector<TableForm>& forms, const Refinement* untiled, const BuildMs& untiledBuild,
                 const Animation& animation, const std::vector<float>& reference, const Shape& shape,
                 const FrameSettings& frames, Progress& progress, const std::string& label, std::vector<Record>& records,
                 std::vector<std::string>& warnings) {
    static std::unique_ptr<VulkanContext> context;
    static std::string unavailable;
    if (!context && unavailable.empty()) {
        try {
            context = std::make_unique<VulkanContext>(VulkanOptions{Validation::Off, {}, false, false});
        } catch (const std::exception& e) {
            unavailable = e.what();
            warnings.push_back("no Vulkan rows: " + unavailable);
        }
    }
    if (!context) return;
    const std::size_t controlCount = refinement.perLevel.controlCount, refinedCount = refinement.perLevel.refinedCount();
    std::vector<float> control(3 * controlCount), out(3 * refinedCount), canonical;
    const auto measure = [&](Record r, const Refinement& tables, TableForm form) {
        r.threads = 0;  // the driver's own threads
        progress.show(label + ": " + r.evaluator + " (" + context->deviceName() + ")");
        try {
            const std::unique_ptr<Evaluator> evaluator = makeVulkanEvaluator(*context, tablesOf(tables), form);
            r.timing = timeFrames(
                frames, [&](int frame) { animation.write(frame, control.data(), 3); },
                [&] { evaluator->evaluate(control, {}); });
            r.normalsTiming = timeFrames(
                warmOnly(frames), [&](int frame) { animation.write(frame, control.data(), 3); },
                [&] { evaluator->evaluateKept(control, true); });
            r.hasNormals = true;
            animation.writeRest(control.data(), 3);
            evaluator->evaluate(control, out);
            if (form == TableForm::Tiled) {  // drawing order -> canonical, outside the timing
                canonical.resize(out.size());
                toCanonical<float>(tables.tiled, out, canonical, 3);
                out.swap(canonical);
            }
        } catch (const std::exception& e) {
            warnings.push_back(model.name + " " + r.evaluator + ": " + e.what());
            return;
        }
        r.maxDiff = maxDifference(out.data(), 3, reference.data(), 3, refinedCount) / shape.diagonal;
        r.shape = shape;
        if (!(r.maxDiff <= 1e-5))
            warnings.push_back(model.name + " " + r.evaluator + " differs from psub-cpu-perlevel by " +
                               std::to_string(r.maxDiff) + " of the bounding-box diagonal");
        records.push_back(r);
    };
    for (TableForm form : forms) measure(psubRecord(model, levels, k, refinement, form, "psub-vulkan", build), refinement, form);
    if (untiled) {
        Record r = tiledRecord(model, levels, k, *untiled, "psub-vulkan", untiledBuild);
        r.evaluator = "psub-vulkan-tiled-notiles";
        r.table = "tiled, no tiles";
        measure(r, *untiled, TableForm::Tiled);
    }
}
#endif

// The tiled form's split: double steps, base level, tiles, the share of finest points the
// tiles write and the share of frame time the per-level rows take (levels up to B and the
// fallback's, timed alone on a copy without tiles).
void tiledNote(const Model& model, int levels, const Refinement& refinement, int threads, const Animation& animation,
               const BuildMs& build, std::vector<std::string>& notes) {
    const TiledTable& tiled = refinement.tiled;
    TiledTable rowsOnly = tiled;
    rowsOnly.side.clear();
    rowsOnly.output.clear();
    std::vector<float> control(3 * std::size_t(tiled.controlCount)), out(3 * std::size_t(tiled.refinedCount));
    const FrameSettings few{2, 15, 2};
    CpuEvaluator<float> whole(tiled, 3, threads), rows(rowsOnly, 3, threads);
    const auto write = [&](int frame) { animation.write(frame, control.data(), 3); };
    const double wholeMs = timeFrames(few, write, [&] { whole.evaluate(control, out); }).median;
    const double rowsMs = timeFrames(few, write, [&] { rows.evaluate(control, out); }).median;
    std::uint64_t fallbackRows = 0;
    for (std::size_t l = tiled.baseLevel; l < tiled.rows.levels.size(); ++l)
        fallbackRows += tiled.rows.levels[l].rowEnd - tiled.rows.levels[l].rowBegin;
    notes.push_back(format("%s P-S %d levels, tiled form: t = %u double steps from level B = %u, %zu tiles; tiles write "
                           "%.1f%% of the %u finest points, the fallback %.1f%% (%llu fallback rows); per-level rows "
                           "(levels up to B and the fallback) take %.3f of %.3f ms per frame (%.0f%%) on %d threads",
                           model.name.c_str(), levels, tiled.doubleSteps, tiled.baseLevel, tiled.tileCount(),
                           100.0 * tiled.fallbackBegin / std::max(1u, tiled.refinedCount), tiled.refinedCount,
                           100.0 - 100.0 * tiled.fallbackBegin / std::max(1u, tiled.refinedCount),
                           (unsigned long long)fallbackRows, rowsMs, wholeMs, 100.0 * rowsMs / std::max(1e-9, wholeMs),
                           threads));
    const double drawingOnly = build.tiledTopology + build.tiled;
    if (build.tiledWithCanonical > drawingOnly * 1.0001)
        notes.push_back(format("%s P-S %d levels, tiled form: built for drawing (no canonical order, no level after B) in "
                               "%.1f ms; with the canonical order (psub subdivide's) %.1f ms",
                               model.name.c_str(), levels, drawingOnly, build.tiledWithCanonical));
}

Shape runPSub(const Model& model, int levels, int k, bool withFactorized, const FrameSettings& frames,
              int allThreads, Progress& progress, const std::string& label, std::vector<Record>& records,
              std::vector<std::string>& warnings, std::vector<std::string>& notes) {
    progress.show(label + ": PSub topology + tables");
    // Built up to 3 times while that takes under a second in all; the fastest of each part.
    // Then the tiled form's lean build the same way (its table is the same; not kept).
    Refinement refinement;
    BuildMs build;
    int repetitions = 0;
    RefineOptions options;
    options.levels = levels;
    options.preprocess = Preprocess::Auto;
    options.factorized = withFactorized;
    options.tiled = true;
    const auto buildStart = Clock::now();
    do {
        refinement = Refinement{};
        refinement = refine(model.mesh, model.connectivity, options);
        build.topology = std::min(build.topology, refinement.topologyMs);
        build.perLevel = std::min(build.perLevel, refinement.perLevelMs);
        build.factorized = std::min(build.factorized, refinement.factorizedMs);
        ++repetitions;
    } while (repetitions < kBuildRepetitions && msSince(buildStart) < kBuildSeconds * 1e3);
    options.factorized = false;
    options.perLevel = false;
    const auto leanStart = Clock::now();
    for (int lean = 0; lean < kBuildRepetitions && (lean == 0 || msSince(leanStart) < kBuildSeconds * 1e3); ++lean) {
        options.canonicalOrder = false;
        bool withoutCanonical = false;
        {
            const Refinement tiledOnly = refine(model.mesh, model.connectivity, options);
            build.tiledTopology = std::min(build.tiledTopology, tiledOnly.topologyMs);
            build.tiled = std::min(build.tiled, tiledOnly.tiledMs);
            withoutCanonical = tiledOnly.tiled.canonical.empty();
            if (!withoutCanonical)  // not the drawing-only build: tiles do not cover the mesh
                build.tiledWithCanonical = std::min(build.tiledWithCanonical, tiledOnly.topologyMs + tiledOnly.tiledMs);
        }
        options.canonicalOrder = true;
        if (withoutCanonical) {
            const Refinement tiledOnly = refine(model.mesh, model.connectivity, options);
            build.tiledWithCanonical = std::min(build.tiledWithCanonical, tiledOnly.topologyMs + tiledOnly.tiledMs);
        }
    }
    const PerLevelTable& perLevel = refinement.perLevel;
    const FactorizedTable& factorized = refinement.factorized;
    const std::size_t controlCount = perLevel.controlCount, refinedCount = perLevel.refinedCount();
    const Animation animation(model.mesh.positions, boxDiagonal(model.mesh.positions));

    std::vector<float> control(3 * controlCount), out(3 * refinedCount), normals(3 * refinedCount), reference;
    Shape shape;
    std::vector<int> threadCounts{1};
    if (allThreads > 1) threadCounts.push_back(allThreads);
    std::vector<TableForm> forms{TableForm::PerLevel};
    if (withFactorized) forms.push_back(TableForm::Factorized);
    forms.push_back(TableForm::Tiled);
    std::vector<float> canonical;
    // Frames with and without normals, and the rest pose against the first record's (in canonical
    // order: the tiled form's drawing order mapped back outside the timing).
    // `tiled`: the tiled table `evaluator` reads, when not refinement's.
    const auto measure = [&](Record& r, CpuEvaluator<float>& evaluator, TableForm form,
                             const TiledTable* tiled = nullptr) {
        progress.show(label + ": " + r.evaluator + " " + std::to_string(r.threads) + " thr");
        r.buildRepetitions = repetitions;
        r.bytesPerFrame -= evaluator.narrowBytesSaved();  // its narrow copy read instead (psub/evaluator.h)
        r.timing = timeFrames(
            frames, [&](int frame) { animation.write(frame, control.data(), 3); },
            [&] { evaluator.evaluate(control, out); });
        r.normalsTiming = timeFrames(
            warmOnly(frames), [&](int frame) { animation.write(frame, control.data(), 3); },
            [&] { evaluator.evaluate(control, out, normals); });
        r.hasNormals = true;
        animation.writeRest(control.data(), 3);
        evaluator.evaluate(control, out);
        if (form == TableForm::Tiled) {
            canonical.resize(out.size());
            toCanonical<float>(tiled ? *tiled : refinement.tiled, out, canonical, 3);
            out.swap(canonical);
        }
        if (reference.empty()) {
            reference = out;
            shape = measureShape(std::span<const std::uint32_t>(refinement.surface.faceOffsets),
                                 std::span<const std::uint32_t>(refinement.surface.faceVerts), reference.data(),
                                 refinedCount, 3);
        }
        r.maxDiff = maxDifference(out.data(), 3, reference.data(), 3, refinedCount) / shape.diagonal;
        r.shape = shape;
        if (!(r.maxDiff <= 1e-5))
            warnings.push_back(model.name + " P-S " + std::to_string(levels) + " levels: " + r.evaluator + " (" +
                               std::to_string(r.threads) + " threads) differs from psub-cpu-perlevel by " +
                               std::to_string(r.maxDiff) + " of the bounding-box diagonal");
        records.push_back(r);
    };
    for (TableForm form : forms)
        for (int threads : threadCounts) {
            Record r = psubRecord(model, levels, k, refinement, form, "psub-cpu", build);
            r.threads = threads;
            CpuEvaluator<float> evaluator = form == TableForm::Tiled
                                                ? CpuEvaluator<float>(refinement.tiled, 3, threads)
                                                : CpuEvaluator<float>(perLevel, factorized, refinement.surface, form, 3, threads);
            measure(r, evaluator, form);
        }
    // The per-level rows ordered by region, one region per thread (docs/design.md, "Threads and
    // regions"; psub play's candidates when a frame runs on several threads), and the tiled
    // form's: all threads only, the ordering counted in the table's build.
    const auto regionRecord = [&](TableForm form, const std::string& evaluator, const std::string& table,
                                  double orderMs) {
        Record r = psubRecord(model, levels, k, refinement, form, "psub-cpu", build);
        r.evaluator = evaluator;
        r.table = table;
        r.tableMs += orderMs;
        r.buildMs += orderMs;
        r.threads = allThreads;
        return r;
    };
    if (const int regionCount = perLevelFrameThreads(perLevel, 3, allThreads); regionCount > 1) {
        const std::string byRegions = " by " + std::to_string(regionCount) + " regions";
        PerLevelTable regions = perLevel;
        auto orderStart = Clock::now();
        orderLevelsByRegion(regions, std::uint32_t(regionCount));
        Record r = regionRecord(TableForm::PerLevel, "psub-cpu-regions", "per-level" + byRegions, msSince(orderStart));
        CpuEvaluator<float> evaluator(regions, factorized, refinement.surface, TableForm::PerLevel, 3, allThreads);
        measure(r, evaluator, TableForm::PerLevel);
        // The tiled form with its rows up to level B so ordered (level B, which the tiles gather
        // from, keeps its numbers), in place and put back after (the Vulkan runs below get the
        // table as refined).
        if (refinement.tiled.tileCount() > 0 && refinement.tiled.baseLevel > 1) {
            PerLevelTable rows = refinement.tiled.rows;
            orderStart = Clock::now();
            orderLevelsByRegion(refinement.tiled.rows, std::uint32_t(regionCount), refinement.tiled.baseLevel);
            Record t = regionRecord(TableForm::Tiled, "psub-cpu-tiled-regions", "tiled, rows" + byRegions,
                                    msSince(orderStart));
            CpuEvaluator<float> tiledEvaluator(refinement.tiled, 3, allThreads);
            measure(t, tiledEvaluator, TableForm::Tiled);
            refinement.tiled.rows = std::move(rows);
        }
    }
    // The tiled form without a tile (TileSides::None: psub play's candidate on Vulkan and on
    // several CPU threads, where worthTimingWithoutTiles; docs/tiled.md "Tiles or none"): its
    // lean build, as often as the tiled form's (the fastest counted), then all threads and Vulkan.
    Refinement untiled;
    BuildMs untiledBuild = build;
    const bool timesUntiled = worthTimingWithoutTiles(refinement.tiled);
    if (timesUntiled) {
        progress.show(label + ": PSub tiled form without tiles");
        options.tileSides = TileSides::None;
        untiledBuild.tiledTopology = untiledBuild.tiled = untiledBuild.tiledWithCanonical = 1e300;
        const auto untiledStart = Clock::now();
        for (int n = 0; n < kBuildRepetitions && (n == 0 || msSince(untiledStart) < kBuildSeconds * 1e3); ++n) {
            untiled = refine(model.mesh, model.connectivity, options);
            untiledBuild.tiledTopology = std::min(untiledBuild.tiledTopology, untiled.topologyMs);
            untiledBuild.tiled = std::min(untiledBuild.tiled, untiled.tiledMs);
            untiledBuild.tiledWithCanonical = std::min(untiledBuild.tiledWithCanonical, untiled.topologyMs + untiled.tiledMs);
        }
    }
    if (timesUntiled && allThreads > 1) {
        Record r = tiledRecord(model, levels, k, untiled, "psub-cpu", untiledBuild);
        r.evaluator = "psub-cpu-tiled-notiles";
        r.table = "tiled, no tiles";
        r.threads = allThreads;
        CpuEvaluator<float> evaluator(untiled.tiled, 3, allThreads);
        measure(r, evaluator, TableForm::Tiled, &untiled.tiled);
    }
    tiledNote(model, levels, refinement, threadCounts.back(), animation, build, notes);
#if PSUB_HAVE_VULKAN
    benchVulkan(model, levels, k, refinement, build, forms, timesUntiled ? &untiled : nullptr, untiledBuild, animation,
                reference, shape, frames, progress, label, records, warnings);
#endif
    return shape;
}

// P-S topological steps (preprocessing included) whose face count is nearest to `target`;
// 2k on a closed mesh, where it is equal.
int matchingSteps(const Counts& input, bool preprocessed, std::uint64_t target, int k) {
    int best = 2 * k;
    auto distance = [&](int steps) {
        const double faces = double(countsAfterSteps(input, steps).faces);
        return std::abs(faces - double(target));
    };
    for (int steps = preprocessed ? 1 : 0; steps <= 2 * k + 1; ++steps)
        if (distance(steps) < distance(best)) best = steps;
    return best;
}

}  // namespace
}  // namespace detail

int runBench(const BenchOptions& options) {
    using namespace detail;
    const auto start = Clock::now();
    Report report;
    report.machine = describeMachine();
    report.command = options.command;
    report.quick = options.quick;
    report.maxFaces = options.maxFaces;
    report.frames = {options.warmup, options.frames, options.frameBudgetSeconds};
    report.frames.coldFrames = options.coldFrames;
    report.frames.flushBytes = coldFlushBytes();
    if (options.quick) {
        report.frames.warmup = std::min(options.warmup, 1);
        report.frames.frames = std::min(options.frames, 5);
        report.frames.coldFrames = std::min(options.coldFrames, 1);  // the path, not the caches
        report.frames.flushBytes = std::size_t(64) << 20;
    }
    if (report.frames.coldFrames > 0) {
        try {
            flushCaches(report.frames.flushBytes);  // its buffer, once for the run
        } catch (const std::bad_alloc&) {
            report.warnings.push_back(format("no cold frames: %zu MB to write over the caches could not be allocated",
                                             report.frames.flushBytes >> 20));
            report.frames.coldFrames = 0;
        }
    }
    const int allThreads = report.machine.threads;
    Progress progress;
    double load[1] = {0};
    if (::getloadavg(load, 1) == 1) report.loadStart = load[0];
    const CpuTimes cpuStart = readCpuTimes();

    // Models first, so that a bad path fails at once.
    std::vector<std::string> paths = options.models;
    if (paths.empty()) {
        for (const char* name : {"cow.obj", "spot_control_mesh.obj", "cube.obj"})
            paths.push_back(options.dataDir + "/" + name);
        if (options.torus > 0) paths.push_back("torus:" + std::to_string(options.torus));
    }
    std::vector<Model> models;
    for (const std::string& path : paths) {
        progress.show("loading " + path);
        models.push_back(path.rfind("torus:", 0) == 0 ? torusModel(torusSize(path)) : loadModel(path));
    }
    const std::size_t modelCount = models.size();

    // Bandwidth, while little else is resident: 3 arrays of 64M doubles (1.5 GiB) are far
    // above the caches of this machine (quick: 32M, 768 MiB).
    report.triadElements = std::size_t(options.quick ? 32 : 64) << 20;
    const int repetitions = options.quick ? 3 : 10;
    progress.show("memory bandwidth: triad, 1 thread");
    report.triad1 = measureTriad(1, report.triadElements, repetitions);
    progress.show("memory bandwidth: triad, " + std::to_string(allThreads) + " threads");
    report.triadAll = allThreads > 1 ? measureTriad(allThreads, report.triadElements, repetitions) : report.triad1;
    progress.show("memory bandwidth: write-only (streaming stores)");
    report.write1 = measureWriteOnly(1, 3 * report.triadElements, repetitions);
    report.writeAll = allThreads > 1 ? measureWriteOnly(allThreads, 3 * report.triadElements, repetitions) : report.write1;
    progress.show("core to core round trip");
    report.roundTripStart = measureCoreRoundTrip(100000);

    for (std::size_t m = 0; m < modelCount; ++m) {
        const Model& model = models[m];
        const Faces& faces = model.mesh.faces;
        ModelResult info;
        info.name = model.name;
        info.path = model.path;
        info.vertices = faces.vertexCount;
        info.faces = faces.faceCount();
        info.corners = faces.verts.size();
        info.preprocessed = needsPreprocessing(faces, model.connectivity, Preprocess::Auto);
        {
            std::vector<float> p(model.mesh.positions.begin(), model.mesh.positions.end());
            info.input = measureShape(std::span<const Index>(faces.offsets), std::span<const Index>(faces.verts),
                                      p.data(), faces.vertexCount, 3);
        }
        const Counts input = countMesh(faces, model.connectivity);
        auto ccFaces = [&](int k) { return k == 0 ? info.faces : info.corners << (2 * (k - 1)); };

        // Sizes: k = 1..levels, further while the mesh stays small, never above maxFaces.
        for (int k = 1; k <= 12; ++k) {
            const std::uint64_t cc = ccFaces(k);
            const int steps = matchingSteps(input, info.preprocessed, cc, k);
            const std::uint64_t ps = countsAfterSteps(input, steps).faces;
            if (std::max(cc, ps) > options.maxFaces) break;
            if (k > options.levels && cc > options.extendBelow) break;
            info.sizes.push_back(k);
            if (options.quick) break;
        }
        const int shownLevels = std::max(options.levels, info.sizes.empty() ? 0 : info.sizes.back());
        for (int t = 0; t <= 2 * shownLevels + (info.preprocessed ? 1 : 0); ++t)
            info.psFaces.push_back(countsAfterSteps(input, t).faces);
        for (int k = 0; k <= shownLevels; ++k) info.ccFaces.push_back(ccFaces(k));
        if (info.sizes.empty())
            report.warnings.push_back(model.name + ": even Catmull-Clark level 1 (" + std::to_string(ccFaces(1)) +
                                      " faces) is above --max-faces; skipped");

        for (int k : info.sizes) {
            const int steps = matchingSteps(input, info.preprocessed, ccFaces(k), k);
            const int psLevels = steps - (info.preprocessed ? 1 : 0);
            SizeResult size;
            size.model = model.name;
            size.k = k;
            size.psLevels = psLevels;
            size.psFaces = countsAfterSteps(input, steps).faces;
            size.ccFaces = ccFaces(k);
            const std::string label = "[" + std::to_string(m + 1) + "/" + std::to_string(modelCount) + "] " +
                                      model.name + " CC " + std::to_string(k) + " / P-S " + std::to_string(psLevels) +
                                      " (" + std::to_string(size.ccFaces) + " faces)";
            const std::size_t firstRecord = report.records.size();
            const bool withFactorized = size.psFaces <= options.maxFactorizedFaces;
            if (!withFactorized)
                report.notes.push_back(model.name + " P-S " + std::to_string(psLevels) + " levels (" +
                                       std::to_string(size.psFaces) +
                                       " faces): psub-cpu-factorized skipped, above --max-factorized-faces " +
                                       std::to_string(options.maxFactorizedFaces) + " (its table grows with the "
                                       "levels; see README)");
            size.ps = runPSub(model, psLevels, k, withFactorized, report.frames, allThreads, progress, label, report.records,
                              report.warnings, report.notes);
            OsdContext context{report.frames, allThreads, &progress, label, &report.warnings};
            size.cc = runOpenSubdiv(model.mesh, model.name, k, context, report.records);

            // Ratios against OpenSubdiv's fastest configuration of this size.
            double osdFrame = 1e300, osdBuild = 1e300, osdCold = 1e300;
            for (std::size_t i = firstRecord; i < report.records.size(); ++i)
                if (report.records[i].scheme == "cc") {
                    osdFrame = std::min(osdFrame, report.records[i].timing.median);
                    if (report.records[i].timing.coldFrames > 0)
                        osdCold = std::min(osdCold, report.records[i].timing.coldMedian);
                    osdBuild = std::min(osdBuild, report.records[i].buildMs);
                    if (report.records[i].refinedFaces != size.ccFaces)
                        report.warnings.push_back(model.name + " CC level " + std::to_string(k) + ": OpenSubdiv made " +
                                                  std::to_string(report.records[i].refinedFaces) +
                                                  " faces, the closed form says " + std::to_string(size.ccFaces));
                } else if (report.records[i].refinedFaces != size.psFaces) {
                    report.warnings.push_back(model.name + " P-S: refined " +
                                              std::to_string(report.records[i].refinedFaces) +
                                              " faces, the closed form says " + std::to_string(size.psFaces));
                }
            size.osdBestFrameMs = osdFrame;
            size.osdBestBuildMs = osdBuild;
            size.osdBestColdFrameMs = osdCold < 1e300 ? osdCold : 0;
            for (std::size_t i = firstRecord; i < report.records.size(); ++i) {
                Record& r = report.records[i];
                r.ratioVsOsdBest = r.timing.median > 0 ? osdFrame / r.timing.median : 0;
                r.coldRatioVsOsdBest = r.timing.coldMedian > 0 ? size.osdBestColdFrameMs / r.timing.coldMedian : 0;
                r.buildRatioVsOsdBest = r.buildMs > 0 ? osdBuild / r.buildMs : 0;
            }
            for (const Shape& s : {size.ps, size.cc})
                if (!std::isfinite(s.volume) || !std::isfinite(s.diagonal) || s.diagonal <= 0 ||
                    s.diagonal > 1.5 * info.input.diagonal)
                    report.warnings.push_back(model.name + " CC level " + std::to_string(k) +
                                              ": implausible refined shape (volume " + std::to_string(s.volume) +
                                              ", diagonal " + std::to_string(s.diagonal) + ")");
            report.sizes.push_back(size);
        }
        report.models.push_back(std::move(info));
    }
    report.roundTripEnd = measureCoreRoundTrip(100000);
    progress.done();
    if (::getloadavg(load, 1) == 1) report.loadEnd = load[0];
    const CpuTimes cpuEnd = readCpuTimes();
    report.seconds = msSince(start) * 1e-3;
    report.otherCpuSeconds = std::max(0.0, (cpuEnd.busy - cpuStart.busy) - (cpuEnd.self - cpuStart.self));
    report.stealSeconds = cpuEnd.steal - cpuStart.steal;
    if (report.otherCpuSeconds > 0.05 * report.seconds || report.stealSeconds > 0.05 * report.seconds)
        report.warnings.push_back(format("other processes used %.1f CPU-seconds and the hypervisor stole %.1f "
                                         "during this %.0f s run: timings may be noisy",
                                         report.otherCpuSeconds, report.stealSeconds, report.seconds));

    for (Record& r : report.records) {
        const double seconds = r.timing.median * 1e-3;
        r.gbs = seconds > 0 ? double(r.bytesPerFrame) / seconds / 1e9 : 0;
        const double triad = r.threads > 1 ? report.triadAll : report.triad1;
        r.bandwidthFraction = triad > 0 ? r.gbs / triad : 0;
        const double writeOnly = r.threads > 1 ? report.writeAll : report.write1;
        const double floorBytes = 12.0 * double(r.refinedVertices);
        r.floorMs = triad > 0 ? floorBytes / (triad * 1e9) * 1e3 : 0;
        r.floorRatio = r.floorMs > 0 ? r.timing.median / r.floorMs : 0;
        r.coldFloorRatio = r.floorMs > 0 ? r.timing.coldMedian / r.floorMs : 0;
        r.writeFloorMs = writeOnly > 0 ? floorBytes / (writeOnly * 1e9) * 1e3 : 0;
        r.writeFloorRatio = r.writeFloorMs > 0 ? r.timing.median / r.writeFloorMs : 0;
        if (r.hasNormals) {
            r.normalsFloorMs = 2 * r.floorMs;
            r.normalsFloorRatio = r.normalsFloorMs > 0 ? r.normalsTiming.median / r.normalsFloorMs : 0;
        }
    }

    printMarkdown(report, stdout);
    std::fflush(stdout);
    if (!options.jsonPath.empty()) writeJson(report, options.jsonPath);
    if (!options.plotPath.empty()) writeSvg(report, options.plotPath);
    for (const std::string& warning : report.warnings) std::fprintf(stderr, "psub bench: warning: %s\n", warning.c_str());
    return 0;
}

Mesh benchMesh(const std::string& name) {
    return name.rfind("torus:", 0) == 0 ? makeTorus(detail::torusSize(name)) : readObj(name);
}

double parseArgument(const char* text, const char* what, double lo, double hi, bool whole) {
    char* end = nullptr;
    errno = 0;
    const double value = std::strtod(text, &end);
    if (end == text || *end != '\0' || errno == ERANGE || !(value >= lo && value <= hi) ||
        (whole && std::floor(value) != value)) {
        std::fprintf(stderr, "%s: error: %s must be %s from %g to %g, got '%s'\n", program_invocation_short_name, what, whole ? "an integer" : "a number", lo, hi, text);
        std::exit(2);
    }
    return value;
}

}  // namespace psub::bench
