// Internal to stencils/: the tiled table's build in pieces, so that refine can run them level
// by level (docs/tiled.md, "The lean build"): the tiles' blocks chosen on level B, the labels
// that bound which rows the fallback can need, the tiles placed on level N - 2, then the rows
// the fallback needs and the surface in drawing order.
#pragma once

#include "psub/stencils.h"
#include "psub/tiled.h"

#include <omp.h>

#include <cstdint>
#include <exception>
#include <vector>

namespace psub {

// The greedy cover of level B (the plan's sides): each block's side and its g x g gathered
// grid (g = side + 2 halo + 1), in cover order, and which faces the blocks cover.
struct TileBlocks {
    std::uint32_t halo = 0;
    std::vector<std::uint32_t> side;
    std::vector<Index> gather;          // the blocks' grids, one after the other
    std::vector<std::uint8_t> covered;  // per level-B face
};
TileBlocks chooseTileBlocks(const Level& base, const TiledPlan& plan);

// Per vertex of level B, the face hops to the nearest vertex of a face no block covers (0 on
// one, and on no face at all), at most 255. The corners of one face differ by at most 1.
std::vector<std::uint8_t> baseLabels(const Level& base, const TileBlocks& blocks);
// The labels of the level one P-S step finer: a vertex keeps its own, a face's point takes the
// least of its corners', a split boundary edge's point the lesser of its ends'. The corners of
// every new face still differ by at most 1, so a row's sources are labelled at most 1 above
// its destination (docs/tiled.md).
std::vector<std::uint8_t> childLabels(const Level& parent, bool splitBoundary, const std::vector<std::uint8_t>& labels);

// The finest faces of the tiles' lattices, as refine makes them but over drawing positions:
// per face its four corners, from the one refine puts first, and a key in refine's face order
// (the first half-edge of the edge of level N - 2 whose face of level N - 1 holds the first
// half-edge of the edge of level N - 1 the face is made around, times 4, + that half-edge's
// corner there: placeTiles, docs/tiled.md).
struct TileFaces {
    std::vector<Index> corners;        // 4 per face
    std::vector<std::uint32_t> order;  // per face
};

// Walks each block's finest lattice on level N - 2 (`coarse`; none needed without blocks) and
// fills `table`'s tiles, fallbackBegin and canonical (its doubleSteps already set). Returns the
// drawing position of each of the finestCount finest vertices. With `faces` (and double steps),
// also the finest faces of the tiles' lattices, tile after tile: where the tiles cover the mesh,
// the finest level's faces without the topology of levels N - 1 and N.
std::vector<std::uint32_t> placeTiles(TiledTable& table, const TileBlocks& blocks, const Level* coarse, bool coarseSplits,
                                      std::uint32_t finestCount, TileFaces* faces = nullptr);

// Where the blocks cover every face of level B (`base`) and every vertex of it lies on a face,
// the tiles placed on level B itself, with no later level: each tile's inner points numbered
// as placeTiles numbers them, its ring points named by the vertex or the edge of level B they
// lie on (an edge's point by its place along the edge), so the same drawing positions as
// placeTiles gives; then table.surface from the tiles' lattices, tile after tile, each
// lattice's quads row by row (not by first drawn corner), and table.canonical left empty (the
// drawing-only build, RefineOptions::canonicalOrder). Sets the tiles, halo, refinedCount
// (finestCount) and fallbackBegin (the same) only when it can: false, `table` untouched,
// where a block is missing, a vertex has no face, or two vertices of a ring share more than one
// edge (their edge's points could not be told apart by name).
bool placeTilesOnBase(TiledTable& table, const TileBlocks& blocks, const Level& base, std::uint32_t finestCount);

// table.rows from `rows` (levels [0, B) whole; from B on, at least every row the fallback needs):
// the rows from B on that the fallback needs, the last level's destinations as drawing
// positions (without a tile: every row, `rows` itself). std::logic_error when a needed row is
// missing.
void keepFallbackRows(TiledTable& table, const PerLevelTable& rows, const std::vector<std::uint32_t>& drawOf);
void keepFallbackRows(TiledTable& table, PerLevelTable&& rows, const std::vector<std::uint32_t>& drawOf);

// The fallback's points in walk order (docs/tiled.md, "Output order"): its finest points in
// order of first appearance along a breadth-first walk of the finest faces `finest` (canonical
// numbers), then, level by level back to level 1, each level's points in order of first use by
// the rows of the level after (with tiles, level B's by their ancestors two levels before, and the
// tiles' gathers renumbered with them); each group's rows ordered by their new destination.
// table.rows, table.gather, table.canonical and drawOf renumbered to match: the same output
// through `canonical`, with points near on the surface near in memory at every level (the cow
// at 7 steps, no tile: evaluation with normals about 1.6x faster than in canonical order).
// In three parts:
// - walkFallback: per drawing position, the new one (the tiles' unchanged): the fallback's
//   finest points in order of first appearance along a breadth-first walk of the finest faces
//   (over shared corners; faces without a fallback corner neither walked nor crossed). Empty
//   when every point is a tile's.
// - orderFinestByWalk: from the walk, the finest points renumbered (table.canonical and
//   drawOf); returns, per old drawing position, its new one (empty when nothing moved).
// - orderLevelsByWalk: from that, the rows and the levels before them (table.rows, and the
//   tiles' gathers of level B).
std::vector<std::uint32_t> walkFallback(const TiledTable& table, const std::vector<std::uint32_t>& drawOf,
                                        const Faces& finest);
std::vector<std::uint32_t> orderFinestByWalk(TiledTable& table, std::vector<std::uint32_t>& drawOf,
                                             std::vector<std::uint32_t> walk);
void orderLevelsByWalk(TiledTable& table, std::vector<std::uint32_t> position);

// table.surface: the finest faces over drawing positions, ordered by their first drawn corner.
void setTiledSurface(TiledTable& table, const Faces& finest, const std::vector<std::uint32_t>& drawOf);
// The same surface from the tiles' faces (placeTiles) where they cover the finest level (else
// std::logic_error): the same arrays, the finest faces never made.
void setTiledSurfaceFromTiles(TiledTable& table, TileFaces&& faces);

// Runs `first` and `second`, on two threads when `together` and the build has two (OpenMP
// sections; what they run inside on more threads runs on their own one), else one after the
// other, outside any parallel region (inside even a one-thread region, their own parallel loops
// would run on one thread: the 262k-face torus's build was 1-2 ms slower that way). An exception
// of either is rethrown once both are done (the first's if both throw).
template <class First, class Second>
void sideBySide(bool together, First&& first, Second&& second) {
    if (!together || omp_get_max_threads() < 2) {
        first();
        second();
        return;
    }
    std::exception_ptr failures[2];
#pragma omp parallel sections num_threads(2)
    {
#pragma omp section
        try {
            first();
        } catch (...) {
            failures[0] = std::current_exception();
        }
#pragma omp section
        try {
            second();
        } catch (...) {
            failures[1] = std::current_exception();
        }
    }
    for (const std::exception_ptr& failure : failures)
        if (failure) std::rethrow_exception(failure);
}

// Whether the fallback is most of the finest points: the levels' renumbering then takes long
// enough to run beside the faces' sort (otherwise the sort, partly on several threads itself, is
// better left its threads: the 1M-face torus's build, whose fallback is small, was about 5 ms
// slower with the pieces side by side, the walk then beside the last step's rows too).
inline bool mostlyFallback(const TiledTable& table) {
    return table.refinedCount - table.fallbackBegin >= table.refinedCount / 2;
}

// The fallback in walk order, then the surface (both above). The surface depends only on the
// finest points' order, so with `alongside` (and mostlyFallback) it is sorted beside
// orderLevelsByWalk, on a second thread where the build has one. The lean build asks for it; the
// full build, which holds the per-level table as well, does not: there the two's arrays side by
// side raised the peak (Vulkan's `psub play data/cow.obj --levels 7`: 537-573 -> 561-580 MB) for
// a start no shorter through the noise.
void orderByWalkAndSetSurface(TiledTable& table, std::vector<std::uint32_t>& drawOf, const Faces& finest, bool alongside);

}  // namespace psub
