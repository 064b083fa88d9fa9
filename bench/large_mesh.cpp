// Large-mesh run (a benchmark, not a test): refines a generated N x N quad torus until it has
// at least TARGET faces, evaluates three frames with the per-level table (or, with `tiled`,
// positions and then positions + normals with the tiled form, and the memory resident after
// them), and reports time, peak memory and bytes per refined face. Indices are 32-bit: the
// memory guard refuses sizes past 2^32 entries.
//   psub_large_mesh [N=512] [TARGET_FACES=50000000] [per-level|tiled]
#include "bench.h"
#include "psub/evaluator.h"
#include "psub/stencils.h"

#include <sys/resource.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>

namespace {

double peakGiB() {
    rusage usage{};
    getrusage(RUSAGE_SELF, &usage);
    return double(usage.ru_maxrss) / (1024.0 * 1024.0);
}

// Resident memory now (Linux: /proc/self/statm's second field, in pages); -1 where unreadable.
double residentGiB() {
    std::FILE* statm = std::fopen("/proc/self/statm", "r");
    if (!statm) return -1;
    unsigned long long size = 0, resident = 0;
    const bool read = std::fscanf(statm, "%llu %llu", &size, &resident) == 2;
    std::fclose(statm);
    return read ? double(resident) * double(sysconf(_SC_PAGESIZE)) / double(1u << 30) : -1;
}

}  // namespace

int main(int argc, char** argv) {
    const psub::Index n = argc > 1 ? psub::Index(psub::bench::parseArgument(argv[1], "N", 3, 9999)) : 512;
    const double target = argc > 2 ? psub::bench::parseArgument(argv[2], "TARGET_FACES", 1, 1e12, false) : 50e6;
    const std::string form = argc > 3 ? argv[3] : "per-level";
    if (form != "per-level" && form != "tiled") {
        std::fprintf(stderr, "psub_large_mesh: the form is per-level or tiled, not %s\n", form.c_str());
        return 2;
    }
    const bool tiled = form == "tiled";
    using Clock = std::chrono::steady_clock;
    const psub::Mesh mesh = psub::bench::makeTorus(int(n));
    const psub::CheckedMesh checked = psub::checkMesh(mesh);
    int levels = 0;
    while (double(n) * n * std::pow(2.0, levels) < target) ++levels;
    std::printf("torus %u x %u (%u faces), %d P-S levels\n", n, n, n * n, levels);
    auto start = Clock::now();
    psub::RefineOptions options{levels, psub::Preprocess::Auto, false, {}};
    options.tiled = tiled;
    options.perLevel = !tiled;  // the tiled form alone: its lean build
    options.onLevel = [](int level, double seconds) {
        std::fprintf(stderr, "level %d: topology %.2f s, peak %.2f GiB\n", level, seconds, peakGiB());
    };
    psub::Refinement r = psub::refine(mesh, checked.connectivity, options);
    const double buildSeconds = std::chrono::duration<double>(Clock::now() - start).count();
    const double faces = double((tiled ? r.tiled.surface : r.surface).faceOffsets.size() - 1);
    const std::uint32_t refinedCount = tiled ? r.tiled.refinedCount : r.perLevel.refinedCount();
    std::printf("refined: %.0f faces, %u vertices; topology %.2f s, tables %.2f s, tiled form %.2f s, total %.2f s; "
                "per-level table %.2f GiB (%llu indices); peak so far %.2f GiB\n",
                faces, refinedCount, r.topologyMs / 1e3, r.perLevelMs / 1e3, r.tiledMs / 1e3, buildSeconds,
                double(r.perLevel.bytes()) / (1u << 30), (unsigned long long)r.perLevel.indices.size(), peakGiB());
    std::vector<float> control(mesh.positions.begin(), mesh.positions.end());
    std::vector<float> refined(3 * std::size_t(refinedCount));
    const auto time = [&](const char* what, auto&& evaluate, int threads) {
        for (int frame = 0; frame < 3; ++frame) {
            start = Clock::now();
            evaluate();
            std::printf("frame %d (%s): %.1f ms (%d threads)\n", frame, what,
                        std::chrono::duration<double, std::milli>(Clock::now() - start).count(), threads);
        }
    };
    if (tiled) {
        // The tiled evaluator reads only the tiled form, the only table built.
        std::printf("tiled form: %zu tiles, %u of %u points in the fallback, %.2f GiB\n", r.tiled.tileCount(),
                    r.tiled.refinedCount - r.tiled.fallbackBegin, r.tiled.refinedCount, double(r.tiled.bytes()) / (1u << 30));
        psub::CpuEvaluator<float> evaluator(r.tiled);
        time("positions", [&] { evaluator.evaluate(control, refined); }, evaluator.threads());
        std::vector<float> normals(refined.size());
        time("positions + normals", [&] { evaluator.evaluate(control, refined, normals); }, evaluator.threads());
        std::printf("resident with the evaluator after its frames: %.2f GiB\n", residentGiB());
        for (float value : normals)
            if (!(std::abs(value) <= 1.0f + 1e-5f)) {
                std::printf("FAILED: normal component %g is not that of a unit vector\n", double(value));
                return 1;
            }
    } else {
        psub::CpuEvaluator<float> evaluator(r.perLevel, r.factorized, r.surface, psub::TableForm::PerLevel);
        time("positions", [&] { evaluator.evaluate(control, refined); }, evaluator.threads());
    }
    // Sanity: every refined point stays within the torus's bounding box.
    for (float value : refined)
        if (!(std::abs(value) <= 3.0f)) {
            std::printf("FAILED: refined value %g out of range\n", double(value));
            return 1;
        }
    std::printf("peak memory %.2f GiB = %.0f bytes per refined face\n", peakGiB(),
                peakGiB() * (1u << 30) / faces);
    return 0;
}
