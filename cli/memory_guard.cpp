// The memory guard of subdivide and stats: an estimate of the peak bytes of refining to a
// level, and the refusal (naming the most levels that fit) when it exceeds the limit.
#include "memory_guard.h"


#include <cstdio>
#include <string>

#include <unistd.h>

namespace psub::cli {
namespace {

std::uint64_t physicalMemory() {
    const long pages = ::sysconf(_SC_PHYS_PAGES), pageSize = ::sysconf(_SC_PAGESIZE);
    return pages > 0 && pageSize > 0 ? std::uint64_t(pages) * std::uint64_t(pageSize) : 0;
}

// Rough peak bytes of refining to `steps` topological steps: two levels of topology (about 44 B
// per half-edge, 30 B per vertex, 8 B per face), plus every level's table rows, the finest
// surface, the evaluator's level buffers (doubles), the OBJ text of the finest level; a tenth
// more for huge pages (cli/huge_pages.cpp: memory is resident in 2 MiB pages, so partly used
// ones count whole: the cow at 7 steps 345 -> 381 MiB), and 16 MiB for the program itself and
// the allocator's free pages (cli/main.cpp keeps them). With `finestFacesOnly` (psub::refine)
// the finest level is its faces only (4 B per corner and per face); OpenSubdiv's refiner gives
// it half-edges too. Measured peaks (`/usr/bin/time`, `psub subdivide data/cow.obj`,
// 2026-12-03, with huge pages) against the estimates: P-S levels 1 / 4 / 6 / 7 / 8 15.5 / 60.5
// / 198.4 / 380.6 / 674.1 MiB against 22.1 / 68.1 / 225.9 / 436.3 / 857.2 MiB; Catmull-Clark
// levels 1 / 2 / 3 / 4 17.1 / 40.5 / 129.1 / 472.4 MiB against 25.6 / 56.0 / 177.4 / 663.1 MiB.
double estimateBytes(const Counts& input, int steps, Boundary boundary, bool preprocessed, bool finestFacesOnly) {
    auto halfedges = [](const Counts& c) { return 2.0 * double(c.edges) - double(c.boundaryEdges); };
    auto topology = [&](const Counts& c) { return 44 * halfedges(c) + 30 * double(c.vertices) + 8 * double(c.faces); };
    auto after = [&](int k) { return countsAfterSteps(input, k, boundary, preprocessed); };
    const Counts finest = after(steps);
    double bytes = finestFacesOnly && steps > 0 ? 4 * (halfedges(finest) + double(finest.faces)) : topology(finest);
    if (steps > 0) bytes += topology(after(steps - 1));
    for (int k = 1; k <= steps; ++k) {
        const Counts parent = after(k - 1), child = after(k);
        bytes += 4 * (double(child.vertices) + double(parent.vertices) + 3 * halfedges(parent));  // table
        bytes += 24 * double(child.vertices);  // evaluator buffers
    }
    bytes += 4 * (double(finest.faces) + 2 * halfedges(finest) + double(finest.vertices));  // surface
    bytes += 60 * double(finest.vertices) + 25 * double(finest.faces);  // OBJ text
    return 1.1 * bytes + double(16 << 20);
}

std::string humanBytes(double bytes) {
    const char* units[] = {"B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"};
    int unit = 0;
    while (bytes >= 1024 && unit < 6) bytes /= 1024, ++unit;
    char text[32];
    std::snprintf(text, sizeof text, "%.1f %s", bytes, units[unit]);
    return text;
}


}  // namespace

// Throws InputError when `--levels levels` would not fit in `limit` bytes (or in 32-bit
// indices), naming the estimate and the most levels that fit. A level is `stepsPerLevel`
// topological steps (2 for Catmull-Clark, which quadruples the faces), after `extraSteps`
// (the paired method).
void guardMemory(const Mesh& mesh, const Counts& input, int levels, int stepsPerLevel, int extraSteps,
                 std::uint64_t limit, Boundary boundary) {
    if (limit == 0) limit = physicalMemory() / 4 * 3;
    auto steps = [&](int l) { return extraSteps + stepsPerLevel * l; };
    const bool facesOnly = stepsPerLevel == 1;  // P-S: psub::refine; Catmull-Clark: OpenSubdiv
    const auto estimate = [&](int l) { return estimateBytes(input, steps(l), boundary, extraSteps > 0, facesOnly); };
    auto fits = [&](int l) {
        const Counts c = countsAfterSteps(input, steps(l), boundary, extraSteps > 0);
        return estimate(l) <= double(limit) &&
               2.0 * double(c.edges) < double(kNoIndex) && double(c.vertices) < double(kNoIndex);
    };
    if (fits(levels)) return;
    int most = -1;
    while (most + 1 < levels && fits(most + 1)) ++most;
    throw InputError(mesh.source.path + ": --levels " + std::to_string(levels) + " would need about " +
                     humanBytes(estimate(levels)) + " (limit " + humanBytes(double(limit)) +
                     ", and 32-bit indices); " +
                     (most >= 0 ? "--levels " + std::to_string(most) + " is the most that fits"
                                : std::string("not even the input fits")));
}

}  // namespace psub::cli
