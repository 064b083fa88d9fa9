// psub_vulkan_measure: per-frame times of the Vulkan evaluator beside the CPU evaluator on the
// bundled models, and the overhead of one dispatch (a chain of levels that copy one vertex).
// A measurement tool, not a test; `psub bench` is the benchmark of record.
//   psub_vulkan_measure [--width W] [--max-binding BYTES] [--frames N] [MODEL.obj LEVELS]...
//   (default: spot 9 levels, cow 5 levels; width 3)
#include "psub/evaluator.h"
#include "psub/stencils.h"
#include "psub/vulkan_evaluator.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <vector>

#include <time.h>

namespace {

using namespace psub;
using Clock = std::chrono::steady_clock;

double msSince(Clock::time_point start) {
    return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

// CPU time of the whole process (lavapipe's threads included), in ms: less disturbed than
// wall time when other programs share the cores.
double processMs() {
    timespec t{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return double(t.tv_sec) * 1e3 + double(t.tv_nsec) * 1e-6;
}

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v.empty() ? 0 : v[v.size() / 2];
}

double least(const std::vector<double>& v) { return v.empty() ? 0 : *std::min_element(v.begin(), v.end()); }

// Control points of frame `frame` of a wave: xyz, then (width > 3) copies of x.
std::vector<float> wave(const std::vector<double>& positions, int frame, std::uint32_t width) {
    std::vector<float> control(positions.size() / 3 * width);
    for (std::size_t v = 0; v < positions.size() / 3; ++v)
        for (std::uint32_t i = 0; i < width; ++i) {
            const std::uint32_t axis = i < 3 ? i : 0;
            control[width * v + i] =
                float(positions[3 * v + axis] + (axis == 1 ? 0.05 * std::sin(positions[3 * v] + 0.3 * frame) : 0));
        }
    return control;
}

struct Settings {
    std::uint32_t width = 3;
    std::uint64_t maxBinding = 0;
    int frames = 15;
};

void measureModel(VulkanContext& context, const std::string& path, int levels, const Settings& settings) {
    const int frames = settings.frames;
    const std::uint32_t width = settings.width;
    const Mesh mesh = readObj(path);
    const CheckedMesh checked = checkMesh(mesh);
    const Refinement r = refine(mesh, checked.connectivity, {levels, Preprocess::Auto, true, {}});
    std::printf("\n%s, %d P-S levels%s: %u control points -> %u vertices, %zu faces\n", path.c_str(), levels,
                r.preprocessed ? " (after preprocessing)" : "", r.perLevel.controlCount, r.perLevel.refinedCount(),
                r.surface.faceOffsets.size() - 1);
    std::printf("  %-10s %-22s %10s %10s %10s %10s %6s   (medians; min in brackets)\n", "form", "frame", "wall ms",
                "gpu ms", "stencil ms", "cpu ms", "disp.");
    std::vector<float> refined(width * std::size_t(r.perLevel.refinedCount())),
        normals(3 * std::size_t(r.perLevel.refinedCount())), cpuRefined(refined.size());
    for (TableForm form : {TableForm::PerLevel, TableForm::Factorized}) {
        VulkanEvaluator gpu(context, r.perLevel, r.factorized, r.surface, form, width, {Staging::Auto, settings.maxBinding});
        CpuEvaluator<float> cpu(r.perLevel, r.factorized, r.surface, form, width);
        std::vector<double> cpuMs, cpuCpuMs;
        for (int f = 0; f < frames; ++f) {
            const std::vector<float> control = wave(mesh.positions, f, width);
            const auto start = Clock::now();
            const double cpuStart = processMs();
            cpu.evaluate(control, cpuRefined);
            cpuMs.push_back(msSince(start));
            cpuCpuMs.push_back(processMs() - cpuStart);
        }
        struct Variant {
            const char* name;
            bool readBack, withNormals;
        };
        for (const Variant& variant : {Variant{"stay on device", false, false}, Variant{"read back", true, false},
                                       Variant{"read back + normals", true, true}}) {
            std::vector<double> wall, gpuTotal, gpuStencils, cpuTime;
            for (int f = 0; f < frames; ++f) {
                const std::vector<float> control = wave(mesh.positions, f, width);
                const double cpuStart = processMs();
                const auto start = Clock::now();
                gpu.evaluate(control, variant.readBack ? std::span<float>(refined) : std::span<float>(),
                             variant.withNormals ? std::span<float>(normals) : std::span<float>());
                wall.push_back(msSince(start));
                cpuTime.push_back(processMs() - cpuStart);
                gpuTotal.push_back(gpu.lastFrameTimes().totalMs);
                gpuStencils.push_back(gpu.lastFrameTimes().levelsMs);
            }
            std::printf("  %-10s %-22s %10.3f %10.3f %10.3f %10.3f %6zu   [%.3f %.3f %.3f %.3f]  cpu-time %.2f vs %.2f\n",
                        form == TableForm::PerLevel ? "per-level" : "factorized", variant.name, median(wall),
                        median(gpuTotal), median(gpuStencils), median(cpuMs), gpu.dispatchCount(variant.withNormals),
                        least(wall), least(gpuTotal), least(gpuStencils), least(cpuMs), median(cpuTime), median(cpuCpuMs));
        }
        // Agreement with the CPU on the last frame.
        const std::vector<float> control = wave(mesh.positions, 0, width);
        cpu.evaluate(control, cpuRefined);
        gpu.evaluate(control, refined);
        double worst = 0;
        for (std::size_t i = 0; i < refined.size(); ++i) worst = std::max(worst, std::abs(double(refined[i]) - cpuRefined[i]));
        std::printf("  %-10s max |vulkan - cpu| = %.3g\n", "", worst);
    }
}

// A table of `levels` levels, each one row copying the one control point: a chain of
// dispatches that do (almost) nothing, with a barrier after each.
PerLevelTable chain(std::uint32_t levels) {
    PerLevelTable t;
    t.controlCount = 1;
    for (std::uint32_t k = 0; k < levels; ++k) {
        t.levels.push_back({1, 1, k, k + 1, k, k + 1});
        t.groups.push_back({RowKind::Retained, 0, 0, 1, k, 1, k, 1.0, 0.0, 0.0});
        t.destinations.push_back(0);
        t.indices.push_back(0);
    }
    return t;
}

void measureDispatchOverhead(VulkanContext& context, int frames) {
    std::printf("\nDispatch overhead (chains of one-row levels, each a dispatch and a barrier):\n");
    std::printf("  %8s %12s %12s %16s %16s\n", "levels", "wall ms", "gpu ms", "gpu us/dispatch", "wall us/dispatch");
    double wall1 = 0, gpu1 = 0;
    for (std::uint32_t levels : {1u, 10u, 100u, 1000u}) {
        const PerLevelTable table = chain(levels);
        VulkanEvaluator gpu(context, table, {}, {}, TableForm::PerLevel, 3);
        const float control[3] = {1, 2, 3};
        float refined[3];
        std::vector<double> wall, gpuMs;
        for (int f = 0; f < frames; ++f) {
            const auto start = Clock::now();
            gpu.evaluate(control, refined);
            wall.push_back(msSince(start));
            gpuMs.push_back(gpu.lastFrameTimes().totalMs);
        }
        const double w = median(wall), g = median(gpuMs);
        if (levels == 1) wall1 = w, gpu1 = g;
        std::printf("  %8u %12.3f %12.3f %16.2f %16.2f\n", levels, w, g,
                    levels > 1 ? (g - gpu1) * 1e3 / (levels - 1) : 0.0, levels > 1 ? (w - wall1) * 1e3 / (levels - 1) : 0.0);
    }
}

}  // namespace

int main(int argc, char** argv) {
    try {
        VulkanContext context(VulkanOptions{Validation::Default, "", true, false});
        Settings settings;
        std::vector<std::pair<std::string, int>> models;
        for (int i = 1; i < argc; ++i) {
            const std::string arg = argv[i];
            if (i + 1 >= argc) throw std::runtime_error("expected a value after " + arg);
            if (arg == "--width") settings.width = std::uint32_t(std::atoi(argv[++i]));
            else if (arg == "--max-binding") settings.maxBinding = std::strtoull(argv[++i], nullptr, 10);
            else if (arg == "--frames") settings.frames = std::atoi(argv[++i]);
            else models.emplace_back(arg, std::atoi(argv[++i]));
        }
        if (models.empty())
            models = {{std::string(PSUB_DATA_DIR) + "/spot_control_mesh.obj", 9}, {std::string(PSUB_DATA_DIR) + "/cow.obj", 5}};
        for (const auto& [path, levels] : models) measureModel(context, path, levels, settings);
        measureDispatchOverhead(context, 31);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "psub_vulkan_measure: %s\n", e.what());
        return 1;
    }
    return 0;
}
