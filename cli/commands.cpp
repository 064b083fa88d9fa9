// The psub commands subdivide and stats, and what they share with demo (demo.cpp): loading
// and the stats table. The memory guard is in memory_guard.cpp; the engine itself is in
// topology/ and stencils/.
#include "commands.h"
#include "evaluators.h"

#include "memory_guard.h"

#include "psub/animation.h"
#include "psub/catmark.h"
#include "psub/evaluator.h"
#include "psub/output.h"
#include "psub/rules.h"
#include "psub/stencils.h"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <optional>

#include <unistd.h>

namespace psub::cli {

double msSince(Clock::time_point start) {
    return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

TiledTable tiledWithoutTiles(const Mesh& mesh, const Connectivity& connectivity, int levels, Rules rules,
                             Boundary boundary) {
    RefineOptions options;
    options.levels = levels, options.rules = rules, options.boundary = boundary;
    options.tiled = true, options.perLevel = false, options.tileSides = TileSides::None;
    return refine(mesh, connectivity, options).tiled;
}

// ".glb" of "Out.GLB".
std::string lowerExtension(const std::string& path) {
    std::string extension = std::filesystem::path(path).extension().string();
    std::transform(extension.begin(), extension.end(), extension.begin(),
                   [](unsigned char c) { return char(std::tolower(c)); });
    return extension;
}

void printWarnings(const std::vector<std::string>& warnings) {
    std::fflush(stdout);
    for (const std::string& warning : warnings) std::fprintf(stderr, "psub: warning: %s\n", warning.c_str());
}

// A glTF cage posed in world space: its static pose, or clip `animation` (default the first)
// at `at` seconds, clamped to the clip.
Mesh loadGltfPosed(const std::string& path, std::optional<double> at, const std::string& animation,
                   CheckedMesh& checked, std::optional<GltfMaterial>& material) {
    const GltfAsset asset = readGltf(path);
    GltfPlayer player(asset);
    std::vector<float> posed(3 * player.vertexCount());
    if (at) {
        std::optional<std::size_t> clip = animation.empty() && !asset.clips.empty() ? std::optional<std::size_t>(0)
                                                                                   : findClip(asset, animation);
        if (!clip) {
            std::string names;
            for (const GltfClip& c : asset.clips) names += (names.empty() ? "'" : ", '") + c.name + "'";
            throw InputError(path + ": --at: no clip" + (animation.empty() ? "" : " '" + animation + "'") +
                             " (clips: " + (names.empty() ? "none" : names) + ")");
        }
        player.pose(*clip, *at, posed, false);
    } else {
        player.staticPose(posed);
    }
    Mesh mesh = asset.mesh;
    mesh.positions.assign(posed.begin(), posed.end());
    requireFinite(mesh.positions, path, "posed");
    checked = checkMesh(mesh);
    std::vector<std::string> warnings = asset.warnings;
    warnings.insert(warnings.end(), checked.warnings.begin(), checked.warnings.end());
    printWarnings(warnings);
    material = asset.material;
    return mesh;
}

Loaded load(const std::string& path, std::optional<double> at, const std::string& animation) {
    Loaded loaded;
    loaded.mesh = isGltfPath(path) ? loadGltfPosed(path, at, animation, loaded.checked, loaded.material)
                                   : loadChecked(path, loaded.checked);
    loaded.ccProblem = catmarkProblem(loaded.mesh);
    return loaded;
}

std::string header(const std::string& input, const std::string& what) {
    return "written by psub: " + what + "\nfrom " + input;
}

namespace {

void printCatmarkUnavailable(const Loaded& loaded) {
    std::printf("\nCatmull-Clark: unavailable for this mesh (%s)\n", loaded.ccProblem->c_str());
}

const char* preprocessName(bool preprocessed) { return preprocessed ? "after preprocessing" : "no preprocessing"; }

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

// Refined positions from the Vulkan backend (makeEvaluator: float, per-level tables, on a context
// of its own), and the device's name; nothing, with `why`, when no Vulkan device can be used (or
// psub was built without). The CPU path stays CpuEvaluator<double>: the written mesh in double.
std::optional<std::vector<double>> evaluateOnVulkan(const Refinement& r, const std::vector<double>& control,
                                                    std::string& device, std::string& why) {
    try {
        const std::unique_ptr<Evaluator> evaluator =
            makeEvaluator(Backend::Vulkan, tablesOf(r), TableForm::PerLevel, nullptr);
        const std::vector<float> in(control.begin(), control.end());
        std::vector<float> out(3 * std::size_t(evaluator->refinedCount()));
        evaluator->evaluate(in, out);
        device = evaluator->device();
        return std::vector<double>(out.begin(), out.end());
    } catch (const std::runtime_error& e) {  // VulkanError, or built without Vulkan
        why = e.what();
    }
    return std::nullopt;
}

// The refined surface, for writeSurface: faces, positions, optional normals and UVs.
struct Surface {
    const Faces& faces;
    const std::vector<double>& positions;
    std::vector<double> normals;       // empty: not written
    const FaceVaryingTable* uv = nullptr;  // with uvValues, when the input has UVs
    std::vector<double> uvValues;
    std::string what;  // how it was refined, for the OBJ header and the glTF generator field
};

// Writes the refined surface as glTF (by the output's extension) or as OBJ.
void writeSurface(const SubdivideOptions& o, const Surface& s, const Loaded& loaded) {
    const std::string& what = s.what;
    if (!isGltfPath(o.output) && !s.uv)
        return writeOutput(o.output, formatObj(s.faces, s.positions, header(o.input, what)));
    if (!isGltfPath(o.output) && isGltfPath(o.input) && s.uv->width == 2) {  // glTF's v down as OBJ's v up
        std::vector<double> objUv = s.uvValues;
        for (std::size_t i = 1; i < objUv.size(); i += 2) objUv[i] = 1.0 - objUv[i];
        return writeOutput(o.output, formatObjWithUv(s.positions, objUv, s.uv->width, s.uv->faceOffsets,
                                                     s.uv->faceVerts, s.uv->faceValues, header(o.input, what)));
    }
    if (!isGltfPath(o.output))
        return writeOutput(o.output, formatObjWithUv(s.positions, s.uvValues, s.uv->width, s.uv->faceOffsets,
                                                     s.uv->faceVerts, s.uv->faceValues, header(o.input, what)));
    GltfSurface surface{s.positions, s.normals, s.faces.offsets, s.faces.verts, {}, {}};
    std::vector<double> gltfUv;  // an OBJ's vt (v up) as glTF's TEXCOORD_0 (v down): v -> 1 - v
    if (s.uv) {
        surface.faceOffsets = s.uv->faceOffsets;
        surface.faceVerts = s.uv->faceVerts;
        surface.faceValues = s.uv->faceValues;
        surface.uvValues = s.uvValues;
        if (!isGltfPath(o.input) && s.uv->width == 2) {
            gltfUv = s.uvValues;
            for (std::size_t i = 1; i < gltfUv.size(); i += 2) gltfUv[i] = 1.0 - gltfUv[i];
            surface.uvValues = gltfUv;
        }
    }
    const bool binary = lowerExtension(o.output) == ".glb";
    if (loaded.material && loaded.material->baseColorTexture && !s.uv)
        printWarnings({o.output + ": the base colour texture is left out: the surface has no refined UVs"});
    writeOutput(o.output, formatGltf(surface, loaded.material ? &*loaded.material : nullptr, binary,
                                     "psub: " + what));
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
    Surface surface{finest, positions, {}, nullptr, {}, what};
    if (!refinement.uv.empty()) {
        surface.uv = &refinement.uv;
        surface.uvValues.resize(std::size_t(refinement.uv.width) * refinement.uv.valueCount());
        evaluateFaceVarying<double>(refinement.uv, loaded.mesh.uv.values, surface.uvValues);
        surface.what += ", texture coordinates: " + std::string(uvLinearName(o.uvLinear)) +
                        " (docs/face-varying.md: faces straddling a seam are split in two)";
    }
    if (isGltfPath(o.output)) {
        CpuEvaluator<double> evaluator(refinement.perLevel, refinement.factorized, refinement.surface,
                                       TableForm::PerLevel);
        surface.normals.resize(positions.size());
        evaluator.normals(positions, surface.normals);
    }
    writeSurface(o, surface, loaded);
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
    Surface surface{finest.faces, finest.positions, {}, nullptr, {}, what};
    // Level 0 is the input itself: its UVs go out corner for corner (a lossless level-0 path).
    FaceVaryingTable inputUv;
    const Mesh& mesh = loaded.mesh;
    if (o.levels == 0 && !mesh.uv.empty() && finest.faces.offsets == mesh.faces.offsets &&
        finest.faces.verts == mesh.faces.verts) {
        inputUv.width = mesh.uv.width;
        inputUv.faceOffsets = mesh.faces.offsets;
        inputUv.faceVerts = mesh.faces.verts;
        inputUv.faceValues = mesh.uv.corners;
        surface.uv = &inputUv;
        surface.uvValues = mesh.uv.values;
        surface.what += ", texture coordinates as given";
    }
    writeSurface(o, surface, loaded);
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

}  // namespace

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

Mesh loadChecked(const std::string& path, CheckedMesh& checked) {
    std::vector<std::string> warnings;
    Mesh mesh = readObj(path, &warnings);
    checked = checkMesh(mesh);
    warnings.insert(warnings.end(), checked.warnings.begin(), checked.warnings.end());
    printWarnings(warnings);
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

bool isGltfPath(const std::string& path) {
    const std::string extension = lowerExtension(path);
    return extension == ".gltf" || extension == ".glb";
}

int runSubdivide(const SubdivideOptions& options) {
    const Loaded loaded = load(options.input, options.at, options.animation);
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

}  // namespace psub::cli
