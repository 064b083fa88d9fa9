// psub/tables.h: the stencil tables, as plain data: what refinement produces and what every
// evaluator (compute/) consumes. Two forms: per-level kind-coded tables (indices only,
// weights per row group) and one factorized CSR table from the control points straight to
// the finest level; plus the finest surface's faces for drawing and normals. No topology.
#pragma once

#include <cstdint>
#include <vector>

namespace psub {

enum class RowKind : std::uint8_t {
    FaceQuad,      // 4 indices, 1/4 each
    FaceTriangle,  // 3 indices, 1/3 each
    Retained,      // 1 index, copied (boundary, non-manifold and unused vertices)
    VertexQuad,    // interior, all quads: P, n edge neighbours, n diagonals; c, d, e
    VertexMixed,   // interior with a triangle: P, n edge neighbours, m diagonals; f, g, h
    FacePolygon,   // the paired method's point of a larger face: all corners, equal weights
    // Boundary::Smooth's split steps (beyond the paper): the cubic B-spline curve rules.
    BoundaryVertex,  // P, its two boundary neighbours: (a + 6 P + b) / 8
    BoundaryEdge,    // the new point of a boundary edge a b: (a + b) / 2
    // Rules::Shape next to an input corner (psub/rules.h's CornerRule; docs/shape-rules.md).
    VertexCorner,        // the corner itself: P, 3 edge neighbours, 3 diagonals; its c, d, e
    FaceBesideCorner,    // a quad with k = 1..3 input corners: those first (P and n = k - 1),
                         // then the m = 4 - k others; alpha / s and (1 - alpha) / 3 / s
    VertexBesideCorner,  // a regular vertex beside j input corners: P, the n = 4 - j other edge
                         // neighbours, the 4 diagonals; 1/4 + j (1/8 - beta), 1/8, 1/16 (beta = 0)
    // A VertexQuad row of valence 4 rewritten (vertexRowsFromFacePoints, psub/stencils.h): the
    // mean of the four new face points of its faces, 4 indices into the level's own (child)
    // points, 1/4 each (n = 3, m = 0, as FaceQuad). Only as a level's last groups: the level's
    // other rows write what these read.
    VertexFromFacePoints,
    // A VertexQuad row of another valence n (2 to 16) whose edge weight is twice its diagonal one
    // (every valence under the paper's rules, d = 2 e) rewritten the same way
    // (vertexRowsFromFacePoints): its centre P, a point of the parent level, then the n new face
    // points of its faces, the level's own: centre c - n e, edge 4 e (n = n, m = 0). Only as a
    // level's last groups, after its VertexFromFacePoints ones.
    VertexFromCentreAndFacePoints,
};

// Whether a group's rows read points of the level they write (written by the level's earlier
// groups): all of them, or all but the first (VertexFromCentreAndFacePoints: its centre).
inline bool readsOwnLevel(RowKind kind) {
    return kind == RowKind::VertexFromFacePoints || kind == RowKind::VertexFromCentreAndFacePoints;
}

// A run of rows of one kind and shape within one level. Row r of the group has `width`
// = 1 + n + m source indices at indices[indexBegin + (r - rowBegin) * width]: the centre with
// weight `centre`, then n with weight `edge`, then m with weight `diagonal`. The sources are
// points of the parent level, except in readsOwnLevel groups (the child level's; the centre of
// a VertexFromCentreAndFacePoints row is the parent level's).
struct RowGroup {
    RowKind kind;
    std::uint32_t n, m, width;
    std::uint64_t rowBegin, rowCount, indexBegin;  // rows and indices of the whole table
    double centre, edge, diagonal;
};

// One level's slice of the per-level table. Vertex numbers are those of the level (source:
// parent level, destination: child level), as in the output order of docs/scheme.md.
struct StencilLevel {
    std::uint32_t sourceCount, destinationCount;
    std::uint64_t groupBegin, groupEnd;  // into PerLevelTable::groups
    std::uint64_t rowBegin, rowEnd;      // into PerLevelTable::destinations
};

// Per-level, kind-coded table: all levels in one set of contiguous arrays. Each level's rows
// are grouped by (kind, n, m) and, within a group, ordered by destination. With `regions` > 1
// (orderLevelsByRegion, psub/stencils.h) the rows of levels [0, regionLevels) are ordered by
// region of the control mesh within each group, and the points of levels 1 .. regionLevels - 1
// numbered region by region; level regionLevels (the finest level for a whole table) keeps its
// numbering, and so every output value stays the same. The CPU evaluator then gives each thread
// an even share of every group of those levels (docs/design.md, "Threads and regions").
// The tiled form's rows of levels [walkFrom, levels.size()) write points numbered in walk order
// (docs/tiled.md, "Output order"): the first half of each group is then one half of the
// surface, so the CPU evaluator splits those levels the same way.
struct PerLevelTable {
    std::uint32_t controlCount = 0;
    std::uint32_t regions = 1, regionLevels = 0;
    std::uint32_t walkFrom = UINT32_MAX;
    std::vector<StencilLevel> levels;
    std::vector<RowGroup> groups;
    std::vector<std::uint32_t> destinations;  // per row: the child vertex it writes
    std::vector<std::uint32_t> indices;       // per row: its source vertices (parent level)

    std::uint32_t refinedCount() const {
        return levels.empty() ? controlCount : levels.back().destinationCount;
    }
    std::uint64_t bytes() const {
        return groups.size() * sizeof(RowGroup) + levels.size() * sizeof(StencilLevel) +
               4 * (destinations.size() + indices.size());
    }
};

// Factorized table, like OpenSubdiv's Far::StencilTable: row r (a finest-level vertex, in
// output order) is sum of weights[j] * control[indices[j]] for j in offsets[r]..offsets[r+1].
struct FactorizedTable {
    std::uint32_t controlCount = 0;
    std::vector<std::uint64_t> offsets{0};
    std::vector<std::uint32_t> indices;
    std::vector<float> weights;

    std::uint32_t rowCount() const { return std::uint32_t(offsets.size() - 1); }
    std::uint64_t bytes() const { return 8 * offsets.size() + 4 * indices.size() + 4 * weights.size(); }
};

// The finest level's faces as plain arrays, with each vertex's incident faces, for drawing
// and for per-frame normals (gathered per vertex, so the result is deterministic).
struct SurfaceTable {
    std::uint32_t vertexCount = 0;
    std::vector<std::uint32_t> faceOffsets{0}, faceVerts;      // faces, counter-clockwise
    std::vector<std::uint32_t> vertexOffsets{0}, vertexFaces;  // faces around each vertex
};

// A face-varying channel's tables (docs/face-varying.md): per-level rows over the channel's
// own values ("face-varying vertices": one per vertex and side of a seam), from the control
// values to the finest level's; and the finest level's faces as drawn and written with the
// channel. Those are the surface's faces, except that a face straddling a seam is split along
// the seam into two triangles, so that no face mixes values of two sides.
struct FaceVaryingTable {
    std::uint32_t width = 2;
    PerLevelTable perLevel;  // controlCount: the mesh's value count
    std::vector<std::uint32_t> faceOffsets{0};
    std::vector<std::uint32_t> faceVerts;   // per corner: the surface (position) vertex
    std::vector<std::uint32_t> faceValues;  // per corner: the channel's refined value

    bool empty() const { return faceVerts.empty(); }
    std::uint32_t valueCount() const { return perLevel.refinedCount(); }
};

}  // namespace psub
