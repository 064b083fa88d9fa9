// Internals of psub_analysis shared by its source files: grid keys through refinement and
// sparse rows in double. Not installed.
#pragma once

#include "psub/analysis.h"
#include "psub/tables.h"

#include <cstdint>
#include <span>
#include <vector>

namespace psub::detail {

// Rows in compressed form: row r is weights[e] * vertex indices[e], e in offsets[r]..offsets[r+1].
struct SparseRowsD {
    std::vector<std::uint64_t> offsets{0};
    std::vector<std::uint32_t> indices;
    std::vector<double> weights;
};

// Canonical form of the grid point (i, j) of sector s (see GridKey).
GridKey canonical(int s, int i, int j, int n);
std::uint64_t packKey(const GridKey& key);

// Midpoint of grid edge a-b / centre of a grid quad, as keys on the grid of half the unit;
// invalid when the points are not a grid edge / unit square.
GridKey edgeKey(const GridKey& a, const GridKey& b, int n);
GridKey faceKey(std::span<const GridKey> corners, int n);

// Keys of the vertices two P-S steps below `level` (keys per vertex of `level`; `child` is
// the next level's faces, one per edge of `level`), on the grid of half the unit.
std::vector<GridKey> refineKeysTwoSteps(int n, const Faces& level, std::span<const GridKey> keys,
                                        const Faces& child);

// The keys of rings 0..rings in LocalMatrix order.
std::vector<GridKey> neighbourhoodKeys(int n, int rings);

// The square matrix of the rows of `rows` (fine vertex -> coarse vertices) whose fine keys lie
// in rings 0..rings, over the coarse vertices with those keys. Throws std::logic_error (naming
// `what`) when a row reaches outside or does not sum to 1.
LocalMatrix extractMatrix(int n, int rings, std::span<const GridKey> coarseKeys,
                          std::span<const GridKey> fineKeys, const SparseRowsD& rows, const char* what);

// Gives every VertexQuad row of valence `valence` in `table` the weights `weights` (the rows
// carry their weights per group, so every evaluator of the table follows).
void setQuadVertexWeights(PerLevelTable& table, Index valence, VertexWeights weights);

// The per-level table's steps composed in double: control points -> finest level; with
// `rule`, its weights replace the table's where it applies.
SparseRowsD composePerLevel(const PerLevelTable& table, const ExtendedShapeRule* rule = nullptr);

}  // namespace psub::detail
