// shaders/tile_common.glsl: what the two tile kernels share (tile.comp: one workgroup per
// block, grids in shared memory; tile_unrolled.comp: one invocation per block, grids unrolled
// into registers): the tables, the block record, the regular masks' sums over the kernel's
// grids and the write of a lattice point its tile owns (docs/tiled.md, "On Vulkan"). The sums
// are the CPU kernel's (compute/tiled_kernels.cpp), in its order, marked precise. The including
// kernel declares its grids first: grid (the current level), qv and qf (its quincunx level).

// TABLE_A: the dispatch's block records (config.h, PSUB_TILE_RECORD_MEMBERS); TABLE_B: the tiled
// table's gathered level-B vertices; TABLE_C: its border points' drawing positions.
layout(std430, binding = PSUB_BINDING_TABLE_A) readonly buffer Blocks { uvec4 blocks[]; };
layout(std430, binding = PSUB_BINDING_TABLE_B) readonly buffer Gather { uint gathered[]; };
layout(std430, binding = PSUB_BINDING_TABLE_C) readonly buffer Border { uint border[]; };

uvec4 blockWord4(uint i) { return kTexels ? texelFetch(tableTexelsA, int(i)) : blocks[i]; }
uint gatheredAt(uint i) { return kTexels ? texelFetch(tableTexelsB, int(i)).x : gathered[i]; }
uint borderAt(uint i) { return kTexels ? texelFetch(tableTexelsC, int(i)).x : border[i]; }

// Values first .. first + 3 of input element `element` (those beyond kComponents 0).
vec4 readValues(uint element, uint first) {
    if (kComponents <= 4u) return readElement(element);
    const Place p = sourcePlace(element);
    vec4 value = vec4(0.0);
    for (uint i = 0u; i < 4u && first + i < kComponents; ++i) value[i] = readSource(p, first + i);
    return value;
}

void writeValues(uint element, uint first, vec4 value) {
    if (kComponents <= 4u) {
        writeElement(element, value);
        return;
    }
    const Place p = destinationPlace(element);
    for (uint i = 0u; i < 4u && first + i < kComponents; ++i) writeDestination(p, first + i, value[i]);
}

// The mean of four points given as two opposite pairs (a, b) and (c, d): a quad's F-point (its
// two diagonals' pairs of corners), and a regular vertex's V-point (the F-points of its four new
// faces, opposite ones paired: the 9-point mask 1/4, 1/8, 1/16 regrouped). Pairing opposite
// points makes the sum the same under the rotations and reflections between two tiles' frames.
vec4 facePoint(vec4 a, vec4 b, vec4 c, vec4 d) {
    precise vec4 value = 0.25 * ((a + b) + (c + d));
    return value;
}

// The quincunx level of the n x n grid: the F-point of the cell whose first corner is c, the
// V-point of its inner vertex c (the mean of its four cells' F-points, diagonally opposite
// pairs first, as the CPU kernel's).
vec4 quincunxFace(uint c, uint n) { return facePoint(grid[c], grid[c + n + 1u], grid[c + 1u], grid[c + n]); }
vec4 quincunxVertex(uint c, uint n) {
    return facePoint(quincunxFace(c - n - 1u, n), quincunxFace(c, n), quincunxFace(c - n, n), quincunxFace(c - 1u, n));
}

// The diamond (a face of the quincunx level) across x from V(i, j) = qv[v], between it and
// V(i + 1, j), and across y, between it and V(i, j + 1); F(i, j) = qf[f].
vec4 acrossX(uint v, uint f, uint nf) { return facePoint(qv[v], qv[v + 1u], qf[f - nf], qf[f]); }
vec4 acrossY(uint v, uint f, uint nv) { return facePoint(qv[v], qv[v + nv], qf[f - 1u], qf[f]); }

// The fine point of parities (px, py) at V(i, j) = qv[v] and F(i, j) = qf[f] of a quincunx level
// with nv x nv V-points and nf x nf F-points: the diamonds, and the V-points as the mean of the
// four diamonds around them, opposite pairs first (as the CPU kernel's). Call with constant
// parities: the rule is chosen when compiling (lavapipe would run all four rules for every lane
// under a branch).
vec4 finePoint(const uint px, const uint py, uint v, uint f, uint nv, uint nf) {
    vec4 value;
    if (px == 0u && py == 0u)  // the V-point of V(i, j)
        value = facePoint(acrossX(v - 1u, f - 1u, nf), acrossX(v, f, nf), acrossY(v - nv, f - nf, nv), acrossY(v, f, nv));
    else if (py == 0u)
        value = acrossX(v, f, nf);
    else if (px == 0u)
        value = acrossY(v, f, nv);
    else  // the V-point of F(i, j)
        value = facePoint(acrossY(v, f, nv), acrossY(v + 1u, f + 1u, nv), acrossX(v, f, nf), acrossX(v + nv, f + nf, nf));
    return value;
}

// The block being computed (set once per invocation by readBlock).
uint gatherFirst, gridSide, blockX0, blockY0, blockL, blockM, outputBegin, outputEnd, borderFirst, firstValue;

void readBlock(uint block) {
    const uvec4 a = blockWord4(2u * (pc.tableBase + block)), b = blockWord4(2u * (pc.tableBase + block) + 1u);
    gatherFirst = a.x;
    gridSide = a.y;
    blockL = a.z;
    blockM = a.w;
    blockX0 = b.x & 0xffffu;
    blockY0 = b.x >> 16;
    outputBegin = b.y;
    outputEnd = b.z;
    borderFirst = b.w;
}

// Writes the block's lattice point (x, y) if its tile owns it. Each point of the tile's lattice
// is written by one block (the right and top edges by the last block of their row or column);
// points beyond the lattice (a last block cut by the tile's side) by none.
// The drawing position emit() writes lattice point (x, y) of the block at, or ~0u where it
// writes none; `inner`: a point inside the tile's ring (the points whose normals tile.comp
// writes with PSUB_SPEC_TILE_NORMALS).
const uint kNowhere = 0xffffffffu;
uint ownedAt(uint x, uint y, out bool inner) {
    const uint X = blockX0 + x, Y = blockY0 + y, L = blockL, M = blockM;
    inner = false;
    if (X > L || Y > L || (x == M && X != L) || (y == M && Y != L)) return kNowhere;
    if (X > 0u && X < L && Y > 0u && Y < L) {
        inner = true;
        return outputBegin + (Y - 1u) * (L - 1u) + X - 1u;
    }
    const uint at = borderAt(borderFirst + ringEntry(X, Y, L));
    return at >= outputBegin && at < outputEnd ? at : kNowhere;
}

void emit(uint x, uint y, vec4 value) {
    bool inner;
    const uint at = ownedAt(x, y, inner);
    if (at != kNowhere) writeValues(at, firstValue, value);
}
