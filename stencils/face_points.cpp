// vertexRowsFromFacePoints: rewrites a per-level table's regular vertex rows (valence 4, four
// face quads) to read the four new face points around the vertex instead of its nine parent
// points (docs/design.md, "Vertex points from face points"). Reads and writes the table only.
#include "psub/stencils.h"

#include <omp.h>

#include <algorithm>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <vector>

namespace psub {
namespace {

// The face rows around each parent point of one level: up to 4 per point, each as its face point
// and its corner opposite the point (a slot of 2 indices), and how many face rows name the point.
struct FacesAround {
    std::unique_ptr<std::uint32_t[]> slots;  // uninitialised: read only where `count` says written
    std::vector<std::uint8_t> count;         // up to 5 (more than 4 is all that matters)
    const std::uint32_t* of(std::uint32_t p) const { return slots.get() + 8 * std::size_t(p); }
};

// Fills `around`'s slots of parent points [lo, hi) of one level.
void facesAround(const PerLevelTable& table, const StencilLevel& level, FacesAround& around, std::uint32_t lo,
                 std::uint32_t hi) {
    for (std::uint64_t g = level.groupBegin; g < level.groupEnd; ++g) {
        const RowGroup& group = table.groups[g];
        if (group.kind != RowKind::FaceQuad || group.centre != 0.25 || group.edge != 0.25) continue;
        for (std::uint64_t r = 0; r < group.rowCount; ++r) {
            const std::uint32_t* corners = table.indices.data() + group.indexBegin + r * group.width;
            for (std::uint32_t j = 0; j < 4; ++j) {
                const std::uint32_t p = corners[j];
                if (p < lo || p >= hi) continue;
                if (around.count[p] >= 4) {
                    around.count[p] = 5;
                    continue;
                }
                std::uint32_t* slot = around.slots.get() + 8 * std::size_t(p) + 2 * around.count[p]++;
                slot[0] = table.destinations[group.rowBegin + r];
                slot[1] = corners[(j + 2) & 3];
            }
        }
    }
}

// Whether the four face rows around P (`slots`: each face point and its corner opposite P) have
// the row's four diagonals (`row`: P, 4 edge neighbours, 4 diagonals) as their opposite corners.
// They are then P's four faces (the only faces a table's face rows give P: valence 4, quads), each
// edge neighbour in two and each diagonal in one, and the mean of their points is the row's
// 1/4 P + 1/8 sum(edges) + 1/16 sum(diagonals). `tally` is all zeros, and is left so.
bool facesMatchRow(const std::uint32_t* row, const std::uint32_t* slots, std::vector<std::int32_t>& tally) {
    for (std::uint32_t j = 5; j < 9; ++j) --tally[row[j]];
    for (int f = 0; f < 4; ++f) ++tally[slots[2 * f + 1]];
    bool match = true;
    for (std::uint32_t j = 5; j < 9; ++j) match = match && tally[row[j]] == 0, tally[row[j]] = 0;
    for (int f = 0; f < 4; ++f) tally[slots[2 * f + 1]] = 0;
    return match;
}

bool paperRegularVertex(const RowGroup& g) {
    return g.kind == RowKind::VertexQuad && g.n == 4 && g.m == 4 && g.centre == 0.25 && g.edge == 0.125 &&
           g.diagonal == 0.0625;
}

// Marks the level's rows that are rewritten (rewrite[r], r within the level) and fills `around`,
// on the build's threads: each fills the slots of its own run of parent points (every thread
// reads every face row), then checks its share of each vertex group with its own tally.
void markRewrites(const PerLevelTable& table, const StencilLevel& level, FacesAround& around,
                  std::vector<char>& rewrite) {
    around.count.assign(level.sourceCount, 0);
    rewrite.assign(level.rowEnd - level.rowBegin, 0);
    const int threads = level.sourceCount >= 65536 ? omp_get_max_threads() : 1;
#pragma omp parallel num_threads(threads)
    {
        const std::uint64_t t = std::uint64_t(omp_get_thread_num()), n = std::uint64_t(omp_get_num_threads());
        facesAround(table, level, around, std::uint32_t(level.sourceCount * t / n),
                    std::uint32_t(level.sourceCount * (t + 1) / n));
#pragma omp barrier
        std::vector<std::int32_t> tally(level.sourceCount, 0);
        for (std::uint64_t g = level.groupBegin; g < level.groupEnd; ++g) {
            const RowGroup& group = table.groups[g];
            if (!paperRegularVertex(group)) continue;
            for (std::uint64_t r = group.rowCount * t / n; r < group.rowCount * (t + 1) / n; ++r) {
                const std::uint32_t* row = table.indices.data() + group.indexBegin + r * group.width;
                if (around.count[row[0]] == 4 && facesMatchRow(row, around.of(row[0]), tally))
                    rewrite[group.rowBegin + r - level.rowBegin] = 1;
            }
        }
    }
}

}  // namespace

std::uint64_t vertexRowsFromFacePoints(PerLevelTable& table) {
    for (const RowGroup& g : table.groups)
        if (g.kind == RowKind::VertexFromFacePoints)
            throw std::invalid_argument("vertexRowsFromFacePoints: the table has been rewritten already");
    // In place, level by level: each level's kept rows move forward (a rewritten row frees 9
    // indices and takes 4 at its level's end, so writing never overtakes reading), its rewritten
    // rows wait in `moved` and follow as the level's last group.
    std::vector<RowGroup> groups;
    groups.reserve(table.groups.size() + table.levels.size());
    std::uint64_t rewritten = 0, rowsWritten = 0, indicesWritten = 0;
    FacesAround around;  // its slots allocated once, for the largest level
    std::uint32_t sources = 0;
    for (const StencilLevel& level : table.levels) sources = std::max(sources, level.sourceCount);
    around.slots.reset(new std::uint32_t[8 * std::size_t(sources)]);
    std::vector<std::uint32_t> moved;  // per rewritten row: its destination and its P
    std::vector<char> rewrite;         // per row of the level
    for (StencilLevel& level : table.levels) {
        // First the level as it is (its face rows still where `around` found them): which rows
        // are rewritten. Then the kept rows moved forward, and the rewritten ones after them.
        markRewrites(table, level, around, rewrite);
        moved.clear();
        moved.reserve(2 * std::size_t(std::count(rewrite.begin(), rewrite.end(), char(1))));
        const std::uint64_t groupBegin = groups.size(), rowBegin = rowsWritten;
        for (std::uint64_t g = level.groupBegin; g < level.groupEnd; ++g) {
            RowGroup group = table.groups[g];
            const std::uint64_t readRows = group.rowBegin, readIndices = group.indexBegin;
            group.rowBegin = rowsWritten;
            group.indexBegin = indicesWritten;
            for (std::uint64_t r = 0; r < group.rowCount; ++r) {
                const std::uint32_t* row = table.indices.data() + readIndices + r * group.width;
                if (rewrite[readRows + r - level.rowBegin]) {
                    moved.insert(moved.end(), {table.destinations[readRows + r], row[0]});
                    continue;
                }
                table.destinations[rowsWritten++] = table.destinations[readRows + r];
                std::copy(row, row + group.width, table.indices.begin() + std::ptrdiff_t(indicesWritten));
                indicesWritten += group.width;
            }
            group.rowCount = rowsWritten - group.rowBegin;
            if (group.rowCount > 0) groups.push_back(group);
        }
        if (!moved.empty()) {
            const std::uint64_t rows = moved.size() / 2;
            groups.push_back({RowKind::VertexFromFacePoints, 3, 0, 4, rowsWritten, rows, indicesWritten, 0.25, 0.25, 0.0});
            for (std::uint64_t r = 0; r < rows; ++r) {
                table.destinations[rowsWritten++] = moved[2 * r];
                const std::uint32_t* slots = around.of(moved[2 * r + 1]);
                for (int f = 0; f < 4; ++f) table.indices[indicesWritten++] = slots[2 * f];
            }
            rewritten += rows;
        }
        level.groupBegin = groupBegin;
        level.groupEnd = groups.size();
        level.rowBegin = rowBegin;
        level.rowEnd = rowsWritten;
    }
    table.groups = std::move(groups);
    table.destinations.resize(rowsWritten);
    table.indices.resize(indicesWritten);
    return rewritten;
}

}  // namespace psub
