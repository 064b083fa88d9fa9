// psub_many_meshes (a benchmark, not a test): COUNT copies of a small mesh, one evaluator each,
// evaluated every frame, against one mesh of about the same total faces (issue 13, "many
// meshes"): frame times, throughput in refined faces per ms, and the fixed cost per mesh per
// frame. The small meshes run either one after another (each evaluator on all threads; small
// meshes get one) or side by side (an outer loop over the meshes across the threads, each
// evaluator on one); positions alone, and positions with normals. The three are timed in turn,
// ROUNDS times, so that a slow spell of the machine falls on all of them: each round gives the
// ratios of its own times, and the medians and ranges over the rounds are printed.
//   psub_many_meshes SMALL LEVELS BIG BIG_LEVELS [COUNT=50] [FRAMES=30] [FORM=tiled|per-level] [ROUNDS=5]
//   (SMALL, BIG: an OBJ path or torus:N)
#include "detail.h"
#include "psub/evaluator.h"
#include "psub/stencils.h"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace {

using Clock = std::chrono::steady_clock;

struct Model {
    psub::Mesh mesh;
    psub::Refinement refinement;
    std::uint64_t faces = 0;
};

Model refined(const std::string& name, int levels, bool tiled) {
    Model m{psub::bench::benchMesh(name), {}, 0};
    const psub::CheckedMesh checked = psub::checkMesh(m.mesh);
    psub::RefineOptions options{levels, psub::Preprocess::Auto, false, {}};
    options.tiled = tiled;
    options.perLevel = !tiled;  // the tiled form alone: its lean build
    m.refinement = psub::refine(m.mesh, checked.connectivity, options);
    m.faces = (tiled ? m.refinement.tiled.surface : m.refinement.surface).faceOffsets.size() - 1;
    return m;
}

std::unique_ptr<psub::CpuEvaluator<float>> evaluatorFor(const Model& m, bool tiled, int threads) {
    const psub::Refinement& r = m.refinement;
    if (tiled) return std::make_unique<psub::CpuEvaluator<float>>(r.tiled, 3, threads);
    return std::make_unique<psub::CpuEvaluator<float>>(r.perLevel, r.factorized, r.surface, psub::TableForm::PerLevel, 3,
                                                       threads);
}

// One mesh's buffers: control points (moved a little every frame), positions, normals.
struct Buffers {
    std::vector<float> control, refined, normals;
};

Buffers buffersFor(const Model& m) {
    const psub::Refinement& r = m.refinement;
    const bool tiledOnly = r.perLevel.levels.empty() && r.tiled.refinedCount > 0;
    const std::size_t refined = 3 * std::size_t(tiledOnly ? r.tiled.refinedCount : r.perLevel.refinedCount());
    return {std::vector<float>(m.mesh.positions.begin(), m.mesh.positions.end()), std::vector<float>(refined),
            std::vector<float>(refined)};
}

void move(Buffers& b, int frame) {
    for (std::size_t i = 2; i < b.control.size(); i += 3) b.control[i] += 1e-4f * float((frame + i) % 7);
}

// Median ms per frame of `frames` frames (after 2 warm-up frames) of `frameWork(frame)`.
template <class Work>
double frameMs(int frames, Work&& frameWork) {
    std::vector<double> ms;
    for (int f = 0; f < frames + 2; ++f) {
        const Clock::time_point start = Clock::now();
        frameWork(f);
        if (f >= 2) ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - start).count());
    }
    std::sort(ms.begin(), ms.end());
    return ms[ms.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 5) {
        std::fprintf(stderr,
                     "usage: psub_many_meshes SMALL LEVELS BIG BIG_LEVELS [COUNT] [FRAMES] [tiled|per-level] [ROUNDS]\n");
        return 2;
    }
    using psub::bench::parseArgument;
    const int levels = int(parseArgument(argv[2], "LEVELS", 0, 30)), bigLevels = int(parseArgument(argv[4], "BIG_LEVELS", 0, 30));
    const int count = argc > 5 ? int(parseArgument(argv[5], "COUNT", 1, 10000)) : 50;
    const int frames = argc > 6 ? int(parseArgument(argv[6], "FRAMES", 1, 1e6)) : 30;
    const bool tiled = !(argc > 7 && std::string(argv[7]) == "per-level");
    const int rounds = argc > 8 ? int(parseArgument(argv[8], "ROUNDS", 1, 1000)) : 5;
    const int threads = omp_get_max_threads();
    Model small, big;
    try {
        small = refined(argv[1], levels, tiled);
        big = refined(argv[3], bigLevels, tiled);
    } catch (const psub::InputError& e) {
        std::fprintf(stderr, "psub_many_meshes: error: %s\n", e.what());
        return 1;
    }
    std::printf("%s form, %d threads. Small: %s at %d P-S steps, %llu faces, x %d = %llu faces. Big: %s at %d, %llu "
                "faces.\n",
                tiled ? "tiled" : "per-level", threads, argv[1], levels, (unsigned long long)small.faces, count,
                (unsigned long long)(small.faces * count), argv[3], bigLevels, (unsigned long long)big.faces);

    std::vector<Buffers> buffers;
    std::vector<std::unique_ptr<psub::CpuEvaluator<float>>> oneAfterAnother, sideBySide;
    for (int i = 0; i < count; ++i) {
        buffers.push_back(buffersFor(small));
        oneAfterAnother.push_back(evaluatorFor(small, tiled, threads));
        sideBySide.push_back(evaluatorFor(small, tiled, 1));
    }
    Buffers bigBuffers = buffersFor(big);
    const std::unique_ptr<psub::CpuEvaluator<float>> bigEvaluator = evaluatorFor(big, tiled, threads);

    for (const bool withNormals : {false, true}) {
        const auto run = [&](psub::CpuEvaluator<float>& e, Buffers& b) {
            e.evaluate(b.control, b.refined, withNormals ? std::span<float>(b.normals) : std::span<float>());
        };
        // Per round: the three frame times; then each one's median and each ratio's.
        std::vector<double> bigMs, sequentialMs, parallelMs;
        for (int round = 0; round < rounds; ++round) {
            bigMs.push_back(frameMs(frames, [&](int f) {
                move(bigBuffers, f);
                run(*bigEvaluator, bigBuffers);
            }));
            sequentialMs.push_back(frameMs(frames, [&](int f) {
                for (int i = 0; i < count; ++i) {
                    move(buffers[std::size_t(i)], f);
                    run(*oneAfterAnother[std::size_t(i)], buffers[std::size_t(i)]);
                }
            }));
            parallelMs.push_back(frameMs(frames, [&](int f) {
#pragma omp parallel for schedule(dynamic, 1)
                for (int i = 0; i < count; ++i) {
                    move(buffers[std::size_t(i)], f);
                    run(*sideBySide[std::size_t(i)], buffers[std::size_t(i)]);
                }
            }));
        }
        const auto median = [](std::vector<double> v) {
            std::sort(v.begin(), v.end());
            return v[v.size() / 2];
        };
        const double manyFaces = double(small.faces) * count;
        std::printf("%s (%d rounds; medians, and the range over the rounds in brackets):\n",
                    withNormals ? "positions and normals" : "positions", rounds);
        std::printf("  one mesh:               %8.3f ms, %7.0f faces/ms\n", median(bigMs), double(big.faces) / median(bigMs));
        for (const auto* many : {&sequentialMs, &parallelMs}) {
            // Throughput against one mesh's in the same round, and the fixed cost per mesh.
            std::vector<double> share, fixedUs;
            for (int round = 0; round < rounds; ++round) {
                const double bigRate = double(big.faces) / bigMs[std::size_t(round)], ms = (*many)[std::size_t(round)];
                share.push_back(100.0 * manyFaces / ms / bigRate);
                fixedUs.push_back(1e3 * (ms - manyFaces / bigRate) / count);
            }
            const auto [lowShare, highShare] = std::minmax_element(share.begin(), share.end());
            std::printf("  %d meshes %-18s %8.3f ms, %7.0f faces/ms = %.0f%% of one mesh's (%.0f-%.0f%%); fixed cost "
                        "%.1f us per mesh per frame\n",
                        count, many == &sequentialMs ? "one after another:" : "side by side:", median(*many),
                        manyFaces / median(*many), median(share), *lowShare, *highShare, median(fixedUs));
        }
    }
    return 0;
}
