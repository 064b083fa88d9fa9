// psub view: the interactive window. Per frame: script events and window input, pose the
// control points (wall-clock time, looping), evaluate P-S (CPU or Vulkan) and/or OpenSubdiv's
// Catmull-Clark (its stencil table, CPU), draw each with psub::Renderer into the frame picture,
// HUD and help as captions, present through psub::Presenter. Two frames in flight: the main
// thread evaluates frame n+1 into one slot while a draw thread draws frame n from the other.
// Every renderer a mode needs (per slot, scheme side and layout; each holds every wireframe
// mode) is made before the first frame, again only on a resize or new tables, so s and w create
// nothing. CPU-evaluated vertices are written straight into the chosen renderer's mapped
// vertex buffers when that memory is host-cached ("cpu_upload": "direct"), else into host
// arrays that the renderer copies ("copy"). Tables for a new level, boundary or rules are
// built by std::async while the old ones keep drawing.
#include "view.h"

#include "options.h"
#include "play.h"

#include "psub/catmark.h"
#include "evaluators.h"
#include "psub/evaluator.h"
#include "psub/presenter.h"
#include "psub/render.h"
#include "psub/stencils.h"
#include "psub/vulkan_evaluator.h"

#include <CLI/CLI.hpp>
#include <GLFW/glfw3.h>
#include <fcntl.h>
#include <unistd.h>
#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <condition_variable>
#include <exception>
#include <filesystem>
#include <fstream>
#include <functional>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <span>
#include <sstream>
#include <thread>
#include <utility>
#include <vector>

namespace psub::cli {
namespace {

using Clock = std::chrono::steady_clock;

double msBetween(Clock::time_point a, Clock::time_point b) {
    return std::chrono::duration<double, std::milli>(b - a).count();
}

constexpr std::uint64_t kMaxFaces = 16ull << 20;  // beyond this a level is refused
const char* const kSchemeNames[] = {"ps", "cc", "both"};
const char* const kWireframeNames[] = {"none", "refined", "control"};

// ---------------------------------------------------------------------------------------
// Actions, from keys or the script

enum class Action { LevelUp, LevelDown, Scheme, Wireframe, Play, Boundary, Rules, Help, Frame, Quit };

const std::map<std::string, Action> kScriptKeys = {
    {"+", Action::LevelUp},  {"-", Action::LevelDown}, {"s", Action::Scheme}, {"w", Action::Wireframe},
    {"space", Action::Play}, {"b", Action::Boundary},  {"r", Action::Rules},  {"h", Action::Help},
    {"f", Action::Frame},    {"esc", Action::Quit}};

struct ScriptEvent {
    int frame = 0;
    enum Kind { Key, Drag, Scroll, Resize } kind = Key;
    Action action = Action::Quit;
    int button = 0;  // Drag: 0 left (orbit), 1 right (pan)
    double a = 0, b = 0;
};

std::string keyList() {
    std::string names;
    for (const auto& entry : kScriptKeys) names += (names.empty() ? "" : ", ") + entry.first;
    return names;
}

// The script file: one event per line, `FRAME key K`, `FRAME drag left|right DX DY`,
// `FRAME scroll DY`, `FRAME resize W H`; `#` starts a comment. Throws InputError naming the line.
std::vector<ScriptEvent> readScript(const std::string& path) {
    std::ifstream in(path);
    if (!in) throw InputError(path + ": cannot read the script");
    std::vector<ScriptEvent> events;
    std::string line;
    for (int number = 1; std::getline(in, line); ++number) {
        line = line.substr(0, line.find('#'));
        std::istringstream words(line);
        std::string kind;
        ScriptEvent e;
        if (!(words >> e.frame)) {
            if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
            throw InputError(path + ":" + std::to_string(number) + ": expected a frame number first");
        }
        const std::string where = path + ":" + std::to_string(number) + ": ";
        if (e.frame < 0) throw InputError(where + "frame " + std::to_string(e.frame) + " is negative");
        words >> kind;
        bool ok = true;
        if (kind == "key") {
            std::string key;
            words >> key;
            const auto found = kScriptKeys.find(key);
            if (found == kScriptKeys.end()) throw InputError(where + "unknown key '" + key + "' (keys: " + keyList() + ")");
            e.kind = ScriptEvent::Key, e.action = found->second;
        } else if (kind == "drag") {
            std::string button;
            ok = bool(words >> button >> e.a >> e.b) && (button == "left" || button == "right");
            e.kind = ScriptEvent::Drag, e.button = button == "right";
        } else if (kind == "scroll") {
            ok = bool(words >> e.a);
            e.kind = ScriptEvent::Scroll;
        } else if (kind == "resize") {
            ok = bool(words >> e.a >> e.b) && e.a >= 1 && e.b >= 1 && e.a <= 16384 && e.b <= 16384;
            e.kind = ScriptEvent::Resize;
        } else {
            throw InputError(where + "unknown event '" + kind + "' (events: key, drag, scroll, resize)");
        }
        std::string extra;
        if (!ok || (words >> extra))
            throw InputError(where + "expected `" + kind +
                             (kind == "drag" ? " left|right DX DY`" : kind == "scroll" ? " DY`" : " WIDTH HEIGHT`"));
        events.push_back(e);
    }
    std::stable_sort(events.begin(), events.end(), [](const ScriptEvent& x, const ScriptEvent& y) { return x.frame < y.frame; });
    return events;
}

// ---------------------------------------------------------------------------------------
// Tables, built off the frame loop

struct Built {
    int levels = 0, ccLevels = 0;
    Rules rules = Rules::Paper;
    Boundary boundary = Boundary::Paper;
    Refinement ps;
    std::unique_ptr<CatmarkStencils> ccStencils;  // OpenSubdiv: control points -> level ccLevels
    SurfaceTable cc;                              // its faces
    PerLevelTable ccIdentity;  // no levels over cc's vertices: for its normals
    FactorizedTable none;      // the evaluators keep references to their tables
    std::string error;  // set when the level was refused
};

// Catmull-Clark levels drawn beside `levels` P-S steps: half as many (equal face counts on quads).
int ccLevelsFor(int levels) { return levels / 2; }

// ViewOptions::form.
constexpr int kFormAuto = 0, kFormPerLevel = 1, kFormTiled = 2;

// The P-S tables for `form`: both forms for auto (the choice is timed when they are adopted)
// unless it would not time the per-level rows (autoTimesPerLevel, on `backend`), the tiled form
// alone (its lean build) then and when forced, else the per-level table.
Built buildTables(const Animated& a, int levels, Rules rules, Boundary boundary, int form, Backend backend) {
    Built b;
    b.levels = levels, b.rules = rules, b.boundary = boundary, b.ccLevels = ccLevelsFor(levels);
    const Mesh& mesh = a.mesh;
    const Connectivity& connectivity = a.checked.connectivity;
    const bool preprocess = needsPreprocessing(mesh.faces, connectivity, Preprocess::Auto, mesh.source);
    const Counts finest = countsAfterSteps(countMesh(mesh.faces, connectivity), levels + (preprocess ? 1 : 0), boundary, preprocess);
    if (finest.faces > kMaxFaces) {
        b.error = std::to_string(levels) + " steps would give " + std::to_string(finest.faces) + " faces (limit " +
                  std::to_string(kMaxFaces) + ")";
        return b;
    }
    RefineOptions options;
    options.levels = levels, options.rules = rules, options.boundary = boundary;
    options.tiled = form == kFormAuto || form == kFormTiled;
    options.perLevel = form != kFormTiled && (form != kFormAuto || autoTimesPerLevel(backend, finest.faces, levels));
    options.canonicalOrder = false;  // drawn, never written in canonical order
    b.ps = refine(mesh, connectivity, options);
    b.ccStencils = std::make_unique<CatmarkStencils>(mesh.faces, b.ccLevels);
    b.cc = buildSurfaceTable(b.ccStencils->finestFaces());
    b.ccIdentity.controlCount = b.cc.vertexCount;
    return b;
}

// ---------------------------------------------------------------------------------------
// The camera: frameBox's at the start and on `f`, then orbit, zoom and pan

struct Orbit {
    std::array<float, 3> target{}, direction{0, 0, 1};  // direction: from the target to the eye
    float distance = 1, radius = 1;

    void from(const Camera& c, float framedRadius) {
        target = c.target;
        float length = 0;
        for (int i = 0; i < 3; ++i) direction[i] = c.eye[i] - c.target[i], length += direction[i] * direction[i];
        distance = std::sqrt(length);
        for (float& d : direction) d /= distance;
        radius = framedRadius;
    }
    Camera camera(float aspect) const {
        std::array<float, 3> eye;
        for (int i = 0; i < 3; ++i) eye[i] = target[i] + distance * direction[i];
        return lookAt(eye, target, radius + distance, aspect);
    }
    void orbit(double dx, double dy) {
        float yaw = std::atan2(direction[0], direction[2]) - float(dx) * 0.008f;
        float pitch = std::asin(std::clamp(direction[1], -1.0f, 1.0f)) + float(dy) * 0.008f;
        pitch = std::clamp(pitch, -1.5f, 1.5f);
        direction = {std::cos(pitch) * std::sin(yaw), std::sin(pitch), std::cos(pitch) * std::cos(yaw)};
    }
    void zoom(double wheel) { distance *= std::pow(0.9f, float(wheel)); }
    void pan(double dx, double dy, float pixelsHigh) {
        // right = up x direction, up' = direction x right; one pixel moves the target by the view's height / pixels.
        const std::array<float, 3> right = {direction[2], 0, -direction[0]};
        const float rl = std::max(1e-6f, std::hypot(right[0], right[2]));
        const std::array<float, 3> r = {right[0] / rl, 0, right[2] / rl};
        const std::array<float, 3> u = {direction[1] * r[2] - direction[2] * r[1], direction[2] * r[0] - direction[0] * r[2],
                                        direction[0] * r[1] - direction[1] * r[0]};
        const float scale = 2 * distance * std::tan(0.5f * 30.0f * 3.14159265f / 180) / std::max(1.0f, pixelsHigh);
        for (int i = 0; i < 3; ++i) target[i] += scale * (-float(dx) * r[i] + float(dy) * u[i]);
    }
};

// ---------------------------------------------------------------------------------------
// The viewer

enum Stage { Deform, Upload, Evaluate, Normals, Render, Readback, Present, kStageCount };
constexpr std::array<const char*, kStageCount> kStageNames = {"deform", "upload", "evaluate", "normals",
                                                              "render", "readback", "present"};
constexpr int kMaxFramesInFlight = 2;

// What one scheme draws in a frame slot: its renderers, one per layout (whole window, side by
// side), each with every wireframe mode, made before the loop and kept until the size or the
// tables change (so `s` and `w` create nothing); where the slot's frame is evaluated into (the
// renderer's mapped buffers, or host arrays) and its picture.
struct Side {
    const SurfaceTable* surface = nullptr;
    std::array<std::unique_ptr<Renderer>, 2> renderers;  // index: side by side
    Renderer* renderer = nullptr;                        // the one drawing the slot's frame
    std::span<float> positions, normals;                 // this frame's vertices (CPU, or read back)
    std::vector<float> hostPositions, hostNormals;       // copy path; Vulkan: read back for framing
    Image picture;
    std::uint32_t width = 0;
    Camera camera;
};

// What the slot's frame shows, fixed when it is evaluated: the HUD and the log read this, not
// the viewer's state, which the next frame's keys may already have changed.
struct Shown {
    int scheme = 0, wireframe = 0, levels = 0, ccLevels = 0;
    std::uint64_t psFaces = 0, ccFaces = 0;
    bool playing = false, help = false, capture = false;
    Boundary boundary = Boundary::Paper;
    Rules rules = Rules::Paper;
    bool tiled = false;  // P-S through the tiled form
    double fps = 0, previousPresentMs = 0;
    std::string notice;
    std::array<double, kStageCount> stage{};
};

// A frame in flight: evaluated into by the main thread, then drawn (by the draw thread when two
// are in flight) while the main thread evaluates the next frame into the other slot. With the
// Vulkan backend each slot has its own evaluator, so its device buffers (what the slot's P-S
// renderers draw from) are not overwritten by the next frame's evaluation.
struct Slot {
    std::unique_ptr<Evaluator> evaluator;              // Vulkan: this slot's; CPU: only slot 0's
    const VulkanEvaluator* drawnFromDevice = nullptr;  // the same, when drawn from its buffers
    Side ps, cc;
    std::vector<float> control;  // posed control points (the control cage is drawn from them)
    Image frame;                 // the picture presented: the side(s), the HUD
    Shown shown;
};

// The one thread that draws a slot while the main thread evaluates the next frame. Created
// before the loop; exceptions thrown while drawing come out of wait().
class DrawThread {
public:
    explicit DrawThread(std::function<void(Slot&)> draw) : draw_(std::move(draw)), thread_([this] { run(); }) {}
    ~DrawThread() {
        {
            std::lock_guard lock(mutex_);
            stop_ = true;
        }
        changed_.notify_all();
        thread_.join();
    }
    void start(Slot& slot) {
        {
            std::lock_guard lock(mutex_);
            job_ = &slot;
        }
        changed_.notify_all();
    }
    void wait() {
        std::unique_lock lock(mutex_);
        changed_.wait(lock, [this] { return job_ == nullptr; });
        if (error_) std::rethrow_exception(std::exchange(error_, nullptr));
    }

private:
    void run() {
        std::unique_lock lock(mutex_);
        for (;;) {
            changed_.wait(lock, [this] { return stop_ || job_ != nullptr; });
            if (stop_) return;
            lock.unlock();
            std::exception_ptr error;
            try {
                draw_(*job_);
            } catch (...) {
                error = std::current_exception();
            }
            lock.lock();
            error_ = error, job_ = nullptr;
            changed_.notify_all();
        }
    }
    std::function<void(Slot&)> draw_;
    std::mutex mutex_;
    std::condition_variable changed_;
    Slot* job_ = nullptr;
    bool stop_ = false;
    std::exception_ptr error_;
    std::thread thread_;  // last: starts after the members it uses
};

long residentKiB() {
    char text[128] = {};
    const int fd = ::open("/proc/self/statm", O_RDONLY);
    if (fd < 0) return 0;
    const ssize_t n = ::read(fd, text, sizeof text - 1);
    ::close(fd);
    long pages = 0, resident = 0;
    if (n > 0) std::sscanf(text, "%ld %ld", &pages, &resident);
    return resident * (::sysconf(_SC_PAGESIZE) / 1024);
}

void drawHud(const Shown& s, Backend backend, Image& frame);

struct Viewer {
    const ViewOptions& o;
    Animated& animated;
    GLFWwindow* window = nullptr;
    std::unique_ptr<VulkanContext> context;
    std::unique_ptr<Presenter> presenter;

    std::shared_ptr<Built> built;
    std::future<Built> pending;
    int levels, scheme, wireframe, wantedLevels;
    Rules rules, wantedRules;
    Boundary boundary, wantedBoundary;
    bool playing, help = false, quit = false, framed = false;
    std::unique_ptr<CpuEvaluator<float>> ccNormals;
    TableForm psForm = TableForm::PerLevel;  // the P-S evaluators' (adopt: forced, or auto's choice)
    std::array<Slot, kMaxFramesInFlight> slots;
    int framesInFlight = kMaxFramesInFlight;
    std::unique_ptr<DrawThread> drawThread;  // with 2 frames in flight
    Slot* inFlight = nullptr;                // the slot being drawn, to present
    int inFlightIndex = 0;
    std::uint64_t renderersCreated = 0;  // each Renderer builds its pipelines once
    bool direct = false;  // CPU vertices written into the renderers' mapped (host-cached) buffers
    double renderersMs = 0;  // wall time of the last createRenderers()
    Orbit orbit;
    double seconds = 0;  // animation time
    double fps = 0, frameMs = 0, presentMs = 0;  // fps over the last second; wall time of the last frame
    std::string notice;  // shown in the HUD (refused level, build in progress)
    bool leftDown = false, rightDown = false;
    double cursorX = 0, cursorY = 0;
    std::FILE* log = nullptr;

    Viewer(const ViewOptions& options, Animated& a)
        : o(options), animated(a), levels(options.levels), scheme(options.scheme), wireframe(options.wireframe),
          wantedLevels(options.levels), rules(options.rules), wantedRules(options.rules), boundary(options.boundary),
          wantedBoundary(options.boundary), playing(!options.paused), framesInFlight(options.framesInFlight) {}

    std::uint64_t psFaces() const { return slots[0].ps.surface->faceOffsets.size() - 1; }
    std::uint64_t ccFaces() const { return built->cc.faceOffsets.size() - 1; }

    void act(Action action);
    void startBuild();
    void adopt(Built b);
    void dropRenderers();
    void createRenderers();
    void remakeRenderers();
    void chooseRenderers(Slot& slot);
    void aimCameras(Slot& slot);
    void prepare(Slot& slot, bool capture);
    void evaluate(Slot& slot);
    void evaluateSides(Slot& slot);
    void draw(Slot& slot);
    void startDrawing(Slot& slot, int index);
    bool finishDrawing();
    void frameModel(const Slot& slot);
    void writeLog(const Slot& slot, int index);
};

// Starts building the tables the keys asked for, unless a build runs or they are drawn already.
void Viewer::startBuild() {
    if (pending.valid() || (wantedLevels == levels && wantedRules == rules && wantedBoundary == boundary)) return;
    notice = "building level " + std::to_string(wantedLevels) + "...";
    pending = std::async(std::launch::async, [this, l = wantedLevels, r = wantedRules, b = wantedBoundary] {
        return buildTables(animated, l, r, b, o.form, o.backend);
    });
}

// Every renderer goes (after a resize or with the tables they refer to); no frame is in flight.
void Viewer::dropRenderers() {
    for (Slot& slot : slots)
        for (Side* side : {&slot.ps, &slot.cc}) {
            for (auto& r : side->renderers) r.reset();
            side->renderer = nullptr, side->positions = side->normals = {};
        }
}

// True unless PSUB_VIEW_CPU_UPLOAD=copy asks for the copy path (to compare the two).
bool directUploadAllowed() {
    const char* upload = std::getenv("PSUB_VIEW_CPU_UPLOAD");
    return !(upload && std::string(upload) == "copy");
}

// Every renderer any scheme, layout and wireframe needs, for each slot in flight, at the
// swapchain's size (halves side by side); then whether CPU vertices go direct, and the host
// arrays the copy path (and the Vulkan read-back for framing) needs. No frame is in flight.
void Viewer::createRenderers() {
    const Clock::time_point start = Clock::now();
    const auto [width, height] = presenter->extent();
    const Faces& cage = animated.mesh.faces;
    const Polygons cagePolygons{cage.vertexCount, cage.offsets, cage.verts};
    const bool cached = directUploadAllowed();
    RenderOptions ro;
    ro.height = height, ro.samples = o.samples, ro.everyWireframe = true, ro.cachedVertices = cached;
    const std::uint32_t half = std::max(1u, width / 2);
    direct = cached;
    for (int s = 0; s < framesInFlight; ++s) {
        Slot& slot = slots[std::size_t(s)];
        for (int sideBySide = 0; sideBySide < 2; ++sideBySide) {
            ro.width = sideBySide ? half : width;
            std::unique_ptr<Renderer>& ps = slot.ps.renderers[std::size_t(sideBySide)];
            ps = slot.drawnFromDevice ? std::make_unique<Renderer>(*context, *slot.drawnFromDevice, ro, cagePolygons)
                                      : std::make_unique<Renderer>(*context, polygonsOf(*slot.ps.surface), ro, cagePolygons);
            ro.width = sideBySide ? std::max(1u, width - half) : width;
            std::unique_ptr<Renderer>& cc = slot.cc.renderers[std::size_t(sideBySide)];
            cc = std::make_unique<Renderer>(*context, polygonsOf(*slot.cc.surface), ro, cagePolygons);
            renderersCreated += 2;
            // Direct needs the renderers' layout to be the evaluators' (3 packed floats per vertex).
            direct = direct && cc->verticesCached() && cc->mappedPositions().size() == 3 * std::size_t(built->cc.vertexCount) &&
                     (slot.drawnFromDevice || (ps->verticesCached() &&
                                               ps->mappedPositions().size() == 3 * std::size_t(slots[0].evaluator->refinedCount())));
        }
    }
    for (int s = 0; s < framesInFlight; ++s) {
        Slot& slot = slots[std::size_t(s)];
        for (Side* side : {&slot.ps, &slot.cc}) {
            const bool host = !direct || (side == &slot.ps && slot.drawnFromDevice);
            const std::size_t floats = host ? 3 * std::size_t(side->surface->vertexCount) : 0;
            side->hostPositions.assign(floats, 0.0f), side->hostNormals.assign(floats, 0.0f);
            side->hostPositions.shrink_to_fit(), side->hostNormals.shrink_to_fit();
        }
    }
    renderersMs = msBetween(start, Clock::now());
}

void Viewer::remakeRenderers() {
    dropRenderers();
    createRenderers();
}

// Called with no frame in flight.
void Viewer::adopt(Built b) {
    if (!b.error.empty()) {
        notice = b.error;
        std::fprintf(stderr, "psub: view: level refused: %s\n", b.error.c_str());
        wantedLevels = levels, wantedRules = rules, wantedBoundary = boundary;
        return;
    }
    notice.clear();
    dropRenderers();  // everything that refers to the old tables goes first
    for (Slot& slot : slots) slot.evaluator.reset(), slot.drawnFromDevice = nullptr;
    ccNormals.reset();
    built = std::make_shared<Built>(std::move(b));
    levels = built->levels, rules = built->rules, boundary = built->boundary;
    const Refinement& r = built->ps;
    // The form: forced, or psub play's auto choice, timed on the rest pose.
    FormChoice choice;
    if (o.form == kFormTiled) choice.form = TableForm::Tiled;
    if (o.form == kFormAuto) {
        std::vector<float> control(3 * std::size_t(animated.mesh.faces.vertexCount)), scratch(3 * std::size_t(r.tiled.refinedCount));
        animated.pose(0, control);
        // The third tiled candidate's lean build (on Vulkan and on several CPU threads, where
        // tiles are few: fasterForm), here on the window's thread: Spot at 9 steps 30-50 ms
        // more at a level change.
        const auto withoutTiles = [&] {
            return tiledWithoutTiles(animated.mesh, animated.checked.connectivity, built->levels, built->rules,
                                     built->boundary);
        };
        choice = fasterForm(o.backend, built->ps, context.get(), control, scratch, withoutTiles);
        if (choice.tiled) dropPerLevelTables(built->ps);
    }
    psForm = choice.form;
    for (int s = 0; s < framesInFlight; ++s) {
        Slot& slot = slots[std::size_t(s)];
        if (s == 0 || slots[0].drawnFromDevice) {
            slot.evaluator = s == 0 && choice.tiled ? std::move(choice.tiled)
                                                    : makeEvaluator(o.backend, tablesOf(r), psForm, context.get());
            slot.drawnFromDevice = dynamic_cast<const VulkanEvaluator*>(slot.evaluator.get());
        }
        slot.ps.surface = psForm == TableForm::Tiled ? &r.tiled.surface : &r.surface;
        slot.cc.surface = &built->cc;
        slot.control.assign(3 * std::size_t(animated.mesh.faces.vertexCount), 0.0f);
    }
    ccNormals = std::make_unique<CpuEvaluator<float>>(built->ccIdentity, built->none, built->cc, TableForm::PerLevel);
    createRenderers();
#if defined(__GLIBC__)
    malloc_trim(0);  // the old level's pages: psub keeps freed pages (cli/main.cpp), a viewer gives them back
#endif
}

void Viewer::act(Action action) {
    switch (action) {
    case Action::LevelUp: wantedLevels = std::min(30, wantedLevels + 1); break;
    case Action::LevelDown: wantedLevels = std::max(0, wantedLevels - 1); break;
    case Action::Boundary: wantedBoundary = wantedBoundary == Boundary::Paper ? Boundary::Smooth : Boundary::Paper; break;
    case Action::Rules: wantedRules = wantedRules == Rules::Paper ? Rules::Robust : Rules::Paper; break;
    case Action::Scheme: scheme = (scheme + 1) % 3; break;
    case Action::Wireframe: wireframe = (wireframe + 1) % 3; break;
    case Action::Play: playing = !playing; break;
    case Action::Help: help = !help; break;
    case Action::Frame: framed = false; break;
    case Action::Quit: quit = true; break;
    }
}

// The slot's renderers for the sides its frame shows (made already: this creates nothing), set
// to its wireframe; where its vertices are evaluated into; the slot's picture sizes.
void Viewer::chooseRenderers(Slot& slot) {
    const Shown& s = slot.shown;
    const auto [width, height] = presenter->extent();
    slot.ps.renderer = slot.cc.renderer = nullptr;
    for (Side* side : {&slot.ps, &slot.cc}) {
        if ((side == &slot.ps && s.scheme == 1) || (side == &slot.cc && s.scheme == 0)) continue;
        Renderer& r = *side->renderers[std::size_t(s.scheme == 2)];
        r.setWireframe(Wireframe(s.wireframe));
        side->renderer = &r;
        side->width = r.options().width;
        const bool host = !direct || (side == &slot.ps && slot.drawnFromDevice);
        side->positions = host ? std::span<float>(side->hostPositions) : r.mappedPositions();
        side->normals = host ? std::span<float>(side->hostNormals) : r.mappedNormals();
    }
    if (slot.frame.width != width || slot.frame.height != height)
        slot.frame = filledImage(width, height, RenderOptions{}.background);
}

// The cameras of the slot's sides, from the orbit as it is now.
void Viewer::aimCameras(Slot& slot) {
    const std::uint32_t height = presenter->extent()[1];
    for (Side* side : {&slot.ps, &slot.cc})
        side->camera = orbit.camera(float(std::max(1u, side->width)) / float(height));
}

// Poses the control points and evaluates what is shown into the slot; stage times into its
// Shown. The main thread's work of a frame (it overlaps the drawing of the frame before).
void Viewer::evaluate(Slot& slot) {
    std::array<double, kStageCount>& stage = slot.shown.stage;
    const Clock::time_point start = Clock::now();
    animated.pose(std::fmod(seconds, animated.period), slot.control);
    stage[Deform] = msBetween(start, Clock::now());
    evaluateSides(slot);
}

// Evaluates the sides the slot shows from its posed control points, into the vertices
// chooseRenderers picked; their stage times into its Shown.
void Viewer::evaluateSides(Slot& slot) {
    std::array<double, kStageCount>& stage = slot.shown.stage;
    stage[Upload] = stage[Evaluate] = stage[Normals] = stage[Readback] = 0;
    if (slot.ps.renderer) {
        // Vulkan: this slot's evaluator, so the frame in flight keeps its buffers. Results are
        // read back only where the host needs them: for the camera to frame them.
        Evaluator& evaluator = slot.drawnFromDevice ? *slot.evaluator : *slots[0].evaluator;
        if (slot.drawnFromDevice && framed) evaluator.evaluateKept(slot.control, true);
        else evaluator.evaluate(slot.control, slot.ps.positions, slot.ps.normals);
        const StageTimes times = evaluator.lastTimes();
        stage[Upload] = times.uploadMs;
        stage[Evaluate] = times.evaluateMs;
        stage[Normals] = times.normalsMs;
        stage[Readback] = times.readbackMs;
    }
    if (slot.cc.renderer) {  // OpenSubdiv on the CPU, whatever the backend
        const Clock::time_point ccStart = Clock::now();
        built->ccStencils->evaluate(slot.control, slot.cc.positions);
        const Clock::time_point evaluated = Clock::now();
        ccNormals->normals(slot.cc.positions, slot.cc.normals);
        stage[Evaluate] += msBetween(ccStart, evaluated);
        stage[Normals] += msBetween(evaluated, Clock::now());
    }
}

// Everything the main thread does for a frame before it is drawn; no draw of this slot is in flight.
void Viewer::prepare(Slot& slot, bool capture) {
    Shown& s = slot.shown;
    s = {};
    s.scheme = scheme, s.wireframe = wireframe, s.levels = levels, s.ccLevels = built->ccLevels;
    s.psFaces = psFaces(), s.ccFaces = ccFaces();
    s.playing = playing, s.help = help, s.capture = capture, s.boundary = boundary, s.rules = rules;
    s.tiled = psForm == TableForm::Tiled;
    s.fps = fps, s.previousPresentMs = presentMs, s.notice = notice;
    chooseRenderers(slot);
    evaluate(slot);
    if (!framed) frameModel(slot);
}

// The drawing of a frame (the draw thread's work with two frames in flight): each side from
// its renderer's mapped vertex buffers (CPU, written there directly, or copied from the host
// arrays) or the slot's evaluator's device buffers (Vulkan), side by side composed, the HUD.
void Viewer::draw(Slot& slot) {
    const Shown& s = slot.shown;
    for (Side* side : {&slot.ps, &slot.cc}) {
        if (!side->renderer) continue;
        side->renderer->setControlPositions(slot.control);
        Image& picture = s.scheme == 2 ? side->picture : slot.frame;
        if (side == &slot.ps && slot.drawnFromDevice) side->renderer->drawKept(side->camera, picture);
        else if (direct) side->renderer->drawWritten(side->camera, picture);
        else side->renderer->draw(side->positions, side->normals, side->camera, picture);
        const DrawTimes d = side->renderer->lastTimes();
        slot.shown.stage[Upload] += d.uploadMs, slot.shown.stage[Render] += d.renderMs,
            slot.shown.stage[Readback] += d.readbackMs;
    }
    if (s.scheme == 2) {  // side by side: P-S left, Catmull-Clark right
        Image& frame = slot.frame;
        for (std::uint32_t y = 0; y < frame.height; ++y) {
            std::copy_n(slot.ps.picture.rgba.data() + 4ull * y * slot.ps.width, 4ull * slot.ps.width,
                        frame.rgba.data() + 4ull * y * frame.width);
            std::copy_n(slot.cc.picture.rgba.data() + 4ull * y * slot.cc.width, 4ull * slot.cc.width,
                        frame.rgba.data() + 4ull * (y * frame.width + slot.ps.width));
        }
    }
    if (!o.noHud) drawHud(s, o.backend, slot.frame);
}

// Called after finishDrawing(): the cameras for the slot, then its drawing starts.
void Viewer::startDrawing(Slot& slot, int index) {
    aimCameras(slot);
    inFlight = &slot, inFlightIndex = index;
    if (drawThread) drawThread->start(slot);
    else draw(slot);
}

// Waits for the frame in flight and presents it; when the swapchain had changed it is drawn
// again at the new size first. Returns false when there was none, or when it could not be
// presented after a few tries (the window keeps changing size): the frame is dropped.
bool Viewer::finishDrawing() {
    if (!inFlight) return false;
    Slot& slot = *std::exchange(inFlight, nullptr);
    if (drawThread) drawThread->wait();
    for (int attempt = 0;; ++attempt) {
        const Clock::time_point start = Clock::now();
        const bool presented = presenter->present(slot.frame, slot.shown.capture);
        presentMs = slot.shown.stage[Present] = msBetween(start, Clock::now());
        if (presented) break;
        // The presenter re-created the swapchain (resize): nothing else is in flight.
        remakeRenderers();
        if (attempt == 7) return false;
        // The new renderers' vertex buffers are evaluated into again (from the slot's pose).
        chooseRenderers(slot);
        evaluateSides(slot);
        aimCameras(slot);
        slot.shown.stage[Render] = 0;
        draw(slot);
    }
    return true;
}

// frameBox of what is shown, as psub render frames it.
void Viewer::frameModel(const Slot& slot) {
    Box box;
    if (slot.ps.renderer) box.extend(slot.ps.positions);
    if (slot.cc.renderer) box.extend(slot.cc.positions);
    if (wireframe == 2) box.extend(slot.control);
    const auto [width, height] = presenter->extent();
    const std::uint32_t panel = scheme == 2 ? std::max(1u, width / 2) : width;
    const Camera c = frameBox(box, float(panel) / float(height));
    float radius = 0;
    for (int i = 0; i < 3; ++i) radius += (box.max[i] - box.min[i]) * (box.max[i] - box.min[i]);
    orbit.from(c, 0.5f * std::sqrt(radius) * 1.04f);
    framed = true;
}

void drawHud(const Shown& s, Backend backend, Image& frame) {
    char text[512];
    const std::string ps = "P-S " + std::to_string(s.levels) + (s.tiled ? " steps (tiled)" : " steps");
    const std::string what = s.scheme == 0   ? ps
                             : s.scheme == 1 ? "Catmull-Clark " + std::to_string(s.ccLevels) + " levels"
                                             : ps + " | Catmull-Clark " + std::to_string(s.ccLevels);
    const std::uint64_t faces = (s.scheme != 1 ? s.psFaces : 0) + (s.scheme != 0 ? s.ccFaces : 0);
    const auto& stage = s.stage;
    std::snprintf(text, sizeof text,
                  "%s, %llu faces, %s, %.1f fps\ndeform %.2f  upload %.2f  evaluate %.2f  normals %.2f  render %.2f  "
                  "readback %.2f  present %.2f ms\n%s, wireframe %s, boundary %s, rules %s  (h: help)%s%s",
                  what.c_str(), (unsigned long long)faces, backend == Backend::Vulkan ? "vulkan" : "cpu", s.fps,
                  stage[Deform], stage[Upload], stage[Evaluate], stage[Normals], stage[Render], stage[Readback],
                  s.previousPresentMs, s.playing ? "playing" : "paused", kWireframeNames[s.wireframe],
                  s.boundary == Boundary::Paper ? "paper" : "smooth", s.rules == Rules::Paper ? "paper" : "robust",
                  s.notice.empty() ? "" : "\n", s.notice.c_str());
    const int scale = frame.width >= 1200 ? 2 : 1;  // the stage line fits 1280 pixels at scale 2
    const auto size = textSize(text, scale);
    fillRect(frame, 4, 4, size[0] + 14, size[1] + 12, {240, 240, 240, 255});
    drawText(frame, 10, 10, text, scale, {20, 20, 20, 255});
    if (!s.help) return;
    const char* keys =
        "mouse: left drag orbit, right drag pan, wheel zoom\n"
        "+ / -  level up / down        s  P-S, Catmull-Clark, both\n"
        "w  wireframe none/refined/control   space  play / pause\n"
        "b  boundary paper/smooth      r  rules paper/robust\n"
        "f  frame the model   h  this help   Esc  quit";
    const auto helpSize = textSize(keys, scale);
    const int x = 10, y = size[1] + 24;
    fillRect(frame, x - 6, y - 6, x + helpSize[0] + 6, y + helpSize[1] + 6, {255, 250, 220, 255});
    drawText(frame, x, y, keys, scale, {20, 20, 20, 255});
}

void Viewer::writeLog(const Slot& slot, int index) {
    if (!log) return;
    const Shown& s = slot.shown;
    const auto [width, height] = presenter->extent();
    const bool ps = s.scheme != 1, cc = s.scheme != 0;
    std::fprintf(log,
                 "{\"frame\": %d, \"level\": %d, \"cc_level\": %d, \"scheme\": \"%s\", \"refined_faces\": %llu, "
                 "\"ps_faces\": %llu, \"cc_faces\": %llu, \"drawn\": [%s%s%s], \"width\": %u, \"height\": %u, "
                 "\"ps_form\": \"%s\", \"wireframe\": \"%s\", \"playing\": %s, \"boundary\": \"%s\", \"rules\": \"%s\", \"rss_kib\": %ld, "
                 "\"validation_messages\": %llu, \"frames_in_flight\": %d, \"slot\": %d, \"renderers_created\": %llu, "
                 "\"cpu_upload\": \"%s\", \"frame_ms\": %.4f, \"stages\": {",
                 index, s.levels, s.ccLevels, kSchemeNames[s.scheme], (unsigned long long)(ps ? s.psFaces : s.ccFaces),
                 (unsigned long long)s.psFaces, (unsigned long long)s.ccFaces, ps ? "\"ps\"" : "", ps && cc ? ", " : "",
                 cc ? "\"cc\"" : "", width, height, s.tiled ? "tiled" : "per-level", kWireframeNames[s.wireframe], s.playing ? "true" : "false",
                 s.boundary == Boundary::Paper ? "paper" : "smooth", s.rules == Rules::Paper ? "paper" : "robust",
                 residentKiB(), (unsigned long long)context->validationMessageCount(), framesInFlight,
                 int(&slot - slots.data()), (unsigned long long)renderersCreated, direct ? "direct" : "copy", frameMs);
    for (int i = 0; i < kStageCount; ++i)
        std::fprintf(log, "%s\"%s_ms\": %.4f", i ? ", " : "", kStageNames[std::size_t(i)], s.stage[std::size_t(i)]);
    std::fprintf(log, "}}\n");
}

// GLFW callbacks: the viewer is the window's user pointer.
Viewer& viewerOf(GLFWwindow* w) { return *static_cast<Viewer*>(glfwGetWindowUserPointer(w)); }

void onChar(GLFWwindow* w, unsigned int codepoint) {
    static const std::map<unsigned int, Action> keys = {
        {'+', Action::LevelUp}, {'=', Action::LevelUp}, {'-', Action::LevelDown}, {'s', Action::Scheme},
        {'w', Action::Wireframe}, {' ', Action::Play}, {'b', Action::Boundary}, {'r', Action::Rules},
        {'h', Action::Help}, {'f', Action::Frame}};
    if (const auto found = keys.find(codepoint); found != keys.end()) viewerOf(w).act(found->second);
}

void onKey(GLFWwindow* w, int key, int, int action, int) {
    if (key == GLFW_KEY_ESCAPE && action == GLFW_PRESS) viewerOf(w).act(Action::Quit);
}

void onButton(GLFWwindow* w, int button, int action, int) {
    Viewer& v = viewerOf(w);
    if (button == GLFW_MOUSE_BUTTON_LEFT) v.leftDown = action == GLFW_PRESS;
    if (button == GLFW_MOUSE_BUTTON_RIGHT) v.rightDown = action == GLFW_PRESS;
    glfwGetCursorPos(w, &v.cursorX, &v.cursorY);
}

void onCursor(GLFWwindow* w, double x, double y) {
    Viewer& v = viewerOf(w);
    const double dx = x - v.cursorX, dy = y - v.cursorY;
    v.cursorX = x, v.cursorY = y;
    if (v.leftDown) v.orbit.orbit(dx, dy);
    if (v.rightDown) v.orbit.pan(dx, dy, float(v.presenter->extent()[1]));
}

void onScroll(GLFWwindow* w, double, double dy) { viewerOf(w).orbit.zoom(dy); }

std::string glfwLastError() {
    const char* text = nullptr;
    glfwGetError(&text);
    return text ? text : "no reason given";
}

// Opens the window; returns nullptr after a message naming $DISPLAY when there is none.
GLFWwindow* openWindow(const ViewOptions& o) {
    const char* display = std::getenv("DISPLAY");
    const std::string which = display && *display ? "$DISPLAY=" + std::string(display) + " cannot be opened"
                                                   : std::string("$DISPLAY is not set");
    if (!glfwInit()) {
        std::fprintf(stderr,
                     "psub: error: view: no display (%s; GLFW: %s): run under a display, or headless with "
                     "`xvfb-run -a psub view ...`, or draw frames offscreen with `psub play --render DIR`\n",
                     which.c_str(), glfwLastError().c_str());
        return nullptr;
    }
    glfwWindowHint(GLFW_CLIENT_API, GLFW_NO_API);
    glfwWindowHint(GLFW_RESIZABLE, GLFW_TRUE);
    const std::string title = "psub view: " + std::filesystem::path(o.input).filename().string();
    GLFWwindow* window = glfwCreateWindow(int(o.width), int(o.height), title.c_str(), nullptr, nullptr);
    if (!window) {
        std::fprintf(stderr, "psub: error: view: cannot open a window (%s; GLFW: %s)\n", which.c_str(),
                     glfwLastError().c_str());
        glfwTerminate();
        return nullptr;
    }
    return window;
}

int loop(Viewer& v, const std::vector<ScriptEvent>& script) {
    const ViewOptions& o = v.o;
    std::size_t next = 0;
    Clock::time_point last = Clock::now(), fpsStart = last, firstDrawn = last, advanced = last;
    int fpsFrames = 0, drawn = 0;
    // Presents and logs the frame in flight, if any.
    auto finish = [&] {
        const Slot* slot = v.inFlight;
        const int index = v.inFlightIndex;
        if (!v.finishDrawing()) return;
        const Clock::time_point now = Clock::now();
        v.frameMs = msBetween(last, now);
        v.writeLog(*slot, index);
        if (++drawn == 1) firstDrawn = now;
        last = now;
        ++fpsFrames;
        if (msBetween(fpsStart, now) >= 1000) {
            v.fps = 1000.0 * fpsFrames / msBetween(fpsStart, now);
            char title[160];
            std::snprintf(title, sizeof title, "psub view: %.1f fps", v.fps);
            glfwSetWindowTitle(v.window, title);
            fpsStart = now, fpsFrames = 0;
        }
    };
    for (int index = 0; !v.quit && !glfwWindowShouldClose(v.window); ++index) {
        glfwPollEvents();
        for (std::size_t e = next; e < script.size() && script[e].frame == index; ++e)
            if (script[e].kind == ScriptEvent::Resize) finish();  // the frame before is shown at the old size
        for (; next < script.size() && script[next].frame == index; ++next) {
            const ScriptEvent& e = script[next];
            if (e.kind == ScriptEvent::Key) v.act(e.action);
            if (e.kind == ScriptEvent::Drag) e.button ? v.orbit.pan(e.a, e.b, float(v.presenter->extent()[1])) : v.orbit.orbit(e.a, e.b);
            if (e.kind == ScriptEvent::Scroll) v.orbit.zoom(e.a);
            if (e.kind == ScriptEvent::Resize) {
                glfwSetWindowSize(v.window, int(e.a), int(e.b));
                // The X server applies the size; wait (at most 2 s) until GLFW sees it.
                const Clock::time_point asked = Clock::now();
                int w = 0, h = 0;
                while (msBetween(asked, Clock::now()) < 2000) {
                    glfwWaitEventsTimeout(0.01);
                    glfwGetFramebufferSize(v.window, &w, &h);
                    if (w == int(e.a) && h == int(e.b)) break;
                }
            }
        }
        if (v.quit) break;
        if (v.pending.valid() && v.pending.wait_for(std::chrono::seconds(0)) == std::future_status::ready) {
            finish();  // the tables it draws from go
            v.adopt(v.pending.get());
        }
        v.startBuild();
        int w = 0, h = 0;
        glfwGetFramebufferSize(v.window, &w, &h);
        if (w == 0 || h == 0) {  // minimised: nothing to draw
            finish();
            glfwWaitEventsTimeout(0.1);
            --index;
            continue;
        }
        const auto extent = v.presenter->extent();
        if (std::uint32_t(w) != extent[0] || std::uint32_t(h) != extent[1]) {
            finish();
            v.presenter->recreate();
            v.remakeRenderers();
        }
        const Clock::time_point now = Clock::now();
        if (v.playing && index > 0) v.seconds += o.step > 0 ? o.step : msBetween(advanced, now) / 1000.0;
        advanced = now;
        const bool lastFrame = o.frames > 0 && index + 1 == o.frames;
        Slot& slot = v.slots[std::size_t(index % v.framesInFlight)];
        v.prepare(slot, lastFrame && !o.screenshot.empty());  // overlaps the drawing of the frame before
        finish();
        v.startDrawing(slot, index);
        if (v.framesInFlight == 1) finish();
        if (lastFrame) break;
    }
    finish();
    if (!o.screenshot.empty()) {
        if (drawn == 0 || (o.frames > 0 && drawn < o.frames)) {
            std::fprintf(stderr, "psub: error: view: --screenshot needs --frames N and all N frames drawn\n");
            return 1;
        }
        writePng(o.screenshot, v.presenter->screenshot());
    }
    const double seconds = msBetween(firstDrawn, Clock::now()) / 1000.0;
    std::printf("psub view: %d frames drawn; %.2f fps after the first frame (%d frames in %.2f s); present mode %s; "
                "%d frames in flight; %llu renderers made (the last set in %.0f ms)\n",
                drawn, drawn > 1 && seconds > 0 ? (drawn - 1) / seconds : 0.0, drawn - 1, seconds,
                v.presenter->presentMode(), v.framesInFlight, (unsigned long long)v.renderersCreated, v.renderersMs);
    return 0;
}

int view(const ViewOptions& o, Animated& animated, const std::vector<ScriptEvent>& script, GLFWwindow* window) {
    Viewer v(o, animated);
    v.window = window;
    try {
        v.context = std::make_unique<VulkanContext>(presentableOptions());
        v.presenter = std::make_unique<Presenter>(*v.context, window, !o.noVsync);
    } catch (const VulkanError& e) {
        std::fprintf(stderr, "psub: error: view: %s\n", e.what());
        return 1;
    }
    glfwSetWindowUserPointer(window, &v);
    glfwSetCharCallback(window, onChar);
    glfwSetKeyCallback(window, onKey);
    glfwSetMouseButtonCallback(window, onButton);
    glfwSetCursorPosCallback(window, onCursor);
    glfwSetScrollCallback(window, onScroll);
    // The first tables are built here, before the loop (later ones off it).
    Built first = buildTables(animated, o.levels, o.rules, o.boundary, o.form, o.backend);
    if (!first.error.empty()) throw InputError(o.input + ": --levels " + first.error);
    v.adopt(std::move(first));
    if (v.framesInFlight > 1) v.drawThread = std::make_unique<DrawThread>([&v](Slot& slot) { v.draw(slot); });
    struct CloseLog {
        std::FILE*& f;
        ~CloseLog() {
            if (f) std::fclose(f);
        }
    } closeLog{v.log};
    if (!o.log.empty() && !(v.log = std::fopen(o.log.c_str(), "w"))) {
        std::fprintf(stderr, "psub: error: view: cannot write the log %s\n", o.log.c_str());
        return 1;
    }
    int status = 0;
    try {
        status = loop(v, script);
    } catch (const VulkanError& e) {
        std::fprintf(stderr, "psub: error: view: %s\n", e.what());
        status = 1;
    } catch (const InputError&) {
        throw;
    } catch (const std::runtime_error& e) {  // the screenshot could not be written
        std::fprintf(stderr, "psub: error: view: %s\n", e.what());
        status = 1;
    }
    if (v.drawThread && v.inFlight) {  // left by an error: its drawing ends before the renderers go
        try {
            v.drawThread->wait();
        } catch (...) {
        }
    }
    if (v.pending.valid()) v.pending.wait();
    glfwSetWindowUserPointer(window, nullptr);
    return status;
}
}  // namespace

CLI::App* addViewCommand(CLI::App& app, ViewOptions& o) {
    static const std::map<std::string, int> schemes = {{"ps", 0}, {"cc", 1}, {"both", 2}};
    static const std::map<std::string, int> wireframes = {{"none", 0}, {"refined", 1}, {"control", 2}};
    CLI::App* vi = app.add_subcommand("view", "Play an animated, refined mesh in a window (GLFW + Vulkan)");
    vi->add_option("input", o.input, "control mesh: .obj, or .gltf / .glb with skinning, morph targets and clips")
        ->required();
    vi->add_option("-l,--levels", o.levels, "P-S steps (+ and - change it)")->check(CLI::Range(0, 30))->default_val(3);
    addChoice(vi, "--scheme", o.scheme, schemes,
              "ps; cc: Catmull-Clark through OpenSubdiv (levels / 2 levels, on the CPU); both side by side", "ps");
    vi->add_option("--anim", o.animation,
                   "wave, twist or bend (procedural), or a glTF clip's name (default: a glTF file's first clip, "
                   "else wave); plays in wall-clock time, looping");
    addChoice(vi, "--backend", o.backend, kCpuOrVulkan, "where the P-S stencils and normals run: cpu or vulkan", "cpu");
    addChoice(vi, "--rules", o.rules, kRulesNames, "P-S rules: paper, or robust (r toggles)", "paper");
    static const std::map<std::string, int> forms = {{"auto", kFormAuto}, {"per-level", kFormPerLevel}, {"tiled", kFormTiled}};
    addChoice(vi, "--form", o.form, forms,
              "P-S table form: auto (as psub play: the fastest of a quick timing at each level built: the "
              "per-level rows, the tiled form, on several CPU threads the rows ordered by region; on Vulkan "
              "and several CPU threads, where tiles write under 90% of the points, the tiled form without "
              "tiles; on the CPU from 262144 refined faces the tiled form alone), per-level or tiled",
              "auto");
    addChoice(vi, "--boundary", o.boundary, kBoundaryNames, "paper, or smooth (b toggles)", "paper");
    addChoice(vi, "--wireframe", o.wireframe, wireframes, "none, refined or control (w cycles)", "none");
    addSize(vi, "--size", o.width, o.height, "window size", 1, "1280x720");
    addSamples(vi, o.samples);
    vi->add_flag("--no-vsync", o.noVsync, "present as fast as possible (to measure)");
    vi->add_flag("--no-hud", o.noHud, "hide the overlay of timings and state");
    vi->add_flag("--paused", o.paused, "start paused (space plays)");
    vi->add_option("--frames-in-flight", o.framesInFlight,
                   "2: frame n+1 is evaluated while frame n is drawn (a draw thread); 1: one after the other")
        ->check(CLI::Range(1, kMaxFramesInFlight))
        ->default_val(2);
    vi->add_option("--step", o.step,
                   "advance the animation by this many seconds per frame instead of by the wall clock "
                   "(reproducible scripts)")
        ->check(CLI::Range(0.0, 1e6));
    CLI::Option* frames =
        vi->add_option("--frames", o.frames, "exit with status 0 after this many frames")->check(CLI::Range(1, 100000000));
    vi->add_option("--script", o.script, "replay key and mouse events at frame numbers (format below)");
    vi->add_option("--screenshot", o.screenshot,
                   "with --frames: write the last frame's swapchain image as PNG (atomically)")
        ->needs(frames);
    vi->add_option("--log", o.log,
                   "write one JSON line per frame: frame, level, cc_level, scheme, refined_faces, ps_faces, cc_faces, "
                   "drawn, width, height, wireframe, playing, boundary, rules, rss_kib, validation_messages, frames_in_flight, "
                   "slot (the frame slot drawn), renderers_created (so far; each builds its pipelines once; all are made "
                   "before frame 0, again on a resize), cpu_upload (direct: CPU-evaluated vertices written into the "
                   "renderers' mapped, host-cached buffers; copy: into host arrays, then copied), frame_ms "
                   "(wall time since the last frame), "
                   "stages.{deform,upload,evaluate,normals,render,readback,present}_ms");
    vi->footer(
        "Mouse: left drag orbits, right drag pans, the wheel zooms. Keys: + / - level (tables built in the\n"
        "background; the old level draws meanwhile), s P-S / Catmull-Clark / both, w wireframe, space\n"
        "play/pause, b boundary, r rules, f frame the model, h help, Esc quits (status 0).\n"
        "The start camera is psub render's (it frames the surface at the first frame). Pixels: 8-bit\n"
        "sRGB values, as psub render writes them, shown through a UNORM swapchain (no re-encoding).\n"
        "Memory: every renderer a mode needs is made up front (8 with 2 frames in flight: slot x scheme x\n"
        "layout, each with all wireframe modes): 240 bytes per window pixel at --msaa 4 (221 MB at\n"
        "1280x720), and about 256 bytes per refined face of P-S and of Catmull-Clark (vertices,\n"
        "triangles, wireframe edges; README: \"Interactive window\").\n"
        "Script (--script FILE): one event per line, applied before drawing that frame (frames count\n"
        "from 0), # starts a comment:\n"
        "  FRAME key K                 K: + - s w space b r h f esc\n"
        "  FRAME drag left|right DX DY  orbit (left) or pan (right) by DX, DY pixels\n"
        "  FRAME scroll DY             zoom (positive: closer)\n"
        "  FRAME resize W H            resize the window\n"
        "A bad script (unknown key or event, bad numbers) is an error naming the line: exit 1.\n"
        "Needs a display: without one it exits 1; use `xvfb-run -a psub view ...` or `psub play --render`.\n"
        "Examples:\n  psub view data/spot_control_mesh.obj --levels 4 --anim twist\n"
        "  psub view data/two_bone_cylinder.glb --levels 4 --backend vulkan\n"
        "  xvfb-run -a psub view data/cube.obj --frames 60 --script keys.txt --screenshot out.png --log log.jsonl");
    return vi;
}

int runView(const ViewOptions& o) {
    const std::vector<ScriptEvent> script = o.script.empty() ? std::vector<ScriptEvent>{} : readScript(o.script);
    PlayOptions playOptions;
    playOptions.input = o.input;
    playOptions.animation = o.animation;
    Animated animated = loadAnimated(playOptions);
    GLFWwindow* window = openWindow(o);
    if (!window) return 1;
    int status = 1;
    try {
        status = view(o, animated, script, window);
    } catch (...) {
        glfwDestroyWindow(window);
        glfwTerminate();
        throw;
    }
    glfwDestroyWindow(window);
    glfwTerminate();
    return status;
}

}  // namespace psub::cli
