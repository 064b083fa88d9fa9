// The CLI's one choice of backend: makeEvaluator turns --backend into an Evaluator (the
// contract of psub/evaluate.h); nothing after it branches on the backend. And the auto table
// form of psub play and psub view (autoTimesPerLevel, fasterForm).
#pragma once

#include "commands.h"
#include "psub/evaluate.h"
#if PSUB_HAVE_VULKAN
#include "psub/vulkan_evaluator.h"
#endif

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
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

// `ms` with three decimals.
inline std::string millis(double ms) {
    char text[32];
    std::snprintf(text, sizeof text, "%.3f", ms);
    return text;
}

// The fastest of 9 evaluations of `control` into `out` (3 x refined floats) with normals, as
// psub play and psub view run every frame (the tiled form computes most normals in its tile
// pass, the others in passes after the positions), in milliseconds, after one to warm up. The
// minimum, not the median: on a shared machine noise only adds (the median of 5 picked the
// slower of two candidates 0.5 ms apart in one of three loads of Spot at 10 steps).
inline double quickFrameMs(Evaluator& evaluator, const std::vector<float>& control, std::vector<float>& out) {
    std::vector<float> normals(out.size());
    double fastest = 1e300;
    evaluator.evaluate(control, out, normals);  // warm-up
    for (int k = 0; k < 9; ++k) {
        const auto start = std::chrono::steady_clock::now();
        evaluator.evaluate(control, out, normals);
        fastest = std::min(fastest, std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
    }
    return fastest;
}

// Auto builds and times the per-level candidates too (the full build), unless it runs on the CPU
// at kTiledAloneFaces refined faces or more (and two steps or more): there it builds the tiled
// form alone (its lean build, as --form tiled) and times only it. The per-level rows (the same
// rows in the canonical order, or ordered by region) were slower there on every mesh measured,
// on one thread and on two, by 1.3-4.6x (the tiled form's normals run in one pass over its walk
// order), and building and timing them was most of the start: the cow at 7 steps (1.1M faces,
// two threads) 1.69 s against 0.38 s forced tiled (bench/README.md, "Session 32").
constexpr std::uint64_t kTiledAloneFaces = std::uint64_t(1) << 18;
inline bool autoTimesPerLevel(Backend backend, std::uint64_t refinedFaces, int levels) {
    return backend != Backend::Cpu || refinedFaces < kTiledAloneFaces || levels < 2;
}

// The auto table form, by a quick timing (quickFrameMs: positions and normals, on `backend`) of
// each candidate on `control`:
// - the per-level rows (where `r` has them: autoTimesPerLevel);
// - the tiled form of `r`; without a tile, the fallback's rows alone in walk order
//   (docs/tiled.md) and its normals in one pass over that order, faster on one CPU thread too
//   (the cow at 7 steps 91-105 fps against 51-53, the double torus 82 against 43);
// - on the CPU when a frame runs on several threads, both with their rows ordered by region, one
//   region per thread (orderLevelsByRegion, the tiled form's rows up to its level B;
//   docs/design.md, "Threads and regions": faster where a thread reading another's fresh writes
//   is dear, slower on one thread);
// - on Vulkan, and on the CPU when a frame runs on several threads, where
//   worthTimingWithoutTiles(r.tiled): the tiled form without a tile, from `withoutTiles` (a lean
//   build with TileSides::None; none given: not timed), every point the fallback's, in walk
//   order, its normals in a pass after. Faster on two CPU threads on Spot at 5 to 11 steps (at 9:
//   0.51 ms against 0.76-0.78 with normals), slower at 12, and on lavapipe at 9 (5.3-5.5 ms
//   against 6.0-6.3) (docs/tiled.md, "Tiles or none"). When it wins, it replaces r.tiled; on
//   Vulkan the tiled evaluator timed before is let go first, and made again if it wins (one
//   mesh's tables on the device at a time).
// One evaluator at a time (a device's memory may hold one mesh's tables, not two): `tiled` is the
// tiled one when it won, else empty (make the per-level one again). The rows of the winner stay
// region-ordered if that won (the same output, bit for bit). `reason`: "auto: ...", for
// summaries. On lavapipe the tile kernel's first compile takes seconds (Mesa's shader cache keeps
// it).
struct FormChoice {
    TableForm form = TableForm::PerLevel;
    std::unique_ptr<Evaluator> tiled;
    std::string reason;
};
template <class Refinement>
FormChoice fasterForm(Backend backend, Refinement& r, VulkanContext* context, const std::vector<float>& control,
                      std::vector<float>& out, const std::function<TiledTable()>& withoutTiles = {}) {
    FormChoice choice;
    const bool tiles = r.tiled.tileCount() > 0;
    const double tiledShare = 100.0 * r.tiled.fallbackBegin / std::max(1u, r.tiled.refinedCount);
    const bool perLevel = !r.perLevel.levels.empty() || r.tiled.rows.levels.empty();  // built (not the lean build)
    const PerLevelTable& rows = perLevel ? r.perLevel : r.tiled.rows;
    const int threads =
        backend == Backend::Cpu && rows.regions == 1 && rows.levels.size() > 1 ? perLevelFrameThreads(rows) : 1;
    const std::string byRegions = " by " + std::to_string(threads) + " regions";
    double bestMs = INFINITY;
    std::string times = "rest pose with normals ";
    if (perLevel) {
        bestMs = quickFrameMs(*makeEvaluator(backend, tablesOf(r), TableForm::PerLevel, context), control, out);
        times += millis(bestMs) + " ms per-level, ";
    }
    {
        std::unique_ptr<Evaluator> tiled = makeEvaluator(backend, tablesOf(r), TableForm::Tiled, context);
        const double tiledMs = quickFrameMs(*tiled, control, out);
        times += millis(tiledMs) + " ms tiled";
        if (tiledMs < bestMs) bestMs = tiledMs, choice.form = TableForm::Tiled, choice.tiled = std::move(tiled);
        if (tiles && threads > 1 && r.tiled.baseLevel > 1) {  // rows to order before level B
            std::unique_ptr<Evaluator> asRefined = std::move(choice.tiled);  // it reads r.tiled.rows
            PerLevelTable refinedRows = r.tiled.rows;
            orderLevelsByRegion(r.tiled.rows, std::uint32_t(threads), r.tiled.baseLevel);
            tiled = makeEvaluator(backend, tablesOf(r), TableForm::Tiled, context);
            const double regionMs = quickFrameMs(*tiled, control, out);
            times += ", " + millis(regionMs) + " ms tiled" + byRegions;
            if (regionMs < bestMs) {
                bestMs = regionMs, choice.form = TableForm::Tiled, choice.tiled = std::move(tiled);
            } else {
                tiled.reset();
                r.tiled.rows = std::move(refinedRows);
                choice.tiled = std::move(asRefined);
            }
        }
    }
    bool untiled = false;
    if (withoutTiles && (backend == Backend::Vulkan || threads > 1) && worthTimingWithoutTiles(r.tiled)) {
        TiledTable none = withoutTiles();
        const bool heldTiled = choice.tiled != nullptr;
        if (backend == Backend::Vulkan) choice.tiled.reset();
        const EvaluatorTables tables{r.perLevel, r.factorized, r.surface, none};
        double noneMs = INFINITY;
        {
            std::unique_ptr<Evaluator> candidate = makeEvaluator(backend, tables, TableForm::Tiled, context);
            noneMs = quickFrameMs(*candidate, control, out);
        }
        times += ", " + millis(noneMs) + " ms tiled without tiles";
        if (noneMs < bestMs) {
            bestMs = noneMs, untiled = true, choice.form = TableForm::Tiled, choice.tiled.reset();
            r.tiled = std::move(none);  // the evaluator made below reads it there
        }
        if (untiled || (heldTiled && !choice.tiled))
            choice.tiled = makeEvaluator(backend, tablesOf(r), TableForm::Tiled, context);
    }
    if (perLevel && threads > 1) {
        PerLevelTable regions = r.perLevel;
        orderLevelsByRegion(regions, std::uint32_t(threads));
        const EvaluatorTables tables{regions, r.factorized, r.surface, r.tiled};
        const double regionMs = quickFrameMs(*makeEvaluator(backend, tables, TableForm::PerLevel, context), control, out);
        times += ", " + millis(regionMs) + " ms per-level" + byRegions;
        if (regionMs < bestMs) choice.form = TableForm::PerLevel, choice.tiled.reset(), r.perLevel = std::move(regions);
    }
    if (!perLevel) times += "; per-level untimed from " + std::to_string(kTiledAloneFaces) + " faces";
    choice.reason = !tiles    ? "auto: no regular tiles; " + times
                    : untiled ? "auto: no tiles (" + std::to_string(int(std::lround(tiledShare))) +
                                    "% of the points were tiled); " + times
                              : "auto: " + std::to_string(int(std::lround(tiledShare))) + "% of the points tiled; " + times;
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
