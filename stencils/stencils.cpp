// Builds the per-level kind-coded table, the factorized table and the surface table.
#include "psub/stencils.h"

#include "psub/rules.h"
#include "step_rows.h"
#include "tiled_build.h"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <exception>
#include <map>
#include <stdexcept>
#include <tuple>

namespace psub {
namespace {

using GroupKey = std::tuple<RowKind, std::uint32_t, std::uint32_t>;

RowGroup makeGroup(RowKind kind, std::uint32_t n, std::uint32_t m, Rules rules) {
    RowGroup g{kind, n, m, 1 + n + m, 0, 0, 0, 1.0, 0.0, 0.0};
    switch (kind) {
    case RowKind::FaceQuad:
    case RowKind::FaceTriangle:
    case RowKind::FacePolygon:
    case RowKind::VertexFromFacePoints: g.centre = g.edge = 1.0 / g.width; break;
    case RowKind::Retained: break;
    case RowKind::BoundaryVertex: std::tie(g.centre, g.edge) = std::tuple(0.75, 0.125); break;
    case RowKind::BoundaryEdge: g.centre = g.edge = 0.5; break;
    case RowKind::VertexQuad: {
        const VertexWeights w = quadVertexWeights(n, rules);
        std::tie(g.centre, g.edge, g.diagonal) = std::tuple(w.centre, w.edge, w.diagonal);
        break;
    }
    case RowKind::VertexFromCentreAndFacePoints: {  // psub/tables.h: c - n e, 4 e
        const VertexWeights w = quadVertexWeights(n, rules);
        std::tie(g.centre, g.edge, g.diagonal) = std::tuple(w.centre - n * w.diagonal, 4 * w.diagonal, 0.0);
        break;
    }
    case RowKind::VertexMixed: {
        const VertexWeights w = mixedVertexWeights(n, m);
        std::tie(g.centre, g.edge, g.diagonal) = std::tuple(w.centre, w.edge, w.diagonal);
        break;
    }
    case RowKind::VertexCorner: {
        const VertexWeights w = shapeCornerRule().centre;
        std::tie(g.centre, g.edge, g.diagonal) = std::tuple(w.centre, w.edge, w.diagonal);
        break;
    }
    case RowKind::FaceBesideCorner: {
        const double alpha = shapeCornerRule().faceCorner, other = (1 - alpha) / 3;
        const double sum = (n + 1) * alpha + m * other;  // k = n + 1 corners, m others
        g.centre = g.edge = alpha / sum;
        g.diagonal = other / sum;
        break;
    }
    case RowKind::VertexBesideCorner: {
        // A corner beside the vertex leaves its row (beta = 0) and its 1/8 goes to the centre.
        if (shapeCornerRule().neighbour != 0)
            throw std::logic_error("VertexBesideCorner rows carry beta = 0 only");
        g.centre = 0.25 + (4 - n) * 0.125;
        g.edge = 0.125;
        g.diagonal = 0.0625;
        break;
    }
    }
    return g;
}

// The rows of one step (parent level -> child level): each child vertex's kind and shape, and
// its sources written in place. Old vertex v gives row v, face f gives row oldVertices + f,
// and, when the step splits the boundary, boundary edge i gives row oldVertices + faces + i.
// `paired` retains every old vertex (the paired method; a face-varying channel's "all"); a
// face marked in `seamFaces` (a face-varying seam triangle) gets the midpoint of its first two
// corners (docs/face-varying.md). Under Rules::Shape, the parent's input corners (psub/rules.h's
// CornerRule) change their own rows, the rows of the quads around them and those of their
// regular neighbours.
struct StepRows {
    const Faces& faces;
    const Connectivity& c;
    bool paired;
    bool splitBoundary;
    std::span<const std::uint8_t> seamFaces;
    std::vector<Index> boundaryHalfedges;  // split steps: per boundary edge, in edge order
    std::vector<char> corner;              // per parent vertex; empty when there are none

    StepRows(const Faces& f, const Connectivity& connectivity, bool isPaired, bool split,
             std::span<const std::uint8_t> seams, std::span<const char> inputCorners)
        : faces(f), c(connectivity), paired(isPaired), splitBoundary(split), seamFaces(seams) {
        if (!paired && std::find(inputCorners.begin(), inputCorners.end(), 1) != inputCorners.end()) {
            corner.resize(faces.vertexCount);
            for (Index v = 0; v < inputCorners.size() && v < faces.vertexCount; ++v)
                corner[v] = inputCorners[v] && cornerShaped(faces, c, v);
        }
        if (!split) return;
        boundaryHalfedges.reserve(c.boundaryEdgeCount);
        for (Index h : c.edgeHalfedge)
            if (c.twin[h] == kNoIndex) boundaryHalfedges.push_back(h);
    }

    std::uint32_t oldVertices() const { return faces.vertexCount; }
    std::uint32_t firstEdgePoint() const { return faces.vertexCount + faces.faceCount(); }
    std::uint32_t childCount() const { return firstEdgePoint() + std::uint32_t(boundaryHalfedges.size()); }
    bool curveVertex(std::uint32_t d) const { return splitBoundary && c.kind[d] == VertexKind::Boundary; }
    bool seamPoint(std::uint32_t d) const {
        return d >= oldVertices() && !seamFaces.empty() && seamFaces[d - oldVertices()] != 0;
    }

    bool isCorner(Index v) const { return !corner.empty() && corner[v]; }
    std::uint32_t cornersOfQuad(std::uint32_t f) const {
        std::uint32_t k = 0;
        if (!corner.empty() && faces.faceSize(f) == 4)
            for (Index v : faces.face(f)) k += corner[v] ? 1 : 0;
        return k == 4 ? 0 : k;  // four: equal weights, the paper's row
    }
    std::uint32_t cornerNeighbours(Index v) const {
        std::uint32_t j = 0;
        if (!corner.empty())
            for (Index h : c.outgoingOf(v)) j += corner[faces.verts[c.next[h]]] ? 1 : 0;
        return j;
    }

    GroupKey shape(std::uint32_t d) const {
        if (d >= firstEdgePoint() || seamPoint(d)) return {RowKind::BoundaryEdge, 1, 0};
        if (d >= oldVertices()) {
            if (const std::uint32_t k = cornersOfQuad(d - oldVertices()); k > 0)
                return {RowKind::FaceBesideCorner, k - 1, 4 - k};
            const std::uint32_t size = faces.faceSize(d - oldVertices());
            return {size == 4 ? RowKind::FaceQuad : size == 3 ? RowKind::FaceTriangle : RowKind::FacePolygon,
                    size - 1, 0};
        }
        if (curveVertex(d)) return {RowKind::BoundaryVertex, 2, 0};
        if (paired || isRetained(c.kind[d])) return {RowKind::Retained, 0, 0};
        std::uint32_t quads = 0, triangles = 0;
        for (Index h : c.outgoingOf(d)) ++(faces.faceSize(c.faceOf[h]) == 4 ? quads : triangles);
        const std::uint32_t n = quads + triangles;
        if (triangles != 0) return {RowKind::VertexMixed, n, quads};
        if (isCorner(d)) return {RowKind::VertexCorner, n, n};
        if (const std::uint32_t j = n == 4 ? cornerNeighbours(d) : 0; j > 0) return {RowKind::VertexBesideCorner, n - j, n};
        return {RowKind::VertexQuad, n, n};
    }

    // Sources of row d: the centre, its n edge neighbours, its m diagonals (docs/scheme.md's Pi, Pj);
    // a boundary curve vertex: itself, then its boundary neighbours; an edge point: its ends.
    void sources(std::uint32_t d, std::uint32_t* out) const {
        if (d >= firstEdgePoint()) {
            const Index h = boundaryHalfedges[d - firstEdgePoint()];
            *out++ = faces.verts[h];
            *out++ = faces.verts[c.next[h]];
            return;
        }
        if (seamPoint(d)) {
            *out++ = faces.verts[faces.offsets[d - oldVertices()]];
            *out++ = faces.verts[faces.offsets[d - oldVertices()] + 1];
            return;
        }
        if (d >= oldVertices()) {
            const std::uint32_t f = d - oldVertices();
            if (cornersOfQuad(f) > 0) {  // the input corners first
                for (Index v : faces.face(f))
                    if (corner[v]) *out++ = v;
                for (Index v : faces.face(f))
                    if (!corner[v]) *out++ = v;
                return;
            }
            for (Index v : faces.face(f)) *out++ = v;
            return;
        }
        *out++ = d;
        if (curveVertex(d)) {
            const BoundaryNeighbours around = boundaryNeighbours(faces, c, d);
            *out++ = around.previous;
            *out++ = around.next;
            return;
        }
        if (paired || isRetained(c.kind[d])) return;
        // Beside an input corner (VertexBesideCorner), the corner leaves the row.
        const bool beside = !corner.empty() && std::get<0>(shape(d)) == RowKind::VertexBesideCorner;
        for (Index h : c.outgoingOf(d))
            if (!beside || !corner[faces.verts[c.next[h]]]) *out++ = faces.verts[c.next[h]];
        for (Index h : c.outgoingOf(d))
            if (faces.faceSize(c.faceOf[h]) == 4) *out++ = faces.verts[c.next[c.next[h]]];
    }
};

}  // namespace

// Appends one step's rows to `table`, grouped by (kind, n, m), each group in destination order.
// The child vertices are cut into runs, one per thread: each run finds its rows' shapes and
// counts them per group; the counts give each run its place in every group, where it then
// writes its rows. The table is the same whatever the number of runs.
void appendStepRows(PerLevelTable& table, const Faces& faces, const Connectivity& connectivity, bool paired,
                    bool splitBoundary, std::span<const std::uint8_t> seamFaces, Rules rules,
                    std::span<const char> inputCorners, std::span<const std::uint8_t> keep) {
    const StepRows step(faces, connectivity, paired, splitBoundary, seamFaces, inputCorners);
    const std::uint32_t childCount = step.childCount();
    if (!keep.empty() && keep.size() != childCount) throw std::invalid_argument("appendStepRows: keep has the wrong size");
    const auto made = [&](std::uint32_t d) { return keep.empty() || keep[d] != 0; };
    constexpr std::uint32_t kRowsPerRun = 32768;
    const int runs = int(std::clamp<std::uint32_t>(childCount / kRowsPerRun, 1, std::uint32_t(omp_get_max_threads())));
    const auto runBegin = [&](int r) { return std::uint32_t(std::uint64_t(childCount) * std::uint32_t(r) / std::uint32_t(runs)); };
    struct Run {
        std::map<GroupKey, std::uint32_t> firstMet;  // the run's groups, numbered as first met
        std::vector<std::uint64_t> rows;             // per group of the run: its rows there
        std::vector<std::size_t> group;              // per group of the run: its index in table.groups
        std::vector<std::uint64_t> next;             // per group of the run: the next row it writes
    };
    std::vector<Run> run(std::size_t(runs), Run{});
    std::vector<std::uint32_t> groupOfRow(childCount);  // the group's number in its run

    // Pass 1: the shape of every row, with a one-entry cache since neighbouring rows mostly
    // share a shape. (A failed allocation here leaves the threads as an exception, not a crash.)
    std::exception_ptr failure;
#pragma omp parallel for num_threads(runs) schedule(static, 1)
    for (int r = 0; r < runs; ++r) {
        try {
            Run& mine = run[std::size_t(r)];
            GroupKey lastKey{RowKind::Retained, ~0u, ~0u};
            std::uint32_t lastGroup = 0;
            for (std::uint32_t d = runBegin(r), end = runBegin(r + 1); d < end; ++d) {
                if (!made(d)) continue;
                const GroupKey key = step.shape(d);
                if (key != lastKey) {
                    const auto [it, inserted] = mine.firstMet.try_emplace(key, std::uint32_t(mine.rows.size()));
                    if (inserted) mine.rows.push_back(0);
                    lastKey = key;
                    lastGroup = it->second;
                }
                groupOfRow[d] = lastGroup;
                ++mine.rows[lastGroup];
            }
        } catch (...) {
#pragma omp critical(psub_step_rows)
            failure = std::current_exception();
        }
    }
    if (failure) std::rethrow_exception(failure);

    // Groups in (kind, n, m) order, laid out after what the table holds; in each group the
    // runs' rows follow one another in run order.
    std::map<GroupKey, std::uint64_t> rowsOfKey;
    for (const Run& r : run)
        for (const auto& [key, group] : r.firstMet) rowsOfKey[key] += r.rows[group];
    StencilLevel level{step.oldVertices(), childCount, table.groups.size(), 0, table.destinations.size(), 0};
    std::map<GroupKey, std::size_t> groupOfKey;
    std::uint64_t rowBegin = table.destinations.size(), indexBegin = table.indices.size();
    for (const auto& [key, count] : rowsOfKey) {
        RowGroup g = makeGroup(std::get<0>(key), std::get<1>(key), std::get<2>(key), rules);
        g.rowBegin = rowBegin;
        g.rowCount = count;
        g.indexBegin = indexBegin;
        rowBegin += g.rowCount;
        indexBegin += g.rowCount * g.width;
        groupOfKey[key] = table.groups.size();
        table.groups.push_back(g);
    }
    level.groupEnd = table.groups.size();
    level.rowEnd = rowBegin;
    std::map<GroupKey, std::uint64_t> placed;  // per group: the rows of earlier runs
    for (Run& r : run) {
        r.group.resize(r.rows.size());
        r.next.resize(r.rows.size());
        for (const auto& [key, group] : r.firstMet) {
            r.group[group] = groupOfKey[key];
            r.next[group] = table.groups[r.group[group]].rowBegin + placed[key];
            placed[key] += r.rows[group];
        }
    }

    // Pass 2: every row's destination and sources, written in place.
    table.destinations.resize(rowBegin);
    table.indices.resize(indexBegin);
#pragma omp parallel for num_threads(runs) schedule(static, 1)
    for (int r = 0; r < runs; ++r) {
        Run& mine = run[std::size_t(r)];
        for (std::uint32_t d = runBegin(r), end = runBegin(r + 1); d < end; ++d) {
            if (!made(d)) continue;
            const std::uint32_t group = groupOfRow[d];
            const RowGroup& g = table.groups[mine.group[group]];
            const std::uint64_t row = mine.next[group]++;
            table.destinations[row] = d;
            step.sources(d, &table.indices[g.indexBegin + (row - g.rowBegin) * g.width]);
        }
    }
    table.levels.push_back(level);
}

namespace {

void appendLevel(PerLevelTable& table, const Level& parent, bool paired, bool splitBoundary, Rules rules,
                 std::span<const char> inputCorners) {
    appendStepRows(table, parent.faces, parent.connectivity, paired, splitBoundary, {}, rules, inputCorners);
}

// Room for the rows of steps firstStep..lastStep, from the counts of level firstStep - 1, so
// that the table's arrays are allocated once instead of growing (and being copied) at every
// level. A row's sources are its centre, its edge neighbours and its diagonals (1 + 2 valence
// at most, summing to at most V + 4E), a face point's corners (2E in all), a boundary row's two
// or three; a hint only: an estimate that falls short just lets the arrays grow.
void reserveRows(PerLevelTable& table, Counts parent, int firstStep, int lastStep, Boundary boundary, bool preprocessed) {
    std::uint64_t rows = 0, indices = 0;
    for (int k = firstStep; k <= lastStep; ++k) {
        const Counts child = countsAfterStep(parent, splitsBoundary(boundary, k - (preprocessed ? 1 : 0)));
        rows += child.vertices;
        indices += parent.vertices + 6 * parent.edges + 3 * parent.boundaryEdges;
        parent = child;
    }
    try {
        table.destinations.reserve(table.destinations.size() + rows);
        table.indices.reserve(table.indices.size() + indices);
    } catch (const std::exception&) {  // too large to reserve: the steps will say so, or fit as they grow
    }
}

}  // namespace

PerLevelTable buildPerLevelTable(const Hierarchy& hierarchy, Rules rules) {
    PerLevelTable table;
    table.controlCount = hierarchy.levels.front().faces.vertexCount;
    const std::vector<char> corners = inputCorners(hierarchy.levels.front().faces, hierarchy.levels.front().connectivity, rules);
    for (std::size_t k = 1; k < hierarchy.levels.size(); ++k)
        appendLevel(table, hierarchy.levels[k - 1], hierarchy.preprocessed && k == 1,
                    hierarchy.splitsBoundary(k), rules, corners);
    return table;
}

namespace {

// Sparse rows in compressed form, weights in double while composing.
struct SparseRows {
    std::vector<std::uint64_t> offsets{0};
    std::vector<std::uint32_t> indices;
    std::vector<double> weights;
};

// Destinations [first, last) of one level composed with the rows that map control points to the
// parent level: each child row is the weighted sum of its sources' rows, merged in a dense
// accumulator and emitted with indices ascending.
SparseRows composeRows(const PerLevelTable& table, const std::vector<std::uint32_t>& groupOf, const std::vector<std::uint64_t>& rowOf,
                       const SparseRows& parent, std::uint32_t first, std::uint32_t last) {
    SparseRows out;
    out.offsets.reserve(std::size_t(last - first) + 1);
    std::vector<double> accumulator(table.controlCount, 0.0);
    std::vector<std::uint32_t> seenBy(table.controlCount, ~0u);  // the row that last touched it
    std::vector<std::uint32_t> touched;
    for (std::uint32_t d = first; d < last; ++d) {
        const RowGroup& g = table.groups[groupOf[d]];
        const std::uint32_t* sources = &table.indices[g.indexBegin + (rowOf[d] - g.rowBegin) * g.width];
        for (std::uint32_t j = 0; j < g.width; ++j) {
            const double w = j == 0 ? g.centre : j <= g.n ? g.edge : g.diagonal;
            for (std::uint64_t e = parent.offsets[sources[j]]; e < parent.offsets[sources[j] + 1]; ++e) {
                const std::uint32_t i = parent.indices[e];
                if (seenBy[i] != d) {
                    seenBy[i] = d;
                    accumulator[i] = 0.0;
                    touched.push_back(i);
                }
                accumulator[i] += w * parent.weights[e];
            }
        }
        std::sort(touched.begin(), touched.end());
        for (std::uint32_t i : touched) {
            out.indices.push_back(i);
            out.weights.push_back(accumulator[i]);
        }
        touched.clear();
        out.offsets.push_back(out.indices.size());
    }
    return out;
}

}  // namespace

FactorizedTable buildFactorizedTable(const PerLevelTable& perLevel) {
    for (const RowGroup& g : perLevel.groups)
        if (readsOwnLevel(g.kind))
            throw std::invalid_argument("buildFactorizedTable: the table's vertex rows read face points "
                                        "(vertexRowsFromFacePoints); compose the table as the rules built it");
    const std::uint32_t controls = perLevel.controlCount;
    SparseRows current;  // control -> current level; the identity to begin with
    current.offsets.resize(std::size_t(controls) + 1);
    for (std::uint32_t v = 0; v <= controls; ++v) current.offsets[v] = v;
    for (std::uint32_t v = 0; v < controls; ++v) current.indices.push_back(v);
    current.weights.assign(controls, 1.0);

    for (const StencilLevel& level : perLevel.levels) {
        std::vector<std::uint32_t> groupOf(level.destinationCount);
        std::vector<std::uint64_t> rowOf(level.destinationCount);
        for (std::uint64_t g = level.groupBegin; g < level.groupEnd; ++g)
            for (std::uint64_t r = perLevel.groups[g].rowBegin; r < perLevel.groups[g].rowBegin + perLevel.groups[g].rowCount; ++r) {
                groupOf[perLevel.destinations[r]] = std::uint32_t(g);
                rowOf[perLevel.destinations[r]] = r;
            }
        // Contiguous slices of destinations, one per thread, joined in order.
        const int slices = level.destinationCount > 20000 ? omp_get_max_threads() : 1;
        std::vector<SparseRows> parts(static_cast<std::size_t>(slices));
#pragma omp parallel for num_threads(slices) schedule(static, 1)
        for (int t = 0; t < slices; ++t)
            parts[std::size_t(t)] = composeRows(perLevel, groupOf, rowOf, current,
                                               std::uint32_t(std::uint64_t(level.destinationCount) * std::uint64_t(t) / std::uint64_t(slices)),
                                               std::uint32_t(std::uint64_t(level.destinationCount) * std::uint64_t(t + 1) / std::uint64_t(slices)));
        SparseRows next = std::move(parts[0]);
        for (std::size_t t = 1; t < parts.size(); ++t) {
            const std::uint64_t base = next.indices.size();
            for (std::size_t r = 1; r < parts[t].offsets.size(); ++r) next.offsets.push_back(base + parts[t].offsets[r]);
            next.indices.insert(next.indices.end(), parts[t].indices.begin(), parts[t].indices.end());
            next.weights.insert(next.weights.end(), parts[t].weights.begin(), parts[t].weights.end());
        }
        current = std::move(next);
    }
    FactorizedTable table;
    table.controlCount = controls;
    table.offsets = std::move(current.offsets);
    table.indices = std::move(current.indices);
    table.weights.assign(current.weights.begin(), current.weights.end());
    return table;
}

SurfaceTable buildSurfaceTable(Faces finest) {
    SurfaceTable surface;
    surface.vertexCount = finest.vertexCount;
    surface.vertexOffsets.assign(std::size_t(finest.vertexCount) + 1, 0);
    for (Index v : finest.verts) ++surface.vertexOffsets[v + 1];
    for (Index v = 0; v < finest.vertexCount; ++v) surface.vertexOffsets[v + 1] += surface.vertexOffsets[v];
    surface.vertexFaces.resize(finest.verts.size());
    std::vector<std::uint32_t> fill(surface.vertexOffsets.begin(), surface.vertexOffsets.end() - 1);
    for (Index f = 0; f < finest.faceCount(); ++f)
        for (Index v : finest.face(f)) surface.vertexFaces[fill[v]++] = f;
    surface.faceOffsets = std::move(finest.offsets);
    surface.faceVerts = std::move(finest.verts);
    return surface;
}

}  // namespace psub

namespace psub {

Refinement refine(const Mesh& mesh, const Connectivity& connectivity, const RefineOptions& options) {
    using Clock = std::chrono::steady_clock;
    const auto ms = [](Clock::time_point start) {
        return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
    };
    Refinement out;
    out.levels = options.levels;
    out.preprocessed = needsPreprocessing(mesh.faces, connectivity, options.preprocess, mesh.source);
    // Level by level, keeping only the parent's topology: each step's table is built as soon
    // as its parent exists, and the parent is dropped (the peak is two levels, not all).
    out.perLevel.controlCount = mesh.faces.vertexCount;
    Level parent{mesh.faces, connectivity};
    const std::vector<char> corners = inputCorners(mesh.faces, connectivity, options.rules);
    const int steps = options.levels + (out.preprocessed ? 1 : 0);
    // The tiled form: its plan once the first quad level exists, its blocks chosen on level B,
    // its tiles placed while level N - 2 (where their lattices are walked) is the parent, before
    // it is refined (and consumed). Without the per-level table (the lean build) its own rows
    // are made here: levels up to B whole, then only those its fallback can need (labels,
    // docs/tiled.md), the last level's only for the fallback's points.
    const bool lean = options.tiled && !options.perLevel;
    if (!options.perLevel && (!options.tiled || options.factorized))
        throw std::invalid_argument("refine: only the tiled form can be built without the per-level table");
    const int firstQuadLevel = out.preprocessed && steps > 0 ? 1 : 0;
    TiledPlan plan{0, 0};
    TileBlocks blocks;
    std::vector<std::uint8_t> labels;  // the lean build's, of the current level (B and on)
    PerLevelTable leanRows;
    leanRows.controlCount = mesh.faces.vertexCount;
    std::vector<std::uint32_t> drawOf;
    // Without the per-level table and the face-varying channel, tiles that cover the whole mesh
    // give the finest faces themselves (placeTiles): refinement then ends on level N - 2.
    TileFaces tileFaces;
    bool surfaceFromTiles = false;
    // Room for the lean build's rows of the steps known to make every row (as the per-level
    // table's): the paired step, the steps up to level B, and all of them once level B has no
    // tile. Without it the cow at 7 steps (no tile), built without huge pages, spent over half
    // its table's time growing and copying its rows (bench/README.md, "Session 23").
    int leanReservedThrough = 0;
    const auto reserveLeanRows = [&](int k) {  // parent is level k
        if (!lean || leanReservedThrough != k) return;
        int whole = int(plan.baseLevel);  // the plan is made on the first quad level
        if (k < firstQuadLevel)
            whole = firstQuadLevel;
        else if (plan.doubleSteps == 0 || (k >= whole && blocks.side.empty()))
            whole = steps;
        if (whole <= k) return;
        reserveRows(leanRows, countMesh(parent.faces, parent.connectivity), k + 1, whole, options.boundary, out.preprocessed);
        leanReservedThrough = whole;
    };
    const auto planTiles = [&](int k) {  // parent is level k
        if (!options.tiled) return;
        const auto start = Clock::now();
        if (k == firstQuadLevel) {
            plan = planTiled(std::size_t(steps), out.preprocessed, parent);
            plan.sides = options.tileSides;
            out.tiled.controlCount = mesh.faces.vertexCount;
            out.tiled.baseLevel = plan.baseLevel;
            out.tiled.doubleSteps = plan.doubleSteps;
        }
        if (k == int(plan.baseLevel) && plan.doubleSteps > 0) {
            blocks = chooseTileBlocks(parent, plan);
            if (lean && !blocks.side.empty()) labels = baseLabels(parent, blocks);
        }
        reserveLeanRows(k);
        out.tiledMs += ms(start);
    };
    // Where the tiles are placed: on level N - 2, the parent of step N - 1 (without double
    // steps, none to walk: at the last step).
    const auto placesTiles = [&](int k) { return options.tiled && k == steps - (plan.doubleSteps > 0 ? 1 : 0); };
    // The lean build's rows of step k (parent is level k - 1).
    const auto appendLeanRows = [&](int k, bool split) {
        // Every row up to level B (when preprocessed the plan comes only after step 1) and
        // without tiles; else those whose labels are within reach of the fallback, then the
        // fallback's points.
        std::vector<std::uint8_t> keep;  // empty: every row
        const bool whole = k <= firstQuadLevel || k <= int(plan.baseLevel) || blocks.side.empty();
        if (!whole && k < steps) {
            labels = childLabels(parent, split, labels);
            const std::uint8_t bound = std::uint8_t(1 + steps - k);
            keep.resize(labels.size());
            for (std::size_t v = 0; v < labels.size(); ++v) keep[v] = labels[v] <= bound;
        } else if (!whole) {
            keep.resize(drawOf.size());
            for (std::size_t v = 0; v < drawOf.size(); ++v) keep[v] = drawOf[v] >= out.tiled.fallbackBegin;
        }
        appendStepRows(leanRows, parent.faces, parent.connectivity, out.preprocessed && k == 1, split, {}, options.rules,
                       corners, keep);
    };
    // The face-varying channel follows the positions level by level (docs/face-varying.md).
    const bool uv = !mesh.uv.empty() && options.boundary == Boundary::Paper;
    // The drawing-only build (RefineOptions::canonicalOrder false): where the blocks chosen on
    // level B (the parent, level k) cover it whole, the tiles placed there, the rest of the steps
    // only counted (their levels' sizes, no rows).
    bool drawingOnly = false;
    const auto placeOnBase = [&](int k) {
        if (!lean || options.canonicalOrder || uv || plan.doubleSteps == 0 || k != int(plan.baseLevel) || k < firstQuadLevel)
            return false;
        const auto start = Clock::now();
        Counts counts = countMesh(parent.faces, parent.connectivity);
        std::vector<Counts> after;  // levels k + 1 .. steps
        for (int step = k + 1; step <= steps; ++step)
            after.push_back(counts = countsAfterStep(counts, splitsBoundary(options.boundary, step - (out.preprocessed ? 1 : 0))));
        if (!placeTilesOnBase(out.tiled, blocks, parent, std::uint32_t(counts.vertices))) return false;
        std::uint64_t vertices = parent.faces.vertexCount;
        for (const Counts& level : after) {
            leanRows.levels.push_back({std::uint32_t(vertices), std::uint32_t(level.vertices), leanRows.groups.size(),
                                       leanRows.groups.size(), leanRows.destinations.size(), leanRows.destinations.size()});
            vertices = level.vertices;
        }
        out.tiled.rows = std::move(leanRows);
        out.tiledMs += ms(start);
        if (options.onLevel)  // the steps not taken
            for (int step = k + 1; step <= steps; ++step) options.onLevel(step, 0);
        return drawingOnly = true;
    };
    planTiles(0);
    FaceVaryingLevel uvLevel;
    std::vector<char> uvCorners;  // Rules::Shape's input corners of the channel's own mesh
    if (uv) {
        const auto start = Clock::now();
        out.uv.width = mesh.uv.width;
        out.uv.perLevel.controlCount = mesh.uv.valueCount();
        uvLevel = faceVaryingBase(mesh, connectivity);
        uvCorners = inputCorners(uvLevel.faces, uvLevel.connectivity, options.rules);
        out.uvMs += ms(start);
    }
    if (options.perLevel)
        reserveRows(out.perLevel, countMesh(mesh.faces, connectivity), 1, steps, options.boundary, out.preprocessed);
    for (int k = 1; k <= steps && !placeOnBase(k - 1); ++k) {
        auto start = Clock::now();
        const bool split = splitsBoundary(options.boundary, k - (out.preprocessed ? 1 : 0));
        if (uv) {
            appendFaceVaryingLevel(out.uv.perLevel, uvLevel, out.preprocessed && k == 1, options.uvLinear, options.rules,
                                   uvCorners);
            uvLevel = refineFaceVarying(uvLevel, parent);
            out.uvMs += ms(start);
            start = Clock::now();
        }
        if (options.perLevel) {
            appendLevel(out.perLevel, parent, out.preprocessed && k == 1, split, options.rules, corners);
            out.perLevelMs += ms(start);
        }
        if (placesTiles(k)) {
            start = Clock::now();
            const Counts middle = countsAfterStep(countMesh(parent.faces, parent.connectivity), split);
            const Counts finest =
                k < steps ? countsAfterStep(middle, splitsBoundary(options.boundary, steps - (out.preprocessed ? 1 : 0))) : middle;
            // Only where every face of level B is a tile's (then every finest face is).
            const bool facesFromTiles = lean && !uv && plan.doubleSteps > 0 && !blocks.side.empty() &&
                                        std::find(blocks.covered.begin(), blocks.covered.end(), 0) == blocks.covered.end();
            drawOf = placeTiles(out.tiled, blocks, plan.doubleSteps > 0 ? &parent : nullptr, split, Index(finest.vertices),
                                facesFromTiles ? &tileFaces : nullptr);
            if (facesFromTiles && out.tiled.fallbackBegin == out.tiled.refinedCount && tileFaces.order.size() == finest.faces) {
                // Every finest point a tile's: no row after level B is needed, and the surface
                // is the tiles' faces. The rows of the last two steps (none kept) only record the
                // levels' sizes.
                appendLeanRows(k, split);
                leanRows.levels.push_back({std::uint32_t(middle.vertices), std::uint32_t(finest.vertices),
                                           leanRows.groups.size(), leanRows.groups.size(),
                                           leanRows.destinations.size(), leanRows.destinations.size()});
                parent = Level{};  // level N - 2: its topology is not needed any more (the peak)
                setTiledSurfaceFromTiles(out.tiled, std::move(tileFaces));
                surfaceFromTiles = true;
                out.tiledMs += ms(start);
                if (options.onLevel) {  // the two steps not taken
                    options.onLevel(k, 0);
                    options.onLevel(k + 1, 0);
                }
                break;
            }
            tileFaces = {};
            out.tiledMs += ms(start);
        }
        if (lean) {
            start = Clock::now();
            appendLeanRows(k, split);
            out.tiledMs += ms(start);
        }
        start = Clock::now();
        if (k == steps && k > firstQuadLevel) {
            // The finest level: only its faces (the surface), no half-edges.
            parent.faces = refineFaces(parent.faces, parent.connectivity, split);
            parent.connectivity = {};
        } else {
            parent = refineLevel(std::move(parent), split);  // frees the parent while the child grows
        }
        const double topologyMs = ms(start);
        out.topologyMs += topologyMs;
        if (options.onLevel) options.onLevel(k, topologyMs / 1e3);
        planTiles(k);
    }
    if (options.tiled && !drawingOnly) {
        const auto start = Clock::now();
        if (steps == 0) drawOf = placeTiles(out.tiled, blocks, nullptr, false, parent.faces.vertexCount);
        if (lean)
            keepFallbackRows(out.tiled, std::move(leanRows), drawOf);
        else
            keepFallbackRows(out.tiled, out.perLevel, drawOf);
        if (!surfaceFromTiles) orderByWalkAndSetSurface(out.tiled, drawOf, parent.faces, lean);
        out.tiledMs += ms(start);
    }
    parent.connectivity = {};
    if (uv) setFaceVaryingFaces(out.uv, uvLevel);
    if (uv && options.tiled) {
        const auto start = Clock::now();
        setTiledFaceVaryingFaces(out.tiled, out.uv);
        out.uvMs += ms(start);
    }
    auto start = Clock::now();
    if (options.perLevel) out.surface = buildSurfaceTable(std::move(parent.faces));
    out.perLevelMs += ms(start);
    if (options.factorized) {
        start = Clock::now();
        out.factorized = buildFactorizedTable(out.perLevel);
        out.factorizedMs = ms(start);
    }
    if (options.vertexRowsFromFacePoints) {
        start = Clock::now();
        if (options.perLevel) vertexRowsFromFacePoints(out.perLevel);
        out.perLevelMs += ms(start);
        start = Clock::now();
        if (options.tiled) vertexRowsFromFacePoints(out.tiled.rows);
        out.tiledMs += ms(start);
    }
    return out;
}

}  // namespace psub
