// psub/tiled.h: the tiled table form, as plain data (built in stencils/, applied in compute/).
// Levels up to a base level B go through per-level rows; each regular block of level-B faces
// (a tile) is then refined the last 2t steps at once with compiled-in regular masks over an
// implicit grid, and only its finest lattice points are written. Every other finest point
// comes from per-level rows kept only where they are needed (the fallback). docs/tiled.md
// has the design. No topology here.
#pragma once

#include "psub/tables.h"

#include <cstdint>
#include <vector>

namespace psub {

// Output order of the tiled form ("drawing order"): the tiles' points, tile after tile (each
// tile: its lattice's inner points row by row, then the border points it owns), then the
// fallback's points in walk order (near on the surface, near in memory: docs/tiled.md, "Output
// order"). `canonical[p]` is the canonical (SPEC) index of drawing position p; `surface` is the
// finest faces over drawing positions.
struct TiledTable {
    static constexpr std::uint32_t kMaxLattice = 128;  // side << doubleSteps never exceeds it
    std::uint32_t controlCount = 0, refinedCount = 0;
    std::uint32_t baseLevel = 0;    // B: rows.levels[0, B) are the full per-level rows
    std::uint32_t doubleSteps = 0;  // t: a tile runs 2t P-S steps from level B
    std::uint32_t halo = 0;         // rings of level-B faces gathered around a tile's block

    // rows.levels[B, N): only the rows the fallback needs; the last level's destinations are
    // drawing positions (in [fallbackBegin, refinedCount)), the points of levels B + 1 .. N - 1
    // (1 .. N - 1 without a tile) numbered in walk order (each level's grouped by the row group
    // that writes them), not canonical.
    PerLevelTable rows;
    std::uint32_t fallbackBegin = 0;

    // Tile k: a side x side block of level-B faces. Its gathered grid is g x g level-B vertices
    // (g = side + 2 halo + 1), row by row, at gather[gatherBegin[k] ..]; its lattice is
    // (L + 1) x (L + 1) finest points, L = side * 2^t; it writes drawing positions from
    // output[k]: first the (L - 1)^2 inner points row by row, then the border points it owns.
    // border[borderBegin[k] ..] holds the drawing position of each of its 4L border points
    // (lattice rows 0 and L whole, and the two end points of each row between, row by row);
    // the tile owns those that fall in its own output range.
    std::vector<std::uint32_t> side;
    std::vector<std::uint64_t> gatherBegin{0};
    std::vector<std::uint32_t> gather;
    std::vector<std::uint32_t> output;
    std::vector<std::uint64_t> borderBegin{0};
    std::vector<std::uint32_t> border;

    std::vector<std::uint32_t> canonical;  // per drawing position: its canonical index
    SurfaceTable surface;  // finest faces over drawing positions, ordered by their first drawn corner

    // The face-varying channel's finest faces (FaceVaryingTable's, split seam faces included)
    // over drawing positions: per corner, uvFaceVerts the drawing position of its surface
    // vertex and uvFaceValues the channel's value, unchanged (the values are evaluated once,
    // per level, by evaluateFaceVarying); faces ordered like `surface`'s, by their first drawn
    // corner. Empty without a channel (setTiledFaceVaryingFaces in psub/stencils.h).
    std::vector<std::uint32_t> uvFaceOffsets{0}, uvFaceVerts, uvFaceValues;

    std::size_t tileCount() const { return side.size(); }
    std::uint32_t lattice(std::size_t k) const { return side[k] << doubleSteps; }  // L
    std::uint32_t gridSize(std::size_t k) const { return side[k] + 2 * halo + 1; }  // g
    // The drawing position of tile k's lattice point (x, y), 0 <= x, y <= L (a border point's
    // may be another tile's or the fallback's).
    std::uint32_t drawingPosition(std::size_t k, std::uint32_t x, std::uint32_t y) const {
        const std::uint32_t L = lattice(k);
        if (x > 0 && x < L && y > 0 && y < L) return output[k] + (y - 1) * (L - 1) + x - 1;
        const std::uint32_t e = y == 0 ? x : y == L ? 3 * L - 1 + x : L + 2 * y - 1 + (x == L ? 1 : 0);
        return border[borderBegin[k] + e];
    }
    // Bytes needed to evaluate (not counting `canonical`, used only to write canonical order,
    // nor `surface` and the channel's faces, used only to draw).
    std::uint64_t bytes() const {
        return rows.bytes() + 4 * (side.size() + gather.size() + output.size() + border.size()) +
               8 * (gatherBegin.size() + borderBegin.size());
    }
};

}  // namespace psub
