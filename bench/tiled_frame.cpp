// psub_tiled_frame (a benchmark, not a test): per-frame time of the tiled form against the
// per-level rows of one model, on 1 and 2 threads, several rounds interleaved, medians, and the
// ratio to the triad floor (12 B per refined vertex at the triad bandwidth of the same thread
// count) measured in the same run. Memory as psub allocates it (its malloc settings and huge pages).
//   psub_tiled_frame MODEL|torus:N LEVELS [FRAMES=20] [ROUNDS=3] [profile|build|build-per-level|build-lean|pair|normals|context|sets]
// With "profile", only the tiled form on 1 thread, FRAMES x ROUNDS frames (for perf); with
// "build", only the builds, ROUNDS times each in one process
// (the per-level table with its surface; the tiled form's lean build), for perf, and with
// "build-per-level" or "build-lean" only one of them; with "pair",
// the per-level rows of one mesh on 1 thread, of two copies side by side on 2 threads, and of
// one mesh on 2 threads (what a second thread is worth to one mesh, and to two), then the
// region-ordered copy of the table (orderLevelsByRegion) on 1 and 2 threads; with "normals", on
// 2 threads, the tiled form's frame without and with normals, and the per-level form's normals();
// with "context", on 2 threads, the tiled form's frame back to back, after a frame with normals
// and after 256 MB written (what the caches hold between frames); with "sets", the tile
// kernel's instruction sets this CPU has, frame by frame in turn, on 1 and 2 threads, positions
// and with normals.
#include "detail.h"
#include "psub/evaluator.h"
#include "psub/stencils.h"

#include <malloc.h>
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <climits>
#include <cmath>
#include <cstdio>
#include <string>
#include <time.h>
#include <vector>

namespace {

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
}

// Wall milliseconds of work().
template <class Work>
double msOf(Work&& work) {
    const auto start = std::chrono::steady_clock::now();
    work();
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

// Median ms of `frames` evaluations, the control points moving before each.
double frameMs(psub::CpuEvaluator<float>& evaluator, std::vector<float>& control, std::vector<float>& out, int frames) {
    std::vector<double> times;
    for (int f = 0; f < frames + 2; ++f) {
        for (std::size_t i = 0; i < control.size(); i += 3) control[i + 2] += 1e-4f * float((f + i) % 7);
        const double ms = msOf([&] { evaluator.evaluate(control, out); });
        if (f >= 2) times.push_back(ms);
    }
    return median(times);
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 3) {
        std::fprintf(stderr, "usage: psub_tiled_frame MODEL|torus:N LEVELS [FRAMES] [ROUNDS] [profile|build|build-per-level|build-lean|pair|normals|context|sets]\n");
        return 2;
    }
    const std::string model = argv[1];
    using psub::bench::parseArgument;
    const int levels = int(parseArgument(argv[2], "LEVELS", 0, 30)),
              frames = argc > 3 ? int(parseArgument(argv[3], "FRAMES", 1, 1e6)) : 20,
              rounds = argc > 4 ? int(parseArgument(argv[4], "ROUNDS", 1, 1000)) : 3;
    psub::Mesh mesh;
    try {
        mesh = psub::bench::benchMesh(model);
    } catch (const psub::InputError& e) {
        std::fprintf(stderr, "psub_tiled_frame: error: %s\n", e.what());
        return 1;
    }
    // As cli/main.cpp's tuneAllocator, and with its operator new (cli/huge_pages.cpp, linked in):
    // psub's allocator settings in every mode. Until session 43 the build modes had the first two
    // only: the cow's lean build at 7 steps then spent 116 ms of its 400-430 faulting in the
    // rows' last two levels (244-256 ms with huge pages, as psub builds it).
    mallopt(M_MMAP_THRESHOLD, 32 << 20);
    mallopt(M_TRIM_THRESHOLD, INT_MAX);
    mallopt(M_TOP_PAD, 64 << 20);
    const psub::CheckedMesh checked = psub::checkMesh(mesh);
    psub::RefineOptions options{levels, psub::Preprocess::Auto, false, {}};
    const std::string mode = argc > 5 ? argv[5] : "";
    if (mode == "build" || mode == "build-per-level" || mode == "build-lean") {
        for (int round = 0; round < rounds; ++round) {
            // One at a time: each build's memory is free again for the next.
            psub::Refinement r;
            if (mode != "build-lean") {
                options.tiled = false;
                options.perLevel = true;
                r = psub::refine(mesh, checked.connectivity, options);
                std::printf("per-level build: topology %.1f ms, rows and surface %.1f ms%s", r.topologyMs, r.perLevelMs,
                            mode == "build" ? "; " : "\n");
                r = {};
            }
            if (mode != "build-per-level") {
                options.tiled = true;
                options.perLevel = false;
                r = psub::refine(mesh, checked.connectivity, options);
                std::printf("lean tiled build: topology %.1f ms, tiled table %.1f ms\n", r.topologyMs, r.tiledMs);
            }
        }
        return 0;
    }
    options.tiled = true;
    const psub::Refinement r = psub::refine(mesh, checked.connectivity, options);
    const psub::TiledTable& tiled = r.tiled;
    std::printf("%s, %d P-S levels: %zu faces, %u vertices; t = %u, B = %u, %zu tiles, %.1f%% tiled\n", model.c_str(),
                levels, r.surface.faceOffsets.size() - 1, tiled.refinedCount, tiled.doubleSteps, tiled.baseLevel,
                tiled.tileCount(), 100.0 * tiled.fallbackBegin / std::max(1u, tiled.refinedCount));
    options.perLevel = false;
    const psub::Refinement lean = psub::refine(mesh, checked.connectivity, options);
    std::printf("build: topology %.1f ms, per-level rows %.1f ms, tiled table %.1f ms; the lean build: topology %.1f ms, "
                "tiled table %.1f ms\n",
                r.topologyMs, r.perLevelMs, r.tiledMs, lean.topologyMs, lean.tiledMs);
    std::vector<float> control(mesh.positions.begin(), mesh.positions.end());
    std::vector<float> out(3 * std::size_t(tiled.refinedCount));
    const double bytes = 12.0 * tiled.refinedCount;
    if (mode == "normals") {
        using Evaluator = psub::CpuEvaluator<float>;
        Evaluator tiledForm(tiled, 3, 2), perLevelForm(r.perLevel, r.factorized, r.surface, psub::TableForm::PerLevel, 3, 2);
        std::vector<float> normals(out.size()), canonical(out.size());
        for (int round = 0; round < rounds; ++round) {
            std::vector<double> positions, withNormals, perLevelNormals;
            for (int f = 0; f < frames; ++f) {
                positions.push_back(msOf([&] { tiledForm.evaluate(control, out); }));
                withNormals.push_back(msOf([&] { tiledForm.evaluate(control, out, normals); }));
                perLevelForm.evaluate(control, canonical);
                perLevelNormals.push_back(msOf([&] { perLevelForm.normals(canonical, normals); }));
            }
            std::printf("tiled frame %.3f ms, with normals %.3f ms (normals %.3f); per-level normals() %.3f ms\n",
                        median(positions), median(withNormals), median(withNormals) - median(positions),
                        median(perLevelNormals));
        }
        return 0;
    }
    if (mode == "sets") {
        // The tile kernel's instruction sets (setTileKernelInstructions) frame by frame in one
        // process, on 1 and 2 threads, positions and with normals: the VM's state changes
        // between processes, not within a frame's neighbours.
        std::vector<std::string> sets;
        for (const char* set : {"avx512f", "avx2", "baseline"})
            if (psub::setTileKernelInstructions(set)) sets.push_back(set);
        std::vector<float> normals(out.size());
        for (int threads : {1, 2}) {
            psub::CpuEvaluator<float> tiledForm(tiled, 3, threads);
            for (int round = 0; round < rounds; ++round) {
                std::vector<std::vector<double>> positions(sets.size()), withNormals(sets.size());
                for (int f = 0; f < frames; ++f)
                    for (std::size_t k = 0; k < sets.size(); ++k) {
                        psub::setTileKernelInstructions(sets[k]);
                        positions[k].push_back(msOf([&] { tiledForm.evaluate(control, out); }));
                        withNormals[k].push_back(msOf([&] { tiledForm.evaluate(control, out, normals); }));
                    }
                std::printf("threads %d:", threads);
                for (std::size_t k = 0; k < sets.size(); ++k)
                    std::printf(" %s %.3f ms (with normals %.3f)", sets[k].c_str(), median(positions[k]), median(withNormals[k]));
                std::printf("\n");
            }
        }
        return 0;
    }
    if (mode == "pair") {
        // Does a second thread help one mesh as much as it helps two? The per-level rows of one
        // mesh on 1 thread, of two copies side by side (one evaluator of 1 thread each, both
        // threads at once) and of one mesh on 2 threads, FRAMES frames of each in turn.
        using Evaluator = psub::CpuEvaluator<float>;
        Evaluator one(r.perLevel, r.factorized, r.surface, psub::TableForm::PerLevel, 3, 1);
        Evaluator copy(r.perLevel, r.factorized, r.surface, psub::TableForm::PerLevel, 3, 1);
        Evaluator two(r.perLevel, r.factorized, r.surface, psub::TableForm::PerLevel, 3, 2);
        psub::PerLevelTable regions = r.perLevel;
        const double orderMs = msOf([&] { psub::orderLevelsByRegion(regions, 2); });
        Evaluator regionOne(regions, r.factorized, r.surface, psub::TableForm::PerLevel, 3, 1);
        Evaluator regionTwo(regions, r.factorized, r.surface, psub::TableForm::PerLevel, 3, 2);
        std::vector<float> out2(out.size());
        two.evaluate(control, out);
        regionTwo.evaluate(control, out2);
        if (out != out2) {
            std::fprintf(stderr, "psub_tiled_frame: the region-ordered table gave other values\n");
            return 1;
        }
        // The tiled form with its rows up to level B ordered by region (level B, which the tiles
        // gather from, keeps its numbering).
        psub::TiledTable tiledRegions = tiled;
        psub::orderLevelsByRegion(tiledRegions.rows, 2, tiled.baseLevel);
        Evaluator tiledTwo(tiled, 3, 2), tiledRegionTwo(tiledRegions, 3, 2);
        tiledTwo.evaluate(control, out);
        tiledRegionTwo.evaluate(control, out2);
        if (out != out2) {
            std::fprintf(stderr, "psub_tiled_frame: the region-ordered tiled table gave other values\n");
            return 1;
        }
        std::printf("region order: %.1f ms to make; frames equal to the table's\n", orderMs);
        const auto timed = [&](auto&& frame) {
            std::vector<double> times;
            for (int f = 0; f < frames; ++f) times.push_back(msOf(frame));
            return median(times);
        };
        for (int round = 0; round < rounds; ++round) {
            const double single = timed([&] { one.evaluate(control, out); });
            const double sideBySide = timed([&] {
#pragma omp parallel num_threads(2)
                (omp_get_thread_num() == 0 ? one : copy).evaluate(control, omp_get_thread_num() == 0 ? out : out2);
            });
            const double shared = timed([&] { two.evaluate(control, out); });
            const double regionSingle = timed([&] { regionOne.evaluate(control, out); });
            const double regionShared = timed([&] { regionTwo.evaluate(control, out); });
            const double tiledShared = timed([&] { tiledTwo.evaluate(control, out); });
            const double tiledRegionShared = timed([&] { tiledRegionTwo.evaluate(control, out); });
            std::printf("per-level rows: one mesh on 1 thread %.3f ms; two copies side by side %.3f ms; "
                        "one mesh on 2 threads %.3f ms; region-ordered, 1 thread %.3f ms, 2 threads %.3f ms; "
                        "tiled, 2 threads %.3f ms, region-ordered up to level B %.3f ms\n",
                        single, sideBySide, shared, regionSingle, regionShared, tiledShared, tiledRegionShared);
        }
        return 0;
    }
    if (mode == "context") {
        // The tiled form's positions on 2 threads in three states of the caches: frames back to
        // back (as the other modes and psub bench time them); each after a frame with normals (as
        // psub play runs them: the normals pass's bytes between two evaluations); each after 256 MB
        // written by both threads (nothing of the frame's left in any cache).
        psub::CpuEvaluator<float> tiledEvaluator(tiled, 3, 2);
        std::vector<float> normals(out.size());
        std::vector<char> junk(std::size_t(256) << 20, 1);
        const auto ms = [&] { return msOf([&] { tiledEvaluator.evaluate(control, out); }); };
        for (int round = 0; round < rounds; ++round) {
            std::vector<double> warm, afterNormals, cold;
            for (int f = 0; f < frames; ++f) warm.push_back(ms());
            for (int f = 0; f < frames; ++f) {
                tiledEvaluator.evaluate(control, out, normals);
                afterNormals.push_back(ms());
            }
            for (int f = 0; f < frames; ++f) {
#pragma omp parallel for num_threads(2)
                for (int half = 0; half < 2; ++half)
                    std::fill(junk.begin() + std::ptrdiff_t(half * junk.size() / 2),
                              junk.begin() + std::ptrdiff_t((half + 1) * junk.size() / 2), char(f));
                cold.push_back(ms());
            }
            std::printf("tiled, 2 threads: back to back %.3f ms, after a frame with normals %.3f ms, after 256 MB "
                        "written %.3f ms (medians)\n",
                        median(warm), median(afterNormals), median(cold));
        }
        return 0;
    }
    if (mode == "profile") {
        // The thread's CPU time per frame too: on a shared machine it counts only this work.
        psub::CpuEvaluator<float> tiledEvaluator(tiled, 3, 1);
        std::vector<double> cpu;
        for (int f = 0; f < frames * rounds; ++f) {
            timespec a{}, b{};
            clock_gettime(CLOCK_THREAD_CPUTIME_ID, &a);
            tiledEvaluator.evaluate(control, out);
            clock_gettime(CLOCK_THREAD_CPUTIME_ID, &b);
            cpu.push_back(double(b.tv_sec - a.tv_sec) * 1e3 + double(b.tv_nsec - a.tv_nsec) / 1e6);
        }
        std::printf("tiled, 1 thread: %.3f ms wall, %.3f ms CPU (medians); floor %.3f ms at %.1f GB/s\n",
                    frameMs(tiledEvaluator, control, out, frames), median(cpu),
                    bytes / (psub::bench::detail::measureTriad(1, std::size_t(1) << 25, 5) * 1e9) * 1e3,
                    psub::bench::detail::measureTriad(1, std::size_t(1) << 25, 3));
        return 0;
    }
    for (int threads : {1, 2}) {
        const double triad = psub::bench::detail::measureTriad(threads, std::size_t(1) << 25, 5);
        psub::CpuEvaluator<float> perLevel(r.perLevel, r.factorized, r.surface, psub::TableForm::PerLevel, 3, threads);
        psub::CpuEvaluator<float> tiledEvaluator(tiled, 3, threads);
        std::vector<double> perLevelMs, tiledMs;
        for (int round = 0; round < rounds; ++round) {
            perLevelMs.push_back(frameMs(perLevel, control, out, frames));
            tiledMs.push_back(frameMs(tiledEvaluator, control, out, frames));
        }
        const double floorMs = bytes / (triad * 1e9) * 1e3, p = median(perLevelMs), t = median(tiledMs);
        std::printf("threads %d: triad %.1f GB/s, floor %.3f ms; per-level %.3f ms (%.1fx floor); tiled %.3f ms "
                    "(%.1fx floor), %.2fx faster than per-level",
                    threads, triad, floorMs, p, p / floorMs, t, t / floorMs, p / t);
        if (threads > 1) std::printf("; core round trip %.0f ns", psub::bench::detail::measureCoreRoundTrip(100000));
        std::printf("\n");
    }
    return 0;
}
