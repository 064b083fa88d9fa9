// vertexRowsFromFacePoints: rewrites a per-level table's regular vertex rows (valence 4, four
// face quads) to read the four new face points around the vertex instead of its nine parent
// points (docs/design.md, "Vertex points from face points"). Reads and writes the table only.
#include "psub/stencils.h"

#include <cstdint>
#include <stdexcept>
#include <vector>

namespace psub {
namespace {

// The face rows around each parent point of one level: up to 4 per point (each face point, and
// where its row's corners are in the table's indices), and how many face rows name the point.
struct FacesAround {
    std::vector<std::uint32_t> point, count;
    std::vector<std::uint64_t> corners;
};

FacesAround facesAround(const PerLevelTable& table, const StencilLevel& level) {
    const std::size_t slots = 4 * std::size_t(level.sourceCount);
    FacesAround around{std::vector<std::uint32_t>(slots), std::vector<std::uint32_t>(level.sourceCount, 0),
                       std::vector<std::uint64_t>(slots)};
    for (std::uint64_t g = level.groupBegin; g < level.groupEnd; ++g) {
        const RowGroup& group = table.groups[g];
        if (group.kind != RowKind::FaceQuad || group.centre != 0.25 || group.edge != 0.25) continue;
        for (std::uint64_t r = 0; r < group.rowCount; ++r) {
            const std::uint64_t at = group.indexBegin + r * group.width;
            for (std::uint32_t j = 0; j < 4; ++j) {
                const std::uint32_t p = table.indices[at + j];
                if (around.count[p] < 4) {
                    const std::size_t slot = 4 * std::size_t(p) + around.count[p];
                    around.point[slot] = table.destinations[group.rowBegin + r];
                    around.corners[slot] = at;
                }
                ++around.count[p];
            }
        }
    }
    return around;
}

// Whether the four face rows around P (their corners: 16 indices at `corners`) hold exactly P
// four times, each edge neighbour twice and each diagonal once, as `row` (P, 4 edge neighbours,
// 4 diagonals) names them: then the mean of the four face points is the row's 1/4 P + 1/8
// sum(edges) + 1/16 sum(diagonals). `tally` is all zeros, and is left so.
bool facesMatchRow(const PerLevelTable& table, const std::uint32_t* row, const std::uint64_t* corners,
                   std::vector<std::int32_t>& tally) {
    const auto forEachCorner = [&](auto&& visit) {
        for (int f = 0; f < 4; ++f)
            for (int j = 0; j < 4; ++j) visit(table.indices[corners[f] + std::uint64_t(j)]);
    };
    for (std::uint32_t j = 0; j < 9; ++j) tally[row[j]] -= j == 0 ? 4 : j <= 4 ? 2 : 1;
    forEachCorner([&](std::uint32_t c) { ++tally[c]; });
    bool match = true;
    for (std::uint32_t j = 0; j < 9; ++j) match = match && tally[row[j]] == 0;
    forEachCorner([&](std::uint32_t c) { tally[c] = 0; });
    for (std::uint32_t j = 0; j < 9; ++j) tally[row[j]] = 0;
    return match;
}

bool paperRegularVertex(const RowGroup& g) {
    return g.kind == RowKind::VertexQuad && g.n == 4 && g.m == 4 && g.centre == 0.25 && g.edge == 0.125 &&
           g.diagonal == 0.0625;
}

}  // namespace

std::uint64_t vertexRowsFromFacePoints(PerLevelTable& table) {
    for (const RowGroup& g : table.groups)
        if (g.kind == RowKind::VertexFromFacePoints)
            throw std::invalid_argument("vertexRowsFromFacePoints: the table has been rewritten already");
    PerLevelTable out;
    out.controlCount = table.controlCount;
    out.regions = table.regions;
    out.regionLevels = table.regionLevels;
    out.walkFrom = table.walkFrom;
    out.groups.reserve(table.groups.size() + table.levels.size());
    out.destinations.reserve(table.destinations.size());
    out.indices.reserve(table.indices.size());
    std::uint64_t rewritten = 0;
    std::vector<std::int32_t> tally;
    std::vector<std::uint32_t> moved;  // per rewritten row: its destination, then its 4 face points
    for (const StencilLevel& level : table.levels) {
        const FacesAround around = facesAround(table, level);
        tally.assign(level.sourceCount, 0);
        moved.clear();
        StencilLevel next = level;
        next.groupBegin = out.groups.size();
        next.rowBegin = out.destinations.size();
        for (std::uint64_t g = level.groupBegin; g < level.groupEnd; ++g) {
            const RowGroup& group = table.groups[g];
            RowGroup kept = group;
            kept.rowBegin = out.destinations.size();
            kept.indexBegin = out.indices.size();
            const bool regular = paperRegularVertex(group);
            for (std::uint64_t r = 0; r < group.rowCount; ++r) {
                const std::uint32_t* row = table.indices.data() + group.indexBegin + r * group.width;
                const std::uint32_t destination = table.destinations[group.rowBegin + r];
                const std::size_t slot = 4 * std::size_t(row[0]);
                if (regular && around.count[row[0]] == 4 && facesMatchRow(table, row, &around.corners[slot], tally)) {
                    moved.push_back(destination);
                    moved.insert(moved.end(), &around.point[slot], &around.point[slot] + 4);
                    continue;
                }
                out.destinations.push_back(destination);
                out.indices.insert(out.indices.end(), row, row + group.width);
            }
            kept.rowCount = out.destinations.size() - kept.rowBegin;
            if (kept.rowCount > 0) out.groups.push_back(kept);
        }
        if (!moved.empty()) {
            const std::uint64_t rows = moved.size() / 5;
            out.groups.push_back({RowKind::VertexFromFacePoints, 3, 0, 4, out.destinations.size(), rows,
                                  out.indices.size(), 0.25, 0.25, 0.0});
            for (std::uint64_t r = 0; r < rows; ++r) {
                out.destinations.push_back(moved[5 * r]);
                out.indices.insert(out.indices.end(), &moved[5 * r + 1], &moved[5 * r + 5]);
            }
            rewritten += rows;
        }
        next.groupEnd = out.groups.size();
        next.rowEnd = out.destinations.size();
        out.levels.push_back(next);
    }
    table = std::move(out);
    return rewritten;
}

}  // namespace psub
