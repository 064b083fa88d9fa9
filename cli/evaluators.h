// The CLI's one choice of backend: makeEvaluator turns --backend into an Evaluator (the
// contract of psub/evaluate.h); nothing after it branches on the backend. And the auto table
// form of psub play and psub view (fasterForm).
#pragma once

#include "commands.h"
#include "psub/evaluate.h"
#if PSUB_HAVE_VULKAN
#include "psub/vulkan_evaluator.h"
#endif

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace psub {
class VulkanContext;
}

namespace psub::cli {

// Backend::Vulkan runs on `context` (a VulkanContext the caller created, which must outlive the
// evaluator) or, when it is null, on a context of the evaluator's own; Backend::Cpu ignores it.
// Throws VulkanError (a std::runtime_error) when no Vulkan device is usable, and
// std::runtime_error for Vulkan in a psub built without it.
inline std::unique_ptr<Evaluator> makeEvaluator(Backend backend, const EvaluatorTables& tables, TableForm form,
                                                [[maybe_unused]] VulkanContext* context) {
    if (backend != Backend::Vulkan) return makeCpuEvaluator(tables, form);
#if PSUB_HAVE_VULKAN
    return context ? makeVulkanEvaluator(*context, tables, form) : makeVulkanEvaluator(tables, form);
#else
    throw std::runtime_error("this psub was built without Vulkan (PSUB_BUILD_VULKAN=OFF)");
#endif
}

// Median milliseconds of 5 evaluations of `control` into `out` (3 x refined floats), after one
// to warm up.
inline double quickFrameMs(Evaluator& evaluator, const std::vector<float>& control, std::vector<float>& out) {
    std::vector<double> ms;
    evaluator.evaluate(control, out);  // warm-up
    for (int k = 0; k < 5; ++k) {
        const auto start = std::chrono::steady_clock::now();
        evaluator.evaluate(control, out);
        ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
    }
    std::sort(ms.begin(), ms.end());
    return ms[ms.size() / 2];
}

// The auto table form: the tiled one when `r` (built with both forms) has tiles and a quick
// timing of both on `control` (quickFrameMs, on `backend`) finds it faster than the per-level
// rows; on meshes whose finest points come mostly from the fallback it is slower
// (docs/tiled.md). One evaluator at a time (a device's memory may hold one mesh's tables, not
// two): `tiled` is the tiled one when it won, else empty (make the per-level one again).
// `reason`: "auto: ...", for summaries. On lavapipe the tile kernel's first compile takes
// seconds (Mesa's shader cache keeps it).
struct FormChoice {
    TableForm form = TableForm::PerLevel;
    std::unique_ptr<Evaluator> tiled;
    std::string reason;
};
template <class Refinement>
FormChoice fasterForm(Backend backend, const Refinement& r, VulkanContext* context, const std::vector<float>& control,
                      std::vector<float>& out) {
    FormChoice choice;
    if (r.tiled.tileCount() == 0) {
        choice.reason = "auto: no regular tiles";
        return choice;
    }
    const double perLevelMs = quickFrameMs(*makeEvaluator(backend, tablesOf(r), TableForm::PerLevel, context), control, out);
    std::unique_ptr<Evaluator> tiled = makeEvaluator(backend, tablesOf(r), TableForm::Tiled, context);
    const double tiledMs = quickFrameMs(*tiled, control, out);
    if (tiledMs < perLevelMs) choice.form = TableForm::Tiled, choice.tiled = std::move(tiled);
    char reason[160];
    std::snprintf(reason, sizeof reason, "auto: %.0f%% of the points tiled; rest pose %.3f ms tiled, %.3f ms per-level",
                  100.0 * r.tiled.fallbackBegin / std::max(1u, r.tiled.refinedCount), tiledMs, perLevelMs);
    choice.reason = reason;
    return choice;
}

// Once the tiled form is chosen nothing reads the per-level table or its canonical surface
// (the tiled table holds its own rows and faces), so their memory goes back: `psub play` of
// the 1M-face torus held 267 MB while playing, now 203 MB.
inline void dropPerLevelTables(Refinement& r) {
    r.perLevel = PerLevelTable{};
    r.surface = SurfaceTable{};
}

}  // namespace psub::cli
