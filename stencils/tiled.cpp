// Builds the tiled table form (psub/tiled.h): finds regular blocks of level-B faces by walking
// half-edges (their sides chosen by a cost model), maps their finest lattices to canonical
// indices by walking the level two steps coarser (the finest level's topology is never needed),
// assigns drawing positions, and keeps the per-level rows the fallback points need; in pieces
// (tiled_build.h) that refine also runs level by level for the lean build.
#include "psub/stencils.h"
#include "psub/tiled.h"
#include "tiled_build.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <omp.h>
#include <span>
#include <stdexcept>
#include <string>

namespace psub {
namespace {

constexpr std::uint32_t kNone = ~0u;
constexpr std::uint32_t kHalo[] = {0, 2, 3, 4};  // rings of level-B faces around a block, per double step count

// Moves on a quad mesh around regular vertices (interior, valence 4, four quads). rot(h) is
// the next half-edge counter-clockwise around h's tail (the face order of refineFaces keeps
// every level consistently oriented, so rot turns the same way everywhere on one level).
struct Walker {
    const Faces& faces;
    const Connectivity& c;
    std::vector<std::uint8_t> regularFlags = {};  // regular(v) per vertex, when cached (cacheRegular)
    bool allQuads = false;  // every face a quad (noteAllQuads): regular(v) need not look at v's faces
    // Per vertex, when cached: the face hops to the nearest vertex that is not regular (kNone
    // where there is none). In a regular region a face hop is one step of the grid's Chebyshev
    // distance, so a block's grid, a square of radius r around its centre vertex, is all
    // regular only where the centre's clearance exceeds r.
    std::vector<std::uint32_t> clearance = {};

    Index head(Index h) const { return faces.verts[c.next[h]]; }
    Index rot(Index h) const { return c.twin[c.next[c.next[c.next[h]]]]; }
    Index rot3(Index h) const { return rot(rot(rot(h))); }
    Index straight(Index h) const { return rot(rot(c.twin[h])); }  // on past head(h)
    // Forced inline: called for every vertex of every walk, and GCC left it a call in
    // placeTiles (7% of the torus's lean build in perf).
    [[gnu::always_inline]] bool regular(Index v) const {
        if (!regularFlags.empty()) return regularFlags[v] != 0;
        if (c.kind[v] != VertexKind::Interior || c.valence[v] != 4) return false;
        if (allQuads) return true;
        for (Index h : c.outgoingOf(v))
            if (faces.faceSize(c.faceOf[h]) != 4) return false;
        return true;
    }
    // For level N - 2, whose lattices are walked once: a scan of the faces in order instead of
    // every walked vertex's four faces (a miss each: a fifth of placeTiles on the torus).
    void noteAllQuads() {
        allQuads = true;
        for (Index f = 0; f < faces.faceCount() && allQuads; ++f) allQuads = faces.faceSize(f) == 4;
    }
    // For level B, whose blocks are walked once per side the cost model tries.
    void cacheRegular() {
        std::vector<std::uint8_t> flags(faces.vertexCount);
        for (Index v = 0; v < faces.vertexCount; ++v) flags[v] = regular(v) ? 1 : 0;
        regularFlags = std::move(flags);
        std::vector<Index> irregular;
        for (Index v = 0; v < faces.vertexCount; ++v)
            if (!regularFlags[v]) irregular.push_back(v);
        clearance = hopsFrom(std::move(irregular), kNone);
    }
    // Per vertex, the face hops from the nearest of `sources`, kNone where none is within
    // `depth`: breadth first over the vertices of each face, a face expanded once, from its
    // first corner dequeued (the nearest: its other corners are then at most one more).
    std::vector<std::uint32_t> hopsFrom(std::vector<Index> sources, std::uint32_t depth) const {
        std::vector<Index>& queue = sources;  // grows from them
        std::vector<std::uint32_t> hops(faces.vertexCount, kNone);
        std::vector<std::uint8_t> expanded(faces.faceCount(), 0);
        for (Index v : queue) hops[v] = 0;
        for (std::size_t i = 0; i < queue.size(); ++i) {
            if (hops[queue[i]] >= depth) continue;
            for (Index h : c.outgoingOf(queue[i])) {
                const Index f = c.faceOf[h];
                if (expanded[f]) continue;
                expanded[f] = 1;
                for (Index u : faces.face(f))
                    if (hops[u] == kNone) hops[u] = hops[queue[i]] + 1, queue.push_back(u);
            }
        }
        return hops;
    }
    // Per side, when cached (cacheCentres): whether the vertex is within side / 2 face hops of
    // a vertex whose clearance exceeds halo + side / 2, as the centre of a block of that side
    // must. A block's centre is side / 2 hops from its first corner, so no block of that side
    // starts at a vertex without the flag: walkBlock turns it away before walking.
    std::vector<std::vector<std::uint8_t>> nearCentre = {};

    void cacheCentres(const std::vector<std::uint32_t>& sides, std::uint32_t halo) {
        // Without an irregular vertex every walk skips the centre (its clearance is kNone).
        if (clearance.empty() || largestClearance() == kNone) return;
        for (std::uint32_t side : sides) {
            if (side < nearCentre.size() && !nearCentre[side].empty()) continue;
            if (side >= nearCentre.size()) nearCentre.resize(side + 1);
            std::vector<Index> centres;  // the vertices with the clearance a centre needs
            for (Index v = 0; v < faces.vertexCount; ++v)
                if (clearance[v] > halo + side / 2) centres.push_back(v);
            const std::vector<std::uint32_t> hops = hopsFrom(std::move(centres), side / 2);
            std::vector<std::uint8_t> near(faces.vertexCount);
            for (Index v = 0; v < faces.vertexCount; ++v) near[v] = hops[v] != kNone;
            nearCentre[side] = std::move(near);
        }
    }
    bool mayCentre(Index v, std::uint32_t side) const {
        return side >= nearCentre.size() || nearCentre[side].empty() || nearCentre[side][v] != 0;
    }

    std::uint32_t largestClearance() const {
        return clearance.empty() ? kNone : *std::max_element(clearance.begin(), clearance.end());
    }
};

// Marks for walkBlock's check that a grid's vertices are distinct: vertex v is in the current
// grid when seen[v] == round (a new round per grid, no clearing).
struct SeenMarks {
    std::vector<std::uint32_t> seen;
    std::uint32_t round = 0;
};

// Whether the cells on the outer ring of the side x side block whose first cell's first
// corner has the +x half-edge hx are all free (not `covered`), its ring's vertices regular. A
// block of the greedy cover that overlaps an earlier one, which is at least as large (sides
// come largest first), has a covered cell on that ring: 4 side moves find it, where the walk
// of the whole grid met it only after its halo rows.
bool ringFree(const Walker& w, Index hx, std::uint32_t side, const std::vector<std::uint8_t>& covered) {
    Index ux = hx;
    const auto free = [&] { return !covered[w.c.faceOf[ux]]; };
    // Moves keeping ux the +x half-edge of the vertex reached (false where that is irregular).
    const auto move = [&](Index h, bool turnBack) {
        if (!w.regular(w.head(h))) return false;
        ux = turnBack ? w.rot3(w.c.twin[h]) : w.c.twin[h];
        return true;
    };
    if (!free()) return false;
    for (std::uint32_t x = 1; x < side; ++x) {  // the bottom row, +x
        if (!w.regular(w.head(ux))) return false;
        ux = w.straight(ux);
        if (!free()) return false;
    }
    for (std::uint32_t y = 1; y < side; ++y) {  // the last column, +y
        const Index up = w.rot(ux);
        if (!w.regular(w.head(up))) return false;
        ux = w.rot(w.c.twin[up]);
        if (!free()) return false;
    }
    for (std::uint32_t x = 1; x < side; ++x)  // the top row, -x
        if (!move(w.rot(w.rot(ux)), false) || !free()) return false;
    for (std::uint32_t y = 2; y < side; ++y)  // the first column, -y
        if (!move(w.rot3(ux), true) || !free()) return false;
    return true;
}

// The g x g level-B vertices (row by row, x along face f's first edge, y along its last,
// face f's first corner at (halo, halo)) and the side x side faces of the block, when every
// one of those vertices is regular and distinct and no face of the block is `covered`.
bool walkBlock(const Walker& w, Index f, std::uint32_t side, std::uint32_t halo, const std::vector<std::uint8_t>& covered,
               std::vector<Index>& grid, std::vector<Index>& cells, SeenMarks& marks) {
    if (w.faces.faceSize(f) != 4) return false;
    const std::uint32_t g = side + 2 * halo + 1;
    Index v = w.faces.verts[w.faces.offsets[f]], hx = w.faces.offsets[f];
    if (!w.regular(v) || !w.mayCentre(v, side)) return false;
    // First the grid's centre, (g - 1) / 2 = halo + side / 2 on each axis. It is side / 2 face
    // hops from v, so its clearance is within side / 2 of v's: v's must exceed the halo, and
    // where v's exceeds halo + side the centre's is large enough without walking there (the
    // torus: its failing walks, on strips beside covered blocks, fail in the ring walk).
    if (!w.clearance.empty() && w.clearance[v] <= halo + side) {
        if (w.clearance[v] <= halo) return false;
        // Diagonally, one step up and one right at a time: after s of them the centre is
        // side / 2 - s hops away, so the clearance here must exceed halo + s.
        Index u = v, ux = hx;
        for (std::uint32_t s = 1; s <= side / 2; ++s) {
            const Index up = w.rot(ux);
            u = w.head(up);
            if (!w.regular(u)) return false;
            ux = w.rot(w.c.twin[up]);
            u = w.head(ux);
            if (!w.regular(u) || w.clearance[u] <= halo + s) return false;
            ux = w.straight(ux);
        }
        if (w.clearance[u] <= (g - 1) / 2) return false;
    }
    if (!ringFree(w, hx, side, covered)) return false;
    // To the grid's origin: halo steps -y, then halo steps -x.
    for (std::uint32_t s = 0; s < halo; ++s) {
        const Index down = w.rot3(hx);
        v = w.head(down);
        if (!w.regular(v)) return false;
        hx = w.rot3(w.c.twin[down]);
    }
    for (std::uint32_t s = 0; s < halo; ++s) {
        const Index left = w.rot(w.rot(hx));
        v = w.head(left);
        if (!w.regular(v)) return false;
        hx = w.c.twin[left];
    }
    grid.resize(std::size_t(g) * g);
    cells.clear();
    if (marks.seen.size() < w.faces.vertexCount || ++marks.round == 0) {
        marks.seen.assign(w.faces.vertexCount, 0);
        marks.round = 1;
    }
    // Distinct as it goes: a block larger than the regular region it wraps around (a torus)
    // fails at its first repeated vertex, not after the whole grid.
    for (std::uint32_t y = 0; y < g; ++y) {
        Index u = v, ux = hx;
        for (std::uint32_t x = 0; x < g; ++x) {
            if (marks.seen[u] == marks.round) return false;
            marks.seen[u] = marks.round;
            grid[std::size_t(y) * g + x] = u;
            if (x >= halo && x < halo + side && y >= halo && y < halo + side) {
                cells.push_back(w.c.faceOf[ux]);
                if (covered[cells.back()]) return false;
            }
            if (x + 1 == g) break;
            u = w.head(ux);
            if (!w.regular(u)) return false;
            ux = w.straight(ux);
        }
        if (y + 1 == g) break;
        const Index up = w.rot(hx);
        v = w.head(up);
        if (!w.regular(v)) return false;
        hx = w.rot(w.c.twin[up]);
    }
    return true;
}

// The half-edge leaving `from` whose straight walk of `steps` edges ends at `to`, or kNone.
Index directionTo(const Walker& w, Index from, Index to, std::uint32_t steps) {
    for (Index o : w.c.outgoingOf(from)) {
        Index d = o, v = from;
        bool ok = true;
        for (std::uint32_t s = 1; s <= steps && ok; ++s) {
            v = w.head(d);
            if (s < steps) {
                ok = w.regular(v);
                if (ok) d = w.straight(d);
            }
        }
        if (ok && v == to) return o;
    }
    return kNone;
}

// How refineLevel numbers the finest level's vertices (SPEC order) in terms of the level two
// steps coarser (N - 2): a vertex keeps its index at every level; the next level's F-points
// follow its vertices, in face order, and the faces of level N - 1 are made one per coarse
// edge, in edge order (two for a boundary edge that step splits).
struct FinestNames {
    Index coarseVertices = 0;  // vertices of level N - 2: its faces' F-points follow them on N - 1
    Index middleVertices = 0;  // vertices of level N - 1: its faces' F-points follow them on N
    std::vector<Index> childFace = {};  // per coarse edge, its first face on N - 1 (empty: the edge's index)

    FinestNames(const Level& coarse, bool splitsBoundary) {
        const Connectivity& c = coarse.connectivity;
        const bool split = splitsBoundary && c.boundaryEdgeCount > 0;
        coarseVertices = coarse.faces.vertexCount;
        middleVertices = coarseVertices + coarse.faces.faceCount() + (split ? c.boundaryEdgeCount : 0);
        if (!split) return;
        childFace.resize(c.edgeCount());
        Index face = 0;
        for (Index e = 0; e < c.edgeCount(); ++e) {
            childFace[e] = face;
            face += c.twin[c.edgeHalfedge[e]] == kNoIndex ? 2 : 1;
        }
    }
    // The finest point at the middle of coarse edge e (the F-point of its face on N - 1), and
    // at the middle of coarse face f (the F-point of f on N - 1, kept on N).
    Index edgePoint(Index e) const { return middleVertices + (childFace.empty() ? e : childFace[e]); }
    Index facePoint(Index f) const { return coarseVertices + f; }
};

// The finest level's (L+1) x (L+1) lattice of a block (row by row, in the block's frame), or
// false when it cannot be walked as a regular grid. Walked on the level two steps coarser
// (walker w), whose (L/2+1)^2 lattice points keep their index on the finest level, their
// edges' and cells' middles named by `names`: a quarter of the finest walk's steps, on a level
// a quarter of its size.
bool walkLattice(const Walker& w, const FinestNames& names, std::span<const Index> grid, std::uint32_t g,
                 std::uint32_t halo, std::uint32_t steps, std::uint32_t lattice, std::vector<Index>& points,
                 std::vector<Index>* cellEdges = nullptr) {
    const Index v00 = grid[std::size_t(halo) * g + halo];
    if (!w.regular(v00)) return false;
    const std::uint32_t coarseSteps = steps / 2, coarseLattice = lattice / 2, side = lattice + 1;
    const Index hx = directionTo(w, v00, grid[std::size_t(halo) * g + halo + 1], coarseSteps);
    const Index hy = directionTo(w, v00, grid[std::size_t(halo + 1) * g + halo], coarseSteps);
    if (hx == kNone || hy == kNone) return false;
    // walkBlock's +y is rot(+x), and refinement keeps the orientation, so the same holds here.
    if (w.rot(hx) != hy) return false;
    points.resize(std::size_t(side) * side);
    if (cellEdges) cellEdges->resize(std::size_t(coarseLattice) * coarseLattice);
    Index v = v00, vx = hx;
    for (std::uint32_t y = 0; y <= coarseLattice; ++y) {
        Index u = v, ux = vx;
        Index* even = points.data() + std::size_t(2 * y) * side;
        Index* odd = even + side;
        for (std::uint32_t x = 0; x <= coarseLattice; ++x) {
            even[2 * x] = u;
            if (x < coarseLattice) even[2 * x + 1] = names.edgePoint(w.c.edgeOf[ux]);
            if (y < coarseLattice) {
                odd[2 * x] = names.edgePoint(w.c.edgeOf[w.rot(ux)]);
                // The cell between +x and +y = rot(+x): the face of +x (faces turn counter-clockwise).
                if (x < coarseLattice) odd[2 * x + 1] = names.facePoint(w.c.faceOf[ux]);
                if (cellEdges && x < coarseLattice) (*cellEdges)[std::size_t(y) * coarseLattice + x] = ux;
            }
            if (x == coarseLattice) break;
            u = w.head(ux);
            if (!w.regular(u)) return false;
            ux = w.straight(ux);
        }
        if (y == coarseLattice) break;
        const Index up = w.rot(vx);
        v = w.head(up);
        if (!w.regular(v)) return false;
        vx = w.rot(w.c.twin[up]);  // -y at v turned once is +x
    }
    return true;
}

// The greedy cover of level B by blocks: for each side in turn, over faces in order, each
// side x side block whose grid walks (walkBlock) and whose faces no earlier block has, if
// accept(side, grid, cells) takes it (its faces are then covered). Given up, unfinished, once
// `stop` is set.
template <class Accept>
void coverBlocks(const Walker& w, const std::vector<std::uint32_t>& sides, std::uint32_t halo, Accept&& accept,
                 const std::atomic<bool>* stop) {
    std::vector<std::uint8_t> covered(w.faces.faceCount(), 0);
    std::vector<Index> grid, cells;
    SeenMarks marks;
    for (std::uint32_t side : sides)
        for (Index f = 0; f < w.faces.faceCount(); ++f) {
            if (stop && f % 4096 == 0 && stop->load(std::memory_order_relaxed)) return;
            if (covered[f] || !walkBlock(w, f, side, halo, covered, grid, cells, marks)) continue;
            if (!accept(side, grid, cells)) continue;
            for (Index c : cells) covered[c] = 1;
        }
}

// The cost model of cheapestCover, in values the CPU tile kernel computes (per vertex value).
// A tile: each double step a quincunx pass over an n x n grid's (n - 2)^2 + (n - 1)^2 points
// and a fine pass over the (2n - 9)^2 grid, the last one only over the (L + 1)^2 lattice, plus
// a fixed cost per tile; a finest point no tile has (the per-level rows of every level): a
// few values. Both constants measured on the 2-core EPYC VM of bench/README.md ("Session 9").
constexpr double kTileFixedCost = 750, kFallbackPointCost = 6;
// The largest level B on which cheapestCover tries every side (about 0.07 s more there).
constexpr Index kEverySideFaces = 1 << 13;

double tileCost(std::uint32_t side, std::uint32_t t, std::uint32_t halo) {
    double values = kTileFixedCost, n = side + 2.0 * halo + 1;
    for (std::uint32_t s = 0; s < t; ++s) {
        const double fine = s + 1 == t ? double(side << t) + 1 : 2 * n - 9;
        values += (n - 2) * (n - 2) + (n - 1) * (n - 1) + fine * fine;
        n = 2 * n - 9;
    }
    return values;
}

// One greedy cover (coverBlocks) with `sides`, its blocks kept (unfinished once `stop` is set).
TileBlocks coverWith(const Walker& w, const std::vector<std::uint32_t>& sides, std::uint32_t halo,
                     const std::atomic<bool>* stop = nullptr) {
    TileBlocks blocks;
    blocks.halo = halo;
    blocks.covered.assign(w.faces.faceCount(), 0);
    coverBlocks(
        w, sides, halo,
        [&](std::uint32_t side, const std::vector<Index>& grid, const std::vector<Index>& cells) {
            blocks.side.push_back(side);
            blocks.gather.insert(blocks.gather.end(), grid.begin(), grid.end());
            for (Index c : cells) blocks.covered[c] = 1;
            return true;
        },
        stop);
    return blocks;
}

// The cheapest greedy cover: sides S, S / 2, S / 4, ... while a tile of that side costs less
// than its points' rows, S any side from the largest (kMaxLattice / 2^t) down to 3/8 of it
// (past kEverySideFaces only the largest and 3/4, 1/2 and 3/8 of it), the one whose cover
// costs least (tileCost, and the fallback's points); no block when no side is worth a tile.
// A regular region whose side is no multiple of the largest would otherwise get strips of
// small tiles (a 36 x 36 torus at t = 2: 32, 16 and 4 where four tiles of 18 cost least), and
// small regular regions tiles dearer than their rows (Spot at 9 steps: 4,089 tiles, most of a
// few faces, made the frame twice as slow as the per-level rows). A cover no cheaper than one
// with a larger first side is not kept: ties keep the larger tiles. Each cover tried is kept
// whole, so the one chosen is not walked again.
TileBlocks cheapestCover(Walker& w, std::uint32_t t, std::uint32_t halo) {
    const std::uint32_t largest = TiledTable::kMaxLattice >> t;
    const double finestPerFace = std::ldexp(1.0, 2 * int(t));
    // A side is worth a tile only where the tile costs less than the rows of its points, and
    // fits only where some vertex has the clearance its grid needs (the cow at 7 steps: none;
    // its covers walked from every face took 2.3 s to find no tile).
    const std::uint32_t clearance = w.largestClearance();
    const auto worthwhile = [&](std::uint32_t side) {
        return side > 0 && tileCost(side, t, halo) < double(side) * side * finestPerFace * kFallbackPointCost;
    };
    // A block's g x g grid (g = side + 2 halo + 1) has distinct vertices, so g^2 is at most the
    // level's vertex count: larger sides never place a block (a 64 x 64 torus at t = 1: sides 60
    // to 64, whose walks around the torus made the search 0.2 s instead of 0.07).
    const auto fits = [&](std::uint32_t side) {
        const std::uint64_t g = side + 2 * halo + 1;
        return (side + 2 * halo) / 2 < clearance && g * g <= w.faces.vertexCount;
    };
    const bool everySide = w.faces.faceCount() <= kEverySideFaces;
    std::vector<std::vector<std::uint32_t>> candidates;
    for (std::uint32_t first = largest; first > 0 && first >= largest * 3 / 8; --first) {
        const bool listed = first == largest || first == largest * 3 / 4 || first == largest / 2 || first == largest * 3 / 8;
        if (!(everySide || listed) || !worthwhile(first)) continue;
        std::vector<std::uint32_t> sides;
        for (std::uint32_t side = first; worthwhile(side); side /= 2)
            if (fits(side)) sides.push_back(side);
        // A first side that does not fit leaves the sides of a smaller first one: walked once.
        if (!sides.empty() && std::find(candidates.begin(), candidates.end(), sides) == candidates.end())
            candidates.push_back(std::move(sides));
    }
    for (const std::vector<std::uint32_t>& sides : candidates) w.cacheCentres(sides, halo);
    // Each cover is a walk from every face, independent of the others: they run in parallel.
    // Every face of a cover costs at least the least cost per face of any side the candidates
    // have (tileCost / side^2) or of a face's rows, so a cover that costs the faces' count times
    // that least cost cannot be beaten: when the first candidate's does (on a torus whose side
    // is a multiple of the largest block's, every face in blocks of that side, whose cost per
    // face is the least), the others are given up and it is kept (4 covers -> 1).
    double leastPerFace = finestPerFace * kFallbackPointCost;
    for (const std::vector<std::uint32_t>& sides : candidates)
        for (std::uint32_t side : sides) leastPerFace = std::min(leastPerFace, tileCost(side, t, halo) / (double(side) * side));
    const double leastCost = leastPerFace * w.faces.faceCount() * (1 + 1e-12);
    std::vector<TileBlocks> covers(candidates.size());
    std::vector<double> costs(candidates.size(), std::numeric_limits<double>::infinity());
    std::atomic<bool> firstIsCheapest{false};
#pragma omp parallel for schedule(dynamic, 1) if (w.faces.faceCount() > 4096)
    for (std::ptrdiff_t i = 0; i < std::ptrdiff_t(candidates.size()); ++i) {
        if (firstIsCheapest.load()) continue;
        TileBlocks& blocks = covers[std::size_t(i)];
        blocks = coverWith(w, candidates[std::size_t(i)], halo, i == 0 ? nullptr : &firstIsCheapest);
        if (i > 0 && firstIsCheapest.load()) continue;  // maybe unfinished
        double cost = 0, covered = 0;
        for (std::uint32_t side : blocks.side) cost += tileCost(side, t, halo), covered += double(side) * side;
        costs[std::size_t(i)] = cost + (w.faces.faceCount() - covered) * finestPerFace * kFallbackPointCost;
        if (i == 0 && costs[0] <= leastCost) firstIsCheapest.store(true);
    }
    std::size_t best = 0;
    for (std::size_t i = 1; i < candidates.size(); ++i)
        if (costs[i] < costs[best]) best = i;
    if (candidates.empty()) {
        TileBlocks none;
        none.halo = halo;
        none.covered.assign(w.faces.faceCount(), 0);
        return none;
    }
    return std::move(covers[best]);
}

// Level k of `in` appended to `out`: every row, or only those whose destination is `needed`,
// with destinations renumbered through `renumber` when given.
void appendRows(PerLevelTable& out, const PerLevelTable& in, std::size_t k, const std::vector<std::uint8_t>* needed,
                const std::vector<std::uint32_t>* renumber) {
    const StencilLevel& level = in.levels[k];
    StencilLevel copy{level.sourceCount, level.destinationCount, out.groups.size(), 0, out.destinations.size(), 0};
    for (std::uint64_t gi = level.groupBegin; gi < level.groupEnd; ++gi) {
        const RowGroup& g = in.groups[gi];
        RowGroup kept = g;
        kept.rowBegin = out.destinations.size();
        kept.indexBegin = out.indices.size();
        kept.rowCount = 0;
        for (std::uint64_t r = g.rowBegin; r < g.rowBegin + g.rowCount; ++r) {
            const std::uint32_t d = in.destinations[r];
            if (needed && !(*needed)[d]) continue;
            out.destinations.push_back(renumber ? (*renumber)[d] : d);
            const auto first = in.indices.begin() + std::ptrdiff_t(g.indexBegin + (r - g.rowBegin) * g.width);
            out.indices.insert(out.indices.end(), first, first + g.width);
            ++kept.rowCount;
        }
        if (kept.rowCount > 0) out.groups.push_back(kept);
    }
    copy.groupEnd = out.groups.size();
    copy.rowEnd = out.destinations.size();
    out.levels.push_back(copy);
}

}  // namespace

TiledPlan planTiled(std::size_t levelCount, bool preprocessed, const Level& firstQuadLevel) {
    const std::size_t quadLevels = levelCount - (preprocessed && levelCount > 0 ? 1 : 0);
    const Walker w{firstQuadLevel.faces, firstQuadLevel.connectivity};
    double irregular = 0;
    for (Index v = 0; v < firstQuadLevel.faces.vertexCount; ++v) irregular += w.regular(v) ? 0 : 1;
    const double faces = std::max<double>(1, firstQuadLevel.faces.faceCount());
    // Expected share of level-B faces whose one-face tile's grid, (2 halo + 2)^2 vertices,
    // holds an irregular one: their count stays while the faces double with every level.
    const auto missed = [&](std::uint32_t t) {
        const double grid = 2.0 * kHalo[t] + 2;
        return irregular * grid * grid / (faces * std::ldexp(1.0, int(quadLevels) - 2 * int(t)));
    };
    std::uint32_t t = std::uint32_t(std::min<std::size_t>(3, quadLevels / 2));
    while (t > 1 && missed(t) > 0.1) --t;
    return {std::uint32_t(levelCount) - 2 * t, t};
}

bool worthTimingWithoutTiles(const TiledTable& tiled) {
    return tiled.tileCount() > 0 && tiled.fallbackBegin < 0.9 * tiled.refinedCount;
}

TileBlocks chooseTileBlocks(const Level& base, const TiledPlan& plan) {
    if (plan.doubleSteps > 3) throw std::invalid_argument("chooseTileBlocks: at most 3 double steps");
    const std::uint32_t halo = kHalo[plan.doubleSteps];
    if (plan.doubleSteps == 0 || plan.sides == TileSides::None) {
        TileBlocks blocks;
        blocks.halo = halo;
        blocks.covered.assign(base.faces.faceCount(), 0);
        return blocks;
    }
    Walker w{base.faces, base.connectivity};
    w.cacheRegular();
    if (plan.sides != TileSides::Every) return cheapestCover(w, plan.doubleSteps, halo);
    std::vector<std::uint32_t> sides;
    for (std::uint32_t side = TiledTable::kMaxLattice >> plan.doubleSteps; side > 0; side /= 2) sides.push_back(side);
    w.cacheCentres(sides, halo);
    return coverWith(w, sides, halo);
}

std::vector<std::uint8_t> baseLabels(const Level& base, const TileBlocks& blocks) {
    const Faces& faces = base.faces;
    std::vector<std::uint32_t> hops(faces.vertexCount, kNone);
    std::vector<Index> queue;
    std::vector<std::uint8_t> used(faces.vertexCount, 0), expanded(faces.faceCount(), 0);
    for (Index f = 0; f < faces.faceCount(); ++f)
        for (Index v : faces.face(f)) {
            used[v] = 1;
            if (!blocks.covered[f] && hops[v] == kNone) hops[v] = 0, queue.push_back(v);
        }
    for (Index v = 0; v < faces.vertexCount; ++v)
        if (!used[v]) hops[v] = 0, queue.push_back(v);  // on no face: the fallback's
    // Breadth first over the corners of each face (each face expanded once, from its first
    // corner dequeued), as Walker::cacheRegular.
    for (std::size_t i = 0; i < queue.size(); ++i)
        for (Index h : base.connectivity.outgoingOf(queue[i])) {
            const Index f = base.connectivity.faceOf[h];
            if (expanded[f]) continue;
            expanded[f] = 1;
            for (Index u : faces.face(f))
                if (hops[u] == kNone) hops[u] = hops[queue[i]] + 1, queue.push_back(u);
        }
    std::vector<std::uint8_t> labels(faces.vertexCount);
    for (Index v = 0; v < faces.vertexCount; ++v) labels[v] = std::uint8_t(std::min<std::uint32_t>(hops[v], 255));
    return labels;
}

std::vector<std::uint8_t> childLabels(const Level& parent, bool splitBoundary, const std::vector<std::uint8_t>& labels) {
    const Faces& faces = parent.faces;
    const Connectivity& c = parent.connectivity;
    std::vector<std::uint8_t> child(labels);
    child.reserve(std::size_t(faces.vertexCount) + faces.faceCount() + (splitBoundary ? c.boundaryEdgeCount : 0));
    for (Index f = 0; f < faces.faceCount(); ++f) {
        std::uint8_t least = 255;
        for (Index v : faces.face(f)) least = std::min(least, labels[v]);
        child.push_back(least);
    }
    if (splitBoundary)  // the boundary edges' points, in edge order (appendStepRows' numbering)
        for (Index h : c.edgeHalfedge)
            if (c.twin[h] == kNoIndex) child.push_back(std::min(labels[faces.verts[h]], labels[faces.verts[c.next[h]]]));
    return child;
}

namespace {

// The 4 finest faces inside the coarse cell whose first corner's +x half-edge is e0 (its
// corners c_0 .. c_3 counter-clockwise, e_i from c_i to c_(i+1)), written at `corners` (4 each)
// and `order` (1 each), both moved on: the lattice cells around its middle point M (= `at(1,
// 1)`, `at(x, y)` the drawing position of the finest point x, y halves of a coarse edge from
// c_0). Each is the face refine makes around the edge of level N - 1 between c_i and M; refine
// numbers those edges in the order of their first half-edge, and starts each face at that
// half-edge's tail (topology/refine.cpp). Of the edge's two half-edges, c_i -> M lies in the face
// of level N - 1 made for e_(i-1)'s coarse edge (at its corner 2 if e_(i-1) is that edge's first
// half-edge, else 0) and M -> c_i in the one made for e_i's (corner 3, else 1); the faces of
// level N - 1 follow the coarse edges in order. So the first half-edge is c_i -> M where
// e_(i-1)'s edge comes first (the face starts at c_i), else M -> c_i (it starts at M), and the
// face's `order` is 4 x that coarse edge's first half-edge + the corner: refine's order
// (docs/tiled.md, "The lean build").
template <class At>
void appendCellFaces(const Connectivity& c, Index e0, At&& at, Index*& corners, std::uint32_t*& order) {
    const Index e[4] = {e0, c.next[e0], c.next[c.next[e0]], c.next[c.next[c.next[e0]]]};
    // Per corner c_i: its lattice cell's corners counter-clockwise from c_i ((x, y) offsets).
    static constexpr std::uint32_t kCell[4][4][2] = {{{0, 0}, {1, 0}, {1, 1}, {0, 1}},
                                                     {{2, 0}, {2, 1}, {1, 1}, {1, 0}},
                                                     {{2, 2}, {1, 2}, {1, 1}, {2, 1}},
                                                     {{0, 2}, {0, 1}, {1, 1}, {1, 2}}};
    // An edge's first half-edge is the lesser of its two (completeConnectivity numbers the edges
    // as their first half-edges come): so edges compare as those, and 4 x it + the corner orders
    // the faces as 4 x the edge's number + the corner would.
    Index first[4];
    for (int i = 0; i < 4; ++i) first[i] = std::min(e[i], c.twin[e[i]]);
    for (int i = 0; i < 4; ++i) {
        const int in = (i + 3) % 4, out = i;
        const bool fromCorner = first[in] < first[out];
        const std::uint32_t start = fromCorner ? 0 : 2;  // c_i or M
        for (int j = 0; j < 4; ++j) {
            const std::uint32_t* p = kCell[i][(start + j) % 4];
            *corners++ = at(p[0], p[1]);
        }
        *order++ = fromCorner ? 4 * first[in] + (first[in] == e[in] ? 2 : 0) : 4 * first[out] + (first[out] == e[out] ? 3 : 1);
    }
}

// The drawing positions of the next tile of `table` (its lattice's finest points `points`, row
// by row, and its gathered grid `grid`): its inner points next, next + 1, ... row by row, then
// those of its ring that no earlier tile numbered; its entries appended to the table.
void numberTile(TiledTable& table, std::uint32_t side, std::uint32_t lattice, std::span<const Index> grid,
                const std::vector<Index>& points, std::vector<std::uint32_t>& drawOf, std::uint32_t& next) {
    table.side.push_back(side);
    table.gather.insert(table.gather.end(), grid.begin(), grid.end());
    table.gatherBegin.push_back(table.gather.size());
    table.output.push_back(next);
    const auto at = [&](std::uint32_t x, std::uint32_t y) -> std::uint32_t& {
        return drawOf[points[std::size_t(y) * (lattice + 1) + x]];
    };
    for (std::uint32_t y = 1; y < lattice; ++y)
        for (std::uint32_t x = 1; x < lattice; ++x) {
            if (at(x, y) != kNone) throw std::logic_error("placeTiles: a tile's inner point is shared");
            at(x, y) = next++;
        }
    const auto borderPoint = [&](std::uint32_t x, std::uint32_t y) {
        if (at(x, y) == kNone) at(x, y) = next++;
        table.border.push_back(at(x, y));
    };
    for (std::uint32_t y = 0; y <= lattice; ++y)
        for (std::uint32_t x = 0; x <= lattice; x += (y == 0 || y == lattice) ? 1 : lattice) borderPoint(x, y);
    table.borderBegin.push_back(table.border.size());
}

// The finest faces of tile k's lattice, whose cells' +x half-edges on level N - 2 are
// `cellEdges` (appendCellFaces, cell by cell, row by row), at `corners` and `order`. The
// lattice's drawing positions come from the tile's output range and border list, not drawOf
// (in canonical order, a miss a point, and written by another thread: read from there, the
// 16.8M-face torus's faces took longer on two threads than on one); `drawn` holds them.
void appendTileFaces(const TiledTable& table, const Connectivity& coarse, std::size_t k,
                     const std::vector<Index>& cellEdges, std::vector<Index>& drawn, Index* corners, std::uint32_t* order) {
    const std::uint32_t lattice = table.lattice(k), cells = lattice / 2;
    drawn.resize(std::size_t(lattice + 1) * (lattice + 1));
    for (std::uint32_t y = 0; y <= lattice; ++y)
        for (std::uint32_t x = 0; x <= lattice; ++x) drawn[std::size_t(y) * (lattice + 1) + x] = table.drawingPosition(k, x, y);
    for (std::uint32_t y = 0; y < cells; ++y)
        for (std::uint32_t x = 0; x < cells; ++x)
            appendCellFaces(coarse, cellEdges[std::size_t(y) * cells + x],
                            [&](std::uint32_t dx, std::uint32_t dy) {
                                return drawn[std::size_t(2 * y + dy) * (lattice + 1) + 2 * x + dx];
                            },
                            corners, order);
}

}  // namespace

std::vector<std::uint32_t> placeTiles(TiledTable& table, const TileBlocks& blocks, const Level* coarse, bool coarseSplits,
                                      std::uint32_t finestCount, TileFaces* faces) {
    table.refinedCount = finestCount;
    table.halo = blocks.halo;
    std::vector<std::uint32_t> drawOf(finestCount, kNone);
    std::uint32_t next = 0;
    if (!blocks.side.empty()) {
        if (!coarse) throw std::logic_error("placeTiles: tiles without level N - 2");
        Walker walker{coarse->faces, coarse->connectivity};
        walker.noteAllQuads();
        const FinestNames names(*coarse, coarseSplits);
        const std::uint32_t steps = 1u << table.doubleSteps, halo = blocks.halo;
        const std::size_t tiles = blocks.side.size();
        // Per tile: its first gathered point and its first face (every face of every lattice).
        std::vector<std::size_t> gatherAt(tiles + 1, 0), faceAt(tiles + 1, 0);
        for (std::size_t k = 0; k < tiles; ++k) {
            const std::size_t g = blocks.side[k] + 2 * halo + 1, lattice = std::size_t(blocks.side[k]) * steps;
            gatherAt[k + 1] = gatherAt[k] + g * g;
            faceAt[k + 1] = faceAt[k] + lattice * lattice;
        }
        if (faces) faces->corners.resize(4 * faceAt[tiles]), faces->order.resize(faceAt[tiles]);
        // The tiles in batches: their lattices walked on the threads, then numbered in turn (the
        // drawing positions follow the tiles' order: the same numbers as one thread gives), then
        // their faces made on the threads. The walks and the faces read level N - 2 (misses,
        // mostly) and the table's numbers of their own tile, and write their own arrays; they
        // were three quarters of placeTiles (perf, the 1M-face torus, whose tiled table took
        // 54-56 ms, now 46-48, on two threads of the 2-vCPU VM: docs/tiled.md, "The lean build").
        struct Walked {
            std::vector<Index> points, cellEdges, drawn;
        };
        const int threads = faceAt[tiles] >= 65536 ? omp_get_max_threads() : 1;
        const std::size_t batch = 4 * std::size_t(threads);
        const auto latticeOf = [&](std::size_t k) { return blocks.side[k] * steps; };
        const auto gridOf = [&](std::size_t k) {
            return std::span<const Index>(blocks.gather.data() + gatherAt[k], gatherAt[k + 1] - gatherAt[k]);
        };
        // Sized for the largest tile here, so that nothing is allocated on the threads (an
        // exception there would end the program, not reach the caller).
        const std::size_t largest = *std::max_element(blocks.side.begin(), blocks.side.end());
        std::vector<Walked> walked(batch);
        for (Walked& mine : walked) {
            mine.points.reserve((largest * steps + 1) * (largest * steps + 1));
            mine.drawn.reserve(mine.points.capacity());
            if (faces) mine.cellEdges.reserve(largest * steps / 2 * (largest * steps / 2));
        }
        for (std::size_t b = 0; b < tiles; b += batch) {
            const std::ptrdiff_t end = std::ptrdiff_t(std::min(tiles, b + batch));
            int failed = 0;
#pragma omp parallel for num_threads(threads) schedule(dynamic, 1) reduction(| : failed)
            for (std::ptrdiff_t k = std::ptrdiff_t(b); k < end; ++k) {
                const std::uint32_t g = blocks.side[std::size_t(k)] + 2 * halo + 1;
                Walked& mine = walked[std::size_t(k) - b];
                // A block's grid is regular and its vertices distinct on level B, so its lattice
                // is on level N - 2: the walk cannot fail on a table's own levels.
                if (!walkLattice(walker, names, gridOf(std::size_t(k)), g, halo, steps, latticeOf(std::size_t(k)),
                                 mine.points, faces ? &mine.cellEdges : nullptr))
                    failed = 1;
            }
            if (failed) throw std::logic_error("placeTiles: a tile's lattice does not walk on level N - 2");
            for (std::size_t k = b; k < std::size_t(end); ++k)
                numberTile(table, blocks.side[k], latticeOf(k), gridOf(k), walked[k - b].points, drawOf, next);
            if (!faces) continue;
#pragma omp parallel for num_threads(threads) schedule(dynamic, 1)
            for (std::ptrdiff_t k = std::ptrdiff_t(b); k < end; ++k) {
                Walked& mine = walked[std::size_t(k) - b];
                appendTileFaces(table, coarse->connectivity, std::size_t(k), mine.cellEdges, mine.drawn,
                                faces->corners.data() + 4 * faceAt[std::size_t(k)], faces->order.data() + faceAt[std::size_t(k)]);
            }
        }
    }
    table.fallbackBegin = next;
    for (std::uint32_t v = 0; v < finestCount; ++v)
        if (drawOf[v] == kNone) drawOf[v] = next++;
    table.canonical.resize(finestCount);
    for (std::uint32_t v = 0; v < finestCount; ++v) table.canonical[drawOf[v]] = v;
    return drawOf;
}

namespace {

// The surface of tiles that cover the finest level: their lattices' quads tile after tile, row
// by row, corners counter-clockwise in the tile's frame as the surface's faces turn
// (walkLattice); each vertex's faces in face order, as buildSurfaceTable lists them, but made
// tile by tile on the threads: an inner point's four faces are its own tile's (below left,
// below, left, its own), a ring point's are gathered from the tiles' ring quads in turn.
SurfaceTable latticeSurface(const TiledTable& t) {
    const std::size_t tiles = t.tileCount();
    std::vector<std::size_t> faceAt(tiles + 1, 0);
    for (std::size_t k = 0; k < tiles; ++k) faceAt[k + 1] = faceAt[k] + std::size_t(t.lattice(k)) * t.lattice(k);
    const std::size_t faceCount = faceAt[tiles];
    SurfaceTable surface;
    surface.vertexCount = t.refinedCount;
    const bool threads = faceCount >= 65536;
    // Fresh memory is most of the time on its first use in a process (the 16.8M-face torus: 0.5 s
    // of its first build's 0.7), and a vector zeroes it on one thread: the faces' arrays on one,
    // the vertices' on the other.
    sideBySide(
        threads,
        [&] {
            surface.faceOffsets.resize(faceCount + 1);
            surface.faceVerts.resize(4 * faceCount);
        },
        [&] {
            surface.vertexOffsets.assign(std::size_t(t.refinedCount) + 1, 0);
            surface.vertexFaces.resize(4 * faceCount);
        });
    const auto inner = [&](std::size_t k) { return std::size_t(t.lattice(k) - 1) * (t.lattice(k) - 1); };
#pragma omp parallel for schedule(dynamic, 1) if (threads)
    for (std::ptrdiff_t tile = 0; tile < std::ptrdiff_t(tiles); ++tile) {
        const std::size_t k = std::size_t(tile);
        const std::uint32_t L = t.lattice(k);
        std::size_t f = faceAt[k];
        for (std::uint32_t y = 0; y < L; ++y)
            for (std::uint32_t x = 0; x < L; ++x, ++f) {
                std::uint32_t* q = &surface.faceVerts[4 * f];
                q[0] = t.drawingPosition(k, x, y);
                q[1] = t.drawingPosition(k, x + 1, y);
                q[2] = t.drawingPosition(k, x + 1, y + 1);
                q[3] = t.drawingPosition(k, x, y + 1);
                surface.faceOffsets[f + 1] = std::uint32_t(4 * (f + 1));
            }
        std::fill_n(surface.vertexOffsets.begin() + t.output[k] + 1, inner(k), 4u);
    }
    // A ring point's faces: counted, then listed, over the ring quads of every tile in turn.
    std::vector<std::uint8_t> ring(t.refinedCount, 0);
    for (std::uint32_t p : t.border) ring[p] = 1;
    const auto eachRingCorner = [&](auto&& visit) {
        for (std::size_t k = 0; k < tiles; ++k) {
            const std::uint32_t L = t.lattice(k);
            for (std::uint32_t y = 0; y < L; ++y)
                for (std::uint32_t x = 0; x < L; x += (y == 0 || y + 1 == L) ? 1 : L - 1) {
                    const std::uint32_t f = std::uint32_t(faceAt[k] + std::size_t(y) * L + x);
                    for (int c = 0; c < 4; ++c)
                        if (ring[surface.faceVerts[4 * std::size_t(f) + c]]) visit(surface.faceVerts[4 * std::size_t(f) + c], f);
                }
        }
    };
    eachRingCorner([&](std::uint32_t p, std::uint32_t) { ++surface.vertexOffsets[p + 1]; });
    for (std::uint32_t p = 0; p < t.refinedCount; ++p) surface.vertexOffsets[p + 1] += surface.vertexOffsets[p];
    if (surface.vertexOffsets.back() != surface.vertexFaces.size())
        throw std::logic_error("latticeSurface: the tiles' faces do not cover the finest level");
    // ring[p] - 1: the faces of ring point p listed so far (valence 4: every vertex of a tile's grid is regular).
    eachRingCorner([&](std::uint32_t p, std::uint32_t f) { surface.vertexFaces[surface.vertexOffsets[p] + ring[p]++ - 1] = f; });
#pragma omp parallel for schedule(dynamic, 1) if (threads)
    for (std::ptrdiff_t tile = 0; tile < std::ptrdiff_t(tiles); ++tile) {
        const std::size_t k = std::size_t(tile);
        const std::uint32_t L = t.lattice(k);
        for (std::uint32_t y = 1; y < L; ++y)
            for (std::uint32_t x = 1; x < L; ++x) {
                const std::uint32_t p = t.output[k] + (y - 1) * (L - 1) + x - 1;
                const std::uint32_t below = std::uint32_t(faceAt[k] + std::size_t(y - 1) * L + x), above = below + L;
                std::uint32_t* faces = &surface.vertexFaces[surface.vertexOffsets[p]];
                faces[0] = below - 1, faces[1] = below, faces[2] = above - 1, faces[3] = above;
            }
    }
    return surface;
}

}  // namespace

bool placeTilesOnBase(TiledTable& table, const TileBlocks& blocks, const Level& base, std::uint32_t finestCount) {
    const Faces& faces = base.faces;
    const Connectivity& c = base.connectivity;
    if (blocks.side.empty() || table.doubleSteps == 0 || blocks.covered.size() != std::size_t(faces.faceCount()) ||
        std::find(blocks.covered.begin(), blocks.covered.end(), 0) != blocks.covered.end())
        return false;
    for (Index v = 0; v < faces.vertexCount; ++v)
        if (c.outgoingOf(v).empty()) return false;
    const std::uint32_t steps = 1u << table.doubleSteps, halo = blocks.halo;
    // The drawing position of each level-B vertex's finest point and of each edge's steps - 1
    // inner points (point i from the tail of the edge's first half-edge), once numbered.
    std::vector<std::uint32_t> vertexAt(faces.vertexCount, kNone), edgeAt(std::size_t(c.edgeCount()) * (steps - 1), kNone);
    // Point i of `steps` from a to b: its slot, or null where a and b share no edge or several.
    const auto edgeSlot = [&](Index a, Index b, std::uint32_t i) -> std::uint32_t* {
        Index found = kNoIndex;
        for (Index h : c.outgoingOf(a)) {
            if (faces.verts[c.next[h]] != b) continue;
            if (found != kNoIndex) return nullptr;
            found = h;
        }
        if (found == kNoIndex) return nullptr;
        const Index e = c.edgeOf[found];
        const bool forward = faces.verts[c.edgeHalfedge[e]] == a;
        return &edgeAt[std::size_t(e) * (steps - 1) + (forward ? i : steps - i) - 1];
    };
    TiledTable placed;
    placed.doubleSteps = table.doubleSteps;
    std::uint32_t next = 0;
    std::size_t gathered = 0, faceCount = 0;
    for (std::size_t k = 0; k < blocks.side.size(); ++k) {
        const std::uint32_t side = blocks.side[k], g = side + 2 * halo + 1, L = side * steps;
        const std::span<const Index> grid(blocks.gather.data() + gathered, std::size_t(g) * g);
        gathered += grid.size();
        placed.side.push_back(side);
        placed.gather.insert(placed.gather.end(), grid.begin(), grid.end());
        placed.gatherBegin.push_back(placed.gather.size());
        placed.output.push_back(next);
        next += (L - 1) * (L - 1);
        faceCount += std::size_t(L) * L;
        // Level-B grid vertex (X, Y) of the block (its corner (0, 0) at the halo's end).
        const auto vertex = [&](std::uint32_t X, std::uint32_t Y) { return grid[std::size_t(halo + Y) * g + halo + X]; };
        for (std::uint32_t y = 0; y <= L; ++y)
            for (std::uint32_t x = 0; x <= L; x += (y == 0 || y == L) ? 1 : L) {
                std::uint32_t* slot = nullptr;
                if (x % steps == 0 && y % steps == 0)
                    slot = &vertexAt[vertex(x / steps, y / steps)];
                else if (y % steps == 0)  // on rows 0 and L: along +x
                    slot = edgeSlot(vertex(x / steps, y / steps), vertex(x / steps + 1, y / steps), x % steps);
                else  // on columns 0 and L: along +y
                    slot = edgeSlot(vertex(x / steps, y / steps), vertex(x / steps, y / steps + 1), y % steps);
                if (!slot) return false;
                if (*slot == kNone) *slot = next++;
                placed.border.push_back(*slot);
            }
        placed.borderBegin.push_back(placed.border.size());
    }
    if (next != finestCount)
        throw std::logic_error("placeTilesOnBase: the tiles number " + std::to_string(next) + " points of " +
                               std::to_string(finestCount));
    placed.refinedCount = finestCount;
    placed.fallbackBegin = finestCount;
    placed.halo = halo;
    placed.surface = latticeSurface(placed);
    table.halo = placed.halo;
    table.refinedCount = placed.refinedCount;
    table.fallbackBegin = placed.fallbackBegin;
    table.side = std::move(placed.side);
    table.gather = std::move(placed.gather);
    table.gatherBegin = std::move(placed.gatherBegin);
    table.output = std::move(placed.output);
    table.border = std::move(placed.border);
    table.borderBegin = std::move(placed.borderBegin);
    table.canonical.clear();
    table.surface = std::move(placed.surface);
    return true;
}

namespace {

// Per level from B + 1 to the finest (index k + 1 for level k's rows; the others empty):
// whether the fallback needs the level's point, marked from the finest level back.
std::vector<std::vector<std::uint8_t>> neededByFallback(const TiledTable& table, const PerLevelTable& rows,
                                                        const std::vector<std::uint32_t>& drawOf) {
    const std::size_t levels = rows.levels.size();
    std::vector<std::vector<std::uint8_t>> neededAt(levels + 1);
    neededAt[levels].resize(table.refinedCount);
    for (std::uint32_t v = 0; v < table.refinedCount; ++v) neededAt[levels][v] = drawOf[v] >= table.fallbackBegin;
    for (std::size_t k = levels; k-- > std::size_t(table.baseLevel) + 1;) {
        const StencilLevel& level = rows.levels[k];
        neededAt[k].assign(level.sourceCount, 0);
        for (std::uint64_t gi = level.groupBegin; gi < level.groupEnd; ++gi) {
            const RowGroup& g = rows.groups[gi];
            for (std::uint64_t r = g.rowBegin; r < g.rowBegin + g.rowCount; ++r) {
                if (!neededAt[k + 1][rows.destinations[r]]) continue;
                const std::uint64_t first = g.indexBegin + (r - g.rowBegin) * g.width;
                for (std::uint32_t j = 0; j < g.width; ++j) neededAt[k][rows.indices[first + j]] = 1;
            }
        }
    }
    return neededAt;
}

// `rows` may hold only some of a level's rows (refine's lean build): every point the fallback
// needs must have its own.
void requireEveryNeededRow(const StencilLevel& kept, const std::vector<std::uint8_t>& needed, std::size_t k) {
    if (kept.rowEnd - kept.rowBegin != std::uint64_t(std::count(needed.begin(), needed.end(), std::uint8_t(1))))
        throw std::logic_error("keepFallbackRows: a point the fallback needs has no row on level " + std::to_string(k + 1));
}

}  // namespace

void keepFallbackRows(TiledTable& table, PerLevelTable&& rows, const std::vector<std::uint32_t>& drawOf) {
    if (table.fallbackBegin == 0) {
        table.rows = std::move(rows);
        return;
    }
    // As the copying form below, but in place: levels [0, B) stay where they are, and each
    // kept row of the later levels moves down over those dropped (never up), so nothing is
    // copied into new arrays (the cow at 8 steps: its rows' copy was a quarter of the build).
    const std::vector<std::vector<std::uint8_t>> neededAt = neededByFallback(table, rows, drawOf);
    const std::size_t levels = rows.levels.size();
    if (levels <= table.baseLevel) throw std::logic_error("keepFallbackRows: no level after level B");
    const StencilLevel& base = rows.levels[table.baseLevel];
    std::uint64_t groupsEnd = base.groupBegin, rowsEnd = base.rowBegin;
    std::uint64_t indicesEnd = 0;  // where the groups before level B end
    if (base.groupBegin > 0) {
        const RowGroup& last = rows.groups[base.groupBegin - 1];
        indicesEnd = last.indexBegin + last.rowCount * last.width;
    }
    for (std::size_t k = table.baseLevel; k < levels; ++k) {
        const StencilLevel level = rows.levels[k];
        const std::vector<std::uint8_t>& needed = neededAt[k + 1];
        const std::vector<std::uint32_t>* renumber = k + 1 == levels ? &drawOf : nullptr;
        StencilLevel& kept = rows.levels[k];
        kept.groupBegin = groupsEnd, kept.rowBegin = rowsEnd;
        for (std::uint64_t gi = level.groupBegin; gi < level.groupEnd; ++gi) {
            RowGroup g = rows.groups[gi];
            const std::uint64_t rowBegin = g.rowBegin, rowCount = g.rowCount, indexBegin = g.indexBegin;
            if (rowBegin < rowsEnd || indexBegin < indicesEnd)  // rows laid out in group order, as every builder does
                throw std::logic_error("keepFallbackRows: rows out of order on level " + std::to_string(k + 1));
            g.rowBegin = rowsEnd, g.indexBegin = indicesEnd, g.rowCount = 0;
            for (std::uint64_t r = rowBegin; r < rowBegin + rowCount; ++r) {
                const std::uint32_t d = rows.destinations[r];
                if (!needed[d]) continue;
                rows.destinations[rowsEnd++] = renumber ? (*renumber)[d] : d;
                const auto first = rows.indices.begin() + std::ptrdiff_t(indexBegin + (r - rowBegin) * g.width);
                std::copy(first, first + g.width, rows.indices.begin() + std::ptrdiff_t(indicesEnd));
                indicesEnd += g.width;
                ++g.rowCount;
            }
            if (g.rowCount > 0) rows.groups[groupsEnd++] = g;
        }
        kept.groupEnd = groupsEnd, kept.rowEnd = rowsEnd;
        requireEveryNeededRow(kept, needed, k);
    }
    rows.groups.resize(groupsEnd);
    rows.destinations.resize(rowsEnd);
    rows.indices.resize(indicesEnd);
    table.rows = std::move(rows);
}

void keepFallbackRows(TiledTable& table, const PerLevelTable& rows, const std::vector<std::uint32_t>& drawOf) {
    // Without a tile every row is kept, in canonical order.
    if (table.fallbackBegin == 0) {
        table.rows = rows;
        return;
    }
    // Levels [0, B) whole; the rest only where the fallback needs them.
    const std::vector<std::vector<std::uint8_t>> neededAt = neededByFallback(table, rows, drawOf);
    const std::size_t levels = rows.levels.size();
    table.rows = PerLevelTable{};
    table.rows.controlCount = rows.controlCount;
    for (std::size_t k = 0; k < levels; ++k) {
        const bool fallback = k >= table.baseLevel;
        appendRows(table.rows, rows, k, fallback ? &neededAt[k + 1] : nullptr, k + 1 == levels ? &drawOf : nullptr);
        if (fallback) requireEveryNeededRow(table.rows.levels.back(), neededAt[k + 1], k);
    }
}

namespace {

// The finest faces over drawing positions, sorted (counting sort, stable) by their first drawn
// corner. The corners are mapped in one pass in face order (in parallel); the sort then moves
// each face once.
Faces facesInDrawingOrder(const Faces& finest, const std::vector<std::uint32_t>& drawOf, std::uint32_t refinedCount) {
    const Index faceCount = finest.faceCount();
    std::vector<Index> mapped(finest.verts.size());
    std::vector<std::uint32_t> firstDrawn(faceCount);
#pragma omp parallel for schedule(static) if (faceCount > 65536)
    for (std::ptrdiff_t f = 0; f < std::ptrdiff_t(faceCount); ++f) {
        std::uint32_t first = kNone;
        for (Index h = finest.offsets[std::size_t(f)]; h < finest.offsets[std::size_t(f) + 1]; ++h)
            first = std::min(first, mapped[h] = drawOf[finest.verts[h]]);
        firstDrawn[std::size_t(f)] = first;
    }
    // Per first drawn corner: where its faces and their corners start.
    std::vector<Index> faceStart(std::size_t(refinedCount) + 1, 0), cornerStart(faceStart);
    for (Index f = 0; f < faceCount; ++f) {
        ++faceStart[firstDrawn[f] + 1];
        cornerStart[firstDrawn[f] + 1] += finest.faceSize(f);
    }
    for (std::size_t p = 0; p < refinedCount; ++p) {
        faceStart[p + 1] += faceStart[p];
        cornerStart[p + 1] += cornerStart[p];
    }
    Faces faces;
    faces.vertexCount = finest.vertexCount;
    faces.verts.resize(finest.verts.size());
    faces.offsets.resize(std::size_t(faceCount) + 1);
    for (Index f = 0; f < faceCount; ++f) {
        const std::uint32_t key = firstDrawn[f];
        std::copy(mapped.begin() + finest.offsets[f], mapped.begin() + finest.offsets[f + 1],
                  faces.verts.begin() + cornerStart[key]);
        cornerStart[key] += finest.faceSize(f);
        faces.offsets[++faceStart[key]] = cornerStart[key];
    }
    return faces;
}

}  // namespace

void setTiledSurface(TiledTable& table, const Faces& finest, const std::vector<std::uint32_t>& drawOf) {
    // The sort's arrays are freed before the surface's are made (beside the levels' renumbering
    // the cow's lean build at 7 steps peaked at 265 MB with them alive, 243 MB without).
    table.surface = buildSurfaceTable(facesInDrawingOrder(finest, drawOf, table.refinedCount));
}

void setTiledSurfaceFromTiles(TiledTable& table, TileFaces&& tileFaces) {
    const std::uint32_t count = table.refinedCount;
    const std::size_t faceCount = tileFaces.order.size();
    if (table.fallbackBegin != count || tileFaces.corners.size() != 4 * faceCount)
        throw std::logic_error("setTiledSurfaceFromTiles: the tiles do not cover the finest level");
    // As facesInDrawingOrder: by first drawn corner, and among faces of the same, in refine's
    // order (a counting sort, then the few faces of each first corner by their order).
    const auto firstDrawn = [&](std::size_t f) {
        const Index* q = &tileFaces.corners[4 * f];
        return std::min(std::min(q[0], q[1]), std::min(q[2], q[3]));
    };
    std::vector<Index> faceStart(std::size_t(count) + 2, 0);
    for (std::size_t f = 0; f < faceCount; ++f) ++faceStart[firstDrawn(f) + 2];
    for (std::size_t p = 0; p < count; ++p) faceStart[p + 2] += faceStart[p + 1];
    std::vector<Index> sorted(faceCount);
    for (std::size_t f = 0; f < faceCount; ++f) sorted[faceStart[firstDrawn(f) + 1]++] = Index(f);
    // Each first corner's faces (at most a few) by refine's order: an insertion sort.
    for (std::size_t p = 0; p < count; ++p)
        for (Index i = faceStart[p] + 1; i < faceStart[p + 1]; ++i)
            for (Index j = i; j > faceStart[p] && tileFaces.order[sorted[j]] < tileFaces.order[sorted[j - 1]]; --j)
                std::swap(sorted[j], sorted[j - 1]);
    faceStart = {};
    tileFaces.order = {};
    std::vector<Index> verts(4 * faceCount), offsets(faceCount + 1);
    for (std::size_t i = 0; i < faceCount; ++i) {
        std::copy_n(&tileFaces.corners[4 * std::size_t(sorted[i])], 4, &verts[4 * i]);
        offsets[i + 1] = Index(4 * (i + 1));
    }
    tileFaces = {};
    sorted = {};
    Faces faces;
    faces.vertexCount = count;
    faces.verts = std::move(verts);
    faces.offsets = std::move(offsets);
    table.surface = buildSurfaceTable(std::move(faces));
}

void orderByWalkAndSetSurface(TiledTable& table, std::vector<std::uint32_t>& drawOf, const Faces& finest, bool alongside) {
    // drawOf is final once the finest points are renumbered. The two below write different
    // members of `table` and read nothing the other writes. Side by side the cow's lean build at
    // 7 steps (1.1M faces, no tile) took about 25 ms (9%) less on two threads.
    std::vector<std::uint32_t> position = orderFinestByWalk(table, drawOf, walkFallback(table, drawOf, finest));
    sideBySide(alongside && !position.empty() && mostlyFallback(table), [&] { orderLevelsByWalk(table, std::move(position)); },
               [&] { setTiledSurface(table, finest, drawOf); });
}

TiledTable buildTiledTable(const PerLevelTable& perLevel, const Level& base, const Level& coarse, bool coarseSplits,
                           const Faces& finest, TiledPlan plan) {
    if (plan.doubleSteps > 3 || plan.baseLevel + 2 * plan.doubleSteps != perLevel.levels.size())
        throw std::invalid_argument("buildTiledTable: the plan does not fit the per-level table");
    // The walk order follows each level's rows as the rules built them (a vertex row's sources
    // in the parent level).
    for (const RowGroup& g : perLevel.groups)
        if (readsOwnLevel(g.kind))
            throw std::invalid_argument("buildTiledTable: the table's vertex rows read face points "
                                        "(vertexRowsFromFacePoints); build the tiled form first, then rewrite each");
    TiledTable table;
    table.controlCount = perLevel.controlCount;
    table.baseLevel = plan.baseLevel;
    table.doubleSteps = plan.doubleSteps;
    if (plan.doubleSteps > 0) {
        // The levels must be the table's: B and N - 2 by their vertex counts, the split flag by
        // the count of level N - 1 it implies.
        const StencilLevel& coarseStep = perLevel.levels[perLevel.levels.size() - 2];
        if (base.faces.vertexCount != perLevel.levels[plan.baseLevel].sourceCount ||
            coarse.faces.vertexCount != coarseStep.sourceCount ||
            FinestNames(coarse, coarseSplits).middleVertices != coarseStep.destinationCount ||
            finest.vertexCount != perLevel.refinedCount())
            throw std::invalid_argument("buildTiledTable: the levels given are not the per-level table's B, N - 2 and N");
    }
    std::vector<std::uint32_t> drawOf =
        placeTiles(table, chooseTileBlocks(base, plan), &coarse, coarseSplits, perLevel.refinedCount());
    keepFallbackRows(table, perLevel, drawOf);
    orderByWalkAndSetSurface(table, drawOf, finest, false);  // beside the per-level table
    return table;
}

void setTiledFaceVaryingFaces(TiledTable& tiled, const FaceVaryingTable& channel) {
    const std::uint32_t count = tiled.refinedCount;
    if (tiled.canonical.size() != count)
        throw std::invalid_argument("setTiledFaceVaryingFaces: the tiled table has no drawing order");
    std::vector<std::uint32_t> drawOf(count);
    for (std::uint32_t p = 0; p < count; ++p) drawOf[tiled.canonical[p]] = p;
    const std::size_t faceCount = channel.faceOffsets.size() - 1;
    // Counting sort (stable) of the faces by their first drawn corner, as tiled.surface's.
    std::vector<std::uint32_t> firstDrawn(faceCount), start(std::size_t(count) + 1, 0);
    for (std::size_t f = 0; f < faceCount; ++f) {
        std::uint32_t first = kNone;
        for (std::uint32_t c = channel.faceOffsets[f]; c < channel.faceOffsets[f + 1]; ++c) {
            if (channel.faceVerts[c] >= count)
                throw std::invalid_argument("setTiledFaceVaryingFaces: face " + std::to_string(f) + " names vertex " +
                                            std::to_string(channel.faceVerts[c]) + " of " + std::to_string(count));
            first = std::min(first, drawOf[channel.faceVerts[c]]);
        }
        if (first == kNone) throw std::invalid_argument("setTiledFaceVaryingFaces: face " + std::to_string(f) + " is empty");
        firstDrawn[f] = first;
        ++start[first + 1];
    }
    for (std::size_t p = 0; p < count; ++p) start[p + 1] += start[p];
    std::vector<std::uint32_t> order(faceCount);
    for (std::size_t f = 0; f < faceCount; ++f) order[start[firstDrawn[f]]++] = std::uint32_t(f);
    tiled.uvFaceOffsets.assign(1, 0);
    tiled.uvFaceOffsets.reserve(faceCount + 1);
    tiled.uvFaceVerts.clear();
    tiled.uvFaceValues.clear();
    tiled.uvFaceVerts.reserve(channel.faceVerts.size());
    tiled.uvFaceValues.reserve(channel.faceValues.size());
    for (std::uint32_t f : order) {
        for (std::uint32_t c = channel.faceOffsets[f]; c < channel.faceOffsets[f + 1]; ++c) {
            tiled.uvFaceVerts.push_back(drawOf[channel.faceVerts[c]]);
            tiled.uvFaceValues.push_back(channel.faceValues[c]);
        }
        tiled.uvFaceOffsets.push_back(std::uint32_t(tiled.uvFaceVerts.size()));
    }
}

TiledTable buildTiledTable(const Hierarchy& hierarchy, const PerLevelTable& perLevel, TileSides sides) {
    TiledPlan plan = planTiled(hierarchy.levels.size() - 1, hierarchy.preprocessed,
                               hierarchy.levels[hierarchy.preprocessed && hierarchy.levels.size() > 1 ? 1 : 0]);
    plan.sides = sides;
    const std::size_t coarse = hierarchy.levels.size() >= 3 ? hierarchy.levels.size() - 3 : 0;
    return buildTiledTable(perLevel, hierarchy.levels[plan.baseLevel], hierarchy.levels[coarse],
                           hierarchy.splitsBoundary(coarse + 1), hierarchy.finest().faces, plan);
}

}  // namespace psub
