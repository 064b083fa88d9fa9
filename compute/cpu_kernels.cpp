// CPU stencil kernels: per-level row groups (weights per group) and factorized rows, with
// fixed-width paths for 3 and 4 values per vertex and a generic one.
#include "psub/evaluator.h"

#if defined(__SSE2__)
#include <immintrin.h>
#endif

#include <algorithm>
#include <cassert>
#include <cmath>
#include <type_traits>

namespace psub {
namespace {

#if defined(__SSE2__)
// One group's slice of NarrowRows (psub/evaluator.h): its rows' offsets and its blocks' bases,
// or nulls.
struct NarrowGroup {
    const std::uint16_t* offsets = nullptr;
    const std::uint32_t* bases = nullptr;
    const std::uint32_t* firstDestination = nullptr;
};

NarrowGroup narrowGroup(const PerLevelTable& table, const RowGroup& g, const NarrowRows* narrow) {
    if (!narrow) return {};
    const std::uint32_t first = narrow->firstBlock[std::size_t(&g - table.groups.data())];
    if (first == kNoNarrowRows) return {};
    return {narrow->offsets.data() + 4 * std::uint64_t(kNarrowBlock) * first, narrow->bases.data() + 4 * std::uint64_t(first),
            narrow->firstDestination.data() + first};
}
#endif

// Where a row's first source (its centre) lies: the buffer of its other sources, or, for
// VertexFromCentreAndFacePoints rows, the parent level (psub/tables.h).
template <class T>
struct Centre {
    const T* source;
    BufferLayout layout;
    std::uint32_t count;  // the points of that buffer
    bool padded;          // one more value readable past its last point (RowReads)
};

// Sums `count` source elements listed in `ix` into acc (fixed width W, or `length` when W=0).
template <class T, int W>
inline void addElements(T* acc, const std::uint32_t* ix, std::uint32_t count, const T* source,
                        BufferLayout layout, T weight) {
    const std::uint32_t length = W > 0 ? std::uint32_t(W) : layout.length;
    for (std::uint32_t j = 0; j < count; ++j) {
        const T* p = source + std::size_t(ix[j]) * layout.stride + layout.offset;
        for (std::uint32_t i = 0; i < length; ++i) acc[i] += weight * p[i];
    }
}

// Rows r0..r1 of group g. N and M are the group's edge and diagonal counts when known at
// compile time (the common shapes: face quads and triangles, copies, valence 3 and 4), or -1.
template <class T, int W, int N, int M>
void applyGroup(const PerLevelTable& table, const RowGroup& g, std::uint64_t r0, std::uint64_t r1,
                const T* source, BufferLayout sl, T* destination, BufferLayout dl, Centre<T> c) {
    const T centre = T(g.centre), edge = T(g.edge), diagonal = T(g.diagonal);
    const std::uint32_t n = N >= 0 ? std::uint32_t(N) : g.n, m = M >= 0 ? std::uint32_t(M) : g.m;
    const std::uint32_t width = 1 + n + m;
    const std::uint32_t length = W > 0 ? std::uint32_t(W) : sl.length;
    const std::uint32_t* indices = table.indices.data() + g.indexBegin;
    const std::uint32_t* destinations = table.destinations.data() + g.rowBegin;
    for (std::uint64_t r = r0; r < r1; ++r) {
        const std::uint32_t* ix = indices + r * width;
        T* out = destination + std::size_t(destinations[r]) * dl.stride + dl.offset;
        if constexpr (W > 0) {
            T acc[W] = {}, edges[W] = {}, diagonals[W] = {};
            addElements<T, W>(acc, ix, 1, c.source, c.layout, centre);
            if (N != 0) addElements<T, W>(edges, ix + 1, n, source, sl, T(1));
            if (M != 0) addElements<T, W>(diagonals, ix + 1 + n, m, source, sl, T(1));
            for (int i = 0; i < W; ++i) out[i] = acc[i] + edge * edges[i] + diagonal * diagonals[i];
        } else {
            for (std::uint32_t i = 0; i < length; ++i) out[i] = 0;
            addElements<T, 0>(out, ix, 1, c.source, c.layout, centre);
            addElements<T, 0>(out, ix + 1, n, source, sl, edge);
            addElements<T, 0>(out, ix + 1 + n, m, source, sl, diagonal);
        }
    }
}

#if defined(__SSE2__)
// applyGroup for float and 3 values per vertex with SSE: a vertex per register (x, y, z, -),
// each lane doing applyGroup's operations in its order (the weight-1 products are exact), so
// the results are bit-identical. A 16-byte load reads one value past the vertex: past the
// buffer only for the parent level's last vertex of a packed buffer, which is loaded value
// by value, unless the buffer has room past it (`Padded3`: packed, readable past the end), when
// no load is tested and the stride is known.
// `Lean` (N > 0, M = 0, and diagonal x 0 = +0): the sums start from their first term, not from
// 0 + it. Adding 0 changes nothing but the sign of a zero (0 + -0 = +0), and the row's last
// addition, of diagonal x 0 = +0, turns every zero positive anyway, so the bits are the same
// (the cow at 7 steps: 4.2-4.3 against 4.4-4.6 ms a frame on one thread).
// With `narrow` (a group's NarrowRows, Padded3 and Lean rows of four sources, packed
// destinations) each block of kNarrowBlock rows that fits reads its sources' 16-bit offsets
// from their bases, the same loads and operations in the same order: the same bits.
template <int N, int M, bool Padded3, bool Lean = false>
void applyGroupSse3(const PerLevelTable& table, const RowGroup& g, std::uint64_t r0, std::uint64_t r1,
                    const float* source, BufferLayout sl, std::uint32_t sourceCount, float* destination,
                    BufferLayout dl, bool ascending, NarrowGroup narrow, Centre<float> c) {
    const __m128 centre = _mm_set1_ps(float(g.centre)), edge = _mm_set1_ps(float(g.edge)),
                 diagonal = _mm_set1_ps(float(g.diagonal));
    const std::uint32_t n = N >= 0 ? std::uint32_t(N) : g.n, m = M >= 0 ? std::uint32_t(M) : g.m;
    const std::uint32_t width = 1 + n + m;
    const std::uint32_t wide = sl.offset + 3 < sl.stride ? sourceCount : sourceCount - 1;
    const float* base = source + sl.offset;
    const std::size_t stride = sl.stride;
    auto load = [&](std::uint32_t i) __attribute__((always_inline)) {
        if constexpr (Padded3) return _mm_loadu_ps(source + 3 * std::size_t(i));
        const float* q = base + std::size_t(i) * stride;
        if (i < wide) [[likely]]
            return _mm_loadu_ps(q);
        return _mm_setr_ps(q[0], q[1], q[2], 0.0f);
    };
    // The centre, as `load` (Padded3: its buffer padded and packed too).
    const std::uint32_t centreWide = c.layout.offset + 3 < c.layout.stride ? c.count : c.count - 1;
    auto loadCentre = [&](std::uint32_t i) __attribute__((always_inline)) {
        if constexpr (Padded3) return _mm_loadu_ps(c.source + 3 * std::size_t(i));
        const float* q = c.source + c.layout.offset + std::size_t(i) * c.layout.stride;
        if (i < centreWide) [[likely]]
            return _mm_loadu_ps(q);
        return _mm_setr_ps(q[0], q[1], q[2], 0.0f);
    };
    const std::uint32_t* indices = table.indices.data() + g.indexBegin;
    const std::uint32_t* destinations = table.destinations.data() + g.rowBegin;
    const __m128 zero = _mm_setzero_ps();
    const __m128 diagonalTerm = _mm_mul_ps(diagonal, zero);
    auto row = [&](std::uint64_t r) __attribute__((always_inline)) {
        const std::uint32_t* ix = indices + r * width;
        if constexpr (Lean) {
            __m128 edges = load(ix[1]);
            for (std::uint32_t j = 2; j <= n; ++j) edges = _mm_add_ps(edges, load(ix[j]));
            return _mm_add_ps(_mm_add_ps(_mm_mul_ps(centre, loadCentre(ix[0])), _mm_mul_ps(edge, edges)), diagonalTerm);
        }
        const __m128 acc = _mm_add_ps(zero, _mm_mul_ps(centre, loadCentre(ix[0])));
        __m128 edges = zero, diagonals = zero;
        if (N != 0)
            for (std::uint32_t j = 1; j <= n; ++j) edges = _mm_add_ps(edges, load(ix[j]));
        if (M != 0)
            for (std::uint32_t j = 1 + n; j < width; ++j) diagonals = _mm_add_ps(diagonals, load(ix[j]));
        return _mm_add_ps(_mm_add_ps(acc, _mm_mul_ps(edge, edges)), _mm_mul_ps(diagonal, diagonals));
    };
    auto store3 = [](float* out, __m128 v) __attribute__((always_inline)) {
        _mm_storel_pi(reinterpret_cast<__m64*>(out), v);
        _mm_store_ss(out + 2, _mm_movehl_ps(v, v));
    };
    if (r0 >= r1) return;
    // When destinations ascend within the group (`ascending`: every level of a table as refined,
    // the intermediate ones of a region-ordered table) and the range's are consecutive (a level's
    // new face points, say), they need not be read, and a row's 16-byte store may spill into the
    // next row's vertex, written next by this thread (packed destinations only).
    // Forced inline, as the lambdas above: called as functions from it, the rows reloaded every
    // value they captured, from memory, each row (2x slower).
    // Two rows an iteration (the loop's own instructions halved: 3-5% of a narrow row, session 36);
    // each row's 16-byte store before the next row's, which overwrites its spill.
    const auto run = [&](float* out, std::uint64_t begin, std::uint64_t end, auto&& value) __attribute__((always_inline)) {
        std::uint64_t r = begin;
        for (; r + 2 < end; r += 2, out += 6) {
            const __m128 a = value(r), b = value(r + 1);
            _mm_storeu_ps(out, a);
            _mm_storeu_ps(out + 3, b);
        }
        if (r + 1 < end) {
            _mm_storeu_ps(out, value(r));
            out += 3;
        }
        store3(out, value(end - 1));
    };
    const auto each = [&](std::uint64_t begin, std::uint64_t end, auto&& value) __attribute__((always_inline)) {
        for (std::uint64_t r = begin; r < end; ++r)
            store3(destination + std::size_t(destinations[r]) * 3 + dl.offset, value(r));
    };
    const auto consecutive = [&](std::uint64_t begin, std::uint64_t end, auto&& value) __attribute__((always_inline)) {
        float* out = destination + std::size_t(destinations[begin]) * dl.stride + dl.offset;
        if (dl.stride == 3) return run(out, begin, end, value);
        for (std::uint64_t r = begin; r < end; ++r, out += dl.stride) store3(out, value(r));
    };
    // Ascending with gaps (the tiled form's finest level, grouped within chunks of its walk:
    // docs/tiled.md, "Output order"): blocks whose destinations are consecutive are stored as
    // above, the others one by one.
    const auto block = [&](std::uint64_t begin, std::uint64_t end, auto&& value) __attribute__((always_inline)) {
        if (destinations[end - 1] - destinations[begin] == end - 1 - begin) return consecutive(begin, end, value);
        each(begin, end, value);
    };
    if constexpr (Padded3 && Lean && N == 3 && M == 0) {
        if (narrow.offsets && dl.stride == 3) {
            for (std::uint64_t b = r0 / kNarrowBlock; b * kNarrowBlock < r1; ++b) {
                const std::uint64_t begin = std::max(r0, b * kNarrowBlock), end = std::min(r1, (b + 1) * kNarrowBlock);
                // A block's consecutive destinations from its first, none read.
                const auto narrowBlock = [&](auto&& value) __attribute__((always_inline)) {
                    const std::uint32_t first = narrow.firstDestination[b];
                    if (first == kScattered) return each(begin, end, value);
                    run(destination + (std::size_t(first) + (begin - b * kNarrowBlock)) * 3 + dl.offset, begin, end, value);
                };
                const std::uint32_t* bases = narrow.bases + 4 * b;
                if (bases[0] == kWideBlock) {
                    narrowBlock(row);
                    continue;
                }
                const float *s0 = c.source + 3 * std::size_t(bases[0]), *s1 = source + 3 * std::size_t(bases[1]),
                            *s2 = source + 3 * std::size_t(bases[2]), *s3 = source + 3 * std::size_t(bases[3]);
                // Each offset by a load of its own: one 8-byte load and the shifts and masks to
                // split it took a row 1-7% longer (session 36).
                const auto narrowRow = [&](std::uint64_t r) __attribute__((always_inline)) {
                    const std::uint16_t* offsets = narrow.offsets + 4 * r;
                    __m128 edges = _mm_loadu_ps(s1 + 3 * std::size_t(offsets[1]));
                    edges = _mm_add_ps(edges, _mm_loadu_ps(s2 + 3 * std::size_t(offsets[2])));
                    edges = _mm_add_ps(edges, _mm_loadu_ps(s3 + 3 * std::size_t(offsets[3])));
                    const __m128 first = _mm_loadu_ps(s0 + 3 * std::size_t(offsets[0]));
                    return _mm_add_ps(_mm_add_ps(_mm_mul_ps(centre, first), _mm_mul_ps(edge, edges)), diagonalTerm);
                };
                narrowBlock(narrowRow);
            }
            return;
        }
    }
    if (ascending && destinations[r1 - 1] - destinations[r0] == r1 - 1 - r0) return consecutive(r0, r1, row);
    if (ascending && dl.stride == 3) {
        constexpr std::uint64_t kConsecutiveBlock = 64;
        for (std::uint64_t begin = r0; begin < r1; begin += kConsecutiveBlock)
            block(begin, std::min(begin + kConsecutiveBlock, r1), row);
        return;
    }
    if (dl.stride == 3 && dl.offset == 0) {  // packed: the stride known
        for (std::uint64_t r = r0; r < r1; ++r) store3(destination + 3 * std::size_t(destinations[r]), row(r));
        return;
    }
    for (std::uint64_t r = r0; r < r1; ++r)
        store3(destination + std::size_t(destinations[r]) * dl.stride + dl.offset, row(r));
}
#endif

template <class T, int W>
void applyGroupOfAnyShape(const PerLevelTable& table, const RowGroup& g, std::uint64_t r0, std::uint64_t r1,
                          const T* source, BufferLayout sl, std::uint32_t sourceCount, T* destination,
                          BufferLayout dl, [[maybe_unused]] bool ascending, [[maybe_unused]] bool sourcePadded,
                          [[maybe_unused]] const NarrowRows* narrow, Centre<T> c) {
#if defined(__SSE2__)
    if constexpr (std::is_same_v<T, float> && W == 3) {
        // Untested loads: the cow's frame at 7 steps a fifth shorter (docs/design.md).
        const bool padded3 = sourcePadded && sl.offset == 0 && sl.stride == 3 && c.padded && c.layout.offset == 0 &&
                             c.layout.stride == 3;
        // Rows without diagonals whose diagonal term, diagonal x 0, is +0 (most rows: face points,
        // vertex points from face points) skip the two additions of 0 (`Lean`): the same bits.
        const bool lean = g.n > 0 && g.m == 0 && !std::signbit(g.diagonal);
        const auto apply = [&]<int N, int M>() {
            if constexpr (N > 0 && M == 0) {
                if (lean && padded3)
                    return applyGroupSse3<N, M, true, true>(table, g, r0, r1, source, sl, sourceCount, destination, dl,
                                                            ascending, narrowGroup(table, g, narrow), c);
                if (lean) return applyGroupSse3<N, M, false, true>(table, g, r0, r1, source, sl, sourceCount, destination, dl, ascending, {}, c);
            }
            if (padded3) return applyGroupSse3<N, M, true>(table, g, r0, r1, source, sl, sourceCount, destination, dl, ascending, {}, c);
            applyGroupSse3<N, M, false>(table, g, r0, r1, source, sl, sourceCount, destination, dl, ascending, {}, c);
        };
        if (g.n == 3 && g.m == 0) return apply.template operator()<3, 0>();
        if (g.n == 4 && g.m == 4) return apply.template operator()<4, 4>();
        if (g.n == 0 && g.m == 0) return apply.template operator()<0, 0>();
        if (g.n == 2 && g.m == 0) return apply.template operator()<2, 0>();
        if (g.n == 3 && g.m == 3) return apply.template operator()<3, 3>();
        return apply.template operator()<-1, -1>();
    }
#else
    (void)sourceCount;
#endif
    if (g.n == 3 && g.m == 0) return applyGroup<T, W, 3, 0>(table, g, r0, r1, source, sl, destination, dl, c);
    if (g.n == 4 && g.m == 4) return applyGroup<T, W, 4, 4>(table, g, r0, r1, source, sl, destination, dl, c);
    if (g.n == 0 && g.m == 0) return applyGroup<T, W, 0, 0>(table, g, r0, r1, source, sl, destination, dl, c);
    if (g.n == 2 && g.m == 0) return applyGroup<T, W, 2, 0>(table, g, r0, r1, source, sl, destination, dl, c);
    if (g.n == 3 && g.m == 3) return applyGroup<T, W, 3, 3>(table, g, r0, r1, source, sl, destination, dl, c);
    applyGroup<T, W, -1, -1>(table, g, r0, r1, source, sl, destination, dl, c);
}

template <class T, int W>
void levelRows(const PerLevelTable& table, const StencilLevel& level, const T* source,
               BufferLayout sl, T* destination, BufferLayout dl, std::uint64_t rowBegin,
               std::uint64_t rowEnd, RowReads reads) {
    // A region-ordered table's last level ordered (its numbering kept) lists each group's rows
    // by region, not by destination.
    const bool ascending = table.regions == 1 || &level != &table.levels[table.regionLevels - 1];
    for (std::uint64_t gi = level.groupBegin; gi < level.groupEnd; ++gi) {
        const RowGroup& g = table.groups[gi];
        const std::uint64_t first = g.rowBegin - level.rowBegin;  // group's rows in the level
        const std::uint64_t begin = std::max(rowBegin, first), end = std::min(rowEnd, first + g.rowCount);
        if (begin >= end) continue;
        const NarrowRows* narrow = readsNarrowRows(g, reads) ? reads.narrow : nullptr;
        const Centre<T> parent{source, sl, level.sourceCount, reads.sourcePadded};
        if (readsOwnLevel(g.kind)) {  // reads the level's own face points (and a centre in the parent)
            const Centre<T> own{destination, dl, level.destinationCount, reads.destinationPadded};
            applyGroupOfAnyShape<T, W>(table, g, begin - first, end - first, destination, dl, level.destinationCount,
                                       destination, dl, ascending, reads.destinationPadded, narrow,
                                       g.kind == RowKind::VertexFromCentreAndFacePoints ? parent : own);
        } else {
            applyGroupOfAnyShape<T, W>(table, g, begin - first, end - first, source, sl, level.sourceCount,
                                       destination, dl, ascending, reads.sourcePadded, narrow, parent);
        }
    }
}

template <class T, int W>
void factorizedRows(const FactorizedTable& table, const T* source, BufferLayout sl, T* destination,
                    BufferLayout dl, std::uint32_t rowBegin, std::uint32_t rowEnd) {
    const std::uint32_t length = W > 0 ? std::uint32_t(W) : sl.length;
    for (std::uint32_t r = rowBegin; r < rowEnd; ++r) {
        T* out = destination + std::size_t(r) * dl.stride + dl.offset;
        const std::uint64_t begin = table.offsets[r], end = table.offsets[r + 1];
        if constexpr (W > 0) {
            T acc[W] = {};
            for (std::uint64_t e = begin; e < end; ++e) {
                const T* p = source + std::size_t(table.indices[e]) * sl.stride + sl.offset;
                const T w = T(table.weights[e]);
                for (int i = 0; i < W; ++i) acc[i] += w * p[i];
            }
            for (int i = 0; i < W; ++i) out[i] = acc[i];
        } else {
            for (std::uint32_t i = 0; i < length; ++i) out[i] = 0;
            for (std::uint64_t e = begin; e < end; ++e) {
                const T* p = source + std::size_t(table.indices[e]) * sl.stride + sl.offset;
                const T w = T(table.weights[e]);
                for (std::uint32_t i = 0; i < length; ++i) out[i] += w * p[i];
            }
        }
    }
}

}  // namespace

template <class T>
void evaluateLevelRows(const PerLevelTable& table, std::size_t level, const T* source,
                       BufferLayout sl, T* destination, BufferLayout dl, std::uint64_t rowBegin,
                       std::uint64_t rowEnd, RowReads reads) {
    assert(sl.valid() && dl.valid() && sl.length == dl.length && level < table.levels.size());
    const StencilLevel& l = table.levels[level];
    if (sl.length == 3)
        return levelRows<T, 3>(table, l, source, sl, destination, dl, rowBegin, rowEnd, reads);
    if (sl.length == 4)
        return levelRows<T, 4>(table, l, source, sl, destination, dl, rowBegin, rowEnd, reads);
    levelRows<T, 0>(table, l, source, sl, destination, dl, rowBegin, rowEnd, reads);
}

template <class T>
void evaluateFactorizedRows(const FactorizedTable& table, const T* source, BufferLayout sl,
                            T* destination, BufferLayout dl, std::uint32_t rowBegin,
                            std::uint32_t rowEnd) {
    assert(sl.valid() && dl.valid() && sl.length == dl.length && rowEnd <= table.rowCount());
    if (sl.length == 3) return factorizedRows<T, 3>(table, source, sl, destination, dl, rowBegin, rowEnd);
    if (sl.length == 4) return factorizedRows<T, 4>(table, source, sl, destination, dl, rowBegin, rowEnd);
    factorizedRows<T, 0>(table, source, sl, destination, dl, rowBegin, rowEnd);
}

template void evaluateLevelRows<float>(const PerLevelTable&, std::size_t, const float*, BufferLayout,
                                       float*, BufferLayout, std::uint64_t, std::uint64_t, RowReads);
template void evaluateLevelRows<double>(const PerLevelTable&, std::size_t, const double*, BufferLayout,
                                        double*, BufferLayout, std::uint64_t, std::uint64_t, RowReads);
template void evaluateFactorizedRows<float>(const FactorizedTable&, const float*, BufferLayout, float*,
                                            BufferLayout, std::uint32_t, std::uint32_t);
template void evaluateFactorizedRows<double>(const FactorizedTable&, const double*, BufferLayout,
                                             double*, BufferLayout, std::uint32_t, std::uint32_t);

}  // namespace psub
