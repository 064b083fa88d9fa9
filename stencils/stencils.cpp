// Builds the per-level kind-coded table, the factorized table and the surface table.
#include "psub/stencils.h"

#include "psub/rules.h"

#include <algorithm>
#include <chrono>
#include <map>
#include <stdexcept>
#include <tuple>

namespace psub {
namespace {

// One row before grouping: its kind and shape, and its source indices.
struct Row {
    RowKind kind;
    std::uint32_t n, m;
};

using GroupKey = std::tuple<RowKind, std::uint32_t, std::uint32_t>;

RowGroup makeGroup(RowKind kind, std::uint32_t n, std::uint32_t m) {
    RowGroup g{kind, n, m, 1 + n + m, 0, 0, 0, 1.0, 0.0, 0.0};
    switch (kind) {
    case RowKind::FaceQuad:
    case RowKind::FaceTriangle:
    case RowKind::FacePolygon: g.centre = g.edge = 1.0 / g.width; break;
    case RowKind::Retained: break;
    case RowKind::VertexQuad: {
        const VertexWeights w = quadVertexWeights(n);
        std::tie(g.centre, g.edge, g.diagonal) = std::tuple(w.centre, w.edge, w.diagonal);
        break;
    }
    case RowKind::VertexMixed: {
        const VertexWeights w = mixedVertexWeights(n, m);
        std::tie(g.centre, g.edge, g.diagonal) = std::tuple(w.centre, w.edge, w.diagonal);
        break;
    }
    }
    return g;
}

// Appends the rows of one step (parent level -> child level) to `table`, grouped by shape.
void appendLevel(PerLevelTable& table, const Level& parent, bool paired) {
    const Faces& faces = parent.faces;
    const Connectivity& c = parent.connectivity;
    const std::uint32_t oldVertices = faces.vertexCount, childCount = oldVertices + faces.faceCount();

    // Each child vertex's row: shape, and its sources in a flat list (rowSources).
    std::vector<Row> rows(childCount);
    std::vector<std::uint64_t> rowStart(std::size_t(childCount) + 1, 0);
    std::vector<std::uint32_t> rowSources;
    rowSources.reserve(std::size_t(childCount) * 6);
    for (std::uint32_t v = 0; v < oldVertices; ++v) {
        rowSources.push_back(v);
        if (paired || isRetained(c.kind[v])) {
            rows[v] = {RowKind::Retained, 0, 0};
        } else {
            std::uint32_t quads = 0, triangles = 0;
            for (Index h : c.outgoingOf(v)) rowSources.push_back(faces.verts[c.next[h]]);
            for (Index h : c.outgoingOf(v)) {
                if (faces.faceSize(c.faceOf[h]) == 4) {
                    rowSources.push_back(faces.verts[c.next[c.next[h]]]);
                    ++quads;
                } else {
                    ++triangles;
                }
            }
            const std::uint32_t n = std::uint32_t(c.outgoingOf(v).size());
            rows[v] = triangles == 0 ? Row{RowKind::VertexQuad, n, n} : Row{RowKind::VertexMixed, n, quads};
        }
        rowStart[v + 1] = rowSources.size();
    }
    for (Index f = 0; f < faces.faceCount(); ++f) {
        const std::uint32_t size = faces.faceSize(f);
        const RowKind kind = size == 4 ? RowKind::FaceQuad
                             : size == 3 ? RowKind::FaceTriangle
                                         : RowKind::FacePolygon;
        rows[oldVertices + f] = {kind, size - 1, 0};
        for (Index v : faces.face(f)) rowSources.push_back(v);
        rowStart[oldVertices + f + 1] = rowSources.size();
    }

    // Group rows by (kind, n, m), each group's rows in destination order.
    std::map<GroupKey, std::uint64_t> rowsPerGroup;
    for (const Row& row : rows) ++rowsPerGroup[{row.kind, row.n, row.m}];
    StencilLevel level{oldVertices, childCount, table.groups.size(), 0,
                       table.destinations.size(), 0};
    std::map<GroupKey, std::size_t> groupOf;
    std::uint64_t rowBegin = table.destinations.size(), indexBegin = table.indices.size();
    for (const auto& [key, count] : rowsPerGroup) {
        RowGroup g = makeGroup(std::get<0>(key), std::get<1>(key), std::get<2>(key));
        g.rowBegin = rowBegin;
        g.rowCount = count;
        g.indexBegin = indexBegin;
        rowBegin += count;
        indexBegin += count * g.width;
        groupOf[key] = table.groups.size();
        table.groups.push_back(g);
    }
    level.groupEnd = table.groups.size();
    level.rowEnd = rowBegin;
    table.destinations.resize(rowBegin);
    table.indices.resize(indexBegin);
    std::vector<std::uint64_t> filled(table.groups.size() - level.groupBegin, 0);
    for (std::uint32_t d = 0; d < childCount; ++d) {
        const std::size_t gi = groupOf[{rows[d].kind, rows[d].n, rows[d].m}];
        const RowGroup& g = table.groups[gi];
        const std::uint64_t r = filled[gi - level.groupBegin]++;
        table.destinations[g.rowBegin + r] = d;
        std::copy(rowSources.begin() + std::ptrdiff_t(rowStart[d]),
                  rowSources.begin() + std::ptrdiff_t(rowStart[d + 1]),
                  table.indices.begin() + std::ptrdiff_t(g.indexBegin + r * g.width));
    }
    table.levels.push_back(level);
}

}  // namespace

PerLevelTable buildPerLevelTable(const Hierarchy& hierarchy) {
    PerLevelTable table;
    table.controlCount = hierarchy.levels.front().faces.vertexCount;
    for (std::size_t k = 1; k < hierarchy.levels.size(); ++k)
        appendLevel(table, hierarchy.levels[k - 1], hierarchy.preprocessed && k == 1);
    return table;
}

FactorizedTable buildFactorizedTable(const PerLevelTable& perLevel) {
    const std::uint32_t controls = perLevel.controlCount;
    // Current rows (control -> current level), starting with the identity.
    std::vector<std::uint64_t> offsets(std::size_t(controls) + 1);
    std::vector<std::uint32_t> indices(controls);
    std::vector<double> weights(controls, 1.0);
    for (std::uint32_t v = 0; v <= controls; ++v) offsets[v] = v;
    for (std::uint32_t v = 0; v < controls; ++v) indices[v] = v;

    std::vector<double> accumulator(controls, 0.0);
    std::vector<bool> touched(controls, false);
    std::vector<std::uint32_t> touchedList;
    for (const StencilLevel& level : perLevel.levels) {
        // Where each destination's row lives: its group and position.
        std::vector<std::pair<std::uint64_t, std::uint64_t>> rowOf(level.destinationCount);
        for (std::uint64_t gi = level.groupBegin; gi < level.groupEnd; ++gi)
            for (std::uint64_t r = 0; r < perLevel.groups[gi].rowCount; ++r)
                rowOf[perLevel.destinations[perLevel.groups[gi].rowBegin + r]] = {gi, r};
        std::vector<std::uint64_t> nextOffsets{0};
        nextOffsets.reserve(std::size_t(level.destinationCount) + 1);
        std::vector<std::uint32_t> nextIndices;
        std::vector<double> nextWeights;
        for (std::uint32_t d = 0; d < level.destinationCount; ++d) {
            const RowGroup& g = perLevel.groups[rowOf[d].first];
            const std::uint32_t* sources = &perLevel.indices[g.indexBegin + rowOf[d].second * g.width];
            for (std::uint32_t j = 0; j < g.width; ++j) {
                const double w = j == 0 ? g.centre : j <= g.n ? g.edge : g.diagonal;
                for (std::uint64_t e = offsets[sources[j]]; e < offsets[sources[j] + 1]; ++e) {
                    if (!touched[indices[e]]) {
                        touched[indices[e]] = true;
                        touchedList.push_back(indices[e]);
                    }
                    accumulator[indices[e]] += w * weights[e];
                }
            }
            std::sort(touchedList.begin(), touchedList.end());
            for (std::uint32_t i : touchedList) {
                nextIndices.push_back(i);
                nextWeights.push_back(accumulator[i]);
                accumulator[i] = 0;
                touched[i] = false;
            }
            touchedList.clear();
            nextOffsets.push_back(nextIndices.size());
        }
        offsets = std::move(nextOffsets);
        indices = std::move(nextIndices);
        weights = std::move(nextWeights);
    }
    FactorizedTable table;
    table.controlCount = controls;
    table.offsets = std::move(offsets);
    table.indices = std::move(indices);
    table.weights.assign(weights.begin(), weights.end());
    return table;
}

SurfaceTable buildSurfaceTable(const Faces& finest) {
    SurfaceTable surface;
    surface.vertexCount = finest.vertexCount;
    surface.faceOffsets = finest.offsets;
    surface.faceVerts = finest.verts;
    surface.vertexOffsets.assign(std::size_t(finest.vertexCount) + 1, 0);
    for (Index v : finest.verts) ++surface.vertexOffsets[v + 1];
    for (Index v = 0; v < finest.vertexCount; ++v) surface.vertexOffsets[v + 1] += surface.vertexOffsets[v];
    surface.vertexFaces.resize(finest.verts.size());
    std::vector<std::uint32_t> fill(surface.vertexOffsets.begin(), surface.vertexOffsets.end() - 1);
    for (Index f = 0; f < finest.faceCount(); ++f)
        for (Index v : finest.face(f)) surface.vertexFaces[fill[v]++] = f;
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
    auto start = Clock::now();
    const Hierarchy hierarchy = refineTopology(mesh.faces, connectivity, out.preprocessed,
                                               options.levels, options.onLevel);
    out.topologyMs = ms(start);
    start = Clock::now();
    out.perLevel = buildPerLevelTable(hierarchy);
    out.surface = buildSurfaceTable(hierarchy.finest().faces);
    out.perLevelMs = ms(start);
    if (options.factorized) {
        start = Clock::now();
        out.factorized = buildFactorizedTable(out.perLevel);
        out.factorizedMs = ms(start);
    }
    return out;
}

}  // namespace psub
