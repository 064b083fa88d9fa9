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
template <class T>
void doubleStep(const T* c, std::uint32_t n, T* qv, T* qf, T* f) {
    const T quarter = T(0.25), eighth = T(0.125), sixteenth = T(0.0625);
    const std::size_t nv = n - 2, nf = n - 1, m = nextSize(n);
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
    // V(i, j): the V-point of c's vertex (i, j); F(i, j): the F-point of the cell (i, j)-(i+1, j+1).
    const auto V = [&](std::size_t i, std::size_t j) { return qv[(j - 1) * nv + (i - 1)]; };
    const auto F = [&](std::size_t i, std::size_t j) { return qf[j * nf + i]; };
    for (std::size_t q = 0; q < m; ++q) {
        T* out = f + q * m;
        const std::size_t Y = q + 4;
        if (Y % 2 == 0) {
            const std::size_t j = Y / 2;
            for (std::size_t p = 0; p < m; p += 2) {  // even x: V-point of V(i, j)
                const std::size_t i = (p + 4) / 2;
                out[p] = quarter * V(i, j) + eighth * ((F(i - 1, j - 1) + F(i, j)) + (F(i, j - 1) + F(i - 1, j))) +
                         sixteenth * ((V(i - 1, j) + V(i + 1, j)) + (V(i, j - 1) + V(i, j + 1)));
            }
            for (std::size_t p = 1; p < m; p += 2) {  // odd x: F-point of the diamond across x
                const std::size_t i = (p + 3) / 2;
                out[p] = quarter * ((V(i, j) + V(i + 1, j)) + (F(i, j - 1) + F(i, j)));
            }
        } else {
            const std::size_t j = (Y - 1) / 2;
            for (std::size_t p = 0; p < m; p += 2) {  // even x: F-point of the diamond across y
                const std::size_t i = (p + 4) / 2;
                out[p] = quarter * ((V(i, j) + V(i, j + 1)) + (F(i - 1, j) + F(i, j)));
            }
            for (std::size_t p = 1; p < m; p += 2) {  // odd x: V-point of F(i, j)
                const std::size_t i = (p + 3) / 2;
                out[p] = quarter * F(i, j) + eighth * ((V(i, j) + V(i + 1, j + 1)) + (V(i + 1, j) + V(i, j + 1))) +
                         sixteenth * ((F(i - 1, j) + F(i + 1, j)) + (F(i, j - 1) + F(i, j + 1)));
            }
        }
    }
}

// The largest grid side any step of any tile of `table` uses.
std::uint32_t largestGrid(const TiledTable& table) {
    std::uint32_t largest = 0;
    for (std::size_t k = 0; k < table.tileCount(); ++k) {
        std::uint32_t n = table.gridSize(k);
        largest = std::max(largest, n);
        for (std::uint32_t s = 0; s < table.doubleSteps; ++s) largest = std::max(largest, n = nextSize(n));
    }
    return largest;
}

}  // namespace

std::size_t tileScratchSize(const TiledTable& table, std::uint32_t width) {
    const std::size_t n = largestGrid(table);
    return (4 + std::size_t(width)) * n * n;
}

template <class T>
void evaluateTile(const TiledTable& table, std::size_t k, const T* base, std::uint32_t width, T* refined,
                  T* scratch, T* lattice) {
    const std::size_t largest = largestGrid(table), area = largest * largest;
    T *a = scratch, *b = scratch + area, *qv = scratch + 2 * area, *qf = scratch + 3 * area;
    T* finals = scratch + 4 * area;  // the finest grid of each value, one after another
    const std::uint32_t g = table.gridSize(k), L = table.lattice(k), t = table.doubleSteps;
    const std::uint32_t* gather = table.gather.data() + table.gatherBegin[k];
    // The lattice's (0, 0) in the finest grid: 2^t (halo - 4) + 4 (see docs/tiled.md).
    const std::size_t r0 = (std::size_t(table.halo) << t) + 4 - (std::size_t(4) << t);
    std::uint32_t n = g;
    for (std::uint32_t c = 0; c < width; ++c) {
        for (std::size_t i = 0; i < std::size_t(g) * g; ++i) a[i] = base[std::size_t(gather[i]) * width + c];
        T* from = a;
        n = g;
        for (std::uint32_t s = 0; s < t; ++s) {
            T* to = s + 1 == t ? finals + c * area : (from == a ? b : a);
            doubleStep(from, n, qv, qf, to);
            n = nextSize(n);
            from = to;
        }
    }
    const auto value = [&](std::uint32_t c, std::uint32_t x, std::uint32_t y) {
        return finals[c * area + (y + r0) * n + (x + r0)];
    };
    if (lattice) {
        for (std::uint32_t y = 0; y <= L; ++y)
            for (std::uint32_t x = 0; x <= L; ++x)
                for (std::uint32_t c = 0; c < width; ++c)
                    lattice[(std::size_t(y) * (L + 1) + x) * width + c] = value(c, x, y);
        return;
    }
    const std::uint32_t begin = table.output[k];
    const std::uint32_t end = k + 1 < table.tileCount() ? table.output[k + 1] : table.fallbackBegin;
    T* out = refined + std::size_t(begin) * width;
    for (std::uint32_t y = 1; y < L; ++y)
        for (std::uint32_t x = 1; x < L; ++x)
            for (std::uint32_t c = 0; c < width; ++c) *out++ = value(c, x, y);
    const std::uint32_t* border = table.border.data() + table.borderBegin[k];
    std::size_t e = 0;
    for (std::uint32_t y = 0; y <= L; ++y)
        for (std::uint32_t x = 0; x <= L; x += (y == 0 || y == L) ? 1 : L, ++e)
            if (border[e] >= begin && border[e] < end)
                for (std::uint32_t c = 0; c < width; ++c) refined[std::size_t(border[e]) * width + c] = value(c, x, y);
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
