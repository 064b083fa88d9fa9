// vertexRowsFromFacePoints: rewrites a per-level table's vertex rows of quads to read the new
// face points around the vertex instead of its parent points (docs/design.md, "Vertex points
// from face points"): a regular one (valence 4) their mean, one of another valence its centre
// and them. Reads and writes the table only.
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
// The centres of the rows rewritableExtraordinary takes get n slots each in wideSlots: point p's
// from wideBegin[wideId[p]], wideCount[wideId[p]] face rows found (more than n: the row is kept).
struct FacesAround {
    std::unique_ptr<std::uint32_t[]> slots;  // uninitialised: read only where `count` says written
    std::vector<std::uint8_t> count;         // up to 5 (more than 4 is all that matters)
    const std::uint32_t* of(std::uint32_t p) const { return slots.get() + 8 * std::size_t(p); }
    std::vector<std::uint32_t> wideId;     // per parent point: kNotWide, or its place in wideBegin
    std::vector<std::uint64_t> wideBegin;  // per extraordinary centre: its first slot (2 indices each)
    std::vector<std::uint32_t> wideSlots, wideCount;
    std::vector<std::uint32_t> wideCentres;  // the points whose wideId is set
};

constexpr std::uint32_t kNotWide = ~0u;
// The largest valence whose rows are rewritten (wider rows keep their parent points).
constexpr std::uint32_t kMaxWideValence = 16;

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
                const std::uint32_t facePoint = table.destinations[group.rowBegin + r], opposite = corners[(j + 2) & 3];
                if (const std::uint32_t w = around.wideId[p]; w != kNotWide) {
                    const std::uint64_t slot = around.wideBegin[w] + 2 * std::uint64_t(around.wideCount[w]);
                    if (slot < around.wideBegin[w + 1]) around.wideSlots[slot] = facePoint, around.wideSlots[slot + 1] = opposite;
                    ++around.wideCount[w];  // past n: the row is kept
                }
                if (around.count[p] >= 4) {
                    around.count[p] = 5;
                    continue;
                }
                std::uint32_t* slot = around.slots.get() + 8 * std::size_t(p) + 2 * around.count[p]++;
                slot[0] = facePoint;
                slot[1] = opposite;
            }
        }
    }
}

// Whether the n face rows around P (`slots`: each face point and its corner opposite P) have the
// row's n diagonals (`diagonals`) as their opposite corners. They are then P's n faces (each edge
// neighbour in two, each diagonal in one), whose points sum to (n P + 2 sum(edges) +
// sum(diagonals)) / 4. `tally` is all zeros, and is left so.
bool facesMatchDiagonals(const std::uint32_t* diagonals, std::uint32_t n, const std::uint32_t* slots,
                         std::vector<std::int32_t>& tally) {
    for (std::uint32_t j = 0; j < n; ++j) --tally[diagonals[j]];
    for (std::uint32_t f = 0; f < n; ++f) ++tally[slots[2 * f + 1]];
    bool match = true;
    for (std::uint32_t j = 0; j < n; ++j) match = match && tally[diagonals[j]] == 0, tally[diagonals[j]] = 0;
    for (std::uint32_t f = 0; f < n; ++f) tally[slots[2 * f + 1]] = 0;
    return match;
}

bool paperRegularVertex(const RowGroup& g) {
    return g.kind == RowKind::VertexQuad && g.n == 4 && g.m == 4 && g.centre == 0.25 && g.edge == 0.125 &&
           g.diagonal == 0.0625;
}

// A vertex row of quads of another valence n whose edge weight d is twice its diagonal one e (the
// paper's c, d, e at every valence; psub/rules.h): c P + d sum(edges) + e sum(diagonals) is then
// (c - n e) P + 4 e sum(F) over the n face points F around P.
bool rewritableExtraordinary(const RowGroup& g) {
    return g.kind == RowKind::VertexQuad && g.n >= 2 && g.n <= kMaxWideValence && g.n != 4 && g.m == g.n &&
           g.edge == 2 * g.diagonal;
}

// Marks the level's rows that are rewritten (rewrite[r], r within the level) and fills `around`
// (its wideId all kNotWide before; its extraordinary centres' after, until the level is written),
// on the build's threads: each fills the slots of its own run of parent points (every thread
// reads every face row), then checks its share of each vertex group with its own tally.
void markRewrites(const PerLevelTable& table, const StencilLevel& level, FacesAround& around,
                  std::vector<char>& rewrite) {
    around.count.assign(level.sourceCount, 0);
    rewrite.assign(level.rowEnd - level.rowBegin, 0);
    around.wideBegin.assign(1, 0);
    around.wideCentres.clear();
    for (std::uint64_t g = level.groupBegin; g < level.groupEnd; ++g) {
        const RowGroup& group = table.groups[g];
        if (!rewritableExtraordinary(group)) continue;
        for (std::uint64_t r = 0; r < group.rowCount; ++r) {
            const std::uint32_t centre = table.indices[group.indexBegin + r * group.width];
            around.wideCentres.push_back(centre);
            around.wideId[centre] = std::uint32_t(around.wideBegin.size() - 1);
            around.wideBegin.push_back(around.wideBegin.back() + 2 * group.n);
        }
    }
    around.wideSlots.resize(around.wideBegin.back());
    around.wideCount.assign(around.wideBegin.size() - 1, 0);
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
            const bool regular = paperRegularVertex(group), wide = rewritableExtraordinary(group);
            if (!regular && !wide) continue;
            for (std::uint64_t r = group.rowCount * t / n; r < group.rowCount * (t + 1) / n; ++r) {
                const std::uint32_t* row = table.indices.data() + group.indexBegin + r * group.width;
                bool match = false;
                if (regular) {
                    match = around.count[row[0]] == 4 && facesMatchDiagonals(row + 5, 4, around.of(row[0]), tally);
                } else {
                    const std::uint32_t w = around.wideId[row[0]];
                    match = around.wideCount[w] == group.n &&
                            facesMatchDiagonals(row + 1 + group.n, group.n, around.wideSlots.data() + around.wideBegin[w], tally);
                }
                if (match) rewrite[group.rowBegin + r - level.rowBegin] = 1;
            }
        }
    }
}

}  // namespace

std::uint64_t vertexRowsFromFacePoints(PerLevelTable& table) {
    for (const RowGroup& g : table.groups)
        if (readsOwnLevel(g.kind))
            throw std::invalid_argument("vertexRowsFromFacePoints: the table has been rewritten already");
    // In place, level by level: each level's kept rows move forward (a rewritten row frees 9
    // indices and takes 4, or frees 2n + 1 and takes n + 1, at its level's end, so writing never
    // overtakes reading), its rewritten rows wait in `moved` and follow: the regular ones
    // (VertexFromFacePoints), then the others (VertexFromCentreAndFacePoints, a group per group
    // they come from), the level's last groups.
    std::vector<RowGroup> groups;
    groups.reserve(table.groups.size() + 2 * table.levels.size());
    std::uint64_t rewritten = 0, rowsWritten = 0, indicesWritten = 0;
    FacesAround around;  // its slots allocated once, for the largest level
    std::uint32_t sources = 0;
    for (const StencilLevel& level : table.levels) sources = std::max(sources, level.sourceCount);
    around.slots.reset(new std::uint32_t[8 * std::size_t(sources)]);
    around.wideId.assign(sources, kNotWide);
    struct Moved {
        RowGroup from;                    // the group its rows come from
        std::vector<std::uint32_t> rows;  // per rewritten row: its destination and its P
    };
    std::vector<Moved> moved;  // the level's rewritten rows, per group they come from
    std::vector<char> rewrite;  // per row of the level
    const auto addGroup = [&](RowGroup group, const std::vector<std::uint32_t>& rows, auto&& writeSources) {
        group.rowBegin = rowsWritten, group.rowCount = rows.size() / 2, group.indexBegin = indicesWritten;
        for (std::size_t r = 0; r < rows.size(); r += 2) {
            table.destinations[rowsWritten++] = rows[r];
            indicesWritten += writeSources(rows[r + 1], table.indices.data() + indicesWritten);
        }
        groups.push_back(group);
    };
    for (StencilLevel& level : table.levels) {
        // First the level as it is (its face rows still where `around` found them): which rows
        // are rewritten. Then the kept rows moved forward, and the rewritten ones after them.
        markRewrites(table, level, around, rewrite);
        moved.clear();
        const std::uint64_t groupBegin = groups.size(), rowBegin = rowsWritten;
        for (std::uint64_t g = level.groupBegin; g < level.groupEnd; ++g) {
            RowGroup group = table.groups[g];
            const std::uint64_t readRows = group.rowBegin, readIndices = group.indexBegin;
            if (paperRegularVertex(group) || rewritableExtraordinary(group)) moved.push_back({group, {}});
            group.rowBegin = rowsWritten;
            group.indexBegin = indicesWritten;
            for (std::uint64_t r = 0; r < group.rowCount; ++r) {
                const std::uint32_t* row = table.indices.data() + readIndices + r * group.width;
                if (rewrite[readRows + r - level.rowBegin]) {
                    moved.back().rows.insert(moved.back().rows.end(), {table.destinations[readRows + r], row[0]});
                    continue;
                }
                table.destinations[rowsWritten++] = table.destinations[readRows + r];
                std::copy(row, row + group.width, table.indices.begin() + std::ptrdiff_t(indicesWritten));
                indicesWritten += group.width;
            }
            group.rowCount = rowsWritten - group.rowBegin;
            if (group.rowCount > 0) groups.push_back(group);
        }
        std::erase_if(moved, [](const Moved& m) { return m.rows.empty(); });
        for (const Moved& m : moved)
            if (m.from.n == 4)
                addGroup({RowKind::VertexFromFacePoints, 3, 0, 4, 0, 0, 0, 0.25, 0.25, 0.0}, m.rows,
                         [&](std::uint32_t centre, std::uint32_t* out) {
                             const std::uint32_t* slots = around.of(centre);
                             for (int f = 0; f < 4; ++f) out[f] = slots[2 * f];
                             return 4u;
                         });
        for (const Moved& m : moved) {
            if (m.from.n == 4) continue;
            const std::uint32_t n = m.from.n;
            const double e = m.from.diagonal;
            addGroup({RowKind::VertexFromCentreAndFacePoints, n, 0, n + 1, 0, 0, 0, m.from.centre - n * e, 4 * e, 0.0},
                     m.rows, [&](std::uint32_t centre, std::uint32_t* out) {
                         const std::uint32_t w = around.wideId[centre];
                         out[0] = centre;
                         for (std::uint32_t f = 0; f < n; ++f) out[1 + f] = around.wideSlots[around.wideBegin[w] + 2 * f];
                         return n + 1;
                     });
        }
        for (const Moved& m : moved) rewritten += m.rows.size() / 2;
        for (std::uint32_t centre : around.wideCentres) around.wideId[centre] = kNotWide;
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
