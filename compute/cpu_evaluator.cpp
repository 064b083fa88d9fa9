// The threaded CPU evaluator: one OpenMP parallel region per frame, rows shared across threads
// by their speed in the frames before, a barrier of its own between levels; normals per vertex.
#include "psub/evaluator.h"

#if defined(__SSE2__)
#include <immintrin.h>
#endif
#include <omp.h>

#include <algorithm>
#include <atomic>
#include <cassert>
#include <cmath>
#include <stdexcept>
#include <thread>
#include <type_traits>

namespace psub {

std::uint64_t rowShareStart(std::uint64_t count, const double* bounds, std::uint64_t t, std::uint64_t n) {
    if (t == 0) return 0;
    if (t >= n) return count;
    return std::min(count, std::uint64_t(double(count) * bounds[t]));
}

void balanceRowShares(std::span<double> bounds, std::span<double> seconds, std::size_t secondsApart) {
    if (bounds.size() < 2) return;
    const std::size_t n = bounds.size() - 1;
    double total = 0;  // the team's speed: fractions of the rows a second
    for (std::size_t t = 0; t < n; ++t) {
        const double s = seconds[secondsApart * t];
        if (!(s > 0)) return std::fill(seconds.begin(), seconds.end(), 0.0);  // a thread ran no rows
        total += (bounds[t + 1] - bounds[t]) / s;
    }
    double sum = 0;  // each thread's new fraction in place of its seconds (no allocation a frame)
    for (std::size_t t = 0; t < n; ++t) {
        const double fraction = bounds[t + 1] - bounds[t], speed = fraction / seconds[secondsApart * t];
        seconds[secondsApart * t] = std::max(0.75 * fraction + 0.25 * speed / total, 0.25 / double(n));
        sum += seconds[secondsApart * t];
    }
    for (std::size_t t = 0; t + 1 < n; ++t) bounds[t + 1] = bounds[t] + seconds[secondsApart * t] / sum;
    bounds[n] = 1;
    std::fill(seconds.begin(), seconds.end(), 0.0);
}

static void spinPause() {
#if defined(__SSE2__)
    _mm_pause();
#endif
}

void TeamBarrier::wait() {
    const auto threads = std::uint32_t(omp_get_num_threads());
    if (threads == 1) return;
    const std::uint32_t generation = generation_.load(std::memory_order_acquire);
    if (arrived_.fetch_add(1, std::memory_order_acq_rel) + 1 == threads) {
        arrived_.store(0, std::memory_order_relaxed);
        generation_.store(generation + 1, std::memory_order_release);
        return;
    }
    constexpr std::uint32_t kSpins = 1u << 14;  // 0.05-0.6 ms of pauses (10-140 cycles each)
    for (std::uint32_t spins = 0; generation_.load(std::memory_order_acquire) == generation; ++spins) {
        if (spins < kSpins)
            spinPause();
        else
            std::this_thread::yield();
    }
}

namespace {

#if defined(__SSE2__)
constexpr bool kSimd = true;  // float normals through SSE (every x86-64)
#else
constexpr bool kSimd = false;
#endif

constexpr std::uint64_t kLevelPadding = 4;  // values after each intermediate level (allocate)

// normals() in one pass (windowedNormalsSimd): vertices a block of 32 at a time, face normals in
// a window of 8192 (128 KB, in the second-level cache; the cow at 7 steps in drawing order needs
// 6400; blocks of 16 and 64 were within 5%, windows of 16384 no faster), on surfaces of at least
// 2^17 faces: with fewer, whose face normals stay in cache between the two passes, the two
// passes were faster (the cow at 70k faces 0.127-0.128 against 0.134 ms, at 35k 0.060-0.061
// against 0.065; at 139k the one pass 0.238 against 0.265-0.267, at 279k 0.483 against
// 0.568-0.571; bench/README.md, "Session 30").
constexpr std::uint32_t kWindowBlock = 32, kWindowFaces = 8192, kWindowMinFaces = 1u << 17;
// Its narrow corners: runs of 64 faces, each with its least corner as the base.
constexpr std::uint32_t kCornerRun = 64;
// A stream face's first corner that marks a tile's ring face (its second: the face), whose
// normal the tile pass has written (planRestWindow).
constexpr std::uint32_t kRingFace = UINT32_MAX;
// A tile border point's weight in a block's work beyond a fallback point's (Spot at 12 steps: 2
// a little faster than 0, 4 and 6 slower).
constexpr std::uint64_t kBorderWork = 2;

// Where thread t of n's share of `count` items begins: at the fraction `bounds` gives it where
// they are a team of n's (the rows' shares, moved toward the threads' speeds), else evenly.
std::uint64_t shareStart(std::uint64_t count, const std::vector<double>& bounds, std::uint64_t t, std::uint64_t n) {
    return bounds.size() == n + 1 ? rowShareStart(count, bounds.data(), t, n) : count * t / n;
}

// This thread's share [begin, end) of `count` items (rows, faces, vertices), as shareStart.
std::pair<std::uint64_t, std::uint64_t> share(std::uint64_t count, const std::vector<double>& bounds) {
    const std::uint64_t t = std::uint64_t(omp_get_thread_num()), n = std::uint64_t(omp_get_num_threads());
    return {shareStart(count, bounds, t, n), shareStart(count, bounds, t + 1, n)};
}

// This thread's share of groups [groupBegin, groupEnd) of a level's rows (their rows within the
// level), balanced by work (source indices plus the write) rather than by row count: a level's
// face rows are far cheaper than its vertex rows. `bounds`: the threads' fractions of the work.
std::pair<std::uint64_t, std::uint64_t> shareByWork(const PerLevelTable& table, const StencilLevel& level,
                                                    std::uint64_t groupBegin, std::uint64_t groupEnd,
                                                    const double* bounds) {
    const std::uint64_t t = std::uint64_t(omp_get_thread_num()), n = std::uint64_t(omp_get_num_threads());
    if (groupBegin == groupEnd) return {0, 0};
    const std::uint64_t first = table.groups[groupBegin].rowBegin - level.rowBegin;
    const RowGroup& lastGroup = table.groups[groupEnd - 1];
    const std::uint64_t last = lastGroup.rowBegin + lastGroup.rowCount - level.rowBegin;
    if (n == 1) return {first, last};
    std::uint64_t total = 0;
    for (std::uint64_t g = groupBegin; g < groupEnd; ++g) total += table.groups[g].rowCount * (table.groups[g].width + 2);
    // The row at which cumulative work reaches `target`.
    auto rowAt = [&](std::uint64_t target) {
        std::uint64_t work = 0;
        for (std::uint64_t g = groupBegin; g < groupEnd; ++g) {
            const RowGroup& group = table.groups[g];
            const std::uint64_t cost = group.width + 2, groupWork = group.rowCount * cost;
            if (work + groupWork >= target)
                return group.rowBegin - level.rowBegin + (target - work + cost - 1) / cost;
            work += groupWork;
        }
        return last;
    };
    return {t == 0 ? first : rowAt(rowShareStart(total, bounds, t, n)),
            t + 1 == n ? last : rowAt(rowShareStart(total, bounds, t + 1, n))};
}

// The first of a level's VertexFromFacePoints groups (its last ones), or groupEnd: the rows
// from there read the points the level's other rows write.
std::uint64_t facePointGroupsBegin(const PerLevelTable& table, const StencilLevel& level) {
    std::uint64_t g = level.groupEnd;
    while (g > level.groupBegin && readsOwnLevel(table.groups[g - 1].kind)) --g;
    return g;
}

// This thread's rows of groups [groupBegin, groupEnd) of level k, from `source` into
// `destination`: its share (the fractions `bounds`) of every row group on the table's
// region-ordered and walk-ordered levels (each thread one region of the mesh at each level,
// reading mostly its own writes: docs/design.md, "Threads and regions"; a group's rows have one
// shape, so equal counts are equal work), else shareByWork's one range. On the cow at 7 steps in
// walk order the even shares took 4.0-4.2 ms a frame, shareByWork's 5.4-5.7 (its range gives one
// thread most face points, the other most vertex points).
template <class T>
void evaluateGroupsShare(const PerLevelTable& table, std::size_t k, std::uint64_t groupBegin, std::uint64_t groupEnd,
                         const T* source, BufferLayout layout, T* destination, RowReads reads, const double* bounds) {
    const StencilLevel& level = table.levels[k];
    const bool regionShares = (table.regions > 1 && k < table.regionLevels) || k >= table.walkFrom;
    const std::uint64_t t = std::uint64_t(omp_get_thread_num()), n = std::uint64_t(omp_get_num_threads());
    if (!regionShares || n == 1) {
        const auto [begin, end] = shareByWork(table, level, groupBegin, groupEnd, bounds);
        return evaluateLevelRows(table, k, source, layout, destination, layout, begin, end, reads);
    }
    for (std::uint64_t g = groupBegin; g < groupEnd; ++g) {
        const RowGroup& group = table.groups[g];
        const std::uint64_t begin = rowShareStart(group.rowCount, bounds, t, n),
                            end = rowShareStart(group.rowCount, bounds, t + 1, n);
        const std::uint64_t first = group.rowBegin - level.rowBegin;
        if (begin < end)
            evaluateLevelRows(table, k, source, layout, destination, layout, first + begin, first + end, reads);
    }
}

// Whether no VertexFromFacePoints row of the finest level reads its last vertex: those rows
// then read the output (which has nothing past that vertex) 16 bytes a vertex, unchecked. The
// tiled form's walk order puts a vertex point last, which only rows of the level after could
// read (the cow at 7 steps: its 548,593 such rows 25% dearer a row checked, a quarter of the
// rows' time; bench/README.md, "Session 34").
bool finestOwnReadsWide(const PerLevelTable& table) {
    if (table.levels.empty()) return false;
    const StencilLevel& level = table.levels.back();
    for (std::uint64_t g = facePointGroupsBegin(table, level); g < level.groupEnd; ++g) {
        const RowGroup& group = table.groups[g];
        const auto first = table.indices.begin() + std::ptrdiff_t(group.indexBegin);
        const auto last = first + std::ptrdiff_t(group.rowCount * group.width);
        if (std::find(first, last, level.destinationCount - 1) != last) return false;
    }
    return true;
}

// The threads' shares of a frame's rows: thread t's from the fraction bounds[t] of each group
// (or of a level's work) to bounds[t + 1]; and where each adds the seconds it spends on them
// (seconds[kSecondsApart t]).
constexpr std::size_t kSecondsApart = 8;  // doubles: a cache line each
struct RowShares {
    const double* bounds;
    double* seconds;
};

// This thread's rows of level k: the rows that read the parent level, then (after a barrier:
// other threads' face points) the VertexFromFacePoints rows, which read the level's own points.
template <class T>
void evaluateLevelShare(const PerLevelTable& table, std::size_t k, const T* source, BufferLayout layout,
                        T* destination, RowReads reads, TeamBarrier& barrier, RowShares shares) {
    const StencilLevel& level = table.levels[k];
    const std::uint64_t split = facePointGroupsBegin(table, level);
    double& seconds = shares.seconds[kSecondsApart * std::size_t(omp_get_thread_num())];
    const double start = omp_get_wtime();
    evaluateGroupsShare(table, k, level.groupBegin, split, source, layout, destination, reads, shares.bounds);
    seconds += omp_get_wtime() - start;
    if (split == level.groupEnd) return;
    barrier.wait();
    const double restart = omp_get_wtime();
    evaluateGroupsShare(table, k, split, level.groupEnd, source, layout, destination, reads, shares.bounds);
    seconds += omp_get_wtime() - restart;
}

// The rows' shares for a team of `team` threads: those of the frames before where the team was
// the same, else even ones.
RowShares sharesForTeam(std::vector<double>& bounds, std::vector<double>& seconds, int team) {
    if (bounds.size() != std::size_t(team) + 1) {
        bounds.resize(std::size_t(team) + 1);
        for (int t = 0; t <= team; ++t) bounds[std::size_t(t)] = double(t) / double(team);
        seconds.assign(kSecondsApart * std::size_t(team), 0.0);
    }
    return {bounds.data(), seconds.data()};
}

// Threads worth starting for `values` output values: a parallel region and its barriers cost
// microseconds (milliseconds when the machine is oversubscribed), so small meshes run on one.
int teamFor(std::uint64_t values, int threads) {
    constexpr std::uint64_t kValuesPerThread = 32768;
    return int(std::clamp<std::uint64_t>(values / kValuesPerThread, 1, std::uint64_t(std::max(threads, 1))));
}

// This thread's tile scratch, at least `size` values, shared by every tiled evaluator the
// thread runs: an application with many meshes (one evaluator each, side by side on the
// threads) keeps one scratch per thread warm in its cache instead of one per mesh cold
// (about 0.9 MB each at t = 2; docs/tiled.md has the measurements).
template <class T>
T* threadScratch(std::size_t size) {
    thread_local std::vector<T> scratch;
    if (scratch.size() < size) scratch.resize(size);
    return scratch.data();
}

}  // namespace

int perLevelFrameThreads(const PerLevelTable& table, std::uint32_t width, int threads) {
    return teamFor(std::uint64_t(table.refinedCount()) * width * (table.levels.size() > 1 ? 2 : 1),
                   threads > 0 ? threads : omp_get_max_threads());
}

template <class T>
CpuEvaluator<T>::CpuEvaluator(const PerLevelTable& perLevel, const FactorizedTable& factorized,
                              const SurfaceTable& surface, TableForm form, std::uint32_t width,
                              int threads)
    : perLevel_(perLevel), factorized_(factorized), surface_(surface), form_(form), width_(width),
      threads_(threads > 0 ? threads : omp_get_max_threads()) {
    if (width == 0) throw std::invalid_argument("CpuEvaluator: width must be at least 1");
    if (form == TableForm::Factorized &&
        (factorized.rowCount() != perLevel.refinedCount() || factorized.controlCount != perLevel.controlCount))
        throw std::invalid_argument("CpuEvaluator: the factorized table was not built for these levels");
    if (form == TableForm::Tiled)
        throw std::invalid_argument("CpuEvaluator: the tiled form takes its TiledTable");
    allocate();
}

static const FactorizedTable& noFactorizedTable() {
    static const FactorizedTable none;
    return none;
}

template <class T>
CpuEvaluator<T>::CpuEvaluator(const TiledTable& tiled, std::uint32_t width, int threads)
    : perLevel_(tiled.rows), factorized_(noFactorizedTable()), surface_(tiled.surface), form_(TableForm::Tiled),
      width_(width), threads_(threads > 0 ? threads : omp_get_max_threads()), tiled_(&tiled) {
    if (width == 0) throw std::invalid_argument("CpuEvaluator: width must be at least 1");
    tileNormals_ = tileNormalSets(tiled);
    prefetchNormals_ = false;
    allocate();
}

template <class T>
void CpuEvaluator<T>::allocate() {
    const PerLevelTable& perLevel = perLevel_;
    const SurfaceTable& surface = surface_;
    const std::uint32_t width = width_;
    std::uint64_t total = 0;
    for (std::size_t k = 0; k + 1 < perLevel.levels.size(); ++k) {
        levelBase_.push_back(total);
        // Each level followed by kLevelPadding values no one writes: the rows read every vertex
        // of the level 16 bytes at a time, the last one's too (evaluateLevelRows's sourcePadded).
        total += std::uint64_t(perLevel.levels[k].destinationCount) * width + kLevelPadding;
    }
    if (form_ != TableForm::Factorized) levels_.resize(total);
    finestOwnReadsWide_ = finestOwnReadsWide(perLevel);
    makeNarrowRows();
    allQuads_ = surface.faceVerts.size() == 4 * (surface.faceOffsets.size() - 1);
    for (std::size_t f = 0; allQuads_ && f + 1 < surface.faceOffsets.size(); ++f)
        allQuads_ = surface.faceOffsets[f] == 4 * f;
    planNormalWindow();
    planRestWindow();
    if (!window_.planned() && !restWindow_.planned()) needFaceNormals();
}

// How level k's rows read: every level after the first from a padded level of levels_, every
// level but the finest into one, the finest where its vertex rows allow (finestOwnReadsWide);
// with the narrow indices where they were made.
template <class T>
RowReads CpuEvaluator<T>::rowReads(std::size_t k) const {
    return {k > 0, k + 1 < perLevel_.levels.size() || finestOwnReadsWide_, narrow_.firstBlock.empty() ? nullptr : &narrow_};
}

// The narrow copy (float, 3 values a vertex) of the groups whose rows read it as rowReads has
// them read (readsNarrowRows).
template <class T>
void CpuEvaluator<T>::makeNarrowRows() {
    if (!std::is_same_v<T, float> || width_ != 3 || form_ == TableForm::Factorized) return;
    std::vector<std::uint8_t> copied(perLevel_.groups.size(), 0);
    for (std::size_t k = 0; k < perLevel_.levels.size(); ++k) {
        const RowReads reads = rowReads(k);
        for (std::uint64_t g = perLevel_.levels[k].groupBegin; g < perLevel_.levels[k].groupEnd; ++g)
            copied[g] = readsNarrowRows(perLevel_.groups[g], reads);
    }
    narrow_ = narrowRows(perLevel_, copied);
}

// A normal per face (padded to 4: one aligned load each), for the two passes: allocated at
// construction where they are the evaluator's way (a frame allocates nothing), not where the one
// pass is (16 bytes a face unused: 268 MB at 16.8M faces). A tiled evaluator whose rest runs in
// one pass allocates it at its first normals() call.
template <class T>
void CpuEvaluator<T>::needFaceNormals() {
    if (faceNormals_.empty()) faceNormals_.resize(4 * (surface_.faceOffsets.size() - 1));
}

// Plans windowedNormalsSimd on a surface of at least kWindowMinFaces quads: blocks of
// kWindowBlock vertices in the surface's order, where, from any block on, the faces from the
// first that any later block reads to the last that any earlier block read span at most the
// window (the tiled form's drawing order; not the canonical order, where a block of vertices
// reads faces from all over the surface: the first test below, one block's own span, rules it
// out). Not where the tiled form's tile pass computes most normals (tileNormals_.worthIt): a
// frame then takes the two passes over the rest, and the plan's copies would be memory unused.
template <class T>
void CpuEvaluator<T>::planNormalWindow() {
    const SurfaceTable& surface = surface_;
    const std::uint32_t vertexCount = surface.vertexCount;
    if (!std::is_same_v<T, float> || !kSimd || !allQuads_ || width_ != 3 || vertexCount == 0 || tileNormals_.worthIt ||
        surface.vertexOffsets.size() != std::size_t(vertexCount) + 1 || surface.faceOffsets.size() - 1 < kWindowMinFaces)
        return;
    const std::uint32_t blocks = (vertexCount - 1) / kWindowBlock + 1;
    std::vector<std::uint32_t> from(blocks, UINT32_MAX), to(blocks, 0);
    bool tooWide = false;
#pragma omp parallel for num_threads(threads_) schedule(static) reduction(|| : tooWide)
    for (std::uint32_t b = 0; b < blocks; ++b) {
        const std::uint32_t* f = surface.vertexFaces.data() + surface.vertexOffsets[b * kWindowBlock];
        const std::uint32_t* fEnd =
            surface.vertexFaces.data() + surface.vertexOffsets[std::min(vertexCount, (b + 1) * kWindowBlock)];
        if (f == fEnd) continue;
        const auto [lo, hi] = std::minmax_element(f, fEnd);
        from[b] = *lo;
        to[b] = *hi + 1;
        tooWide = tooWide || to[b] - from[b] > kWindowFaces;
    }
    if (tooWide) return;
    for (std::uint32_t b = blocks - 1; b-- > 0;) from[b] = std::min(from[b], from[b + 1]);
    std::uint32_t reached = 0;
    for (std::uint32_t b = 0; b < blocks; ++b) {
        reached = std::max(reached, to[b]);
        if (to[b] > 0 && reached - from[b] > kWindowFaces) return;
    }
    NormalWindow& w = window_;
    w.from = std::move(from);
    w.to = std::move(to);
    const std::uint32_t last = vertexCount - 1;
    w.lastVertexFaces.assign(surface.vertexFaces.begin() + surface.vertexOffsets[last],
                             surface.vertexFaces.begin() + surface.vertexOffsets[last + 1]);
    std::sort(w.lastVertexFaces.begin(), w.lastVertexFaces.end());
    // The narrow copies: of the 80 MB the pass moves on the cow at 7 steps, 18 MB fewer, and it
    // is bound by those bytes where the memory system is busy (normals 3.1 -> 2.5 ms there then,
    // within 2% in a quiet sitting; the same bits; bench/README.md, "Session 29"). They are
    // scaled for x86 addressing (a slot by 2, a corner by 3), so a corner costs two instructions,
    // not four: where the memory system is quiet the pass is bound by its instructions (2.13 ->
    // 1.82 ms, "Session 30").
    const std::size_t entries = surface.vertexFaces.size();
    w.slots.resize(entries);
    w.fourFaceBlocks.resize(blocks);
#pragma omp parallel num_threads(threads_)
    {
#pragma omp for schedule(static)
        for (std::size_t j = 0; j < entries; ++j)
            w.slots[j] = std::uint16_t(2 * (surface.vertexFaces[j] & (kWindowFaces - 1)));
#pragma omp for schedule(static)
        for (std::uint32_t b = 0; b < blocks; ++b) {
            const std::uint32_t begin = b * kWindowBlock, end = std::min(vertexCount, begin + kWindowBlock);
            bool four = end - begin == kWindowBlock;
            for (std::uint32_t v = begin; v < end && four; ++v)
                four = surface.vertexOffsets[v + 1] - surface.vertexOffsets[v] == 4;
            w.fourFaceBlocks[b] = four;
        }
    }
    planNarrowCorners(w, surface.faceVerts.data(), surface.faceOffsets.size() - 1);
}

// The tiled form's rest (tileNormals_.restVertices: its tiles' border points and the fallback's,
// a quarter of Spot's at 12 steps) through the one pass as well, instead of the two passes over
// lists (a face normal and its 16 bytes written and read back per face, the lists' indirection):
// the listed vertices block by block, and their faces as a stream in order of first use, a face
// read again more than a window on taken again (so every block's faces lie in the window). The
// stream's corners are copied (32-bit: a run of stream faces spans tiles and fallback), a ring
// face's marked (kRingFace, then its place in ringNormals_): its normal is the tile pass's, kept
// there in ring order (no face normal for the whole surface), not computed again from positions
// the tile pass wrote past the caches. From kWindowMinFaces faces, as the plan of every vertex: on
// smaller meshes the two passes were as fast (a 20k-face torus, two threads: 45-46 against 48-49 us
// for a frame with normals).
template <class T>
void CpuEvaluator<T>::planRestWindow() {
    const SurfaceTable& surface = surface_;
    const std::vector<std::uint32_t>& list = tileNormals_.restVertices;
    if (!std::is_same_v<T, float> || !kSimd || !allQuads_ || width_ != 3 || !tileNormals_.worthIt || list.empty() ||
        surface.vertexOffsets.size() != std::size_t(surface.vertexCount) + 1 || surface.faceOffsets.size() - 1 < kWindowMinFaces)
        return;
    NormalWindow w;
    const std::uint32_t count = std::uint32_t(list.size()), blocks = (count - 1) / kWindowBlock + 1;
    w.entries.resize(std::size_t(count) + 1);
    w.from.resize(blocks);
    w.to.resize(blocks);
    w.fourFaceBlocks.resize(blocks);
    std::vector<std::uint32_t> streamOf(surface.faceOffsets.size() - 1, UINT32_MAX), corners;
    std::vector<std::uint32_t> ringSlot(surface.faceOffsets.size() - 1, UINT32_MAX);  // per face, in ringNormals_
    for (std::size_t i = 0; i < tileNormals_.ringFaces.size(); ++i) ringSlot[tileNormals_.ringFaces[i]] = std::uint32_t(i);
    std::uint32_t streamed = 0;
    for (std::uint32_t b = 0; b < blocks; ++b) {
        const std::uint32_t q0 = b * kWindowBlock, q1 = std::min(count, q0 + kWindowBlock);
        std::uint32_t reads = 0;
        bool four = q1 - q0 == kWindowBlock;
        for (std::uint32_t q = q0; q < q1; ++q) {
            const std::uint32_t faces = surface.vertexOffsets[list[q] + 1] - surface.vertexOffsets[list[q]];
            reads += faces;
            four = four && faces == 4;
        }
        if (reads > kWindowFaces / 2) return;  // a block of many-sided vertices: the two passes
        // Faces streamed at or after keep are still in the window when the block has streamed
        // its own (at most `reads` more).
        const std::uint32_t keep = streamed + reads > kWindowFaces ? streamed + reads - kWindowFaces : 0;
        std::uint32_t least = UINT32_MAX;
        for (std::uint32_t q = q0; q < q1; ++q) {
            w.entries[q] = std::uint32_t(w.slots.size());
            for (std::uint32_t j = surface.vertexOffsets[list[q]]; j < surface.vertexOffsets[list[q] + 1]; ++j) {
                const std::uint32_t f = surface.vertexFaces[j];
                if (streamOf[f] == UINT32_MAX || streamOf[f] < keep) {
                    streamOf[f] = streamed++;
                    if (ringSlot[f] != UINT32_MAX)
                        corners.insert(corners.end(), {kRingFace, ringSlot[f], 0, 0});
                    else
                        corners.insert(corners.end(), surface.faceVerts.begin() + 4 * std::size_t(f),
                                       surface.faceVerts.begin() + 4 * std::size_t(f) + 4);
                }
                w.slots.push_back(std::uint16_t(2 * (streamOf[f] & (kWindowFaces - 1))));
                least = std::min(least, streamOf[f]);
            }
        }
        w.from[b] = least;
        w.to[b] = streamed;
        w.fourFaceBlocks[b] = four;
        // The block's work: its faces streamed, its vertices, and more for tile border points
        // (their faces' corners lie in the tiles, written past the caches).
        std::uint64_t work = streamed - (b == 0 ? 0 : w.to[b - 1]) + (q1 - q0);
        for (std::uint32_t q = q0; q < q1; ++q) work += list[q] < tiled_->fallbackBegin ? kBorderWork : 0;
        w.work.push_back((b == 0 ? 0 : w.work.back()) + work);
    }
    w.entries[count] = std::uint32_t(w.slots.size());
    for (std::uint32_t b = blocks - 1; b-- > 0;) w.from[b] = std::min(w.from[b], w.from[b + 1]);
    const std::uint32_t last = surface.vertexCount - 1;
    for (std::uint32_t i = 0; i < streamed; ++i)
        if (corners[4 * std::size_t(i)] != kRingFace &&
            std::find(corners.begin() + 4 * std::size_t(i), corners.begin() + 4 * std::size_t(i) + 4, last) !=
                corners.begin() + 4 * std::size_t(i) + 4)
            w.lastVertexFaces.push_back(i);
    w.wideCorners = std::move(corners);
    w.vertices = list;
    restWindow_ = std::move(w);
    ringNormals_.assign(4 * tileNormals_.ringFaces.size(), T(0));
}

// Runs of kCornerRun faces, each corner 3 x its offset from the run's least corner, where every
// run spans at most 21,845 vertices (the cow at 7 steps in drawing order: at most 6,454).
template <class T>
void CpuEvaluator<T>::planNarrowCorners(NormalWindow& w, const std::uint32_t* corners, std::size_t faces) const {
    if (faces == 0) return;
    const std::size_t runs = (faces - 1) / kCornerRun + 1;
    w.cornerBase.resize(runs);
    w.corners.resize(4 * faces);
    bool wide = false;
#pragma omp parallel for num_threads(threads_) schedule(static) reduction(|| : wide)
    for (std::size_t r = 0; r < runs; ++r) {
        const std::uint32_t* c = corners + 4 * kCornerRun * r;
        const std::uint32_t* cEnd = corners + 4 * std::min(faces, kCornerRun * (r + 1));
        const auto [lo, hi] = std::minmax_element(c, cEnd);
        w.cornerBase[r] = *lo;
        wide = wide || *hi - *lo > UINT16_MAX / 3;
        for (std::uint16_t* narrow = w.corners.data() + (c - corners); c < cEnd; ++c, ++narrow)
            *narrow = std::uint16_t(3 * (*c - *lo));
    }
    if (wide) {
        std::vector<std::uint16_t>().swap(w.corners);
        std::vector<std::uint32_t>().swap(w.cornerBase);
    }
}

template <class T>
void CpuEvaluator<T>::evaluate(std::span<const T> control, std::span<T> refined) {
    assert(control.size() >= std::size_t(controlCount()) * width_);
    assert(refined.size() >= std::size_t(refinedCount()) * width_);
    const BufferLayout packed{0, width_, width_};
    const int team = perLevelFrameThreads(perLevel_, width_, threads_);
    if (form_ == TableForm::Factorized) {
        const RowShares shares = sharesForTeam(rowBounds_, rowSeconds_, team);
#pragma omp parallel num_threads(team) if (team > 1)
        {
            const double start = omp_get_wtime();
            const auto [begin, end] = share(factorized_.rowCount(), rowBounds_);
            evaluateFactorizedRows(factorized_, control.data(), packed, refined.data(), packed,
                                   std::uint32_t(begin), std::uint32_t(end));
            shares.seconds[kSecondsApart * std::size_t(omp_get_thread_num())] += omp_get_wtime() - start;
        }
        balanceRowShares(rowBounds_, rowSeconds_, kSecondsApart);
        return;
    }
    if (form_ == TableForm::Tiled) return evaluateTiled(control, refined, nullptr, team);
    const std::size_t levels = perLevel_.levels.size();
    if (levels == 0) {
        std::copy(control.begin(), control.begin() + std::ptrdiff_t(controlCount()) * width_, refined.begin());
        return;
    }
    TeamBarrier barrier;
    const RowShares shares = sharesForTeam(rowBounds_, rowSeconds_, team);
#pragma omp parallel num_threads(team) if (team > 1)
    for (std::size_t k = 0; k < levels; ++k) {
        const T* source = k == 0 ? control.data() : levels_.data() + levelBase_[k - 1];
        T* destination = k + 1 == levels ? refined.data() : levels_.data() + levelBase_[k];
        evaluateLevelShare(perLevel_, k, source, packed, destination, rowReads(k), barrier, shares);
        if (k + 1 < levels) barrier.wait();  // after the last, the region's end
    }
    balanceRowShares(rowBounds_, rowSeconds_, kSecondsApart);
}

template <class T>
void CpuEvaluator<T>::evaluate(std::span<const T> control, std::span<T> refined, std::span<T> normals) {
    if (normals.empty()) return evaluate(control, refined);
    assert(width_ >= 3 && normals.size() >= 3 * std::size_t(refinedCount()));
    if (form_ != TableForm::Tiled || perLevel_.levels.empty() || !tileNormals_.worthIt) {
        evaluate(control, refined);
        return this->normals(refined, normals);
    }
    const int team = teamFor(std::uint64_t(refinedCount()) * width_ * 2, threads_);
    evaluateTiled(control, refined, normals.data(), team);
}

// The per-level rows (levels up to B whole, then the fallback's), then the tiles from level B;
// with `normals`, the tiles' inner points' normals in the tile pass and the rest's after it.
template <class T>
void CpuEvaluator<T>::evaluateTiled(std::span<const T> control, std::span<T> refined, T* normals, int team) {
    const BufferLayout packed{0, width_, width_};
    const std::size_t levels = perLevel_.levels.size();
    if (levels == 0) {
        std::copy(control.begin(), control.begin() + std::ptrdiff_t(controlCount()) * width_, refined.begin());
        return;
    }
    const TiledTable& tiled = *tiled_;
    const T* base = tiled.tileCount() == 0 || tiled.baseLevel == 0 ? control.data() : levels_.data() + levelBase_[tiled.baseLevel - 1];
    const std::size_t scratchSize = tileScratchSize(tiled, width_);
    if (normals && !restWindow_.planned()) needFaceNormals();
    // The tile pass's ring faces' normals: for the rest's one pass, in ringNormals_, in ring
    // order; for its two passes, at their faces in faceNormals_.
    const auto tileNormals = [&](std::size_t k) {
        if (!normals) return TileNormals<T>{};
        if (restWindow_.planned()) return TileNormals<T>{normals, ringNormals_.data() + 4 * std::size_t(tileNormals_.ringBegin[k]), nullptr};
        return TileNormals<T>{normals, faceNormals_.data(), tileNormals_.ringFaces.data() + tileNormals_.ringBegin[k]};
    };
    TeamBarrier barrier;
    const RowShares shares = sharesForTeam(rowBounds_, rowSeconds_, team);
#pragma omp parallel num_threads(team) if (team > 1)
    {
        for (std::size_t k = 0; k < levels; ++k) {
            const T* source = k == 0 ? control.data() : levels_.data() + levelBase_[k - 1];
            T* destination = k + 1 == levels ? refined.data() : levels_.data() + levelBase_[k];
            evaluateLevelShare(perLevel_, k, source, packed, destination, rowReads(k), barrier, shares);
            if (k + 1 < levels || tiled.tileCount() > 0 || normals) barrier.wait();  // else the region's end
        }
        if (tiled.tileCount() > 0) {
            T* scratch = threadScratch<T>(scratchSize);
            // One tile at a time: tiles are large (lattices up to 128 a side) and few on small
            // meshes, largest first, so chunks of several left one thread most of the work.
#pragma omp for schedule(dynamic, 1)
            for (std::size_t k = 0; k < tiled.tileCount(); ++k)
                evaluateTile(tiled, k, base, width_, refined.data(), tileNormals(k), scratch);
        }
        // After the loop's implicit barrier (or the last level's) every position is written.
        if (normals && restWindow_.planned())
            windowedNormalsSimd(refined.data(), normals, restWindow_);
        else if (normals)
            normalPasses(refined.data(), normals, &tileNormals_.restFaces, &tileNormals_.restVertices);
    }
    balanceRowShares(rowBounds_, rowSeconds_, kSecondsApart);
}

template <class T>
void CpuEvaluator<T>::normals(std::span<const T> refined, std::span<T> normals) {
    assert(width_ >= 3 && normals.size() >= 3 * std::size_t(surface_.vertexCount));
    const int team = teamFor(3 * std::uint64_t(surface_.vertexCount), threads_);
    if (!window_.planned()) needFaceNormals();
#pragma omp parallel num_threads(team) if (team > 1)
    {
        if (window_.planned())
            windowedNormalsSimd(refined.data(), normals.data(), window_);
        else
            normalPasses(refined.data(), normals.data());
    }
}

template <class T>
void CpuEvaluator<T>::normalPasses(const T* positions, T* normals, const std::vector<std::uint32_t>* faces,
                                   const std::vector<std::uint32_t>* vertices) {
    if constexpr (std::is_same_v<T, float> && kSimd) {
        faceNormalsSimd(positions, faces);
#pragma omp barrier
        vertexNormalsSimd(normals, vertices);
    } else {
        faceNormalsScalar(positions, faces);
#pragma omp barrier
        vertexNormalsScalar(normals, vertices);
    }
}

// Newell's normal of each face: twice its area along its normal. For a quad (nearly every face
// after a few steps) that is exactly the cross product of its diagonals, (p2 - p0) x (p3 - p1),
// which is what is computed: fewer operations, differences only (no rounding that grows with
// the distance from the origin), and the same bits whichever corner the face starts at, so the
// tiled form's tile pass (compute/tiled_kernels.cpp) and the Vulkan kernel get these very values.
template <class T>
void CpuEvaluator<T>::faceNormalsScalar(const T* p, const std::vector<std::uint32_t>* only) {
    const std::uint32_t faces = only ? std::uint32_t(only->size()) : std::uint32_t(surface_.faceOffsets.size() - 1);
    const std::size_t stride = width_;
    T* faceNormals = faceNormals_.data();
    const std::uint32_t* faceOffsets = surface_.faceOffsets.data();
    const std::uint32_t* faceVerts = surface_.faceVerts.data();
    const auto [fBegin, fEnd] = share(faces, rowBounds_);
    for (std::uint32_t i = std::uint32_t(fBegin); i < std::uint32_t(fEnd); ++i) {
        const std::uint32_t f = only ? (*only)[i] : i;
        T n0 = 0, n1 = 0, n2 = 0;
        const std::uint32_t begin = faceOffsets[f], end = faceOffsets[f + 1];
        auto edge = [&](const T* a, const T* b) {
            n0 += (a[1] - b[1]) * (a[2] + b[2]);
            n1 += (a[2] - b[2]) * (a[0] + b[0]);
            n2 += (a[0] - b[0]) * (a[1] + b[1]);
        };
        if (end - begin == 4) {  // a quad: the cross product of its diagonals (kQuadNormal)
            const T* p0 = p + faceVerts[begin] * stride;
            const T* p1 = p + faceVerts[begin + 1] * stride;
            const T* p2 = p + faceVerts[begin + 2] * stride;
            const T* p3 = p + faceVerts[begin + 3] * stride;
            const T ax = p2[0] - p0[0], ay = p2[1] - p0[1], az = p2[2] - p0[2];
            const T bx = p3[0] - p1[0], by = p3[1] - p1[1], bz = p3[2] - p1[2];
            n0 = ay * bz - az * by;
            n1 = az * bx - ax * bz;
            n2 = ax * by - ay * bx;
        } else {
            for (std::uint32_t c = begin; c < end; ++c)
                edge(p + faceVerts[c] * stride, p + faceVerts[c + 1 == end ? begin : c + 1] * stride);
        }
        faceNormals[4 * std::size_t(f)] = n0;
        faceNormals[4 * std::size_t(f) + 1] = n1;
        faceNormals[4 * std::size_t(f) + 2] = n2;
        faceNormals[4 * std::size_t(f) + 3] = 0;
    }
}

// Each vertex gathers its faces' normals in table order, then normalises.
template <class T>
void CpuEvaluator<T>::vertexNormalsScalar(T* out, const std::vector<std::uint32_t>* only) const {
    const T* faceNormals = faceNormals_.data();
    const std::uint32_t* vertexOffsets = surface_.vertexOffsets.data();
    const std::uint32_t* vertexFaces = surface_.vertexFaces.data();
    const auto [vBegin, vEnd] = share(only ? only->size() : surface_.vertexCount, rowBounds_);
    for (std::uint32_t i = std::uint32_t(vBegin); i < std::uint32_t(vEnd); ++i) {
        const std::uint32_t v = only ? (*only)[i] : i;
        T n[4] = {0, 0, 0, 0};
        for (std::uint32_t j = vertexOffsets[v], end = vertexOffsets[v + 1]; j < end; ++j) {
            const T* fn = faceNormals + 4 * std::size_t(vertexFaces[j]);
            for (int axis = 0; axis < 4; ++axis) n[axis] += fn[axis];
        }
        const T n0 = n[0], n1 = n[1], n2 = n[2];
        const T length = std::sqrt(n0 * n0 + n1 * n1 + n2 * n2);
        const T scale = length > 0 ? 1 / length : 0;
        out[3 * std::size_t(v)] = n0 * scale;
        out[3 * std::size_t(v) + 1] = n1 * scale;
        out[3 * std::size_t(v) + 2] = n2 * scale;
    }
}

#if defined(__SSE2__)
// The float passes with SSE: one vertex (x, y, z, -) or face normal per register, each lane
// doing the scalar passes' operations in their order, so the results are bit-identical.
// The face pass computes the three Newell sums (or a quad's diagonals' cross product) as
// products of rotated vectors.
namespace {

__m128 yzx(__m128 v) { return _mm_shuffle_ps(v, v, _MM_SHUFFLE(0, 0, 2, 1)); }
__m128 zxy(__m128 v) { return _mm_shuffle_ps(v, v, _MM_SHUFFLE(0, 1, 0, 2)); }

// (v2 - v0) x (v3 - v1), as the scalar pass; the 4th value 0. Three shuffles, not four:
// c = a b.yzx - a.yzx b holds the cross product's z, x, y (c.x = a.x b.y - a.y b.x, ...), the
// scalar pass's products and differences, so c.yzx has its bits.
__m128 quadNormal(__m128 v0, __m128 v1, __m128 v2, __m128 v3) {
    const __m128 a = _mm_sub_ps(v2, v0), b = _mm_sub_ps(v3, v1);
    const __m128 c = _mm_sub_ps(_mm_mul_ps(a, yzx(b)), _mm_mul_ps(yzx(a), b));
    return _mm_and_ps(yzx(c), _mm_castsi128_ps(_mm_setr_epi32(-1, -1, -1, 0)));
}

// Four sums normalised side by side, transposed (x, y and z of the four in one register
// each), with the scalar operations in their order: one square root and one division for four.
void normaliseFour(__m128& x, __m128& y, __m128& z, __m128& w) {
    _MM_TRANSPOSE4_PS(x, y, z, w);
    const __m128 length = _mm_sqrt_ps(_mm_add_ps(_mm_add_ps(_mm_mul_ps(x, x), _mm_mul_ps(y, y)), _mm_mul_ps(z, z)));
    const __m128 scale = _mm_and_ps(_mm_div_ps(_mm_set1_ps(1.0f), length), _mm_cmpgt_ps(length, _mm_setzero_ps()));
    x = _mm_mul_ps(x, scale);
    y = _mm_mul_ps(y, scale);
    z = _mm_mul_ps(z, scale);
}

void store3(float* o, __m128 unit) {
    _mm_storel_pi(reinterpret_cast<__m64*>(o), unit);
    _mm_store_ss(o + 2, _mm_movehl_ps(unit, unit));
}

// The unit normals of four consecutive vertices from their sums (x, y, z, -), written as 48
// bytes at `o`.
[[gnu::always_inline]] inline void storeFourNormals(float* o, __m128 x, __m128 y, __m128 z, __m128 w) {
    normaliseFour(x, y, z, w);
    // x0 y0 z0 x1 | y1 z1 x2 y2 | z2 x3 y3 z3
    const __m128 xy01 = _mm_unpacklo_ps(x, y), xy23 = _mm_unpackhi_ps(x, y);
    const __m128 z0x1 = _mm_shuffle_ps(z, xy01, _MM_SHUFFLE(2, 2, 0, 0));
    const __m128 y1z1 = _mm_shuffle_ps(xy01, z, _MM_SHUFFLE(1, 1, 3, 3));
    const __m128 z2x3 = _mm_shuffle_ps(z, xy23, _MM_SHUFFLE(2, 2, 2, 2));
    const __m128 y3z3 = _mm_shuffle_ps(xy23, z, _MM_SHUFFLE(3, 3, 3, 3));
    _mm_storeu_ps(o, _mm_shuffle_ps(xy01, z0x1, _MM_SHUFFLE(2, 0, 1, 0)));
    _mm_storeu_ps(o + 4, _mm_shuffle_ps(y1z1, xy23, _MM_SHUFFLE(1, 0, 2, 0)));
    _mm_storeu_ps(o + 8, _mm_shuffle_ps(z2x3, y3z3, _MM_SHUFFLE(2, 0, 2, 0)));
}

// The unit normals of the four vertices v[0..3] from their sums: normalised side by side,
// transposed back, one a register.
void storeFourListedNormals(float* out, const std::uint32_t* v, __m128 x, __m128 y, __m128 z, __m128 w) {
    normaliseFour(x, y, z, w);
    w = _mm_setzero_ps();
    _MM_TRANSPOSE4_PS(x, y, z, w);
    store3(out + 3 * std::size_t(v[0]), x);
    store3(out + 3 * std::size_t(v[1]), y);
    store3(out + 3 * std::size_t(v[2]), z);
    store3(out + 3 * std::size_t(v[3]), w);
}

// The sum of a vertex's face normals faceNormal(j), j = begin .. end - 1 (its entries in the
// surface's vertexFaces), in that order. Four faces (most vertices of a quad mesh) unrolled: no
// loop exit to predict (normals 15-20% faster on the cow at 7 steps), the same sums in the same
// order.
template <class FaceNormal>
[[gnu::always_inline]] inline __m128 faceNormalSum(std::uint32_t begin, std::uint32_t end, FaceNormal& faceNormal) {
    __m128 n = _mm_setzero_ps();
    if (end - begin == 4) {
        const __m128 n0 = faceNormal(begin), n1 = faceNormal(begin + 1);
        const __m128 n2 = faceNormal(begin + 2), n3 = faceNormal(begin + 3);
        return _mm_add_ps(_mm_add_ps(_mm_add_ps(_mm_add_ps(n, n0), n1), n2), n3);
    }
    for (std::uint32_t j = begin; j < end; ++j) n = _mm_add_ps(n, faceNormal(j));
    return n;
}

// One vertex's unit normal from its sum, as the scalar pass computes it.
void storeNormal(float* o, __m128 n) {
    alignas(16) float s[4];
    _mm_store_ps(s, n);
    const float length = std::sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
    const float scale = length > 0 ? 1 / length : 0;
    store3(o, _mm_mul_ps(n, _mm_set1_ps(scale)));
}

}  // namespace

template <class T>
void CpuEvaluator<T>::faceNormalsSimd(const T* p, const std::vector<std::uint32_t>* only) {
    if constexpr (std::is_same_v<T, float>) {
        const std::uint32_t faces = only ? std::uint32_t(only->size()) : std::uint32_t(surface_.faceOffsets.size() - 1);
        const std::size_t stride = width_;
        // A 16-byte load at a vertex reads one value past its position: past the buffer only
        // for the last vertex of a packed buffer, which is loaded value by value.
        const std::uint32_t last = surface_.vertexCount - 1, wide = stride > 3 ? last + 1 : last;
        auto load = [&](std::uint32_t i) {
            const float* q = p + std::size_t(i) * stride;
            if (i < wide) [[likely]]
                return _mm_loadu_ps(q);
            return _mm_setr_ps(q[0], q[1], q[2], 0.0f);
        };
        float* faceNormals = faceNormals_.data();
        const std::uint32_t* faceOffsets = surface_.faceOffsets.data();
        const std::uint32_t* faceVerts = surface_.faceVerts.data();
        // Plain variables, not a structured binding: the lambdas below use them, and clang
        // before 16 refuses a lambda that captures a binding.
        const std::pair<std::uint64_t, std::uint64_t> faceShare = share(faces, rowBounds_);
        const std::uint64_t fBegin = faceShare.first, fEnd = faceShare.second;
        constexpr std::uint32_t kAhead = 16;  // faces prefetched ahead
        const bool prefetch = prefetchNormals_;
        if (allQuads_ && stride == 3 && fBegin < fEnd) {
            // Quads in a packed buffer (the common case): no test per load, the stride known (the
            // cow at 7 steps: normals 3.1-3.4 -> 2.7-2.8 ms). Only the faces around the last
            // vertex go through `load`.
            auto quad = [&](std::uint32_t f, auto prefetching) {
                const std::uint32_t* c = faceVerts + 4 * std::size_t(f);
                if constexpr (decltype(prefetching)::value)
                    if (f + kAhead < fEnd)
                        for (int k = 0; k < 4; ++k) __builtin_prefetch(p + 3 * std::size_t(c[4 * kAhead + k]));
                const __m128 n = quadNormal(_mm_loadu_ps(p + 3 * std::size_t(c[0])), _mm_loadu_ps(p + 3 * std::size_t(c[1])),
                                            _mm_loadu_ps(p + 3 * std::size_t(c[2])), _mm_loadu_ps(p + 3 * std::size_t(c[3])));
                _mm_store_ps(faceNormals + 4 * std::size_t(f), n);
            };
            if (only) {
                // Listed faces (the tiled form's rest): a face is tested, all four corners at
                // once, for the last vertex.
                const __m128i lastVertex = _mm_set1_epi32(int(last));
                for (std::uint32_t i = std::uint32_t(fBegin); i < std::uint32_t(fEnd); ++i) {
                    const std::uint32_t f = (*only)[i];
                    const std::uint32_t* c = faceVerts + 4 * std::size_t(f);
                    const __m128i corners = _mm_loadu_si128(reinterpret_cast<const __m128i*>(c));
                    if (_mm_movemask_epi8(_mm_cmpeq_epi32(corners, lastVertex)) == 0) [[likely]]
                        quad(f, std::false_type{});
                    else
                        _mm_store_ps(faceNormals + 4 * std::size_t(f), quadNormal(load(c[0]), load(c[1]), load(c[2]), load(c[3])));
                }
                return;
            }
            // Every face: those around the last vertex (vertexFaces lists them in order) in
            // sequence with the others, no test per face.
            const std::uint32_t* lastFaces = surface_.vertexFaces.data() + surface_.vertexOffsets[last];
            const std::uint32_t* lastFacesEnd = surface_.vertexFaces.data() + surface_.vertexOffsets[last + 1];
            std::uint32_t f = std::uint32_t(fBegin);
            for (const std::uint32_t* l = lastFaces;; ++l) {
                const std::uint32_t stop = l == lastFacesEnd ? std::uint32_t(fEnd) : std::clamp(*l, f, std::uint32_t(fEnd));
                if (prefetch)
                    for (; f < stop; ++f) quad(f, std::true_type{});
                else
                    for (; f < stop; ++f) quad(f, std::false_type{});
                if (l == lastFacesEnd) return;
                if (f == *l && f < fEnd) {
                    const std::uint32_t* c = faceVerts + 4 * std::size_t(f);
                    _mm_store_ps(faceNormals + 4 * std::size_t(f), quadNormal(load(c[0]), load(c[1]), load(c[2]), load(c[3])));
                    ++f;
                }
            }
        }
        for (std::uint32_t i = std::uint32_t(fBegin); i < std::uint32_t(fEnd); ++i) {
            const std::uint32_t f = only ? (*only)[i] : i;
            const std::uint32_t begin = allQuads_ ? 4 * f : faceOffsets[f];
            const std::uint32_t end = allQuads_ ? begin + 4 : faceOffsets[f + 1];
            if (prefetch && allQuads_ && i + kAhead < fEnd) {
                const std::uint32_t* ahead = faceVerts + 4 * std::size_t(only ? (*only)[i + kAhead] : f + kAhead);
                for (int k = 0; k < 4; ++k) __builtin_prefetch(p + std::size_t(ahead[k]) * stride);
            }
            __m128 n = _mm_setzero_ps();
            if (end - begin == 4) {
                n = quadNormal(load(faceVerts[begin]), load(faceVerts[begin + 1]), load(faceVerts[begin + 2]),
                               load(faceVerts[begin + 3]));
            } else {
                // n += (a.yzx - b.yzx) * (a.zxy + b.zxy) for each edge a b, in corner order.
                for (std::uint32_t c = begin; c < end; ++c) {
                    const __m128 a = load(faceVerts[c]), b = load(faceVerts[c + 1 == end ? begin : c + 1]);
                    n = _mm_add_ps(n, _mm_mul_ps(_mm_sub_ps(yzx(a), yzx(b)), _mm_add_ps(zxy(a), zxy(b))));
                }
                n = _mm_and_ps(n, _mm_castsi128_ps(_mm_setr_epi32(-1, -1, -1, 0)));
            }
            _mm_store_ps(faceNormals + 4 * std::size_t(f), n);
        }
    } else {
        (void)p;
    }
}

template <class T>
void CpuEvaluator<T>::vertexNormalsSimd(T* out, const std::vector<std::uint32_t>* only) const {
    if constexpr (std::is_same_v<T, float>) {
        const float* faceNormals = faceNormals_.data();
        const std::uint32_t* vertexOffsets = surface_.vertexOffsets.data();
        const std::uint32_t* vertexFaces = surface_.vertexFaces.data();
        // Plain variables for the lambdas below (as in the face pass).
        const std::pair<std::uint64_t, std::uint64_t> vertexShare = share(only ? only->size() : surface_.vertexCount, rowBounds_);
        const std::uint64_t vBegin = vertexShare.first, vEnd = vertexShare.second;
        if (vBegin == vEnd) return;
        constexpr std::uint32_t kAhead = 24;  // face references prefetched ahead (all vertices)
        const std::uint32_t prefetchEnd =
            prefetchNormals_ && !only && vertexOffsets[vEnd] > kAhead ? vertexOffsets[vEnd] - kAhead : 0;
        // The sum of vertex v's face normals, in table order; `prefetching` (a std::bool_constant)
        // false compiles the prefetch test out.
        auto faceSum = [&](std::uint32_t v, auto prefetching) {
            auto faceNormal = [&](std::uint32_t j) {
                if constexpr (decltype(prefetching)::value)
                    if (j < prefetchEnd) __builtin_prefetch(faceNormals + 4 * std::size_t(vertexFaces[j + kAhead]));
                return _mm_load_ps(faceNormals + 4 * std::size_t(vertexFaces[j]));
            };
            return faceNormalSum(vertexOffsets[v], vertexOffsets[v + 1], faceNormal);
        };
        std::uint32_t i = std::uint32_t(vBegin);
        // Four consecutive vertices: written as 48 bytes.
        auto fourAtATime = [&](auto prefetching) {
            for (; i + 4 <= std::uint32_t(vEnd); i += 4) {
                storeFourNormals(out + 3 * std::size_t(i), faceSum(i, prefetching), faceSum(i + 1, prefetching),
                                 faceSum(i + 2, prefetching), faceSum(i + 3, prefetching));
            }
        };
        if (!only && prefetchEnd > 0) fourAtATime(std::true_type{});
        if (!only && prefetchEnd == 0) fourAtATime(std::false_type{});
        // Four listed vertices (no prefetches: prefetchEnd is 0).
        for (; only && i + 4 <= std::uint32_t(vEnd); i += 4) {
            const std::uint32_t* v = only->data() + i;
            storeFourListedNormals(out, v, faceSum(v[0], std::false_type{}), faceSum(v[1], std::false_type{}),
                                   faceSum(v[2], std::false_type{}), faceSum(v[3], std::false_type{}));
        }
        // The rest (a listed vertex, or the last few of this thread's share) one by one.
        for (; i < std::uint32_t(vEnd); ++i) {
            const std::uint32_t v = only ? (*only)[i] : i;
            storeNormal(out + 3 * std::size_t(v), faceSum(v, std::true_type{}));
        }
    } else {
        (void)out;
    }
}

template <class T>
void CpuEvaluator<T>::windowedNormalsSimd(const T* p, T* out, const NormalWindow& w) const {
    if constexpr (std::is_same_v<T, float>) {
        // This thread's blocks: its share of them, or of their work where the plan weighs it
        // (w.work: a tiled form's rest costs more at its tiles' borders than in its fallback),
        // by the rows' fractions where the team is theirs (the threads' speeds), else even.
        const std::uint64_t blocks = w.to.size(), n = std::uint64_t(omp_get_num_threads());
        const auto shareAt = [&](std::uint64_t count, std::uint64_t t) { return shareStart(count, rowBounds_, t, n); };
        const auto blockAt = [&](std::uint64_t t) {
            if (w.work.empty()) return shareAt(blocks, t);
            const std::uint64_t goal = shareAt(w.work.back(), t);
            return std::uint64_t(std::lower_bound(w.work.begin(), w.work.end(), goal) - w.work.begin());
        };
        const std::uint64_t thread = std::uint64_t(omp_get_thread_num());
        const std::pair<std::uint64_t, std::uint64_t> blockShare{thread == 0 ? 0 : blockAt(thread),
                                                                 thread + 1 == n ? blocks : blockAt(thread + 1)};
        if (blockShare.first >= blockShare.second) return;
        float* window = threadScratch<float>(4 * std::size_t(kWindowFaces));
        const std::uint32_t* faceVerts = w.wideCorners.empty() ? surface_.faceVerts.data() : w.wideCorners.data();
        const bool narrowCorners = !w.corners.empty();
        const std::uint16_t* corners = w.corners.data();
        const std::uint32_t* cornerBase = w.cornerBase.data();
        const bool listed = !w.vertices.empty();
        const std::uint32_t* entries = listed ? w.entries.data() : surface_.vertexOffsets.data();
        const std::uint16_t* slots = w.slots.data();
        const std::uint32_t last = surface_.vertexCount - 1;
        const std::uint32_t count = listed ? std::uint32_t(w.vertices.size()) : surface_.vertexCount;
        // Stream faces [begin, end) into the window, slot f mod kWindowFaces, the corners narrow
        // (`narrow`, a std::bool_constant: a run's base address and each corner's offset in
        // floats, two instructions a corner) or 32-bit. A 16-byte load at a vertex reads one
        // value past its position: past the buffer only for the last vertex, whose faces load it
        // value by value.
        auto faceNormals = [&](std::uint32_t begin, std::uint32_t end, auto narrow) {
            auto store = [&](std::uint32_t f, __m128 v0, __m128 v1, __m128 v2, __m128 v3) {
                _mm_store_ps(window + 4 * std::size_t(f & (kWindowFaces - 1)), quadNormal(v0, v1, v2, v3));
            };
            // Faces [f, to) of one run: one base, and the window's slots in sequence (a run does
            // not wrap: kWindowFaces is a multiple of kCornerRun).
            auto run = [&](std::uint32_t f, std::uint32_t to) {
                float* s = window + 4 * std::size_t(f & (kWindowFaces - 1));
                if constexpr (decltype(narrow)::value) {
                    const float* q = p + 3 * std::size_t(cornerBase[f / kCornerRun]);
                    for (const std::uint16_t* c = corners + 4 * std::size_t(f); f < to; ++f, c += 4, s += 4)
                        _mm_store_ps(s, quadNormal(_mm_loadu_ps(q + c[0]), _mm_loadu_ps(q + c[1]), _mm_loadu_ps(q + c[2]),
                                                   _mm_loadu_ps(q + c[3])));
                } else {
                    for (const std::uint32_t* c = faceVerts + 4 * std::size_t(f); f < to; ++f, c += 4, s += 4) {
                        if (listed && c[0] == kRingFace) {  // a ring face: the tile pass's normal
                            _mm_store_ps(s, _mm_load_ps(ringNormals_.data() + 4 * std::size_t(c[1])));
                            continue;
                        }
                        _mm_store_ps(s, quadNormal(_mm_loadu_ps(p + 3 * std::size_t(c[0])), _mm_loadu_ps(p + 3 * std::size_t(c[1])),
                                                   _mm_loadu_ps(p + 3 * std::size_t(c[2])), _mm_loadu_ps(p + 3 * std::size_t(c[3]))));
                    }
                }
            };
            auto safe = [&](std::uint32_t f, int k) {
                const std::uint32_t i = decltype(narrow)::value ? cornerBase[f / kCornerRun] + corners[4 * std::size_t(f) + k] / 3u
                                                                : faceVerts[4 * std::size_t(f) + k];
                const float* q = p + 3 * std::size_t(i);
                return i < last ? _mm_loadu_ps(q) : _mm_setr_ps(q[0], q[1], q[2], 0.0f);
            };
            const std::uint32_t* l = std::lower_bound(w.lastVertexFaces.data(), w.lastVertexFaces.data() + w.lastVertexFaces.size(), begin);
            const std::uint32_t* lEnd = w.lastVertexFaces.data() + w.lastVertexFaces.size();
            for (std::uint32_t f = begin; f < end;) {
                const std::uint32_t stop = l == lEnd ? end : std::min(*l, end);
                for (std::uint32_t to; f < stop; f = to) {
                    to = std::min(stop, (f / kCornerRun + 1) * kCornerRun);
                    run(f, to);
                }
                if (f < end) {
                    store(f, safe(f, 0), safe(f, 1), safe(f, 2), safe(f, 3));
                    ++f, ++l;
                }
            }
        };
        // The sum of the face normals of entries [begin, end), in that order (as
        // vertexNormalsSimd's).
        auto faceSum = [&](std::uint32_t begin, std::uint32_t end) {
            auto faceNormal = [&](std::uint32_t j) { return _mm_load_ps(window + 2 * std::size_t(slots[j])); };
            return faceNormalSum(begin, end, faceNormal);
        };
        auto vertexSum = [&](std::uint32_t q) { return faceSum(entries[q], entries[q + 1]); };
        // The normals of positions q .. q + 3 of the block's vertices: listed (`isListed`, a
        // std::bool_constant) four consecutive vertices as 48 bytes, others one by one.
        auto storeFour = [&](std::uint32_t q, __m128 n0, __m128 n1, __m128 n2, __m128 n3, auto isListed) {
            if constexpr (decltype(isListed)::value) {
                const std::uint32_t* v = w.vertices.data() + q;
                if (v[3] - v[0] != 3) return storeFourListedNormals(out, v, n0, n1, n2, n3);
                q = v[0];
            }
            storeFourNormals(out + 3 * std::size_t(q), n0, n1, n2, n3);
        };
        auto vertices = [&](std::uint64_t b, auto isListed) {
            std::uint32_t q = std::uint32_t(b) * kWindowBlock;
            if (w.fourFaceBlocks[b]) {
                // Four faces a vertex: the block's entries run on from its first vertex's (read
                // through a pointer: two instructions a face, not three). faceNormalSum's sums.
                const std::uint16_t* s = slots + entries[q];
                auto fourSum = [&](const std::uint16_t* e) {
                    auto at = [&](int k) { return _mm_load_ps(window + 2 * std::size_t(e[k])); };
                    return _mm_add_ps(_mm_add_ps(_mm_add_ps(_mm_add_ps(_mm_setzero_ps(), at(0)), at(1)), at(2)), at(3));
                };
                for (std::uint32_t i = 0; i < kWindowBlock; i += 4, s += 16)
                    storeFour(q + i, fourSum(s), fourSum(s + 4), fourSum(s + 8), fourSum(s + 12), isListed);
                return;
            }
            const std::uint32_t qEnd = std::min(count, std::uint32_t(b + 1) * kWindowBlock);
            for (; q + 4 <= qEnd; q += 4) storeFour(q, vertexSum(q), vertexSum(q + 1), vertexSum(q + 2), vertexSum(q + 3), isListed);
            for (; q < qEnd; ++q) storeNormal(out + 3 * std::size_t(listed ? w.vertices[q] : q), vertexSum(q));
        };
        std::uint32_t done = w.from[blockShare.first];  // faces [.., done) are in the window
        for (std::uint64_t b = blockShare.first; b < blockShare.second; ++b) {
            const std::uint32_t to = w.to[b];
            if (to > done) {
                const std::uint32_t begin = std::max(done, to - std::min(to, kWindowFaces));
                if (narrowCorners) faceNormals(begin, to, std::true_type{});
                else faceNormals(begin, to, std::false_type{});
                done = to;
            }
            if (listed) vertices(b, std::true_type{});
            else vertices(b, std::false_type{});
        }
    } else {
        (void)p;
        (void)out;
        (void)w;
    }
}
#else
// Without SSE2 (not x86-64) the scalar passes serve floats too.
template <class T>
void CpuEvaluator<T>::faceNormalsSimd(const T* p, const std::vector<std::uint32_t>* only) { faceNormalsScalar(p, only); }
template <class T>
void CpuEvaluator<T>::windowedNormalsSimd(const T*, T*, const NormalWindow&) const {}
template <class T>
void CpuEvaluator<T>::vertexNormalsSimd(T* out, const std::vector<std::uint32_t>* only) const {
    vertexNormalsScalar(out, only);
}
#endif

template <class T>
void CpuEvaluator<T>::setRowShares(std::span<const double> bounds) {
    bool valid = bounds.size() >= 2 && bounds.front() == 0 && bounds.back() == 1;
    for (std::size_t t = 0; valid && t + 1 < bounds.size(); ++t) valid = bounds[t] <= bounds[t + 1];
    if (!valid) throw std::invalid_argument("CpuEvaluator::setRowShares: ascending fractions from 0 to 1 wanted");
    rowBounds_.assign(bounds.begin(), bounds.end());
    rowSeconds_.assign(kSecondsApart * (bounds.size() - 1), 0.0);
}

template class CpuEvaluator<float>;
template class CpuEvaluator<double>;

template <class T>
void evaluateFaceVarying(const FaceVaryingTable& table, std::span<const T> control, std::span<T> refined) {
    static const SurfaceTable noSurface;
    CpuEvaluator<T> evaluator(table.perLevel, noFactorizedTable(), noSurface, TableForm::PerLevel, table.width, 1);
    evaluator.evaluate(control, refined);
}

template void evaluateFaceVarying<float>(const FaceVaryingTable&, std::span<const float>, std::span<float>);
template void evaluateFaceVarying<double>(const FaceVaryingTable&, std::span<const double>, std::span<double>);

}  // namespace psub
