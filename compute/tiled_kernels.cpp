// The tiled form's tile kernel: a tile's gathered level-B grid refined 2t P-S steps with the
// regular masks over implicit grids (one value per vertex at a time), then its finest lattice
// written. Sums pair opposite neighbours, so two tiles that compute a shared point in their
// own frames (rotated or reflected) produce bitwise the same value.
#include "psub/evaluator.h"

#include <algorithm>
#include <utility>

namespace psub {
namespace {

// Grid sizes of a tile whose gathered grid is g x g: each double step maps n to 2n - 9.
std::uint32_t nextSize(std::uint32_t n) { return 2 * n - 9; }

// One double step of one value per vertex: the n x n grid `c` (spacing 1) -> the quincunx
// level (qv: the V-points of c's inner (n-2)^2 vertices, qf: the F-points of its (n-1)^2
// cells) -> the (2n-9)^2 grid `f` of spacing 1/2, whose point (0, 0) lies at c's (2, 2).
// `even`, `odd`: two rows of n values, for the fine rows' two kinds of points before they are
// interleaved. Every loop runs over contiguous x, so that it vectorises.
template <class T>
[[gnu::always_inline]] inline void doubleStepBody(const T* __restrict c, std::uint32_t n, T* __restrict qv,
                                                  T* __restrict qf, T* __restrict f, T* __restrict even,
                                                  T* __restrict odd) {
    const T quarter = T(0.25), eighth = T(0.125), sixteenth = T(0.0625);
    const std::size_t nv = n - 2, nf = n - 1, m = nextSize(n), half = n - 4;
    for (std::size_t y = 1; y + 1 < n; ++y) {
        const T* down = c + (y - 1) * n;
        const T* mid = c + y * n;
        const T* up = c + (y + 1) * n;
        T* out = qv + (y - 1) * nv;
        for (std::size_t x = 1; x + 1 < n; ++x)
            out[x - 1] = quarter * mid[x] + eighth * ((down[x] + up[x]) + (mid[x - 1] + mid[x + 1])) +
                         sixteenth * ((down[x - 1] + up[x + 1]) + (down[x + 1] + up[x - 1]));
    }
    for (std::size_t y = 0; y + 1 < n; ++y) {
        const T* down = c + y * n;
        const T* up = c + (y + 1) * n;
        T* out = qf + y * nf;
        for (std::size_t x = 0; x + 1 < n; ++x) out[x] = quarter * ((down[x] + up[x + 1]) + (down[x + 1] + up[x]));
    }
    // Row v_j[i - 1] = V(i, j), the V-point of c's vertex (i, j); f_j[i] = F(i, j), the F-point
    // of the cell (i, j)-(i+1, j+1). Fine point (p, q) lies at c's ((p + 4) / 2, (q + 4) / 2);
    // entry a of a fine row's two kinds of points has i = a + 2.
    const auto V = [&](std::size_t j) { return qv + (j - 1) * nv; };
    const auto F = [&](std::size_t j) { return qf + j * nf; };
    for (std::size_t q = 0; q < m; ++q) {
        const std::size_t j = q / 2 + 2;
        if (q % 2 == 0) {  // on c's row j: V-points of V(i, j) (even p), diamonds across x (odd p)
            const T *v0 = V(j), *vm = V(j - 1), *vp = V(j + 1), *f0 = F(j), *fm = F(j - 1);
            for (std::size_t i = 2; i < half + 2; ++i)
                even[i - 2] = quarter * v0[i - 1] + eighth * ((fm[i - 1] + f0[i]) + (fm[i] + f0[i - 1])) +
                              sixteenth * ((v0[i - 2] + v0[i]) + (vm[i - 1] + vp[i - 1]));
            for (std::size_t i = 2; i < half + 1; ++i) odd[i - 2] = quarter * ((v0[i - 1] + v0[i]) + (fm[i] + f0[i]));
        } else {  // between c's rows j and j + 1: diamonds across y (even p), V-points of F(i, j) (odd p)
            const T *v0 = V(j), *v1 = V(j + 1), *f0 = F(j), *fm = F(j - 1), *fp = F(j + 1);
            for (std::size_t i = 2; i < half + 2; ++i) even[i - 2] = quarter * ((v0[i - 1] + v1[i - 1]) + (f0[i - 1] + f0[i]));
            for (std::size_t i = 2; i < half + 1; ++i)
                odd[i - 2] = quarter * f0[i] + eighth * ((v0[i - 1] + v1[i]) + (v0[i] + v1[i - 1])) +
                             sixteenth * ((f0[i - 1] + f0[i + 1]) + (fm[i] + fp[i]));
        }
        T* out = f + q * m;
        for (std::size_t a = 0; a + 1 < half; ++a) {
            out[2 * a] = even[a];
            out[2 * a + 1] = odd[a];
        }
        out[m - 1] = even[half - 1];
    }
}

// The float and double steps, each compiled twice (AVX2 and the x86-64 baseline) and chosen
// at load time by the CPU; no fused multiply-add in either, so both give the same bits.
#if defined(__x86_64__) && defined(__GNUC__)
#define PSUB_TILE_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define PSUB_TILE_CLONES
#endif
PSUB_TILE_CLONES void doubleStep(const float* c, std::uint32_t n, float* qv, float* qf, float* f, float* even,
                                 float* odd) {
    doubleStepBody(c, n, qv, qf, f, even, odd);
}
PSUB_TILE_CLONES void doubleStep(const double* c, std::uint32_t n, double* qv, double* qf, double* f, double* even,
                                 double* odd) {
    doubleStepBody(c, n, qv, qf, f, even, odd);
}

// The largest grid side any step of any tile of `table` may use (its largest tiles).
std::uint32_t largestGrid(const TiledTable& table) {
    if (table.doubleSteps == 0) return 0;
    std::uint32_t n = (TiledTable::kMaxLattice >> table.doubleSteps) + 2 * table.halo + 1, largest = n;
    for (std::uint32_t s = 0; s < table.doubleSteps; ++s) largest = std::max(largest, n = nextSize(n));
    return largest;
}

}  // namespace

std::size_t tileScratchSize(const TiledTable& table, std::uint32_t width) {
    const std::size_t n = largestGrid(table);
    return (4 + 2 * std::size_t(width)) * n * n + 2 * n;
}

template <class T>
void evaluateTile(const TiledTable& table, std::size_t k, const T* base, std::uint32_t width, T* refined,
                  T* scratch, T* lattice) {
    const std::size_t largest = largestGrid(table), area = largest * largest;
    T *a = scratch, *b = scratch + area, *qv = scratch + 2 * area, *qf = scratch + 3 * area;
    T* finals = scratch + 4 * area;           // the finest grid of each value, one after another
    T* inputs = finals + width * area;        // the gathered grid of each value
    T *even = inputs + width * area, *odd = even + largest;
    const std::uint32_t g = table.gridSize(k), L = table.lattice(k), t = table.doubleSteps;
    const std::uint32_t* gather = table.gather.data() + table.gatherBegin[k];
    const std::size_t points = std::size_t(g) * g;
    if (width == 3) {
        for (std::size_t i = 0; i < points; ++i) {
            const T* p = base + std::size_t(gather[i]) * 3;
            inputs[i] = p[0];
            inputs[area + i] = p[1];
            inputs[2 * area + i] = p[2];
        }
    } else {
        for (std::size_t i = 0; i < points; ++i)
            for (std::uint32_t c = 0; c < width; ++c) inputs[c * area + i] = base[std::size_t(gather[i]) * width + c];
    }
    std::uint32_t n = g;
    for (std::uint32_t c = 0; c < width; ++c) {
        const T* from = inputs + c * area;
        n = g;
        for (std::uint32_t s = 0; s < t; ++s) {
            T* to = s + 1 == t ? finals + c * area : (s % 2 == 0 ? a : b);
            doubleStep(from, n, qv, qf, to, even, odd);
            n = nextSize(n);
            from = to;
        }
    }
    // The lattice's (0, 0) in the finest grid: 2^t (halo - 4) + 4 (see docs/tiled.md).
    const std::size_t r0 = (std::size_t(table.halo) << t) + 4 - (std::size_t(4) << t);
    const auto row = [&](std::uint32_t y) { return finals + (y + r0) * n + r0; };  // value 0's row y
    if (lattice) {
        for (std::uint32_t y = 0; y <= L; ++y)
            for (std::uint32_t x = 0; x <= L; ++x)
                for (std::uint32_t c = 0; c < width; ++c)
                    lattice[(std::size_t(y) * (L + 1) + x) * width + c] = row(y)[c * area + x];
        return;
    }
    const std::uint32_t begin = table.output[k];
    const std::uint32_t end = k + 1 < table.tileCount() ? table.output[k + 1] : table.fallbackBegin;
    T* out = refined + std::size_t(begin) * width;
    for (std::uint32_t y = 1; y < L; ++y) {
        const T* from = row(y);
        if (width == 3) {
            const T *x0 = from, *x1 = from + area, *x2 = from + 2 * area;
            for (std::uint32_t x = 1; x < L; ++x, out += 3) {
                out[0] = x0[x];
                out[1] = x1[x];
                out[2] = x2[x];
            }
        } else {
            for (std::uint32_t x = 1; x < L; ++x)
                for (std::uint32_t c = 0; c < width; ++c) *out++ = from[c * area + x];
        }
    }
    const std::uint32_t* border = table.border.data() + table.borderBegin[k];
    std::size_t e = 0;
    for (std::uint32_t y = 0; y <= L; ++y)
        for (std::uint32_t x = 0; x <= L; x += (y == 0 || y == L) ? 1 : L, ++e)
            if (border[e] >= begin && border[e] < end)
                for (std::uint32_t c = 0; c < width; ++c)
                    refined[std::size_t(border[e]) * width + c] = row(y)[c * area + x];
}

template <class T>
void toCanonical(const TiledTable& table, std::span<const T> drawing, std::span<T> canonical, std::uint32_t width) {
    for (std::size_t p = 0; p < table.canonical.size(); ++p)
        std::copy_n(drawing.data() + p * width, width, canonical.data() + std::size_t(table.canonical[p]) * width);
}

template void evaluateTile<float>(const TiledTable&, std::size_t, const float*, std::uint32_t, float*, float*, float*);
template void evaluateTile<double>(const TiledTable&, std::size_t, const double*, std::uint32_t, double*, double*,
                                   double*);
template void toCanonical<float>(const TiledTable&, std::span<const float>, std::span<float>, std::uint32_t);
template void toCanonical<double>(const TiledTable&, std::span<const double>, std::span<double>, std::uint32_t);

}  // namespace psub
