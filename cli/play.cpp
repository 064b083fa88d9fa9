// psub play: the real-time playback loop. Loads the control mesh and its animation, refines
// once, creates every evaluator, renderer and buffer up front, then per frame: deform, upload,
// evaluate, normals, (render, readback); each stage timed, median / p95 / max reported.
// The frame loop allocates nothing and creates no Vulkan object.
#include "play.h"
#include "json.h"

#include "options.h"

#include "psub/animation.h"
#include "evaluators.h"
#include "psub/evaluator.h"
#include "psub/output.h"
#include "psub/rules.h"
#include "psub/stencils.h"
#if PSUB_HAVE_VULKAN
#include "psub/vulkan_evaluator.h"
#endif
#if PSUB_HAVE_RENDER
#include "render.h"

#include "psub/render.h"
#endif

#include <CLI/CLI.hpp>
#include <omp.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>

namespace psub::cli {
namespace {

using Clock = std::chrono::steady_clock;

double msBetween(Clock::time_point a, Clock::time_point b) {
    return std::chrono::duration<double, std::milli>(b - a).count();
}

// Beyond this many refined faces playback is refused (memory; nobody plays it in real time).
constexpr std::uint64_t kMaxFaces = 64ull << 20;

// --form: the evaluator's table form (PlayOptions::form).
constexpr int kFormAuto = 0, kFormPerLevel = 1, kFormFactorized = 2, kFormTiled = 3;

bool isGltf(const std::string& path) {
    const std::string extension = std::filesystem::path(path).extension().string();
    return extension == ".gltf" || extension == ".glb" || extension == ".GLTF" || extension == ".GLB";
}

void printWarnings(const std::vector<std::string>& warnings) {
    for (const std::string& warning : warnings) std::fprintf(stderr, "psub: warning: %s\n", warning.c_str());
}

std::string clipList(const GltfAsset& asset) {
    std::string names;
    for (const GltfClip& clip : asset.clips) names += (names.empty() ? "'" : ", '") + clip.name + "'";
    return names.empty() ? "none" : names;
}

}  // namespace

Animated loadAnimated(const PlayOptions& o) {
    Animated a;
    std::vector<std::string> warnings;
    if (isGltf(o.input)) {
        a.asset = std::make_unique<GltfAsset>(readGltf(o.input));
        a.mesh = a.asset->mesh;
        warnings = a.asset->warnings;
        a.player = std::make_unique<GltfPlayer>(*a.asset);
        a.rest.resize(3 * a.player->vertexCount());
        a.player->staticPose(a.rest);
        // Default: the file's first clip, or the wave when it has none.
        const std::string wanted = !o.animation.empty() ? o.animation
                                   : a.asset->clips.empty() ? std::string("wave") : a.asset->clips[0].name;
        if (auto clip = findClip(*a.asset, wanted)) {
            a.clip = *clip;
            a.period = std::max(a.asset->clips[*clip].duration, 1e-3);
            a.name = "glTF clip '" + wanted + "'";
        } else if (auto procedural = parseProcedural(wanted)) {
            a.procedural = procedural;
        } else {
            throw InputError(o.input + ": no animation '" + wanted + "' (clips: " + clipList(*a.asset) +
                             "; procedural: wave, twist, bend)");
        }
    } else {
        a.mesh = readObj(o.input, &warnings);
        a.rest.assign(a.mesh.positions.begin(), a.mesh.positions.end());
        const std::string wanted = o.animation.empty() ? "wave" : o.animation;
        a.procedural = parseProcedural(wanted);
        if (!a.procedural)
            throw InputError(o.input + ": no animation '" + wanted +
                             "': an OBJ file plays wave, twist or bend (glTF files also play their clips)");
    }
    if (a.procedural) a.name = std::string(proceduralName(*a.procedural)) + " (procedural)";
    a.checked = checkMesh(a.mesh);
    checkCoordinateRange(a.mesh, Precision::Float);
    warnings.insert(warnings.end(), a.checked.warnings.begin(), a.checked.warnings.end());
    printWarnings(warnings);
    a.bounds = restBounds(a.rest);
    return a;
}

namespace {

// ---------------------------------------------------------------------------------------
// Per-stage timing

enum Stage { Deform, Upload, Evaluate, Normals, Render, Readback, kStageCount };
constexpr std::array<const char*, kStageCount> kStageNames = {"deform", "upload", "evaluate",
                                                              "normals", "render", "readback"};

struct Summary {
    double median = 0, p95 = 0, max = 0;
};

Summary summarize(std::vector<double> values) {
    if (values.empty()) return {};
    std::sort(values.begin(), values.end());
    const auto at = [&](double q) { return values[std::min(values.size() - 1, std::size_t(q * double(values.size() - 1) + 0.5))]; };
    return {at(0.5), at(0.95), values.back()};
}

struct Timings {
    std::array<std::vector<double>, kStageCount> stages;
    std::vector<double> frames;
    double writeMs = 0;  // PNG files, outside the frame time

    explicit Timings(int count) {
        for (auto& stage : stages) stage.reserve(std::size_t(count));
        frames.reserve(std::size_t(count));
    }
};

// ---------------------------------------------------------------------------------------
// Verification against the rule oracle

struct Verifier {
    Hierarchy hierarchy;
    Rules rules;
    std::vector<double> control;  // scratch, sized once
    int frames = 0;
    double maxError = 0;  // relative to the box diagonal of the frame's control points

    // Throws InputError naming the frame and vertex when `refined` is not the oracle's result.
    void check(int frame, std::span<const float> pose, std::span<const float> refined) {
        control.assign(pose.begin(), pose.end());
        const std::vector<double> expected = refinePositions(hierarchy, control, rules);
        double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
        for (std::size_t i = 0; i < control.size(); ++i) {
            lo[i % 3] = std::min(lo[i % 3], control[i]);
            hi[i % 3] = std::max(hi[i % 3], control[i]);
        }
        const double scale = std::max(1e-30, std::hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]));
        for (std::size_t i = 0; i < expected.size(); ++i) {
            const double error = std::abs(double(refined[i]) - expected[i]) / scale;
            maxError = std::max(maxError, error);
            if (!(error <= 1e-5))
                throw InputError("--verify: frame " + std::to_string(frame) + ", refined vertex " + std::to_string(i / 3 + 1) +
                                 ": " + std::to_string(refined[i]) + " where refining from scratch gives " +
                                 std::to_string(expected[i]) + " (relative error " + std::to_string(error) + " > 1e-5)");
        }
        ++frames;
    }
};

// ---------------------------------------------------------------------------------------
// The loop

struct Playback {
    Playback(const PlayOptions& options, Animated& a) : o(options), animated(a) {}

    const PlayOptions& o;
    Animated& animated;
    Refinement refinement;
    std::vector<float> control, refined, normals;
#if PSUB_HAVE_VULKAN
    std::unique_ptr<VulkanContext> context;
#endif
    std::unique_ptr<Evaluator> evaluator;  // the backend, chosen once (makeEvaluator)
    bool readBack = false;                 // results copied to `refined` and `normals` every frame
    bool drawsKept = false;                // the renderer draws the evaluator's device buffers
#if PSUB_HAVE_RENDER
    std::unique_ptr<Renderer> renderer;
    Camera camera;
    Image image;
    Image textureImage;  // --texture or the glTF material's, read before anything is refined or written
    std::array<float, 4> textureFactor{1.0f, 1.0f, 1.0f, 1.0f};
#endif
    bool textured = false;  // frames are drawn with textureImage
    std::optional<Verifier> verifier;
    std::vector<std::uint32_t> faceless;  // the vertices on no face (checkFrame), listed at set-up
    std::string device;
    TableForm form = TableForm::PerLevel;  // the evaluator's; Tiled writes drawing order
    std::string formReason;                // why auto chose it, for the summary
    std::vector<float> canonical;          // the tiled form's output in canonical order (--verify)
    int hostThreads = omp_get_max_threads();  // OpenMP threads of the CPU-side stages

    bool rendering() const { return !o.renderDir.empty(); }

    // One frame: its stage times go to `t`; with `record` false (the warm-up) nothing is
    // recorded, written or verified.
    void frame(int index, Timings& t, bool record = true);
    void draw(int index, Timings& t);
    void checkFrame(int index) const;
};

// The numeric-range policy per frame (outside the timed part): the posed control points within
// the float limit, and the refined positions and normals (when on the host) finite.
void Playback::checkFrame(int index) const {
    const double limit = coordinateLimit(Precision::Float);
    const std::string frame = o.input + ": frame " + std::to_string(index);
    for (std::size_t i = 0; i < control.size(); ++i)
        if (!(std::abs(control[i]) <= limit)) {
            char value[32];
            std::snprintf(value, sizeof value, "%g", double(control[i]));
            throw InputError(frame + ": posed control vertex " + std::to_string(i / 3 + 1) + " coordinate " +
                             "xyz"[i % 3] + " = " + value + " is outside the float range psub play accepts (+-1e8)");
        }
    if (!readBack) return;
    // A vertex on a face whose position is not finite has a normal that is not finite either
    // (a face's normal takes each corner in a diagonal's difference, the vertex's sums its
    // faces'), so the normals are checked whole and, of the positions, those of the vertices on no
    // face (their normal 0 whatever their position): half the bytes a frame (Spot at 12 steps:
    // the check was a sixth of the loop's time). The positions are scanned whole only when
    // something is not finite, to name the first bad one as before.
    bool finite = allFinite(normals);
    for (std::size_t i = 0; finite && i < faceless.size(); ++i)
        finite = allFinite(std::span<const float>(refined).subspan(3 * std::size_t(faceless[i]), 3));
    if (finite) return;
    requireFinite(refined, frame, "refined");
    requireFinite(normals, frame, "refined normal of");
}

void Playback::frame(int index, Timings& t, bool record) {
    const Clock::time_point start = Clock::now();
    animated.pose(double(index) / o.animationFps, control);
    const Clock::time_point posed = Clock::now();
    double stage[kStageCount] = {msBetween(start, posed), 0, 0, 0, 0, 0};
    if (readBack) evaluator->evaluate(control, refined, normals);
    else evaluator->evaluateKept(control, true);
    const StageTimes times = evaluator->lastTimes();
    stage[Upload] = times.uploadMs;
    stage[Evaluate] = times.evaluateMs;
    stage[Normals] = times.normalsMs;
    stage[Readback] = times.readbackMs;
#if PSUB_HAVE_RENDER
    if (rendering()) {
        if (o.wireframe == int(Wireframe::Control)) renderer->setControlPositions(control);
        if (drawsKept) renderer->drawKept(camera, image);
        else renderer->draw(refined, normals, camera, image);
        const DrawTimes d = renderer->lastTimes();
        stage[Upload] += d.uploadMs;
        stage[Render] = d.renderMs;
        stage[Readback] += d.readbackMs;
    }
#endif
    const Clock::time_point end = Clock::now();
    if (!record) return;
    checkFrame(index);
    for (int s = 0; s < kStageCount; ++s) t.stages[std::size_t(s)].push_back(stage[s]);
    t.frames.push_back(msBetween(start, end));
    if (rendering()) draw(index, t);
    if (verifier) {
        if (form != TableForm::Tiled) return verifier->check(index, control, refined);
        toCanonical<float>(refinement.tiled, refined, canonical, 3);
        verifier->check(index, control, canonical);
    }
}

// Writes the frame's picture (outside the timed frame).
void Playback::draw(int index, Timings& t) {
#if PSUB_HAVE_RENDER
    const Clock::time_point start = Clock::now();
    char name[32];
    std::snprintf(name, sizeof name, "frame_%04d.png", index);
    writePng((std::filesystem::path(o.renderDir) / name).string(), image);
    t.writeMs += msBetween(start, Clock::now());
#else
    (void)index, (void)t;
#endif
}

// Refined vertices, from whichever table was built (the forced tiled form has no per-level one).
std::uint32_t refinedCount(const Refinement& r) {
    return r.perLevel.levels.empty() && r.tiled.refinedCount > 0 ? r.tiled.refinedCount : r.perLevel.refinedCount();
}

void refineAnimated(Playback& p) {
    const PlayOptions& o = p.o;
    const Mesh& mesh = p.animated.mesh;
    const Connectivity& connectivity = p.animated.checked.connectivity;
    const bool preprocess = needsPreprocessing(mesh.faces, connectivity, Preprocess::Auto, mesh.source);
    const Counts finest = countsAfterSteps(countMesh(mesh.faces, connectivity), o.levels + (preprocess ? 1 : 0),
                                           o.boundary, preprocess);
    if (finest.faces > kMaxFaces)
        throw InputError(o.input + ": --levels " + std::to_string(o.levels) + " would give " +
                         std::to_string(finest.faces) + " refined faces; psub play stops at " + std::to_string(kMaxFaces));
    RefineOptions options;
    options.levels = o.levels, options.rules = o.rules, options.boundary = o.boundary;
    options.factorized = o.form == kFormFactorized;
    options.tiled = o.form == kFormTiled || o.form == kFormAuto;
    // The forced tiled form builds only its own table (lean), and so does auto where it would
    // not time the per-level rows.
    options.perLevel = o.form != kFormTiled && (o.form != kFormAuto || autoTimesPerLevel(o.backend, finest.faces, o.levels));
    // Only --verify reads the tiled form's canonical order: without it, the lean build of a mesh
    // the tiles cover whole makes no level after B (RefineOptions::canonicalOrder).
    options.canonicalOrder = o.verify;
    p.refinement = refine(mesh, connectivity, options);
    if (o.verify) {
        Verifier v{refineTopology(mesh.faces, connectivity, preprocess, o.levels, {}, o.boundary), o.rules, {}, 0, 0};
        v.control.reserve(mesh.positions.size());
        p.verifier = std::move(v);
    }
    p.control.resize(3 * std::size_t(mesh.faces.vertexCount));
    p.refined.resize(3 * std::size_t(refinedCount(p.refinement)));
    p.normals.resize(p.refined.size());
}

// The table form: the forced one, or (auto) fasterForm's (cli/evaluators.h) on the rest pose.
// Textured or not: the tiled form draws the texture with its own faces (TiledTable::uvFace...).
// `context`: the Vulkan context when playing on Vulkan.
void chooseForm(Playback& p, VulkanContext* context) {
    if (p.o.form != kFormAuto) {
        p.form = p.o.form == kFormTiled ? TableForm::Tiled
                 : p.o.form == kFormFactorized ? TableForm::Factorized : TableForm::PerLevel;
        p.formReason = "forced";
        return;
    }
    p.animated.pose(0, p.control);
    const auto withoutTiles = [&p] {
        return tiledWithoutTiles(p.animated.mesh, p.animated.checked.connectivity, p.o.levels, p.o.rules, p.o.boundary);
    };
    FormChoice choice = fasterForm(p.o.backend, p.refinement, context, p.control, p.refined, withoutTiles);
    p.form = choice.form;
    if (choice.tiled) p.evaluator = std::move(choice.tiled), dropPerLevelTables(p.refinement);
    p.formReason = std::move(choice.reason);
}

// Creates the evaluator, and the renderer with its camera; returns 1 (after a message) when
// Vulkan is needed but unusable.
int prepare(Playback& p) {
    const PlayOptions& o = p.o;
    const Refinement& r = p.refinement;
#if PSUB_HAVE_VULKAN
    if (o.backend == Backend::Vulkan || p.rendering()) {
        try {
            p.context = std::make_unique<VulkanContext>();
            VulkanContext* context = o.backend == Backend::Vulkan ? p.context.get() : nullptr;
            // A device on the CPU's cores (lavapipe) evaluates on them: the CPU-side stages then
            // run on one thread, since OpenMP's workers spin for a while after each parallel
            // region (the deformers') on the cores the device's threads need (torus 256 x 256
            // at 4 steps: evaluate 16.5-18 -> 11-12 ms, 34-35 -> 50-52 fps).
            if (context && context->cpuDevice()) {
                p.hostThreads = 1;
                omp_set_num_threads(1);
            }
            chooseForm(p, context);
            if (!p.evaluator && context) p.evaluator = makeEvaluator(o.backend, tablesOf(r), p.form, context);
        } catch (const VulkanError& e) {
            std::fprintf(stderr, "psub: error: play: %s\n", e.what());
            return 1;
        }
    }
#else
    if (o.backend == Backend::Vulkan || p.rendering()) {
        std::fprintf(stderr, "psub: error: play: this psub was built without Vulkan (PSUB_BUILD_VULKAN=OFF)\n");
        return 1;
    }
#endif
#if !PSUB_HAVE_RENDER
    if (p.rendering()) {
        std::fprintf(stderr, "psub: error: play: --render: this psub was built without the renderer\n");
        return 1;
    }
#endif
#if PSUB_HAVE_VULKAN
    if (!p.context)
#endif
        chooseForm(p, nullptr);
    if (p.form == TableForm::Tiled) p.canonical.resize(p.refined.size());
    if (!p.evaluator) p.evaluator = makeEvaluator(o.backend, tablesOf(r), p.form, nullptr);
    p.device = p.evaluator->device();
#if PSUB_HAVE_RENDER
    // A Vulkan evaluator's results are drawn where they are, with no read-back (unless --verify
    // reads them anyway); other backends' are uploaded by the renderer.
    const auto* onDevice = dynamic_cast<const VulkanEvaluator*>(p.evaluator.get());
    p.drawsKept = p.rendering() && onDevice && !p.verifier && !p.textured;
#endif
    p.readBack = p.verifier || (p.rendering() && !p.drawsKept) || p.evaluator->resultsOnHost();
    if (p.readBack) {
        const SurfaceTable& surface = p.evaluator->surface();
        for (std::uint32_t v = 0; v < surface.vertexCount; ++v)
            if (surface.vertexOffsets[v + 1] == surface.vertexOffsets[v]) p.faceless.push_back(v);
    }
#if PSUB_HAVE_RENDER
    if (p.rendering()) {
        RenderOptions ro;
        ro.width = o.width, ro.height = o.height, ro.wireframe = Wireframe(o.wireframe), ro.samples = o.samples;
        if (!p.textured && p.animated.asset)  // a glTF material's base colour factor (materialColour)
            if (const std::optional<Rgba> colour = materialColour(p.animated.asset->material)) ro.surface = *colour;
        const Faces& cage = p.animated.mesh.faces;
        const Polygons control{cage.vertexCount, cage.offsets, cage.verts};
        if (p.textured) {
            // UVs do not move with the animation: refined once, here, per level. Their faces
            // name the positions in the order the evaluator writes them: the channel's own
            // (canonical order) or, for the tiled form, the tiled table's (its drawing order).
            TextureData texture = textureData(std::move(p.textureImage), p.animated.mesh, r.uv,
                                              p.form == TableForm::Tiled ? &r.tiled : nullptr);
            texture.factor = p.textureFactor;
            p.renderer = std::make_unique<Renderer>(*p.context, polygonsOf(p.evaluator->surface()), ro, control,
                                                    texture.surfaceTexture());
        } else {
            // The evaluator's surface() indexes the order it writes (the tiled form's drawing order).
            p.renderer = p.drawsKept ? std::make_unique<Renderer>(*p.context, *onDevice, ro, control)
                                     : std::make_unique<Renderer>(*p.context, polygonsOf(p.evaluator->surface()), ro, control);
        }
        // One camera for the whole clip: the box of the control points over one period.
        Box box;
        for (int k = 0; k < 8; ++k) {
            p.animated.pose(p.animated.period * k / 8, p.control);
            box.extend(p.control);
        }
        p.camera = frameBox(box, float(o.width) / float(o.height));
        p.image = filledImage(o.width, o.height, ro.background);
    }
#endif
    return 0;
}

// ---------------------------------------------------------------------------------------
// Reports

Json stagesJson(const Timings& t) {
    Json stages = Json::object();
    for (int s = 0; s < kStageCount; ++s) {
        const Summary m = summarize(t.stages[std::size_t(s)]);
        stages[kStageNames[std::size_t(s)]] = {{"median_ms", m.median}, {"p95_ms", m.p95}, {"max_ms", m.max}};
    }
    return stages;
}

double framesPerSecond(const Timings& t) {
    double total = 0;
    for (double ms : t.frames) total += ms;
    return total > 0 ? 1000.0 * double(t.frames.size()) / total : 0.0;
}

// The "vulkan_validation_messages" count when a Vulkan context ran with the validation layer.
void addValidation(const Playback& p, Json& json) {
#if PSUB_HAVE_VULKAN
    if (p.context && p.context->validationEnabled()) json["vulkan_validation_messages"] = p.context->validationMessageCount();
#else
    (void)p, (void)json;
#endif
}

// The evaluator's table form as --form spells it.
const char* formName(const Playback& p) {
    return p.form == TableForm::Tiled ? "tiled" : p.form == TableForm::Factorized ? "factorized" : "per-level";
}

// The regions the played form's rows are ordered by (1: as refined; docs/design.md).
std::uint32_t regionCount(const Playback& p) {
    return p.form == TableForm::Tiled ? p.refinement.tiled.rows.regions : p.refinement.perLevel.regions;
}

void report(const Playback& p, const Timings& t) {
    const PlayOptions& o = p.o;
    const SurfaceTable& surface = p.form == TableForm::Tiled ? p.refinement.tiled.surface : p.refinement.surface;
    const std::uint64_t faces = surface.faceOffsets.size() - 1;
    const char* backend = o.backend == Backend::Vulkan ? "vulkan" : "cpu";
    if (o.json) {
        Json json = {{"input", o.input}, {"animation", p.animated.name}, {"levels", o.levels},
                     {"refined_faces", faces}, {"refined_vertices", refinedCount(p.refinement)},
                     {"frames", t.frames.size()}, {"fps", framesPerSecond(t)}, {"backend", backend},
                     {"device", p.device}, {"form", formName(p)}, {"regions", regionCount(p)}, {"host_threads", p.hostThreads},
                     {"render", p.rendering() ? Json{{"width", o.width}, {"height", o.height}} : Json(nullptr)},
                     {"stages", stagesJson(t)}, {"verified_frames", p.verifier ? p.verifier->frames : 0},
                     {"max_relative_error", p.verifier ? p.verifier->maxError : 0.0}};
        addValidation(p, json);
        std::printf("%s\n", jsonText(json).c_str());
        return;
    }
    std::printf("%s: %s, %d P-S step%s: %u control points -> %llu faces, %u vertices; %s on %s\n", o.input.c_str(),
                p.animated.name.c_str(), o.levels, o.levels == 1 ? "" : "s", p.animated.mesh.faces.vertexCount,
                (unsigned long long)faces, refinedCount(p.refinement), backend, p.device.c_str());
    const std::string regions = regionCount(p) > 1 ? " by " + std::to_string(regionCount(p)) + " regions" : "";
    std::printf("Table form: %s%s (%s)\n", formName(p), regions.c_str(), p.formReason.c_str());
    if (o.backend == Backend::Vulkan)
        std::printf("CPU-side stages on %d thread%s%s\n", p.hostThreads, p.hostThreads == 1 ? "" : "s",
                    p.hostThreads == 1 ? " (the device runs on the CPU's cores)" : "");
    const Summary frame = summarize(t.frames);
    std::printf("%zu frames: %.1f frames per second (frame time median %.3f ms, p95 %.3f, max %.3f)%s\n\n", t.frames.size(),
                framesPerSecond(t), frame.median, frame.p95, frame.max,
                p.rendering() ? (", drawn at " + std::to_string(o.width) + "x" + std::to_string(o.height)).c_str() : "");
    std::printf("%-9s %10s %10s %10s\n", "stage", "median ms", "p95 ms", "max ms");
    for (int s = 0; s < kStageCount; ++s) {
        const Summary m = summarize(t.stages[std::size_t(s)]);
        std::printf("%-9s %10.3f %10.3f %10.3f\n", kStageNames[std::size_t(s)], m.median, m.p95, m.max);
    }
    if (o.backend == Backend::Vulkan)
        std::printf("\nVulkan: upload = writing the control points to mapped memory; evaluate = submit to fence minus\n"
                    "the normals pass's GPU time (timestamps); readback = copying results to the host (only with\n"
                    "--render or --verify).\n");
    if (p.rendering())
        std::printf("Frames written to %s (%.1f ms per PNG, outside the frame time).\n", o.renderDir.c_str(),
                    t.writeMs / double(std::max<std::size_t>(1, t.frames.size())));
    if (p.verifier)
        std::printf("Verified: all %d frames equal refining that frame's control points from scratch with the rule\n"
                    "oracle (largest difference %.2g of the control box diagonal; limit 1e-5).\n",
                    p.verifier->frames, p.verifier->maxError);
}

const std::map<std::string, int> kPlayWireframe = {{"none", 0}, {"refined", 1}, {"control", 2}};
const std::map<std::string, int> kPlayForms = {
    {"auto", kFormAuto}, {"per-level", kFormPerLevel}, {"factorized", kFormFactorized}, {"tiled", kFormTiled}};

}  // namespace

CLI::App* addPlayCommand(CLI::App& app, PlayOptions& o) {
    CLI::App* pl = app.add_subcommand("play", "Play an animated control mesh, refined every frame; time each stage");
    pl->add_option("input", o.input, "control mesh: .obj, or .gltf / .glb with skinning, morph targets and clips")
        ->required();
    addInteger(pl, "-l,--levels", o.levels, 0, 30, "P-S steps", 3);
    addInteger(pl, "-f,--frames", o.frames, 1, 1000000, "frames to play", 120);
    pl->add_option("--anim", o.animation,
                   "wave, twist or bend (procedural), or the name of a glTF clip (default: a glTF file's first "
                   "clip, else wave)");
    addReal(pl, "--anim-fps", o.animationFps, 1, 10000, "animation time per frame is 1/this seconds", 30);
    addChoice(pl, "--backend", o.backend, kCpuOrVulkan,
              "where the stencils and normals run: cpu (threads) or vulkan (compute shaders)", "cpu");
    addChoice(pl, "--form", o.form, kPlayForms,
              "table form: auto (the fastest of a quick timing at load, positions and normals, on the chosen "
              "backend: the per-level rows, the tiled form, and on several CPU threads both with their rows "
              "ordered by region; on Vulkan and several CPU threads, where tiles write under 90% of the points, "
              "the tiled form without tiles; on the CPU from 262144 refined faces the tiled form alone, built "
              "and timed without the per-level table), per-level, factorized or tiled",
              "auto");
    addChoice(pl, "--rules", o.rules, kRulesNames, "P-S rules: paper, robust or shape (both beyond the paper)", "paper");
    addChoice(pl, "--boundary", o.boundary, kBoundaryNames, "paper, or smooth (beyond the paper)", "paper");
    pl->add_option("--render", o.renderDir, "also draw every frame offscreen (Vulkan) into DIR/frame_NNNN.png");
    addSize(pl, "--size", o.width, o.height, "picture size for --render", 1, "1280x720");
    addChoice(pl, "--wireframe", o.wireframe, kPlayWireframe, "with --render: none, refined or control", "none");
    addSamples(pl, o.samples);
    pl->add_option("--texture", o.texture,
                   "with --render: base-colour image (.png or .jpg) sampled with the mesh's refined UVs "
                   "(default: a glTF material's base colour texture, when there is one)");
    pl->add_flag("--verify", o.verify,
                 "check every frame against refining its control points from scratch with the rule oracle "
                 "(slow; outside the timings)");
    pl->add_flag("--json", o.json,
                 "one JSON object: refined_faces, frames, fps, backend, stages.{deform,upload,evaluate,normals,"
                 "render,readback}.{median_ms,p95_ms,max_ms}, and more");
    pl->footer("Everything is created before the first frame, and one untimed warm-up frame records the\n"
               "command buffers; the loop only deforms, uploads, evaluates the stencil tables, computes\n"
               "normals and (with --render) draws and reads back. fps counts those stages; writing PNG files\n"
               "and --verify are outside it.\n"
               "Examples:\n  psub play data/spot_control_mesh.obj --levels 5 --frames 300 --anim twist\n"
               "  psub play data/cow.obj --levels 4 --backend vulkan --json\n"
               "  psub play data/cube.obj --levels 6 --frames 60 --render frames/ --size 640x360\n"
               "  psub play data/spot_control_mesh_uv.obj --levels 4 --frames 60 --render frames/ --texture data/spot_texture.png\n"
               "  psub play data/two_bone_cylinder.glb --anim bend --levels 4 --verify\n"
               "  psub play data/CesiumMan.glb --levels 3 --frames 60 --render frames/ --size 480x480");
    return pl;
}

int runPlay(const PlayOptions& o) {
    if (!o.texture.empty() && o.renderDir.empty()) {
        std::fprintf(stderr, "psub play: --texture applies with --render only\n");
        return 2;
    }
    Animated animated = loadAnimated(o);
    Playback p(o, animated);
#if PSUB_HAVE_RENDER
    if (!o.texture.empty()) {
        p.textureImage = readTextureImage(o.texture);
        requireUvs(animated.mesh);
        p.textured = true;
    } else if (p.rendering() && animated.asset) {
        if (std::optional<MaterialTexture> material = materialTexture(animated.mesh, animated.asset->material)) {
            p.textureImage = std::move(material->image);
            p.textureFactor = material->factor;
            p.textured = true;
        }
    }
#endif
    refineAnimated(p);
    if (p.rendering()) makeOutputDirectory(o.renderDir);
    if (const int status = prepare(p)) return status;
    // One untimed warm-up frame: command buffers of this kind of frame are recorded and
    // lavapipe compiles its shaders now, not inside the loop.
    Timings warmUp(0);
    p.frame(0, warmUp, false);
    Timings t(o.frames);
    const bool progress = ::isatty(2) != 0 && !o.json;
    Clock::time_point lastProgress = Clock::now();
    for (int frame = 0; frame < o.frames; ++frame) {
        try {
            p.frame(frame, t);
        } catch (const InputError&) {
            throw;
        } catch (const std::runtime_error& e) {  // a frame's PNG could not be written
            std::fprintf(stderr, "psub: error: play: %s\n", e.what());
            return 1;
        }
        if (progress && msBetween(lastProgress, Clock::now()) > 500) {
            std::fprintf(stderr, "\rpsub play: frame %d/%d, %.1f fps ", frame + 1, o.frames, framesPerSecond(t));
            lastProgress = Clock::now();
        }
    }
    if (progress) std::fprintf(stderr, "\r%60s\r", "");
    report(p, t);
    return 0;
}

}  // namespace psub::cli
