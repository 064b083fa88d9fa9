// The psub commands: subdivide, stats and demo. Loading, the memory guard and the tables
// they print live here; the engine itself is in topology/ and stencils/.
#include "commands.h"

#include "analyze.h"

#include "psub/catmark.h"
#include "psub/evaluator.h"
#include "psub/output.h"
#include "psub/rules.h"
#include "psub/stencils.h"
#if PSUB_HAVE_VULKAN
#include "psub/vulkan_evaluator.h"
#endif

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <optional>

#include <unistd.h>

namespace psub::cli {
namespace {

using Clock = std::chrono::steady_clock;

double msSince(Clock::time_point start) {
    return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

struct Loaded {
    Mesh mesh;
    CheckedMesh checked;
    std::optional<std::string> ccProblem;  // why OpenSubdiv cannot refine it (then P-S only)
};

Loaded load(const std::string& path) {
    Loaded loaded;
    loaded.mesh = loadChecked(path, loaded.checked);
    loaded.ccProblem = catmarkProblem(loaded.mesh);
    return loaded;
}

void printCatmarkUnavailable(const Loaded& loaded) {
    std::printf("\nCatmull-Clark: unavailable for this mesh (%s)\n", loaded.ccProblem->c_str());
}

std::uint64_t physicalMemory() {
    const long pages = ::sysconf(_SC_PHYS_PAGES), pageSize = ::sysconf(_SC_PAGESIZE);
    return pages > 0 && pageSize > 0 ? std::uint64_t(pages) * std::uint64_t(pageSize) : 0;
}

// Rough peak bytes of refining to `steps` topological steps with psub::refine, which keeps
// two levels of topology at a time (about 44 B per half-edge, 30 B per vertex, 8 B per face),
// plus every level's table rows, the finest surface, the evaluator's level buffers (doubles)
// and the OBJ text of the finest level.
double estimateBytes(const Counts& input, int steps, Boundary boundary, bool preprocessed) {
    auto halfedges = [](const Counts& c) { return 2.0 * double(c.edges) - double(c.boundaryEdges); };
    auto topology = [&](const Counts& c) { return 44 * halfedges(c) + 30 * double(c.vertices) + 8 * double(c.faces); };
    auto after = [&](int k) { return countsAfterSteps(input, k, boundary, preprocessed); };
    const Counts finest = after(steps);
    double bytes = topology(finest) + (steps > 0 ? topology(after(steps - 1)) : 0.0);
    for (int k = 1; k <= steps; ++k) {
        const Counts parent = after(k - 1), child = after(k);
        bytes += 4 * (double(child.vertices) + double(parent.vertices) + 3 * halfedges(parent));  // table
        bytes += 24 * double(child.vertices);  // evaluator buffers
    }
    bytes += 4 * (double(finest.faces) + 2 * halfedges(finest) + double(finest.vertices));  // surface
    return bytes + 60 * double(finest.vertices) + 25 * double(finest.faces);                 // OBJ text
}

std::string humanBytes(double bytes) {
    const char* units[] = {"B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"};
    int unit = 0;
    while (bytes >= 1024 && unit < 6) bytes /= 1024, ++unit;
    char text[32];
    std::snprintf(text, sizeof text, "%.1f %s", bytes, units[unit]);
    return text;
}

// Throws InputError when `--levels levels` would not fit in `limit` bytes (or in 32-bit
// indices), naming the estimate and the most levels that fit. A level is `stepsPerLevel`
// topological steps (2 for Catmull-Clark, which quadruples the faces), after `extraSteps`
// (the paired method).
void guardMemory(const Mesh& mesh, const Counts& input, int levels, int stepsPerLevel, int extraSteps,
                 std::uint64_t limit, Boundary boundary = Boundary::Paper) {
    if (limit == 0) limit = physicalMemory() / 4 * 3;
    auto steps = [&](int l) { return extraSteps + stepsPerLevel * l; };
    auto fits = [&](int l) {
        const Counts c = countsAfterSteps(input, steps(l), boundary, extraSteps > 0);
        return estimateBytes(input, steps(l), boundary, extraSteps > 0) <= double(limit) &&
               2.0 * double(c.edges) < double(kNoIndex) && double(c.vertices) < double(kNoIndex);
    };
    if (fits(levels)) return;
    int most = -1;
    while (most + 1 < levels && fits(most + 1)) ++most;
    throw InputError(mesh.source.path + ": --levels " + std::to_string(levels) + " would need about " +
                     humanBytes(estimateBytes(input, steps(levels), boundary, extraSteps > 0)) + " (limit " + humanBytes(double(limit)) +
                     ", and 32-bit indices); " +
                     (most >= 0 ? "--levels " + std::to_string(most) + " is the most that fits"
                                : std::string("not even the input fits")));
}

const char* preprocessName(bool preprocessed) { return preprocessed ? "after preprocessing" : "no preprocessing"; }

std::string header(const std::string& input, const std::string& what) {
    return "written by psub: " + what + "\nfrom " + input;
}

// Where the one-line summary goes: stdout, unless the mesh itself went there (-o -).
std::FILE* summaryStream(const std::string& output) { return output == "-" ? stderr : stdout; }

bool progressWanted() { return ::isatty(2) != 0; }

// The finest faces as a Faces value (what formatObj writes).
Faces finestFaces(const SurfaceTable& surface) {
    Faces faces;
    faces.vertexCount = surface.vertexCount;
    faces.offsets = surface.faceOffsets;
    faces.verts = surface.faceVerts;
    return faces;
}

// Refined positions from the Vulkan evaluator (float, per-level tables), and the device's
// name; nothing, with `why`, when no Vulkan device can be used (or psub was built without).
std::optional<std::vector<double>> evaluateOnVulkan(const Refinement& r, const std::vector<double>& control,
                                                    std::string& device, std::string& why) {
#if PSUB_HAVE_VULKAN
    try {
        VulkanContext context;
        VulkanEvaluator evaluator(context, r.perLevel, r.factorized, r.surface, TableForm::PerLevel, 3);
        const std::vector<float> in(control.begin(), control.end());
        std::vector<float> out(3 * std::size_t(evaluator.refinedCount()));
        evaluator.evaluate(in, out);
        device = context.deviceName();
        return std::vector<double>(out.begin(), out.end());
    } catch (const VulkanError& e) {
        why = e.what();
    }
#else
    (void)r, (void)control, (void)device;
    why = "this psub was built without Vulkan (PSUB_BUILD_VULKAN=OFF)";
#endif
    return std::nullopt;
}

int subdividePS(const SubdivideOptions& o, const Loaded& loaded) {
    const Faces& faces = loaded.mesh.faces;
    if (!loaded.mesh.uv.empty() && o.boundary == Boundary::Smooth) {
        std::fprintf(stderr, "psub subdivide: --boundary smooth does not refine texture coordinates, and %s has "
                     "them (vt); use --boundary paper\n", o.input.c_str());
        return 2;
    }
    const bool preprocess = needsPreprocessing(faces, loaded.checked.connectivity, o.preprocess,
                                               loaded.mesh.source);
    const int steps = o.levels + (preprocess ? 1 : 0);
    guardMemory(loaded.mesh, countMesh(faces, loaded.checked.connectivity), o.levels, 1, preprocess ? 1 : 0,
                o.maxMemory, o.boundary);
    const auto start = Clock::now();
    RefineOptions options{o.levels, o.preprocess, false, {}};
    options.rules = o.rules;
    options.boundary = o.boundary;
    options.uvLinear = o.uvLinear;
    if (progressWanted())
        options.onLevel = [&](int level, double seconds) {
            std::fprintf(stderr, "psub: level %d/%d topology in %.1f ms\n", level, steps, seconds * 1e3);
        };
    const Refinement refinement = refine(loaded.mesh, loaded.checked.connectivity, options);
    std::vector<double> positions;
    std::string backendNote;
    if (o.backend != Backend::Cpu) {
        std::string device, why;
        if (auto evaluated = evaluateOnVulkan(refinement, loaded.mesh.positions, device, why)) {
            positions = std::move(*evaluated);
            backendNote = ", float on Vulkan: " + device;
        } else if (o.backend == Backend::Vulkan) {
            std::fprintf(stderr, "psub: error: --backend vulkan: %s\n", why.c_str());
            return 1;
        } else {
            std::fprintf(stderr, "psub: Vulkan unavailable (%s); evaluating on the CPU\n", why.c_str());
        }
    }
    if (positions.empty()) {
        CpuEvaluator<double> evaluator(refinement.perLevel, refinement.factorized, refinement.surface,
                                       TableForm::PerLevel);
        positions.resize(3 * std::size_t(evaluator.refinedCount()));
        evaluator.evaluate(loaded.mesh.positions, positions);
    }
    const Faces finest = finestFaces(refinement.surface);
    const std::string what = "P-S, " + std::to_string(o.levels) + (o.levels == 1 ? " step, " : " steps, ") +
                             preprocessName(preprocess) + (o.rules != Rules::Paper ? std::string(", ") + rulesName(o.rules) + " rules" : "") +
                             (o.boundary == Boundary::Smooth ? ", smooth boundary" : "");
    requireFinite(positions, o.input, "refined");
    if (refinement.uv.empty()) {
        writeOutput(o.output, formatObj(finest, positions, header(o.input, what)));
    } else {
        const FaceVaryingTable& uv = refinement.uv;
        std::vector<double> values(std::size_t(uv.width) * uv.valueCount());
        evaluateFaceVarying<double>(uv, loaded.mesh.uv.values, values);
        const std::string uvWhat = what + ", texture coordinates: " + uvLinearName(o.uvLinear) +
                                   " (docs/face-varying.md: faces straddling a seam are split in two)";
        writeOutput(o.output, formatObjWithUv(positions, values, uv.width, uv.faceOffsets, uv.faceVerts,
                                              uv.faceValues, header(o.input, uvWhat)));
    }
    std::fprintf(summaryStream(o.output), "%s: %u vertices, %u faces (%s%s) in %.1f ms\n", o.output.c_str(),
                finest.vertexCount, refinement.uv.empty() ? finest.faceCount() : Index(refinement.uv.faceOffsets.size() - 1),
                what.c_str(), backendNote.c_str(), msSince(start));
    return 0;
}

int subdivideCC(const SubdivideOptions& o, const Loaded& loaded) {
    if (loaded.ccProblem) throw InputError(*loaded.ccProblem);
    // Catmull-Clark quadruples the faces: estimate it as two P-S-sized steps per level.
    guardMemory(loaded.mesh, countMesh(loaded.mesh.faces, loaded.checked.connectivity), o.levels, 2, 0,
                o.maxMemory);
    const auto start = Clock::now();
    const std::vector<CatmarkLevel> levels =
        refineCatmark(loaded.mesh.faces, loaded.mesh.positions, o.levels);
    const CatmarkLevel& finest = levels.back();
    const std::string what = "Catmull-Clark (OpenSubdiv), " + std::to_string(o.levels) + " levels";
    requireFinite(finest.positions, o.input, "refined");
    writeOutput(o.output, formatObj(finest.faces, finest.positions, header(o.input, what)));
    std::fprintf(summaryStream(o.output), "%s: %u vertices, %u faces (%s) in %.1f ms\n", o.output.c_str(),
                finest.faces.vertexCount, finest.faces.faceCount(), what.c_str(), msSince(start));
    return 0;
}

// One row of the stats table.
void printRow(const char* label, const Counts& c, const VertexClasses& classes, double ms,
              const char* note = "") {
    std::printf("%-16s %10llu %10llu %10llu %10llu %10llu %8llu %8llu %10.2f  %s\n", label,
                (unsigned long long)c.vertices, (unsigned long long)c.edges,
                (unsigned long long)c.faces, (unsigned long long)c.triangles,
                (unsigned long long)c.quads, (unsigned long long)classes.extraordinary,
                (unsigned long long)c.boundaryEdges, ms, note);
}

void printTableHeader(const char* title, const char* timeLabel) {
    std::printf("%-16s %10s %10s %10s %10s %10s %8s %8s %10s\n", title, "V", "E", "F",
                "triangles", "quads", "extraord", "bnd edge", timeLabel);
}

// Prints P-S levels then Catmull-Clark levels with the face counts P-S reaches.
void printStats(const Loaded& loaded, const Hierarchy& hierarchy, const std::vector<double>& levelMs,
                std::uint64_t maxFaces) {
    printTableHeader("P-S", "ms");
    for (std::size_t k = 0; k < hierarchy.levels.size(); ++k) {
        const Level& level = hierarchy.levels[k];
        std::string label = k == 0 ? "input"
                            : hierarchy.preprocessed && k == 1
                                ? "preprocessed"
                                : "level " + std::to_string(k - (hierarchy.preprocessed ? 1 : 0));
        printRow(label.c_str(), countMesh(level.faces, level.connectivity),
                 classifyVertices(level.connectivity), levelMs[k]);
    }
    if (loaded.ccProblem) return printCatmarkUnavailable(loaded);
    int ccLevels = 0;
    std::uint64_t faces = 0;  // Catmull-Clark level 1 has one quad per face corner
    for (Index f = 0; f < loaded.mesh.faces.faceCount(); ++f) faces += loaded.mesh.faces.faceSize(f);
    while (ccLevels < 8 && faces <= maxFaces) ++ccLevels, faces *= 4;
    std::printf("\n");
    printTableHeader("Catmull-Clark", "cum. ms");
    for (int k = 0; k <= ccLevels; ++k) {
        const auto start = Clock::now();
        const std::vector<CatmarkLevel> cc = refineCatmark(loaded.mesh.faces, {}, k, false);
        const double ms = msSince(start);
        const CatmarkLevel& level = cc.back();
        std::string note;
        for (std::size_t j = 1; j < hierarchy.levels.size(); ++j)
            if (k > 0 && hierarchy.levels[j].faces.faceCount() == level.counts.faces)
                note = "same F as P-S " + std::string(hierarchy.preprocessed && j == 1
                                                          ? "preprocessed"
                                                          : "level " + std::to_string(j - (hierarchy.preprocessed ? 1 : 0)));
        const Connectivity connectivity = buildConnectivity(level.faces);
        printRow(("level " + std::to_string(k)).c_str(), level.counts, classifyVertices(connectivity),
                 ms, note.c_str());
    }
}

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

// The engine's real path: tables built once, then frames of animated control points.
// The demo's Vulkan line: the per-level tables on the Vulkan device, the same frames as the
// CPU lines, and the largest difference to the CPU evaluator's result; or why it is not there.
void printVulkanFrames(const Refinement& r, const Loaded& loaded) {
#if PSUB_HAVE_VULKAN
    try {
        VulkanContext context;
        VulkanEvaluator gpu(context, r.perLevel, r.factorized, r.surface, TableForm::PerLevel, 3);
        std::vector<float> control(loaded.mesh.positions.size()), out(3 * std::size_t(gpu.refinedCount())),
            cpuOut(out.size());
        std::vector<double> frameMs, gpuMs;
        for (int frame = 0; frame < 25; ++frame) {
            writeWaveFrame(loaded.mesh.positions, frame, control);
            const auto start = Clock::now();
            gpu.evaluate(control, out);
            frameMs.push_back(msSince(start));
            gpuMs.push_back(gpu.lastFrameTimes().totalMs);
        }
        std::sort(frameMs.begin(), frameMs.end());
        std::sort(gpuMs.begin(), gpuMs.end());
        CpuEvaluator<float> cpu(r.perLevel, r.factorized, r.surface, TableForm::PerLevel);
        cpu.evaluate(control, cpuOut);
        double worst = 0;
        for (std::size_t i = 0; i < out.size(); ++i) worst = std::max(worst, std::abs(double(out[i]) - cpuOut[i]));
        std::printf("  %-10s  median %7.3f ms  min %7.3f ms  (GPU %.3f ms; %s)  max |vulkan - cpu| = %.2g\n",
                    "vulkan", frameMs[frameMs.size() / 2], frameMs.front(), gpuMs[gpuMs.size() / 2],
                    context.deviceName().c_str(), worst);
    } catch (const VulkanError& e) {
        std::printf("  %-10s  unavailable: %s\n", "vulkan", e.what());
    }
#else
    (void)r, (void)loaded;
    std::printf("  %-10s  unavailable: psub was built without Vulkan\n", "vulkan");
#endif
}

void printTablesAndFrames(const Loaded& loaded, int levels, const std::vector<double>& rulePositions) {
    const Refinement r = refine(loaded.mesh, loaded.checked.connectivity, {levels, Preprocess::Auto, true, {}});
    const double refined = r.perLevel.refinedCount();
    std::printf("\nStencil tables (built once; topology %.1f ms):\n", r.topologyMs);
    std::printf("  per-level   %10llu rows %11llu indices %9.1f MiB %6.1f B/vertex  built in %.1f ms\n",
                (unsigned long long)r.perLevel.destinations.size(), (unsigned long long)r.perLevel.indices.size(),
                double(r.perLevel.bytes()) / 1048576, double(r.perLevel.bytes()) / refined, r.perLevelMs);
    std::printf("  factorized  %10u rows %11llu entries %9.1f MiB %6.1f B/vertex  built in %.1f ms\n",
                r.factorized.rowCount(), (unsigned long long)r.factorized.indices.size(),
                double(r.factorized.bytes()) / 1048576, double(r.factorized.bytes()) / refined, r.factorizedMs);

    std::printf("\nPer frame (a wave animates the %u control points; float xyz, all cores):\n",
                r.perLevel.controlCount);
    std::vector<float> control(loaded.mesh.positions.size()), out(3 * std::size_t(r.perLevel.refinedCount()));
    for (TableForm form : {TableForm::PerLevel, TableForm::Factorized}) {
        CpuEvaluator<float> evaluator(r.perLevel, r.factorized, r.surface, form);
        std::vector<double> frameMs;
        for (int frame = 0; frame < 25; ++frame) {
            writeWaveFrame(loaded.mesh.positions, frame, control);
            const auto start = Clock::now();
            evaluator.evaluate(control, out);
            frameMs.push_back(msSince(start));
        }
        std::sort(frameMs.begin(), frameMs.end());
        // The rest pose once more, against the readable rule path.
        std::copy(loaded.mesh.positions.begin(), loaded.mesh.positions.end(), control.begin());
        evaluator.evaluate(control, out);
        double worst = 0;
        for (std::size_t i = 0; i < out.size(); ++i) worst = std::max(worst, std::abs(double(out[i]) - rulePositions[i]));
        std::printf("  %-10s  median %7.3f ms  min %7.3f ms  (%d threads)  max |table - rules| = %.2g\n",
                    form == TableForm::PerLevel ? "per-level" : "factorized", frameMs[frameMs.size() / 2],
                    frameMs.front(), evaluator.threads(), worst);
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

Mesh loadChecked(const std::string& path, CheckedMesh& checked) {
    std::vector<std::string> warnings;
    Mesh mesh = readObj(path, &warnings);
    checked = checkMesh(mesh);
    warnings.insert(warnings.end(), checked.warnings.begin(), checked.warnings.end());
    std::fflush(stdout);
    for (const std::string& warning : warnings) std::fprintf(stderr, "psub: warning: %s\n", warning.c_str());
    return mesh;
}

std::string dataDir() {
    if (const char* env = std::getenv("PSUB_DATA_DIR")) return env;
    namespace fs = std::filesystem;
    if (fs::exists(fs::path(PSUB_SOURCE_DATA_DIR) / "cow.obj")) return PSUB_SOURCE_DATA_DIR;
    std::error_code error;
    const fs::path exe = fs::read_symlink("/proc/self/exe", error);
    return (exe.parent_path().parent_path() / "share" / "psub").string();
}

int runSubdivide(const SubdivideOptions& options) {
    const Loaded loaded = load(options.input);
    const bool onVulkan = options.scheme == Scheme::PS && options.backend != Backend::Cpu;
    checkCoordinateRange(loaded.mesh, onVulkan ? Precision::Float : Precision::Double);
    return options.scheme == Scheme::PS ? subdividePS(options, loaded) : subdivideCC(options, loaded);
}

int runStats(const StatsOptions& options) {
    const auto loadStart = Clock::now();
    const Loaded loaded = load(options.input);
    checkCoordinateRange(loaded.mesh, Precision::Double);
    const double loadMs = msSince(loadStart);
    const Faces& faces = loaded.mesh.faces;
    const bool preprocess = needsPreprocessing(faces, loaded.checked.connectivity,
                                               options.preprocess, loaded.mesh.source);
    guardMemory(loaded.mesh, countMesh(faces, loaded.checked.connectivity), options.levels, 1,
                preprocess ? 1 : 0, options.maxMemory);
    std::vector<double> levelMs{loadMs};
    const Hierarchy hierarchy = refineTopology(faces, loaded.checked.connectivity, preprocess,
                                               options.levels,
                                               [&](int, double seconds) { levelMs.push_back(seconds * 1e3); });
    std::printf("%s: %u vertices, %u faces; %s, %d P-S steps (input ms: read and check; "
                "level ms: topology)\n\n",
                options.input.c_str(), faces.vertexCount, faces.faceCount(),
                preprocessName(preprocess), options.levels);
    printStats(loaded, hierarchy, levelMs, hierarchy.finest().faces.faceCount());
    return 0;
}

int runDemo(const DemoOptions& options) {
    const std::string model = options.model.empty() ? dataDir() + "/cow.obj" : options.model;
    std::printf("PSub demo: the P-S subdivision scheme (Liu, Yang, Guan) on %s\n\n", model.c_str());
    const auto start = Clock::now();
    const Loaded loaded = load(model);
    checkCoordinateRange(loaded.mesh, Precision::Float);  // it also times the float evaluators
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
