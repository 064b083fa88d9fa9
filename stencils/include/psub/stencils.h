// psub/stencils.h: builds the stencil tables of psub/tables.h from a refinement hierarchy with
// the rules of docs/scheme.md, so that every refined vertex is a fixed linear combination of
// coarser ones; and `refine`, which takes a mesh all the way to its tables. Reads topology;
// never evaluates anything per frame.
#pragma once

#include "psub/rules.h"
#include "psub/tables.h"
#include "psub/tiled.h"
#include "psub/topology.h"

#include <cstdint>
#include <functional>
#include <span>
#include <vector>

namespace psub {

// The per-level table of every step of `hierarchy` (the paired method's rows for the first
// step when it was preprocessed), with the weights of `rules` (see psub/rules.h) and the
// boundary rules of `hierarchy.boundary`.
PerLevelTable buildPerLevelTable(const Hierarchy& hierarchy, Rules rules = Rules::Paper);

// Composes the per-level rows into one table from control points to the finest level.
// Weights are accumulated in double and stored as float.
FactorizedTable buildFactorizedTable(const PerLevelTable& perLevel);

SurfaceTable buildSurfaceTable(Faces finest);

// Rewrites `table` so that every VertexQuad row of valence 4 with the paper's weights (1/4, 1/8,
// 1/16), whose four faces all have FaceQuad rows in its level, becomes a VertexFromFacePoints
// row: the mean of those four new face points. In real arithmetic the two are equal (the four
// face points sum to (4 P + 2 sum(edges) + sum(diagonals)) / 4), in float within rounding; the
// row reads 4 points instead of 9. Likewise every VertexQuad row of another valence n (2 to 16)
// whose edge weight is twice its diagonal weight e (the paper's, at every n) and whose n faces all
// have such rows becomes a VertexFromCentreAndFacePoints row: (c - n e) P + 4 e sum(face points),
// n + 1 points instead of 2n + 1. Each level's rewritten rows keep their order, in groups after
// the level's others (psub/tables.h). Returns how many rows were rewritten. refine() applies it
// to the tables it returns unless RefineOptions::vertexRowsFromFacePoints is false
// (docs/design.md, "Vertex points from face points"). std::invalid_argument on a table rewritten
// already.
std::uint64_t vertexRowsFromFacePoints(PerLevelTable& table);

// Cuts the control mesh into `regions` regions of about equal point counts (runs of a breadth-
// first order) and gives every refined point its row's first source's region; then, in place,
// orders the rows of the first `levelCount` levels (all by default) by region within each group
// (in their order within each region), numbers the points of levels 1 .. levelCount - 1 region
// by region, and sets table.regions and table.regionLevels. The control points and level
// `levelCount` (the finest level for a whole table) keep their numbers, so every evaluator gives
// the same bits as before; so do any later levels' rows.
// What it is for: threads that each take an even share of every group (the CPU evaluator's
// split of such a table) then work on one region at every level and read mostly points they
// wrote themselves (docs/design.md, "Threads and regions"). `regions` = 1 leaves the table as it
// is. std::invalid_argument when `regions` is 0, when the table is region-ordered already, or
// when a row names a point its level does not have.
void orderLevelsByRegion(PerLevelTable& table, std::uint32_t regions, std::size_t levelCount = SIZE_MAX);

// Which regular blocks of level B become tiles: Cheapest, those a cost model finds cheaper
// than their points' rows, with sides fitted to the regular regions (docs/tiled.md); Every,
// every regular block, sides halving from the largest down to single faces whatever a tile
// costs (for tests and fuzzing: many small tiles, many tile borders beside the fallback); None,
// no tile at all (the plan's levels kept, every finest point the fallback's, in walk order):
// on two threads and on lavapipe faster than the tiles on some meshes (Spot at 9 steps), so
// psub play and psub view time it too (docs/tiled.md, "Tiles or none").
enum class TileSides { Cheapest, Every, None };

// Whether the tiled form without a tile (TileSides::None) is worth building and timing beside
// `tiled` (on Vulkan, or on several CPU threads): `tiled` has tiles and they write under 90% of
// its finest points. Spot (6-82% tiled at 5 to 12 steps) is faster without them at 5 to 11 steps
// on two threads; the torus (99-100% tiled) is 1.5-2x slower without, and the second build
// doubled psub play's start and peak memory there (docs/tiled.md, "Tiles or none").
bool worthTimingWithoutTiles(const TiledTable& tiled);

// Where the tiled form starts its tiles: levels [0, baseLevel) of the per-level table are
// evaluated whole, then each tile runs 2 * doubleSteps steps (0 when there are too few quad
// levels: everything is then the fallback).
struct TiledPlan {
    std::uint32_t baseLevel, doubleSteps;
    TileSides sides = TileSides::Cheapest;
};

// For a per-level table of `levelCount` levels: as many double steps as fit after the paired
// method (at most 3), fewer while the irregular vertices of the first quad level (level 1 when
// preprocessed, else 0) would leave over a tenth of level B's faces without a tile.
TiledPlan planTiled(std::size_t levelCount, bool preprocessed, const Level& firstQuadLevel);

// The tiled form (psub/tiled.h) of `perLevel`, whose level plan.baseLevel is `base`, whose
// level N - 2 is `coarse` (the same object as `base` may be; its step to level N - 1 split
// boundary edges when `coarseSplits`) and whose finest faces are `finest`. The two levels'
// topology is only read here, never kept; the finest level's topology is not needed.
// `perLevel` as the rules built it: a table rewritten by vertexRowsFromFacePoints is refused
// (std::invalid_argument); rewrite the tiled form's rows after (refine does).
TiledTable buildTiledTable(const PerLevelTable& perLevel, const Level& base, const Level& coarse, bool coarseSplits,
                           const Faces& finest, TiledPlan plan);
TiledTable buildTiledTable(const Hierarchy& hierarchy, const PerLevelTable& perLevel,
                           TileSides sides = TileSides::Cheapest);

// The face-varying channel's finest faces (`channel`'s) in the tiled form's drawing order:
// `tiled`'s uvFaceOffsets, uvFaceVerts and uvFaceValues (psub/tiled.h). Each corner's surface
// vertex is mapped through the inverse of tiled.canonical, its value kept; the faces are
// ordered, stably, by their first drawn corner, as tiled.surface's. std::invalid_argument
// when `channel` names vertices `tiled` does not have.
void setTiledFaceVaryingFaces(TiledTable& tiled, const FaceVaryingTable& channel);

// How a face-varying channel is refined (docs/face-varying.md), like OpenSubdiv's
// FVarLinearInterpolation. Boundaries (the default): the P-S rules in the interior, seam and
// boundary polylines kept. All: linear everywhere (every value kept, faces averaged).
enum class UvLinear { Boundaries, All };

// "boundaries" or "all".
const char* uvLinearName(UvLinear linear);

// The channel's rows of one step from `level` (the paired method's when `paired`), appended
// to `table` as one StencilLevel over face-varying vertices. `inputCorners`: Rules::Shape's
// input corners of the channel's base level (psub/rules.h's inputCorners()).
void appendFaceVaryingLevel(PerLevelTable& table, const FaceVaryingLevel& level, bool paired,
                            UvLinear linear, Rules rules, std::span<const char> inputCorners);

// The finest level's faces of the channel, with the position vertex and value of each corner.
void setFaceVaryingFaces(FaceVaryingTable& table, const FaceVaryingLevel& finest);

// The whole channel of a checked mesh with UVs for `hierarchy` (built from that mesh, with
// Boundary::Paper): what refine() puts in Refinement::uv.
FaceVaryingTable buildFaceVaryingTable(const Hierarchy& hierarchy, const Mesh& mesh,
                                       UvLinear linear = UvLinear::Boundaries, Rules rules = Rules::Paper);

struct RefineOptions {
    int levels = 2;                         // P-S steps after any preprocessing
    Preprocess preprocess = Preprocess::Auto;
    bool factorized = false;                // also build the factorized table
    std::function<void(int level, double seconds)> onLevel;  // progress, after each level (0 s: not refined)
    Rules rules = Rules::Paper;             // Robust: beyond the paper (psub/rules.h)
    Boundary boundary = Boundary::Paper;    // Smooth: beyond the paper (psub/topology.h)
    bool tiled = false;                     // also build the tiled form (psub/tiled.h)
    // The per-level table and the canonical surface (Refinement::perLevel, ::surface). false
    // only with `tiled` (and no factorized table): the tiled form alone, whose fallback's rows
    // are then made only where they can be needed, not copied from the full table (the lean
    // build, docs/tiled.md: less time and memory where tiles cover much of the mesh).
    bool perLevel = true;
    TileSides tileSides = TileSides::Cheapest;  // its tiles
    UvLinear uvLinear = UvLinear::Boundaries;  // the face-varying channel, when the mesh has one
    // The per-level table and the tiled form's rows, once built, rewritten by
    // vertexRowsFromFacePoints (fewer loads per frame); false keeps every row as the rules
    // write it (for what reads or changes the rules' rows: psub analyze's weight experiments).
    bool vertexRowsFromFacePoints = true;
    // The tiled form's `canonical` (drawing position -> canonical index: toCanonical, `psub
    // subdivide`). false, in the lean build, lets refine skip it where the tiles cover the mesh
    // whole (no face-varying channel): the tiles are then placed on level B and no level after B
    // is made (the drawing-only build, docs/tiled.md "The lean build"): the same drawing
    // positions and evaluation, the surface's faces tile after tile, `canonical` empty. Elsewhere
    // it is made anyway.
    bool canonicalOrder = true;
};

// Everything the per-frame loop needs, and nothing of the topology.
struct Refinement {
    bool preprocessed = false;
    int levels = 0;
    PerLevelTable perLevel;
    FactorizedTable factorized;  // empty unless RefineOptions::factorized
    SurfaceTable surface;
    TiledTable tiled;            // empty unless RefineOptions::tiled
    FaceVaryingTable uv;         // empty unless the mesh has UVs (Mesh::uv)
    double topologyMs = 0, perLevelMs = 0, factorizedMs = 0, tiledMs = 0;
    double uvMs = 0;             // the face-varying channel's topology and tables
};

// Refines a checked mesh (see checkMesh) and builds its tables, with the face-varying
// channel's (Refinement::uv) when the mesh has UVs and the boundary is Boundary::Paper (with
// Boundary::Smooth the channel is not refined and Refinement::uv stays empty:
// docs/face-varying.md). Throws InputError when preprocessing is needed but Preprocess::Never
// was asked for.
Refinement refine(const Mesh& mesh, const Connectivity& connectivity, const RefineOptions& options);

}  // namespace psub
