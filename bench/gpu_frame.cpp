// psub_gpu_frame (a benchmark, not a test): the tiled form of a generated N x N quad torus on a
// Vulkan device, a frame = evaluate + normals with the results kept on the device (what `psub
// play --backend vulkan --render` draws from), the GPU time of each frame from timestamp queries
// and the host's wall time around it, medians. Made for a GPU lent for minutes
// (bench/gpu_run.sh builds the carried folder here and runs this there); it runs on lavapipe
// too. The bytes a frame must write at the least (positions and normals, the device's stride:
// 16 + 16 B per refined vertex) over its GPU time give the bandwidth it reaches; with
// BANDWIDTH_GBS (the device's copy bandwidth measured in the same run) also its fraction. One
// frame is then read back and compared with the CPU's tiled evaluator (exit 1 beyond the
// contract's tolerances): the GPU run checks the results on the GPU too.
//   psub_gpu_frame [N=512] [LEVELS=6] [FRAMES=50] [KERNEL=auto] [BANDWIDTH_GBS]
// KERNEL: auto, unrolled, or workgroup[16|32][xTHREADS] (the workgroup kernel with blocks of at
// most that side, plain workgroup and auto letting the device's shared memory choose; THREADS
// 64 to 1024 invocations a workgroup, VulkanEvaluatorOptions::tileThreads, else the default for
// the block side), then any of +normals or +separate (the tile kernel writes the inner points'
// normals itself where it can, fusedTileNormals, the default; or the separate pass does) and
// +staged (the control points through a staging copy, Staging::Always, where a discrete device
// would write them in place).
// Prints one line of text and one JSON object (the last line).
#include "bench.h"
#include "detail.h"
#include "psub/evaluator.h"
#include "psub/stencils.h"
#include "psub/vulkan_context.h"
#include "psub/vulkan_evaluator.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace {

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v.empty() ? 0 : v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
    using psub::bench::parseArgument;
    const int n = argc > 1 ? int(parseArgument(argv[1], "N", 3, 4096)) : 512;
    const int levels = argc > 2 ? int(parseArgument(argv[2], "LEVELS", 1, 12)) : 6;
    const int frames = argc > 3 ? int(parseArgument(argv[3], "FRAMES", 1, 100000)) : 50;
    const std::string kernelName = argc > 4 ? argv[4] : "auto";
    const double bandwidth = argc > 5 ? parseArgument(argv[5], "BANDWIDTH_GBS", 0, 1e6, false) : 0;
    psub::VulkanEvaluatorOptions options;
    std::string kernel = kernelName.substr(0, kernelName.find('+'));
    bool known = true;
    for (std::size_t at = kernel.size(); at < kernelName.size();) {
        const std::size_t next = std::min(kernelName.find('+', at + 1), kernelName.size());
        const std::string flag = kernelName.substr(at + 1, next - at - 1);
        if (flag == "normals") options.fusedTileNormals = true;
        else if (flag == "separate") options.fusedTileNormals = false;
        else if (flag == "staged") options.staging = psub::Staging::Always;
        else known = false;
        at = next;
    }
    for (const auto& [suffix, threads] : {std::pair{"x64", 64u}, std::pair{"x128", 128u}, std::pair{"x256", 256u},
                                     std::pair{"x512", 512u}, std::pair{"x1024", 1024u}})
        if (kernel.ends_with(suffix)) {
            options.tileThreads = threads;
            kernel = kernel.substr(0, kernel.size() - std::string_view(suffix).size());
        }
    if (kernel.starts_with("workgroup")) options.tileKernel = psub::TileKernel::Workgroup;
    if (kernel == "workgroup16") options.tileBlock = 16;
    else if (kernel == "workgroup32") options.tileBlock = 32;
    else if (kernel == "unrolled") options.tileKernel = psub::TileKernel::Unrolled;
    if (!known || (kernel != "auto" && kernel != "unrolled" && !kernel.starts_with("workgroup")) ||
        (kernel.starts_with("workgroup") && kernel != "workgroup" && options.tileBlock == 0) ||
        (options.tileThreads && !kernel.starts_with("workgroup"))) {
        std::fprintf(stderr,
                     "psub_gpu_frame: the tile kernel is auto, unrolled or workgroup[16|32][x64|x128|x256|x512|x1024], then "
                     "+normals or +separate, +staged, not %s\n",
                     kernelName.c_str());
        return 2;
    }
    using Clock = std::chrono::steady_clock;
    const psub::Mesh mesh = psub::bench::makeTorus(n);
    const psub::CheckedMesh checked = psub::checkMesh(mesh);
    psub::RefineOptions refineOptions{levels, psub::Preprocess::Auto, false, {}};
    refineOptions.tiled = true;
    refineOptions.perLevel = false;  // the tiled form alone: its lean build
    const auto buildStart = Clock::now();
    const psub::Refinement r = psub::refine(mesh, checked.connectivity, refineOptions);
    const double buildSeconds = std::chrono::duration<double>(Clock::now() - buildStart).count();
    const psub::TiledTable& tiled = r.tiled;
    try {
        psub::VulkanContext context;
        psub::VulkanEvaluator evaluator(context, tiled, 3, options);
        std::vector<float> control(mesh.positions.begin(), mesh.positions.end());
        std::vector<double> gpu, positions, normals, uploads, wall, hostWrite, hostWait;
        // Untimed frames first: a fifth of the timed ones, at least 3 (a GPU raises its clocks
        // under load; the shader compile and first-touch costs fall on the first).
        const int warmup = std::max(3, frames / 5);
        for (int frame = -warmup; frame < frames; ++frame) {
            for (std::size_t i = 2; i < control.size(); i += 3) control[i] += 1e-4f;
            const auto start = Clock::now();
            evaluator.evaluateKept(control, true);
            const double ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
            const psub::GpuFrameTimes times = evaluator.lastFrameTimes();
            if (frame < 0) continue;
            wall.push_back(ms);
            const psub::HostFrameTimes host = evaluator.lastHostTimes();
            hostWrite.push_back(host.uploadMs), hostWait.push_back(host.waitMs);
            if (times.valid)
                gpu.push_back(times.totalMs), positions.push_back(times.levelsMs), normals.push_back(times.normalsMs),
                    uploads.push_back(times.uploadMs);
        }
        // One more frame read back and checked against the CPU's tiled evaluator: positions within
        // 1e-6 of the bounding-box diagonal (the control points'), normals within 1e-5 (the
        // contract's tolerances); a NaN counts as the largest difference.
        std::vector<float> refined(3 * std::size_t(tiled.refinedCount)), normalsOut(refined.size());
        std::vector<float> cpuRefined(refined.size()), cpuNormals(refined.size());
        evaluator.evaluate(control, refined, normalsOut);
        psub::CpuEvaluator<float>(tiled, 3).evaluate(control, cpuRefined, cpuNormals);
        using psub::bench::detail::maxDifference;
        const double positionDiff = maxDifference(refined.data(), 3, cpuRefined.data(), 3, tiled.refinedCount) /
                                    std::max(psub::bench::detail::boxDiagonal(mesh.positions), 1e-30);
        const double normalDiff = maxDifference(normalsOut.data(), 3, cpuNormals.data(), 3, tiled.refinedCount);
        const bool agrees = positionDiff <= 1e-6 && normalDiff <= 1e-5;
        const double vertices = tiled.refinedCount, faces = double(tiled.surface.faceOffsets.size() - 1);
        const double bytes = vertices * 4.0 * sizeof(float) * 2;  // positions and normals, 4 floats each
        const double gpuMs = median(gpu), reached = gpuMs > 0 ? bytes / (gpuMs * 1e6) : 0;
        const double gpuMin = gpu.empty() ? 0 : *std::min_element(gpu.begin(), gpu.end());
        const std::string device = context.deviceName();
        const unsigned block = evaluator.tileBlockSide();
        const bool normalsInKernel = evaluator.normalsInTileKernel(), inPlace = evaluator.controlsWrittenInPlace();
        const unsigned threads = evaluator.tileThreads();
        std::printf("%s: torus %d x %d, %d P-S levels, %.0f faces, t = %u, %zu tiles, %.1f%% tiled; build %.2f s; ",
                    device.c_str(), n, n, levels, faces, tiled.doubleSteps, tiled.tileCount(),
                    100.0 * tiled.fallbackBegin / std::max(1u, tiled.refinedCount), buildSeconds);
        const std::string invocations = threads ? std::to_string(threads) + " invocations a block" : "one invocation a block";
        std::printf("%s kernel (blocks of %u, %s%s); control points %s; frame (evaluate + normals, kept on "
                    "the device) GPU %.3f ms (positions %.3f of which the upload %.3f, normals %.3f), wall %.3f ms (writing the control points %.3f, "
                    "submit to fence %.3f); it writes %.1f MB a frame: %.1f GB/s",
                    kernelName.c_str(), block, invocations.c_str(), normalsInKernel ? ", normals in it" : "",
                    inPlace ? "written in place" : "through a staging copy", gpuMs, median(positions),
                    median(uploads), median(normals), median(wall), median(hostWrite), median(hostWait), bytes / 1e6,
                    reached);
        if (bandwidth > 0) std::printf(" (%.1f%% of %.0f GB/s)", 100 * reached / bandwidth, bandwidth);
        std::printf("; against the CPU's tiled evaluator: positions %.2g of the diagonal, normals %.2g%s", positionDiff,
                    normalDiff, agrees ? "" : " (FAILED: above 1e-6 and 1e-5)");
        std::printf("\n{\"device\": \"%s\", \"torus\": %d, \"levels\": %d, \"faces\": %.0f, \"vertices\": %.0f, "
                    "\"double_steps\": %u, \"tiles\": %zu, \"tiled_share\": %.4f, \"tile_kernel\": \"%s\", "
                    "\"tile_block\": %u, \"tile_threads\": %u, \"normals_in_tile_kernel\": %s, "
                    "\"controls_in_place\": %s, \"build_s\": %.3f, \"frames\": %d, ",
                    device.c_str(), n, levels, faces, vertices, tiled.doubleSteps, tiled.tileCount(),
                    double(tiled.fallbackBegin) / std::max(1u, tiled.refinedCount), kernelName.c_str(), block,
                    threads, normalsInKernel ? "true" : "false", inPlace ? "true" : "false", buildSeconds, frames);
        std::printf("\"timestamps\": %s, \"gpu_ms_median\": %.4f, \"gpu_ms_min\": %.4f, \"positions_ms_median\": %.4f, "
                    "\"upload_ms_median\": %.4f, \"normals_ms_median\": %.4f, \"wall_ms_median\": %.4f, "
                    "\"host_write_ms_median\": %.4f, \"host_wait_ms_median\": %.4f, ",
                    gpu.empty() ? "false" : "true", gpuMs, gpuMin, median(positions), median(uploads), median(normals),
                    median(wall), median(hostWrite), median(hostWait));
        std::printf("\"bytes_written\": %.0f, \"reached_gbs\": %.2f, \"bandwidth_gbs\": %.2f, "
                    "\"position_difference\": %.3g, \"normal_difference\": %.3g, \"agrees\": %s}\n",
                    bytes, reached, bandwidth, positionDiff, normalDiff, agrees ? "true" : "false");
        if (!agrees) return 1;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "psub_gpu_frame: error: %s\n", e.what());
        return 1;
    }
    return 0;
}
