// Internals of psub bench shared by its files: records, timing, shape, machine, report.
#pragma once

#include "bench.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <span>
#include <string>
#include <vector>

namespace psub::bench::detail {

using Clock = std::chrono::steady_clock;

// printf into a std::string (up to 511 characters).
std::string format(const char* fmt, ...) __attribute__((format(printf, 1, 2)));

inline double msSince(Clock::time_point start) {
    return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

// ---------------------------------------------------------------------------------------
// Machine and bandwidth (machine.cpp)

struct Machine {
    std::string cpu, compiler, osdVersion, date, kernel;
    std::string tileKernel;  // the instruction set of the CPU tile kernel's clone (tileKernelInstructions)
    int cores = 0;          // logical processors online
    int threads = 0;        // "all threads": OpenMP's default team size at start-up
    double memoryGiB = 0;
};

Machine describeMachine();

// CPU time of the whole machine (busy, and stolen by the hypervisor) and of this process, in
// seconds: the difference over a run tells how much else ran beside the benchmark.
struct CpuTimes {
    double busy = 0, steal = 0, self = 0;
};
CpuTimes readCpuTimes();

// STREAM-style triad a[i] = b[i] + s * c[i] over `elements` doubles per array on `threads`
// threads; best of `repetitions`, in GB/s (1e9 B/s) counting 3 arrays x 8 B per element.
double measureTriad(int threads, std::size_t elements, int repetitions);

// Write-only bandwidth: `elements` doubles stored with streaming (non-temporal) stores on
// `threads` threads; best of `repetitions`, in GB/s counting 8 B per element.
double measureWriteOnly(int threads, std::size_t elements, int repetitions);

// The time for a cache line to go from OpenMP's thread 0 to thread 1 and back (an atomic
// counter each bumps in turn), in ns, the median of 5 runs of `rounds`; 0 with one thread. What
// a thread pays to read a point another has just written: on a virtual machine whose two vCPUs
// the host moves between cores that share a last-level cache and cores that do not, it jumps
// (about 100-180 against 440-540 ns on the 2-vCPU EPYC VM of bench/README.md, "Session 41"), and with
// it every frame whose threads read each other's writes.
double measureCoreRoundTrip(int rounds);

// ---------------------------------------------------------------------------------------
// Progress on stderr: one rewritten line on a terminal, one line per step otherwise.

class Progress {
public:
    Progress();
    void show(const std::string& line);
    void done();

private:
    bool tty_;
    std::size_t last_ = 0;
};

// ---------------------------------------------------------------------------------------
// Frames

struct FrameSettings {
    int warmup = 3, frames = 30;  // warm-up stops early once it has taken a second
    double budgetSeconds = 6;     // fewer frames (at least minFrames) when `frames` would take longer
    int minFrames = 10;
    // Then `coldFrames` frames, each after flushCaches(flushBytes): what a frame costs when
    // nothing of the last one is left in the caches (other work between frames, or a cache
    // smaller than the frame's tables and buffers).
    int coldFrames = 0;
    std::size_t flushBytes = 0;
};

struct Timing {
    double median = 0, min = 0;
    int frames = 0;
    double coldMedian = 0, coldMin = 0;
    int coldFrames = 0;
};

// Writes `bytes` (a buffer kept for the run) on every thread, evicting what the caches held.
void flushCaches(std::size_t bytes);
// What flushCaches writes for a cold frame: twice the last-level cache this machine reports,
// from 256 MB to 1 GB.
std::size_t coldFlushBytes();

inline double medianOf(std::vector<double>& ms) {
    std::sort(ms.begin(), ms.end());
    const std::size_t n = ms.size();
    return n == 0 ? 0 : n % 2 ? ms[n / 2] : (ms[n / 2 - 1] + ms[n / 2]) / 2;
}

// Untimed animate(frame) writes new control points; timed evaluate() refines them: warm-up,
// frames back to back, then settings.coldFrames frames each after flushCaches.
template <class Animate, class Evaluate>
Timing timeFrames(const FrameSettings& settings, Animate&& animate, Evaluate&& evaluate) {
    double last = 0, warm = 0;
    int frame = 0;
    for (int i = 0; i < settings.warmup && warm < 1000; ++i, ++frame) {
        animate(frame);
        const auto start = Clock::now();
        evaluate();
        last = msSince(start);
        warm += last;
    }
    int frames = settings.frames;
    if (last > 0 && frames > settings.minFrames && last * 1e-3 * frames > settings.budgetSeconds)
        frames = std::max(settings.minFrames, int(settings.budgetSeconds / (last * 1e-3)));
    std::vector<double> ms;
    ms.reserve(std::size_t(frames));
    for (int i = 0; i < frames; ++i, ++frame) {
        animate(frame);
        const auto start = Clock::now();
        evaluate();
        ms.push_back(msSince(start));
    }
    Timing timing;
    timing.frames = frames;
    timing.median = medianOf(ms);
    timing.min = ms.empty() ? 0 : ms.front();
    std::vector<double> cold;
    for (int i = 0; i < settings.coldFrames; ++i, ++frame) {
        animate(frame);
        flushCaches(settings.flushBytes);
        const auto start = Clock::now();
        evaluate();
        cold.push_back(msSince(start));
    }
    timing.coldFrames = int(cold.size());
    timing.coldMedian = medianOf(cold);
    timing.coldMin = cold.empty() ? 0 : cold.front();
    return timing;
}

// The same settings without cold frames (probes, and frames with normals).
inline FrameSettings warmOnly(FrameSettings settings) {
    settings.coldFrames = 0;
    return settings;
}

// A small travelling wave over the rest pose: y += amplitude * sin(k x + 0.2 frame).
// Builds are repeated (fastest kept) up to this many times while they take under this long.
inline constexpr int kBuildRepetitions = 3;
inline constexpr double kBuildSeconds = 1.0;

// Runs build() up to kBuildRepetitions times while the total stays under kBuildSeconds;
// returns the fastest time in ms and sets `repetitions`.
template <class Build>
double timeBuild(Build&& build, int& repetitions) {
    double best = 1e300;
    repetitions = 0;
    const auto start = Clock::now();
    do {
        const auto one = Clock::now();
        build();
        best = std::min(best, msSince(one));
        ++repetitions;
    } while (repetitions < kBuildRepetitions && msSince(start) < kBuildSeconds * 1e3);
    return best;
}

struct Animation {
    std::vector<float> rest;  // xyz per control point
    float amplitude = 0, wavenumber = 0;

    Animation(std::span<const double> positions, double diagonal);
    std::size_t count() const { return rest.size() / 3; }
    // Writes every control point at `stride` floats (xyz, then 1 for a fourth float).
    void write(int frame, float* destination, unsigned stride) const;
    void writeRest(float* destination, unsigned stride) const;
};

// ---------------------------------------------------------------------------------------
// Shape

struct Shape {
    double volume = 0, diagonal = 0;
};

// Signed volume (fan-triangulated faces, divergence theorem) and bounding-box diagonal of
// the first three floats of each `stride`-float vertex. Offsets and vertices as CSR rows.
template <class Offset, class VertexIndex>
Shape measureShape(std::span<const Offset> offsets, std::span<const VertexIndex> verts,
                   const float* p, std::size_t vertexCount, unsigned stride) {
    Shape shape;
    for (std::size_t f = 0; f + 1 < offsets.size(); ++f) {
        const std::size_t begin = std::size_t(offsets[f]), end = std::size_t(offsets[f + 1]);
        const float* a = p + std::size_t(verts[begin]) * stride;
        for (std::size_t i = begin + 1; i + 1 < end; ++i) {
            const float* b = p + std::size_t(verts[i]) * stride;
            const float* d = p + std::size_t(verts[i + 1]) * stride;
            const double ax = a[0], ay = a[1], az = a[2], bx = b[0], by = b[1], bz = b[2];
            const double dx = d[0], dy = d[1], dz = d[2];
            shape.volume += (ax * (by * dz - bz * dy) - ay * (bx * dz - bz * dx) +
                             az * (bx * dy - by * dx)) / 6;
        }
    }
    double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
    for (std::size_t v = 0; v < vertexCount; ++v)
        for (std::size_t axis = 0; axis < 3; ++axis) {
            lo[axis] = std::min(lo[axis], double(p[v * stride + axis]));
            hi[axis] = std::max(hi[axis], double(p[v * stride + axis]));
        }
    for (int axis = 0; axis < 3; ++axis) shape.diagonal += (hi[axis] - lo[axis]) * (hi[axis] - lo[axis]);
    shape.diagonal = std::sqrt(shape.diagonal);
    return shape;
}

// Bounding-box diagonal of xyz triples.
double boxDiagonal(std::span<const double> positions);

// Largest |a - b| over the first three floats of each vertex.
double maxDifference(const float* a, unsigned strideA, const float* b, unsigned strideB,
                     std::size_t vertexCount);

// ---------------------------------------------------------------------------------------
// Results

// One (model, evaluator, size): the JSON record. Field names in comments are the JSON ones.
struct Record {
    std::string model;           // model
    std::string scheme;          // scheme: "ps" or "cc"
    int levels = 0;              // levels: P-S steps after preprocessing / CC levels
    int ccLevel = 0;             // cc_level: the matched size k
    std::uint64_t refinedFaces = 0, refinedVertices = 0, controlVertices = 0;
    std::string evaluator;       // evaluator
    std::string table;           // table: "per-level", "factorized", "cascading"
    int threads = 1;             // threads
    int layoutFloats = 3;        // layout_floats
    double probe3 = -1, probe4 = -1;  // probe_ms_3f / probe_ms_4f (OpenSubdiv layout choice)
    double buildMs = 0, topologyMs = 0, tableMs = 0;  // build_ms = topology_ms + table_ms
    double buildWithCanonicalMs = 0;  // build_with_canonical_order_ms: the tiled form's with its canonical order
    int buildRepetitions = 1;    // build_repetitions: fastest of these many builds
    std::uint64_t tableBytes = 0;
    std::uint64_t tableEntries = 0;
    Timing timing;               // frame_ms_median, frame_ms_min, frames; cold_frame_ms_median,
                                 // cold_frame_ms_min, cold_frames
    std::uint64_t bytesPerFrame = 0;
    double gbs = 0, bandwidthFraction = 0;
    double ratioVsOsdBest = 0, buildRatioVsOsdBest = 0;
    double maxDiff = 0;          // max_diff_rel: vs the scheme's reference, / bbox diagonal
    Shape shape;
    // floor_ms: refined vertices x 12 B at the triad of the same thread count; floor_ratio =
    // frame_ms_median / floor_ms; write_floor_ms / write_floor_ratio: the same at the
    // write-only (streaming store) bandwidth.
    double floorMs = 0, floorRatio = 0, writeFloorMs = 0, writeFloorRatio = 0;
    // cold_floor_ratio = cold_frame_ms_median / floor_ms; cold_ratio_vs_osd_best: OpenSubdiv's
    // fastest cold frame at this size / this cold frame (where frames were timed cold).
    double coldFloorRatio = 0, coldRatioVsOsdBest = 0;
    // PSub evaluators: frames of positions and normals together (normals_frame_ms_median; the
    // tiled CPU form computes most normals in its tile pass), against the floor of writing both
    // once (24 B per refined vertex at the triad: normals_floor_ms, normals_floor_ratio).
    bool hasNormals = false;
    Timing normalsTiming;
    double normalsFloorMs = 0, normalsFloorRatio = 0;
};

struct SizeResult {
    std::string model;
    int k = 0, psLevels = 0;
    std::uint64_t psFaces = 0, ccFaces = 0;
    Shape ps, cc;
    double osdBestFrameMs = 0, osdBestBuildMs = 0;
    double osdBestColdFrameMs = 0;  // 0: no cold frames
};

struct ModelResult {
    std::string name, path;
    std::uint64_t vertices = 0, faces = 0, corners = 0;
    bool preprocessed = false;
    std::vector<std::uint64_t> psFaces;  // per topological step (0: input; 1: the paired
                                         // method when preprocessed)
    std::vector<std::uint64_t> ccFaces;  // per Catmull-Clark level
    Shape input;
    std::vector<int> sizes;              // the k measured
};

struct Report {
    Machine machine;
    double triadAll = 0, triad1 = 0;
    double writeAll = 0, write1 = 0;  // write-only bandwidth (streaming stores), GB/s
    double roundTripStart = 0, roundTripEnd = 0;  // measureCoreRoundTrip before and after the frames, ns
    std::size_t triadElements = 0;
    std::string command;
    FrameSettings frames;
    bool quick = false;
    std::uint64_t maxFaces = 0;
    std::vector<ModelResult> models;
    std::vector<SizeResult> sizes;
    std::vector<Record> records;
    std::vector<std::string> warnings;
    std::vector<std::string> notes;  // what was skipped and why
    double loadStart = 0, loadEnd = 0;  // 1-minute load average before and after
    double otherCpuSeconds = 0;         // CPU time used by other processes during the run
    double stealSeconds = 0;            // CPU time the hypervisor took during the run
    double seconds = 0;
};

void printMarkdown(const Report& report, std::FILE* out);
void writeJson(const Report& report, const std::string& path);
void writeSvg(const Report& report, const std::string& path);

// ---------------------------------------------------------------------------------------
// OpenSubdiv (osd.cpp): Catmull-Clark `level` levels of `mesh`, its refiner + stencil
// builds and its evaluators. Appends records; returns the finest mesh's shape.

struct OsdContext {
    FrameSettings frames;
    int allThreads = 1;
    Progress* progress = nullptr;
    std::string label;  // progress prefix
    std::vector<std::string>* warnings = nullptr;
};

Shape runOpenSubdiv(const Mesh& mesh, const std::string& model, int level, const OsdContext& context,
                    std::vector<Record>& records);

}  // namespace psub::bench::detail
