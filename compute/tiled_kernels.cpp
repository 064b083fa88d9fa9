// The tiled form's tile kernel: a tile's gathered level-B grid refined 2t P-S steps with the
// regular masks over implicit grids (one value per vertex at a time, the quincunx level a ring
// of four rows; the last step row pair by row pair across the values, only over the tile's
// lattice), each finished lattice row written at once (inner points with streaming stores)
// and, on request, its inner points' unit normals from the lattice in cache (which points and
// faces those are: tileNormalSets, for both evaluators). Sums pair
// opposite neighbours, so two tiles that compute a shared point in their own frames (rotated or
// reflected) produce bitwise the same value.
#include "psub/evaluator.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string_view>
#include <type_traits>
#if defined(__SSE2__)
#include <immintrin.h>
#endif
#include <utility>
#include <vector>

namespace psub {
namespace {

// Grid sizes of a tile whose gathered grid is g x g: each double step maps n to 2n - 9.
std::uint32_t nextSize(std::uint32_t n) { return 2 * n - 9; }

// Rows laid out on 64-byte lines (kLineFloats floats): on this project's AMD EPYC a 64-byte load
// that crosses two lines takes as long as two loads (bench/README.md, "Session 47").
constexpr std::size_t kLineFloats = 16;
std::size_t wholeLines(std::size_t n) { return (n + kLineFloats - 1) / kLineFloats * kLineFloats; }
// A ring of quincunx rows (rowPairBody) for grids of side at most n: eight rows, each of whole
// lines with two lines of room past its end (the AVX-512 loops load the line after their last
// point), and room to move them onto a line.
std::size_t ringStride(std::size_t n) { return wholeLines(n) + 2 * kLineFloats; }
std::size_t quincunxRingSize(std::size_t n) { return 8 * ringStride(n) + 2 * kLineFloats; }
// The finest lattice's planes (evaluateTile), one after the other: rows of whole lines, and room
// to move them so that each row's second point starts a line (interleave3 reads from there).
std::size_t latticePlane() { return wholeLines(TiledTable::kMaxLattice + 1) * (TiledTable::kMaxLattice + 1); }
constexpr std::size_t kLatticeRoom = 2 * kLineFloats;
// A plane of a row of quad or unit normals (evaluateTile): the lattice's quads, whole lines, and
// a line of room for the AVX-512 loop's lanes past the row's last quad (normalRowAvx512).
std::size_t quadPlane() { return wholeLines(TiledTable::kMaxLattice + 1) + kLineFloats; }

// GCC's "no loop-carried dependence": the loops below write no row they read; without it GCC
// does not vectorise them (alias checks), 2x slower. Other compilers go without.
#if defined(__GNUC__) && !defined(__clang__)
#define PSUB_IVDEP _Pragma("GCC ivdep")
#else
#define PSUB_IVDEP
#endif

// Calls point(a) for a = 0 .. count - 1 in blocks of Block steps, Block the vector width of the
// variant, at least 8 (kBlockSteps: 16 floats with AVX-512, 8 with AVX2; 8 doubles with
// either): a loop of a fixed Block steps is vectorised whole, with no scalar remainder; where
// count is no multiple of Block the last block overlaps the one before (points computed twice,
// the same values: each point is a function of rows that no point writes). A small tile's rows
// (36 steps at a lattice of 72) spent as long in their scalar remainder as in their vectors.
// Counts under Block step by step. Block 0 (the baseline, 4 floats a vector: a remainder of at
// most 3): one plain loop; blocks of 4 vectorised badly there (2x slower), blocks of 16
// overlapped too much (14% slower).
template <std::size_t Block, class Point>
[[gnu::always_inline]] inline void inBlocks(std::size_t count, Point point) {
    if constexpr (Block == 0) {
        PSUB_IVDEP
        for (std::size_t a = 0; a < count; ++a) point(a);
        return;
    }
    if (count < Block) {
        for (std::size_t a = 0; a < count; ++a) point(a);
        return;
    }
    std::size_t a = 0;
    for (; a + Block <= count; a += Block) {
        PSUB_IVDEP
        for (std::size_t b = 0; b < Block; ++b) point(a + b);
    }
    if (a == count) return;
    PSUB_IVDEP
    for (std::size_t b = 0; b < Block; ++b) point(count - Block + b);
}

// The two loops that take most of the kernel's time, for floats with AVX-512 (its variant's
// blocks of 16; tileKernelInstructions): quincunxRow's (with the row below's F-points) and
// fineRows' two-row loop. Each row they read is loaded once a block, as the vector of the block
// after the previous one's, and its neighbours at i - 1, i + 1, i + 2 are shifted in from those
// two vectors (valignd) instead of loaded again (loads 8 -> 3 a block in the quincunx loop, 12
// -> 6 in the fine loop); the fine loop's rows start a 64-byte line at its first block
// (rowPairBody), so its loads are whole lines; and the F-point left of each point (quincunx) and
// the diamond left of each point (fine) are the block's own shifted by one lane. The same
// operations on the same values as the generic loops (their lambdas' sums, pair by pair), so
// the same bits (Tiled.EveryInstructionSetGivesTheSameBits). Each returns how many steps it
// made (whole blocks: the rest is the generic loop's). bench/README.md, "Session 47".
#if defined(__x86_64__) && defined(__GNUC__)
#define PSUB_TILE_LOOPS_AVX512 1
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"  // GCC 12 on _mm512_alignr_epi32's unset source
// The 16 values from lane K of `here` on, continued into `next`.
template <int K>
__attribute__((target("avx512f"), always_inline)) inline __m512 onFrom(__m512 here, __m512 next) {
    return _mm512_castsi512_ps(_mm512_alignr_epi32(_mm512_castps_si512(next), _mm512_castps_si512(here), K));
}
// 1/4 ((a + b) + (c + d)), as the generic loops' means.
__attribute__((target("avx512f"), always_inline)) inline __m512 meanOf(__m512 a, __m512 b, __m512 c, __m512 d) {
    return _mm512_mul_ps(_mm512_set1_ps(0.25f), _mm512_add_ps(_mm512_add_ps(a, b), _mm512_add_ps(c, d)));
}

// quincunxRow's loop with fBelow, x from 1 on. Its last block loads up to 15 values past the
// rows it reads: past the grid's last row, the scratch region after the grid's (evaluateTile
// lays every grid out with another region after it); past fBelow's, the ring's room.
__attribute__((target("avx512f"))) std::size_t quincunxRowAvx512(const float* __restrict mid, const float* __restrict up,
                                                                 const float* __restrict fBelow, std::size_t count,
                                                                 float* __restrict v, float* __restrict f) {
    const std::size_t blocks = count / 16;
    if (blocks == 0) return 0;
    // Each vector holds x - 1 .. x + 14: mid, up and fBelow's, and F(x - 1, j) in lane 15.
    __m512 mid0 = _mm512_loadu_ps(mid), up0 = _mm512_loadu_ps(up), below0 = _mm512_loadu_ps(fBelow);
    __m512 hereBefore = _mm512_set1_ps(f[0]);
    for (std::size_t x = 1; x < 16 * blocks + 1; x += 16) {
        const __m512 mid1 = _mm512_loadu_ps(mid + x + 15), up1 = _mm512_loadu_ps(up + x + 15),
                     below1 = _mm512_loadu_ps(fBelow + x + 15);
        const __m512 midX = onFrom<1>(mid0, mid1), upX = onFrom<1>(up0, up1);
        const __m512 here = meanOf(midX, onFrom<2>(up0, up1), onFrom<2>(mid0, mid1), upX);  // F(x, j)
        const __m512 left = onFrom<15>(hereBefore, here);                                    // F(x - 1, j)
        _mm512_storeu_ps(v + x - 1, meanOf(below0, here, onFrom<1>(below0, below1), left));
        _mm512_storeu_ps(f + x, here);
        hereBefore = here;
        mid0 = mid1, up0 = up1, below0 = below1;
    }
    return 16 * blocks;
}

// fineRows' two-row loop (rows q and q + 1), i from i0 on; the rows' value i0 - 1 starts a line.
__attribute__((target("avx512f"))) std::size_t fineRowsAvx512(const float* __restrict v0, const float* __restrict vm,
                                                              const float* __restrict v1, const float* __restrict f0,
                                                              const float* __restrict fm, const float* __restrict fp,
                                                              std::size_t i0, std::size_t count, float* __restrict out,
                                                              float* __restrict next) {
    const std::size_t blocks = count / 16;
    if (blocks == 0) return 0;
    // Lane l of the lower and upper halves of a row pair: a block's even points then odd ones.
    const __m512i lower = _mm512_set_epi32(23, 7, 22, 6, 21, 5, 20, 4, 19, 3, 18, 2, 17, 1, 16, 0);
    const __m512i upper = _mm512_set_epi32(31, 15, 30, 14, 29, 13, 28, 12, 27, 11, 26, 10, 25, 9, 24, 8);
    // Each vector holds i - 1 .. i + 14 of V(j), V(j + 1), F(j), F(j - 1), F(j + 1).
    __m512 v00 = _mm512_load_ps(v0 + i0 - 1), v10 = _mm512_load_ps(v1 + i0 - 1), f00 = _mm512_load_ps(f0 + i0 - 1),
           fm0 = _mm512_load_ps(fm + i0 - 1), fp0 = _mm512_load_ps(fp + i0 - 1);
    // The diamond across x from V(i0 - 1, j), in lane 15.
    __m512 acrossXBefore = _mm512_set1_ps(0.25f * ((v0[i0 - 2] + v0[i0 - 1]) + (fm[i0 - 1] + f0[i0 - 1])));
    for (std::size_t i = i0; i < i0 + 16 * blocks; i += 16) {
        const __m512 v01 = _mm512_load_ps(v0 + i + 15), v11 = _mm512_load_ps(v1 + i + 15),
                     f01 = _mm512_load_ps(f0 + i + 15), fm1 = _mm512_load_ps(fm + i + 15),
                     fp1 = _mm512_load_ps(fp + i + 15), vmI = _mm512_load_ps(vm + i - 1);
        const __m512 v0I = onFrom<1>(v00, v01), v1I = onFrom<1>(v10, v11), f0I = onFrom<1>(f00, f01),
                     fmI = onFrom<1>(fm0, fm1);
        // fineRows' lambdas' diamonds: acrossX(i), acrossY(i), left = acrossX(i - 1), below, right, above.
        const __m512 acrossX = meanOf(v00, v0I, fmI, f0I), acrossY = meanOf(v00, v10, f00, f0I);
        const __m512 left = onFrom<15>(acrossXBefore, acrossX), below = meanOf(vmI, v00, fm0, fmI);
        const __m512 right = meanOf(v0I, v1I, f0I, onFrom<2>(f00, f01));
        const __m512 above = meanOf(v10, v1I, f0I, onFrom<1>(fp0, fp1));
        const __m512 vertexOfV = meanOf(left, acrossX, below, acrossY);
        const __m512 vertexOfF = meanOf(acrossY, right, acrossX, above);
        float* o = out + 2 * (i - i0);
        float* n = next + 2 * (i - i0);
        _mm512_storeu_ps(o, _mm512_permutex2var_ps(vertexOfV, lower, acrossX));
        _mm512_storeu_ps(o + 16, _mm512_permutex2var_ps(vertexOfV, upper, acrossX));
        _mm512_storeu_ps(n, _mm512_permutex2var_ps(acrossY, lower, vertexOfF));
        _mm512_storeu_ps(n + 16, _mm512_permutex2var_ps(acrossY, upper, vertexOfF));
        acrossXBefore = acrossX;
        v00 = v01, v10 = v11, f00 = f01, fm0 = fm1, fp0 = fp1;
    }
    return 16 * blocks;
}

// Lane e of the packed vector k (values 16 k + e of x, y, z triples of 16 points) from two
// vectors: lanes [k] take x (0 - 15) or y (16 - 31) into the triple's place, lanes [3 + k] keep
// those (e) and take z (16 - 31).
constexpr std::array<std::array<std::int32_t, 16>, 6> kTripleLanes = [] {
    std::array<std::array<std::int32_t, 16>, 6> lanes{};
    for (int k = 0; k < 3; ++k)
        for (int e = 0; e < 16; ++e) {
            const int point = (16 * k + e) / 3, axis = (16 * k + e) % 3;
            lanes[k][e] = axis == 0 ? point : axis == 1 ? 16 + point : 0;
            lanes[3 + k][e] = axis == 2 ? 16 + point : e;
        }
    return lanes;
}();

// normalRowBody for floats with AVX-512, in blocks of 16 inner points p = 1 + 16 b ...: the
// rows r and r + 1 at p (whole lines: each lattice row's point 1 starts one, evaluateTile) and
// at p + 1 (shifted in from the next block's), the quads at p and, lane 15 of the block before
// shifted in, at p - 1 (quad 0 made alone). The same operations on the same values as
// quadNormalsBody, vertexNormalsBody and interleave3Body, so the same bits. The last block's
// lanes past point L - 1 (L - 1 is odd: at least one) compute from the rows' room values that
// nothing reads: up to 15 quads into the room of `hi`'s planes (quadPlane) and 45 values past
// out's 3 (L - 1) (the packed ring's room). Needs L > 16.
__attribute__((target("avx512f"))) void normalRowAvx512(const float* __restrict x, const float* __restrict y,
                                                        const float* __restrict z, std::size_t rowStride,
                                                        std::size_t L, const float* __restrict lo,
                                                        float* __restrict hi, std::size_t quadStride,
                                                        float* __restrict out) {
    const std::size_t s = rowStride, qs = quadStride;
    const float* const planes[3] = {x, y, z};
    {  // quad 0
        float a[3], b[3];
        for (int c = 0; c < 3; ++c) a[c] = planes[c][s + 1] - planes[c][0], b[c] = planes[c][s] - planes[c][1];
        hi[0] = a[1] * b[2] - a[2] * b[1];
        hi[qs] = a[2] * b[0] - a[0] * b[2];
        hi[2 * qs] = a[0] * b[1] - a[1] * b[0];
    }
    __m512i lanes[6];
    for (int k = 0; k < 6; ++k) lanes[k] = _mm512_loadu_si512(kTripleLanes[k].data());
    // Per plane: rows r and r + 1 at p .. p + 15; the quads at p - 16 .. p - 1 (lane 15 read),
    // this row's and the row below's.
    __m512 row0[3], row1[3], before[3], loBefore[3] = {};
    for (int c = 0; c < 3; ++c) {
        row0[c] = _mm512_loadu_ps(planes[c] + 1), row1[c] = _mm512_loadu_ps(planes[c] + s + 1);
        before[c] = _mm512_set1_ps(hi[c * qs]);
        if (lo) loBefore[c] = _mm512_set1_ps(lo[c * qs]);
    }
    const std::size_t blocks = (L - 1 + 15) / 16;
    for (std::size_t b = 0; b < blocks; ++b) {
        const std::size_t p = 1 + 16 * b;
        __m512 next0[3], next1[3], across[3], back[3], quad[3];  // across, back: the quads' diagonals
        for (int c = 0; c < 3; ++c) {
            next0[c] = row0[c], next1[c] = row1[c];  // the last block: lane 15 unread
            if (b + 1 < blocks)
                next0[c] = _mm512_loadu_ps(planes[c] + p + 16), next1[c] = _mm512_loadu_ps(planes[c] + s + p + 16);
            across[c] = _mm512_sub_ps(onFrom<1>(row1[c], next1[c]), row0[c]);
            back[c] = _mm512_sub_ps(row1[c], onFrom<1>(row0[c], next0[c]));
        }
        for (int c = 0; c < 3; ++c) {
            const int d = (c + 1) % 3, e = (c + 2) % 3;
            quad[c] = _mm512_sub_ps(_mm512_mul_ps(across[d], back[e]), _mm512_mul_ps(across[e], back[d]));
            _mm512_storeu_ps(hi + c * qs + p, quad[c]);
        }
        if (lo) {
            __m512 sum[3];
            for (int c = 0; c < 3; ++c) {
                const __m512 below = _mm512_loadu_ps(lo + c * qs + p);
                sum[c] = _mm512_add_ps(_mm512_add_ps(onFrom<15>(loBefore[c], below), below),
                                       _mm512_add_ps(onFrom<15>(before[c], quad[c]), quad[c]));
                loBefore[c] = below;
            }
            const __m512 squares = _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(sum[0], sum[0]), _mm512_mul_ps(sum[1], sum[1])),
                                                 _mm512_mul_ps(sum[2], sum[2]));
            const __m512 length = _mm512_sqrt_ps(squares);
            const __m512 inverse = _mm512_div_ps(_mm512_set1_ps(1.0f), length);
            const __m512 scale = _mm512_maskz_mov_ps(_mm512_cmp_ps_mask(length, _mm512_setzero_ps(), _CMP_GT_OQ), inverse);
            const __m512 nx = _mm512_mul_ps(sum[0], scale), ny = _mm512_mul_ps(sum[1], scale), nz = _mm512_mul_ps(sum[2], scale);
            for (int k = 0; k < 3; ++k)
                _mm512_storeu_ps(out + 3 * (p - 1) + 16 * k,
                                 _mm512_permutex2var_ps(_mm512_permutex2var_ps(nx, lanes[k], ny), lanes[3 + k], nz));
        }
        for (int c = 0; c < 3; ++c) before[c] = quad[c], row0[c] = next0[c], row1[c] = next1[c];
    }
}
#pragma GCC diagnostic pop
#endif

// Row j (1 <= j <= n - 2) of the quincunx level of the n x n grid `c` (spacing 1): v, the
// V-points of c's inner vertices (x, j), v[x - 1] for x = 1 .. n - 2, and f, the F-points of
// the cells whose first corner is (x, j), f[x] for x = 0 .. n - 2. A cell's F-point is the mean
// of its corners, its two diagonals' pairs summed first; a vertex's V-point the mean of its four
// cells' F-points, the two diagonally opposite pairs summed first (docs/tiled.md, "How the
// kernels sum them": the 9-point mask regrouped, fewer loads and operations). The F-point of
// (x, j) is made in the loop of the V-point of (x, j), whose loads it shares; the F-points of row
// j - 1 are read from `fBelow` (that row's f, made before) where given, else made again.
template <std::size_t Block, class T>
[[gnu::always_inline]] inline void quincunxRow(const T* __restrict c, std::size_t n, std::size_t j,
                                               const T* __restrict fBelow, T* __restrict v, T* __restrict f) {
    const T quarter = T(0.25);
    const T* down = c + (j - 1) * n;
    const T* mid = c + j * n;
    const T* up = c + (j + 1) * n;
    f[0] = quarter * ((mid[0] + up[1]) + (mid[1] + up[0]));
    if (fBelow) {
        std::size_t done = 0;  // steps made by the AVX-512 loop; the rest in (overlapping) blocks below
#if defined(PSUB_TILE_LOOPS_AVX512)
        if constexpr (Block == 16 && std::is_same_v<T, float>) done = quincunxRowAvx512(mid, up, fBelow, n - 2, v, f);
#endif
        const std::size_t first = done == 0 || done == n - 2 ? done : n - 2 - Block;  // n - 2 >= Block if done > 0
        inBlocks<Block>(n - 2 - first, [&](std::size_t b) __attribute__((always_inline)) {
            const std::size_t x = b + first + 1;
            const T here = quarter * ((mid[x] + up[x + 1]) + (mid[x + 1] + up[x]));      // F(x, j)
            const T left = quarter * ((mid[x - 1] + up[x]) + (mid[x] + up[x - 1]));      // F(x - 1, j)
            v[x - 1] = quarter * ((fBelow[x - 1] + here) + (fBelow[x] + left));
            f[x] = here;
        });
        return;
    }
    inBlocks<Block>(n - 2, [&](std::size_t a) __attribute__((always_inline)) {
        const std::size_t x = a + 1;
        const T here = quarter * ((mid[x] + up[x + 1]) + (mid[x + 1] + up[x]));              // F(x, j)
        const T left = quarter * ((mid[x - 1] + up[x]) + (mid[x] + up[x - 1]));              // F(x - 1, j)
        const T belowLeft = quarter * ((down[x - 1] + mid[x]) + (down[x] + mid[x - 1]));     // F(x - 1, j - 1)
        const T below = quarter * ((down[x] + mid[x + 1]) + (down[x + 1] + mid[x]));         // F(x, j - 1)
        v[x - 1] = quarter * ((belowLeft + here) + (below + left));
        f[x] = here;
    });
}

// Fine rows q (even) and, with `next`, q + 1 from the quincunx rows around c's row j: v0, vm,
// v1 = V(j), V(j - 1), V(j + 1) (v_j[i - 1] = V(i, j), the V-point of c's vertex (i, j)) and
// f0, fm, fp = F(j), F(j - 1), F(j + 1) (f_j[i] = F(i, j), the F-point of the cell (i, j)-(i+1,
// j+1)); points 2 a and 2 a + 1 of a row have i = a + i0. Row q, on c's row j: V-points of
// V(i, j) (even p), diamonds across x (odd p); row q + 1, between c's rows j and j + 1:
// diamonds across y (even p), V-points of F(i, j) (odd p). A diamond (the quincunx level's face)
// is the mean of its two V-points and its two F-points, each pair summed first; a V-point the
// mean of the four diamonds around its vertex, the two opposite pairs summed first (as
// quincunxRow's). Both rows in one loop, each point written in place: their four kinds of
// points share their loads (the kernel is bound by its loads and stores, not its arithmetic),
// in blocks (inBlocks). The lambdas are forced inline: called from inBlocks's lambda GCC
// otherwise called them point by point (3x slower).
template <std::size_t Block, class T>
[[gnu::always_inline]] inline void fineRows(const T* __restrict v0, const T* __restrict vm, const T* __restrict v1,
                                            const T* __restrict f0, const T* __restrict fm, const T* __restrict fp,
                                            std::size_t i0, std::size_t count, T* __restrict out,
                                            T* __restrict next) {
    const T quarter = T(0.25);
    const auto acrossX = [&](std::size_t i) __attribute__((always_inline)) {  // between V(i, j) and V(i + 1, j)
        return quarter * ((v0[i - 1] + v0[i]) + (fm[i] + f0[i]));
    };
    const auto acrossY = [&](std::size_t i) __attribute__((always_inline)) {  // between V(i, j) and V(i, j + 1)
        return quarter * ((v0[i - 1] + v1[i - 1]) + (f0[i - 1] + f0[i]));
    };
    const auto vertexOfV = [&](std::size_t i) __attribute__((always_inline)) {
        const T left = quarter * ((v0[i - 2] + v0[i - 1]) + (fm[i - 1] + f0[i - 1]));  // across x, from V(i - 1, j)
        const T below = quarter * ((vm[i - 1] + v0[i - 1]) + (fm[i - 1] + fm[i]));     // across y, from V(i, j - 1)
        return quarter * ((left + acrossX(i)) + (below + acrossY(i)));
    };
    const auto vertexOfF = [&](std::size_t i) __attribute__((always_inline)) {
        const T right = quarter * ((v0[i] + v1[i]) + (f0[i] + f0[i + 1]));  // across y, from V(i + 1, j)
        const T above = quarter * ((v1[i - 1] + v1[i]) + (f0[i] + fp[i]));  // across x, from V(i, j + 1)
        return quarter * ((acrossY(i) + right) + (acrossX(i) + above));
    };
    if (!next) {
        inBlocks<Block>(count, [&](std::size_t a) __attribute__((always_inline)) {
            out[2 * a] = vertexOfV(a + i0);
            out[2 * a + 1] = acrossX(a + i0);
        });
        out[2 * count] = vertexOfV(count + i0);
        return;
    }
    std::size_t done = 0;  // steps made by the AVX-512 loop; the rest in (overlapping) blocks below
#if defined(PSUB_TILE_LOOPS_AVX512)
    if constexpr (Block == 16 && std::is_same_v<T, float>) done = fineRowsAvx512(v0, vm, v1, f0, fm, fp, i0, count, out, next);
#endif
    const std::size_t first = done == 0 || done == count ? done : count - Block;  // count >= Block where done > 0
    inBlocks<Block>(count - first, [&](std::size_t b) __attribute__((always_inline)) {
        const std::size_t a = b + first;
        out[2 * a] = vertexOfV(a + i0);
        out[2 * a + 1] = acrossX(a + i0);
        next[2 * a] = acrossY(a + i0);
        next[2 * a + 1] = vertexOfF(a + i0);
    });
    out[2 * count] = vertexOfV(count + i0);
    next[2 * count] = acrossY(count + i0);
}

// Fine rows q and (unless q is the last, from + 2 count) q + 1 of a double step of one value
// per vertex: the n x n grid `c` (spacing 1) -> the fine grid of spacing 1/2 (side 2n - 9, its
// point (0, 0) at c's (2, 2)), only its points (p, q) with p, q in [from, from + 2 count]
// (`from` even), row q written to `out` (2 count + 1 values; row q + 1 `outStride` after it). Fine
// point (p, q) lies at c's ((p + 4) / 2, (q + 4) / 2). The quincunx rows j - 1, j, j + 1 they
// read (j = q / 2 + 2) are made as needed into `ring` (quincunxRingSize(n) values: four rows of V-
// and of F-points, row j in slot j mod 4), so the quincunx level never leaves the first-level
// cache (as whole grids it took 2 x 66 KB at the largest tiles): call for q = from, from + 2,
// ... in turn, with the same ring.
template <std::size_t Block, class T>
[[gnu::always_inline]] inline void rowPairBody(const T* __restrict c, std::size_t n, std::size_t from,
                                               std::size_t count, std::size_t q, T* __restrict out,
                                               std::size_t outStride, T* __restrict ring) {
    const std::size_t i0 = from / 2 + 2, j = q / 2 + 2;
    // Four rows of V- and four of F-points (row r in slot r mod 4), each of ringStride(n) values,
    // placed so that every row's value i0 - 1 (the left V-point of the pass's first fine point)
    // starts a 64-byte line, where the AVX-512 fine loop loads whole lines.
    const std::size_t stride = ringStride(n);
    const std::uintptr_t address = reinterpret_cast<std::uintptr_t>(ring);
    T* const onLine = ring + ((64 - address % 64) % 64) / sizeof(T);
    T* const first = onLine + (kLineFloats - (i0 - 1) % kLineFloats) % kLineFloats;
    T* const v[4] = {first, first + stride, first + 2 * stride, first + 3 * stride};
    T* const cells[4] = {first + 4 * stride, first + 5 * stride, first + 6 * stride, first + 7 * stride};
    // Row r's V-points read row r - 1's F-points, made just before it but for the first row.
    // Forced inline: as a function of its own the lambda is compiled without the variant's
    // instruction set (its target attribute), which made the kernel 2x slower.
    const auto row = [&](std::size_t r, bool firstRow) __attribute__((always_inline)) {
        quincunxRow<Block>(c, n, r, firstRow ? nullptr : cells[(r - 1) % 4], v[r % 4], cells[r % 4]);
    };
    // Rows j - 1 .. j + 1 are read; row j + 2, the next pass's, is made a pass ahead, so that no
    // row is read just after its stores (3-4% of the kernel, bench/README.md "Session 47").
    const bool last = q == from + 2 * count;
    if (q == from) {
        row(j - 1, true);
        row(j, false);
        row(j + 1, false);
    }
    if (!last) row(j + 2, false);
    // The last row, even, alone (its F(j + 1) row is not read: fp = f0).
    fineRows<Block>(v[j % 4], v[(j - 1) % 4], v[(j + 1) % 4], cells[j % 4], cells[(j - 1) % 4],
                    last ? cells[j % 4] : cells[(j + 1) % 4], i0, count, out, last ? nullptr : out + outStride);
}

// The whole double step (rowPairBody's points), into `f`.
template <std::size_t Block, class T>
[[gnu::always_inline]] inline void doubleStepBody(const T* __restrict c, std::size_t n, std::size_t from,
                                                  std::size_t count, T* __restrict f, T* __restrict ring) {
    for (std::size_t q = from; q <= from + 2 * count; q += 2)
        rowPairBody<Block>(c, n, from, count, q, f + (q - from) * (2 * count + 1), 2 * count + 1, ring);
}

// Three planes of `count` values each -> count xyz triples.
template <class T>
[[gnu::always_inline]] inline void interleave3Body(const T* __restrict x, const T* __restrict y,
                                                   const T* __restrict z, std::size_t count, T* __restrict out) {
    for (std::size_t i = 0; i < count; ++i) {
        out[3 * i] = x[i];
        out[3 * i + 1] = y[i];
        out[3 * i + 2] = z[i];
    }
}

// Newell's normals of the quads (x, y)-(x + 1, y + 1), x < L, of one lattice row: for a quad,
// the cross product of its diagonals, (p(x+1, y+1) - p(x, y)) x (p(x, y+1) - p(x+1, y)), corners
// counter-clockwise in the tile's frame as in the surface's faces. `x`, `y`, `z`: the row's
// first value in each plane (the next row `side` values on).
template <std::size_t Block, class T>
[[gnu::always_inline]] inline void quadNormalsBody(const T* __restrict x, const T* __restrict y, const T* __restrict z,
                                                   std::size_t side, std::size_t L, T* __restrict nx,
                                                   T* __restrict ny, T* __restrict nz) {
    inBlocks<Block>(L, [&](std::size_t i) __attribute__((always_inline)) {
        const T ax = x[side + i + 1] - x[i], ay = y[side + i + 1] - y[i], az = z[side + i + 1] - z[i];
        const T bx = x[side + i] - x[i + 1], by = y[side + i] - y[i + 1], bz = z[side + i] - z[i + 1];
        nx[i] = ay * bz - az * by;
        ny[i] = az * bx - ax * bz;
        nz[i] = ax * by - ay * bx;
    });
}

// Unit normals of a lattice row's inner points (x = 1 .. L - 1) into three planes: the sum of
// the four quads' normals around each (rows below: `lo`, above: `hi`, as quadNormalsBody writes
// them), scaled to length 1 (0 where the sum is 0), as normals() does. The file is compiled
// without errno for math functions and without trapping floating-point compares
// (compute/CMakeLists.txt), so the square root and the select vectorise (same results).
template <std::size_t Block, class T>
[[gnu::always_inline]] inline void vertexNormalsBody(const T* __restrict lo, const T* __restrict hi, std::size_t stride,
                                                     std::size_t L, T* __restrict nx, T* __restrict ny,
                                                     T* __restrict nz) {
    inBlocks<Block>(L - 1, [&](std::size_t a) __attribute__((always_inline)) {
        const std::size_t i = a + 1;
        const T sx = (lo[i - 1] + lo[i]) + (hi[i - 1] + hi[i]);
        const T sy = (lo[stride + i - 1] + lo[stride + i]) + (hi[stride + i - 1] + hi[stride + i]);
        const T sz = (lo[2 * stride + i - 1] + lo[2 * stride + i]) + (hi[2 * stride + i - 1] + hi[2 * stride + i]);
        const T length = std::sqrt(sx * sx + sy * sy + sz * sz);
        const T inverse = T(1) / length;  // unconditionally (inf at 0): a select, not a branch
        const T scale = length > 0 ? inverse : T(0);
        nx[i - 1] = sx * scale;
        ny[i - 1] = sy * scale;
        nz[i - 1] = sz * scale;
    });
}

// Lattice row r's quad normals (x, y, z: the row's first value in each plane, row r + 1
// `rowStride` on) into `hi` (3 planes `quadStride` apart) and, with `lo` (row r - 1's, as `hi`),
// inner row r's unit normals packed as x, y, z triples into `out` (3 (L - 1) values; `unit`, 3
// planes as `hi`, holds them in between). For floats with AVX-512 in one loop of its own
// (normalRowAvx512), where a row has a whole block.
template <std::size_t Block, class T>
[[gnu::always_inline]] inline void normalRowBody(const T* x, const T* y, const T* z, std::size_t rowStride,
                                                 std::size_t L, const T* lo, T* hi, std::size_t quadStride, T* unit,
                                                 T* out) {
#if defined(PSUB_TILE_LOOPS_AVX512)
    if constexpr (Block == 16 && std::is_same_v<T, float>)
        if (L > 16) return normalRowAvx512(x, y, z, rowStride, L, lo, hi, quadStride, out);
#endif
    quadNormalsBody<Block>(x, y, z, rowStride, L, hi, hi + quadStride, hi + 2 * quadStride);
    if (!lo) return;
    vertexNormalsBody<Block>(lo, hi, quadStride, L, unit, unit + quadStride, unit + 2 * quadStride);
    interleave3Body(unit, unit + quadStride, unit + 2 * quadStride, L - 1, out);
}

// Values `done` to `count` of `from` to the same places of `to`, with streaming (non-temporal)
// stores where `to` is aligned to the vector: a tile's points are written once and not read
// again in the frame. Unless `last`, what is short of a whole vector at the end is left for the
// next call; returns how far it wrote (the next call's `done`). One variant per instruction set
// (PSUB_STREAM_COPY below: 16-, 32- and 64-byte stores, a quarter as many store instructions
// at 64 as at 16 for the same lines).
#if defined(__SSE2__)
#define PSUB_STREAM_COPY(NAME, TARGET, BYTES, FLOATS, DOUBLES)                                                    \
    template <class T>                                                                                           \
    TARGET std::size_t NAME##StreamCopy(const T* from, std::size_t done, std::size_t count, T* to, bool last) {  \
        std::size_t i = done;                                                                                    \
        for (; i < count && reinterpret_cast<std::uintptr_t>(to + i) % BYTES != 0; ++i) to[i] = from[i];        \
        if constexpr (std::is_same_v<T, float>)                                                                  \
            for (; i + BYTES / 4 <= count; i += BYTES / 4) FLOATS;                                               \
        else if constexpr (std::is_same_v<T, double>)                                                            \
            for (; i + BYTES / 8 <= count; i += BYTES / 8) DOUBLES;                                              \
        if (!last) return i;                                                                                     \
        for (; i < count; ++i) to[i] = from[i];                                                                  \
        _mm_sfence();                                                                                            \
        return count;                                                                                            \
    }
PSUB_STREAM_COPY(baseline, , 16, _mm_stream_ps(to + i, _mm_loadu_ps(from + i)),
                 _mm_stream_pd(to + i, _mm_loadu_pd(from + i)))
#else
template <class T>
std::size_t baselineStreamCopy(const T* from, std::size_t done, std::size_t count, T* to, bool) {
    std::copy(from + done, from + count, to + done);
    return count;
}
#endif

// The kernel's steps, compiled once per instruction set (AVX-512, AVX2 and the x86-64
// baseline: the bodies above are inlined into each variant and vectorised for its target),
// one set chosen at run time (tileKernelInstructions; tests force each in turn), the rows in
// blocks of the set's vector width (BYTES, inBlocks; 0 in the baseline: plain loops). No fused
// multiply-add in any (the file is built with -ffp-contract=off: AVX-512F has fused
// multiply-adds of its own), so all give the same bits.
template <class T>
struct TileSteps {
    void (*doubleStep)(const T* c, std::size_t n, std::size_t from, std::size_t count, T* f, T* ring);
    void (*rowPair)(const T* c, std::size_t n, std::size_t from, std::size_t count, std::size_t q, T* out,
                    std::size_t outStride, T* ring);
    void (*normalRow)(const T* x, const T* y, const T* z, std::size_t rowStride, std::size_t L, const T* lo, T* hi,
                      std::size_t quadStride, T* unit, T* out);
    void (*interleave3)(const T* x, const T* y, const T* z, std::size_t count, T* out);
    std::size_t (*streamCopy)(const T* from, std::size_t done, std::size_t count, T* to, bool last);
};

// The steps of inBlocks for a variant of vectors of BYTES: one vector of T, at least 8 (a block
// of 4 vectorised badly: AVX2's doubles 2x slower); 0 for the baseline (BYTES 0).
template <std::size_t Bytes, class T>
constexpr std::size_t kBlockSteps = Bytes == 0 ? 0 : std::max<std::size_t>(8, Bytes / sizeof(T));

#define PSUB_TILE_STEPS(NAME, TARGET, BYTES)                                                                         \
    template <class T>                                                                                               \
    TARGET void NAME##DoubleStep(const T* c, std::size_t n, std::size_t from, std::size_t count, T* f,               \
                                 T* ring) {                                                                          \
        doubleStepBody<kBlockSteps<BYTES, T>>(c, n, from, count, f, ring);                                           \
    }                                                                                                                \
    template <class T>                                                                                               \
    TARGET void NAME##RowPair(const T* c, std::size_t n, std::size_t from, std::size_t count, std::size_t q,         \
                              T* out, std::size_t outStride, T* ring) {                                              \
        rowPairBody<kBlockSteps<BYTES, T>>(c, n, from, count, q, out, outStride, ring);                              \
    }                                                                                                                \
    template <class T>                                                                                               \
    TARGET void NAME##NormalRow(const T* x, const T* y, const T* z, std::size_t rowStride, std::size_t L,            \
                                const T* lo, T* hi, std::size_t quadStride, T* unit, T* out) {                       \
        normalRowBody<kBlockSteps<BYTES, T>>(x, y, z, rowStride, L, lo, hi, quadStride, unit, out);                  \
    }                                                                                                                \
    template <class T>                                                                                               \
    TARGET void NAME##Interleave3(const T* x, const T* y, const T* z, std::size_t count, T* out) {                   \
        interleave3Body(x, y, z, count, out);                                                                        \
    }                                                                                                                \
    template <class T>                                                                                               \
    constexpr TileSteps<T> NAME##Steps{&NAME##DoubleStep<T>, &NAME##RowPair<T>, &NAME##NormalRow<T>,                 \
                                       &NAME##Interleave3<T>, &NAME##StreamCopy<T>};

PSUB_TILE_STEPS(baseline, , 0)
#if defined(__x86_64__) && defined(__GNUC__)
#define PSUB_TILE_X86 1
PSUB_STREAM_COPY(avx2, __attribute__((target("avx2"))), 32, _mm256_stream_ps(to + i, _mm256_loadu_ps(from + i)),
                 _mm256_stream_pd(to + i, _mm256_loadu_pd(from + i)))
PSUB_STREAM_COPY(avx512, __attribute__((target("avx512f"))), 64, _mm512_stream_ps(to + i, _mm512_loadu_ps(from + i)),
                 _mm512_stream_pd(to + i, _mm512_loadu_pd(from + i)))
PSUB_TILE_STEPS(avx2, __attribute__((target("avx2"))), 32)
PSUB_TILE_STEPS(avx512, __attribute__((target("avx512f"))), 64)
#endif
#undef PSUB_TILE_STEPS
#undef PSUB_STREAM_COPY

// The instruction sets, best first, and which of them runs (-1: not chosen yet, the best
// this CPU has on first use).
constexpr const char* kInstructionSets[] = {"avx512f", "avx2", "baseline"};
std::atomic<int> chosenSet{-1};

bool cpuHas(int set) {
#if PSUB_TILE_X86
    __builtin_cpu_init();
    if (set == 0) return __builtin_cpu_supports("avx512f");
    if (set == 1) return __builtin_cpu_supports("avx2");
#endif
    return set == 2;
}

int activeSet() {
    int set = chosenSet.load(std::memory_order_relaxed);
    if (set < 0) {
        set = 0;
        while (!cpuHas(set)) ++set;
        chosenSet.store(set, std::memory_order_relaxed);
    }
    return set;
}

template <class T>
const TileSteps<T>& steps() {
    switch (activeSet()) {
#if PSUB_TILE_X86
    case 0: return avx512Steps<T>;
    case 1: return avx2Steps<T>;
#endif
    default: return baselineSteps<T>;
    }
}

// The largest grid side any step of any tile of `table` may use (its largest tiles).
std::uint32_t largestGrid(const TiledTable& table) {
    if (table.doubleSteps == 0) return 0;
    std::uint32_t n = (TiledTable::kMaxLattice >> table.doubleSteps) + 2 * table.halo + 1, largest = n;
    for (std::uint32_t s = 0; s < table.doubleSteps; ++s) largest = std::max(largest, n = nextSize(n));
    return largest;
}

// Values of a ring of packed inner rows (evaluateTile's `flush`) of `width` values a point: two
// rows (a row pair's, or two rows of normals) and what was short of a vector before them (under
// 16), and for the normals the 45 values normalRowAvx512 writes past a row's end.
std::size_t packedRingSize(std::uint32_t width) { return 2 * std::size_t(width) * (TiledTable::kMaxLattice + 1) + 64; }

}  // namespace

const char* tileKernelInstructions() { return kInstructionSets[activeSet()]; }

bool setTileKernelInstructions(std::string_view name) {
    for (int set = 0; set < 3; ++set)
        if (name == kInstructionSets[set] && cpuHas(set)) {
            chosenSet.store(set, std::memory_order_relaxed);
            return true;
        }
    return false;
}

std::size_t tileScratchSize(const TiledTable& table, std::uint32_t width) {
    const std::size_t n = largestGrid(table);
    return (2 + 2 * std::size_t(width)) * n * n + std::size_t(width) * quincunxRingSize(n) + std::size_t(width) * latticePlane() + kLatticeRoom +
           packedRingSize(width) + packedRingSize(3) + 9 * quadPlane() + 2 * kLineFloats;
}

// Scratch: a, b (one value's grids between double steps), each value's grid before the last
// double step, each value's ring of quincunx rows (rowPairBody), the gathered grid of each
// value, its finest lattice (L + 1)^2 per value, rings of the inner points' packed values and
// of their packed normals, two rows of quad normals and one of unit normals. The last double
// step runs row pair by row pair across the values, and each inner row it finishes is packed
// and its streaming stores issued at once (the normals of the rows below too), so that they
// drain while the next rows are computed.
template <class T>
void evaluateTile(const TiledTable& table, std::size_t k, const T* base, std::uint32_t width, T* refined,
                  const TileNormals<T>& normals, T* scratch, T* lattice) {
    const std::size_t largest = largestGrid(table), area = largest * largest,
                      plane = latticePlane();
    T *a = scratch, *b = scratch + area, *beforeLast = scratch + 2 * area;
    T* quincunxRows = beforeLast + width * area;    // quincunxRingSize(largest) values per value
    T* inputs = quincunxRows + width * quincunxRingSize(largest);  // the gathered grid of each value
    T* finals = inputs + width * area;       // the finest lattice of each value
    T* packed = finals + width * plane + kLatticeRoom;  // the inner points, `width` values each (a ring)
    T* packedNormals = packed + packedRingSize(width);  // the inner points' normals (a ring)
    T* quads = packedNormals + packedRingSize(3);  // two rows of quad normals and one of unit normals
    const std::uint32_t g = table.gridSize(k), L = table.lattice(k), t = table.doubleSteps;
    const std::uint32_t* gather = table.gather.data() + table.gatherBegin[k];
    // Plain copies, not a structured binding: lambdas below call them, and clang before 16
    // does not let a lambda capture a structured binding.
    const TileSteps<T>& chosen = steps<T>();
    const auto doubleStep = chosen.doubleStep;
    const auto rowPair = chosen.rowPair;
    const auto normalRow = chosen.normalRow;
    const auto interleave3 = chosen.interleave3;
    const auto streamCopy = chosen.streamCopy;
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
    // The lattice's (0, 0) in the finest grid: 2^t (halo - 4) + 4 (see docs/tiled.md); only the
    // last step's (L + 1)^2 lattice points are computed.
    const std::size_t r0 = (std::size_t(table.halo) << t) + 4 - (std::size_t(4) << t), side = L + 1;
    // The lattice's rows, `rowStride` apart, each row's point 1 (its first inner point, where
    // interleave3 reads) at a line's start: 4-5% of the kernel (bench/README.md, "Session 47").
    const std::size_t rowStride = wholeLines(side);
    const std::uintptr_t address = reinterpret_cast<std::uintptr_t>(finals);
    finals += ((64 - address % 64) % 64) / sizeof(T) + (kLineFloats - 1);
    std::size_t n = g;  // the grid's side before the last double step
    if (t > 1) {
        for (std::uint32_t c = 0; c < width; ++c) {
            const T* from = inputs + c * area;
            for (std::uint32_t s = 0, m = g; s + 1 < t; ++s, m = nextSize(m)) {
                T* to = s + 2 == t ? beforeLast + c * area : s % 2 == 0 ? a : b;
                doubleStep(from, m, 0, (nextSize(m) - 1) / 2, to, quincunxRows);
                from = to;
            }
        }
        for (std::uint32_t s = 0; s + 1 < t; ++s) n = nextSize(std::uint32_t(n));
    }
    const T* lastInputs = t > 1 ? beforeLast : inputs;
    const auto at = [&](std::uint32_t c, std::uint32_t y, std::uint32_t x) { return finals[c * plane + y * rowStride + x]; };
    const std::uint32_t begin = table.output[k];
    const std::uint32_t end = k + 1 < table.tileCount() ? table.output[k + 1] : table.fallbackBegin;
    T* const destination = lattice ? nullptr : refined + std::size_t(begin) * width;
    // The packed inner rows not yet streamed: ring[0 .. filled - ring) are the stream's values
    // from `first` on; `flush` streams what fills whole vectors and moves the rest (less than
    // one) to the ring's start, so the ring holds at most two rows and that rest
    // (packedRingSize), in the first-level cache. Packed whole, a tile's 194 KB went through the
    // second-level cache and back: the torus at 1M faces 1-2% slower on one thread.
    const auto flush = [&](T* ring, T*& filled, std::size_t& first, T* to, bool last) {
        const std::size_t count = std::size_t(filled - ring);
        const std::size_t done = streamCopy(ring, 0, count, to + first, last);
        if (done > 0) std::copy(ring + done, ring + count, ring);
        first += done;
        filled = ring + (count - done);
    };
    T* out = packed;  // the packed inner rows so far, from stream value `streamed` on
    std::size_t streamed = 0;
    // The inner points' normals, from the lattice's first three values, row by row as the
    // lattice's rows are made: quad normals of row r (lattice rows r and r + 1), then the unit
    // normals of inner row r from quad rows r - 1 and r; rows of quad normals below `quadRow`
    // are made, and `normalsStreamed` values of the packed normals written.
    // Each row 3 planes of quadPlane() values, every plane's value 1 on a line (normalRowAvx512
    // loads whole lines from there).
    const std::size_t qs = quadPlane();
    const std::uintptr_t quadsAddress = reinterpret_cast<std::uintptr_t>(quads);
    quads += ((64 - quadsAddress % 64) % 64) / sizeof(T) + (kLineFloats - 1);
    T* rows[2] = {quads, quads + 3 * qs};
    T* unit = quads + 6 * qs;  // one row's unit normals, 3 planes
    std::uint32_t quadRow = 0;
    T* normalsOut = packedNormals;  // as `out`, from stream value `normalsStreamed` on
    std::size_t normalsStreamed = 0;
    const std::uint32_t* ring = normals.ringFaces;
    std::size_t slot = 0;
    // Row r of quad normals: its ring quads' to their faces (all of rows 0 and L - 1, the ends of
    // the others).
    const auto toFaces = [&](const T* q, std::uint32_t r) {
        if (!normals.faceNormals) return;
        for (std::uint32_t i = 0; i < L; i += (r == 0 || r + 1 == L) ? 1 : L - 1) {
            T* f = normals.faceNormals + 4 * (ring ? std::size_t(*ring++) : slot++);
            f[0] = q[i], f[1] = q[qs + i], f[2] = q[2 * qs + i], f[3] = 0;
        }
    };
    const auto normalRowsTo = [&](std::uint32_t last, bool finish) {
        for (; quadRow <= last; ++quadRow) {
            const std::uint32_t r = quadRow;
            T* hi = rows[r % 2];
            const std::size_t at0 = std::size_t(r) * rowStride;
            normalRow(finals + at0, finals + plane + at0, finals + 2 * plane + at0, rowStride, L,
                      r == 0 ? nullptr : rows[(r - 1) % 2], hi, qs, unit, normalsOut);
            toFaces(hi, r);
            if (r > 0) normalsOut += 3 * std::size_t(L - 1);
        }
        flush(packedNormals, normalsOut, normalsStreamed, normals.normals + 3 * std::size_t(begin), finish);
    };
    for (std::uint32_t y = 0; y <= L; y += 2) {  // lattice rows y and y + 1 (fine rows r0 + y, ...)
        for (std::uint32_t c = 0; c < width; ++c)
            rowPair(lastInputs + c * area, n, r0, L / 2, r0 + y, finals + c * plane + std::size_t(y) * rowStride, rowStride,
                    quincunxRows + c * quincunxRingSize(largest));
        if (lattice) continue;
        for (std::uint32_t row = std::max(y, 1u); row <= std::min(y + 1, L - 1); ++row) {
            if (width == 3) {
                const T* first = finals + row * rowStride + 1;
                interleave3(first, first + plane, first + 2 * plane, L - 1, out);
                out += 3 * std::size_t(L - 1);
            } else {
                for (std::uint32_t x = 1; x < L; ++x)
                    for (std::uint32_t c = 0; c < width; ++c) *out++ = at(c, row, x);
            }
        }
        flush(packed, out, streamed, destination, false);
        if (normals.normals && y > 0) normalRowsTo(std::min(y, L - 1), false);
    }
    if (lattice) {
        for (std::uint32_t y = 0; y <= L; ++y)
            for (std::uint32_t x = 0; x <= L; ++x)
                for (std::uint32_t c = 0; c < width; ++c) lattice[(std::size_t(y) * side + x) * width + c] = at(c, y, x);
        return;
    }
    flush(packed, out, streamed, destination, true);
    if (normals.normals) normalRowsTo(L - 1, true);
    const std::uint32_t* border = table.border.data() + table.borderBegin[k];
    std::size_t e = 0;
    for (std::uint32_t y = 0; y <= L; ++y)
        for (std::uint32_t x = 0; x <= L; x += (y == 0 || y == L) ? 1 : L, ++e)
            if (border[e] >= begin && border[e] < end)
                for (std::uint32_t c = 0; c < width; ++c) refined[std::size_t(border[e]) * width + c] = at(c, y, x);
}

// The tiles' inner points (each tile's first (L - 1)^2 drawing positions) get their normals in
// the tile pass, and the faces of each tile's outer ring of quads their face normals; the rest
// (restVertices, and the faces touching them that no ring holds: restFaces) after it.
TileNormalSets tileNormalSets(const TiledTable& tiled) {
    const SurfaceTable& surface = tiled.surface;
    TileNormalSets sets;
    std::vector<char> inner(surface.vertexCount, 0), inRing(surface.faceOffsets.size() - 1, 0);
    for (std::size_t k = 0; k < tiled.tileCount(); ++k) {
        const std::uint32_t L = tiled.lattice(k);
        std::fill_n(inner.begin() + tiled.output[k], std::size_t(L - 1) * (L - 1), char(1));
        // The face of quad (x, y)-(x+1, y+1).
        const auto face = [&](std::uint32_t x, std::uint32_t y) {
            const std::uint32_t corner = tiled.drawingPosition(k, x, y), opposite = tiled.drawingPosition(k, x + 1, y + 1);
            for (std::uint32_t i = surface.vertexOffsets[corner]; i < surface.vertexOffsets[corner + 1]; ++i) {
                const std::uint32_t f = surface.vertexFaces[i];
                const auto begin = surface.faceVerts.begin() + surface.faceOffsets[f];
                const auto end = surface.faceVerts.begin() + surface.faceOffsets[f + 1];
                if (end - begin == 4 && std::find(begin, end, opposite) != end) return f;
            }
            throw std::logic_error("tileNormalSets: a tile's lattice quad is not a face of the tiled table's surface");
        };
        sets.ringBegin.push_back(std::uint32_t(sets.ringFaces.size()));
        for (std::uint32_t y = 0; y < L; ++y)
            for (std::uint32_t x = 0; x < L; x += (y == 0 || y + 1 == L) ? 1 : L - 1) {
                sets.ringFaces.push_back(face(x, y));
                inRing[sets.ringFaces.back()] = 1;
            }
    }
    std::vector<char> touched(surface.faceOffsets.size() - 1, 0);
    for (std::uint32_t v = 0; v < surface.vertexCount; ++v) {
        if (inner[v]) continue;
        sets.restVertices.push_back(v);
        for (std::uint32_t i = surface.vertexOffsets[v]; i < surface.vertexOffsets[v + 1]; ++i)
            touched[surface.vertexFaces[i]] = 1;
    }
    for (std::uint32_t f = 0; f < touched.size(); ++f)
        if (touched[f] && !inRing[f]) sets.restFaces.push_back(f);
    // Listed vertices cost more each than the plain pass's (an index, scattered reads): where the
    // tiles' inner points are not most of the mesh, the plain pass after the positions is faster
    // (the cow at 7 steps, 20% tiled: 43 ms against 56 ms for both on one thread).
    sets.worthIt = 2 * sets.restVertices.size() < std::size_t(surface.vertexCount);
    return sets;
}

template <class T>
void toCanonical(const TiledTable& table, std::span<const T> drawing, std::span<T> canonical, std::uint32_t width) {
    if (table.canonical.size() != table.refinedCount)
        throw std::invalid_argument("toCanonical: the tiled table was built without its canonical order "
                                    "(RefineOptions::canonicalOrder false)");
    if (drawing.size() < std::size_t(table.refinedCount) * width || canonical.size() < std::size_t(table.refinedCount) * width)
        throw std::invalid_argument("toCanonical: the buffers hold fewer than the table's points");
    for (std::size_t p = 0; p < table.canonical.size(); ++p)
        std::copy_n(drawing.data() + p * width, width, canonical.data() + std::size_t(table.canonical[p]) * width);
}

template void evaluateTile<float>(const TiledTable&, std::size_t, const float*, std::uint32_t, float*,
                                  const TileNormals<float>&, float*, float*);
template void evaluateTile<double>(const TiledTable&, std::size_t, const double*, std::uint32_t, double*,
                                   const TileNormals<double>&, double*, double*);
template void toCanonical<float>(const TiledTable&, std::span<const float>, std::span<float>, std::uint32_t);
template void toCanonical<double>(const TiledTable&, std::span<const double>, std::span<double>, std::uint32_t);

}  // namespace psub
