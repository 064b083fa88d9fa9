// orderLevelsByRegion: renumbers a per-level table's intermediate levels by region of the
// control mesh and orders each row group's rows by region (docs/design.md, "Threads and
// regions"), so that threads taking even shares of every group each work on one region at every
// level and read mostly the points they wrote themselves. walkFallback, orderFinestByWalk and
// orderLevelsByWalk: the tiled form's fallback points, and the levels before, numbered along a
// walk of the surface (docs/tiled.md, "Output order"): the finest points from a walk of the
// finest faces, then the levels before from their rows (level B, where tiles start, from its
// points' ancestors two levels before). Only walkFallback reads faces; the others read the
// tables alone.
#include "psub/stencils.h"
#include "tiled_build.h"

#include <algorithm>
#include <climits>
#include <cstdint>
#include <stdexcept>
#include <utility>
#include <vector>

namespace psub {
namespace {

constexpr std::uint32_t kNone = ~0u;

// Whether a group's rows read the points of their own level (written by the level's earlier
// groups), not of the level before; and whether their first source (the one every child point's
// region and rank follow) does: a VertexFromCentreAndFacePoints row's centre is the parent's.
bool readsChild(const RowGroup& group) { return readsOwnLevel(group.kind); }
bool firstReadsChild(const RowGroup& group) { return group.kind == RowKind::VertexFromFacePoints; }

// Breadth-first ranks of level `at`'s points (0: the control points), over the pairs each row
// of the step from it joins (its first source with each other one); each connected component's
// points follow one another.
std::vector<std::uint32_t> breadthFirstRanks(const PerLevelTable& table, std::size_t at = 0) {
    const std::uint32_t count = at == 0 ? table.controlCount : table.levels[at - 1].destinationCount;
    const StencilLevel& level = table.levels[at];
    const auto forEachPair = [&](auto&& visit) {
        for (std::uint64_t g = level.groupBegin; g < level.groupEnd; ++g) {
            const RowGroup& group = table.groups[g];
            if (readsChild(group)) continue;  // its sources are no control points
            for (std::uint64_t r = 0; r < group.rowCount; ++r) {
                const std::uint32_t* ix = table.indices.data() + group.indexBegin + r * group.width;
                for (std::uint32_t j = 1; j < group.width; ++j)
                    if (ix[0] != ix[j]) visit(ix[0], ix[j]);
            }
        }
    };
    std::vector<std::uint32_t> offsets(std::size_t(count) + 1, 0);
    forEachPair([&](std::uint32_t a, std::uint32_t b) { ++offsets[a + 1], ++offsets[b + 1]; });
    for (std::uint32_t v = 0; v < count; ++v) offsets[v + 1] += offsets[v];
    std::vector<std::uint32_t> next(offsets.begin(), offsets.end() - 1), neighbours(offsets.back());
    forEachPair([&](std::uint32_t a, std::uint32_t b) { neighbours[next[a]++] = b, neighbours[next[b]++] = a; });
    std::vector<std::uint32_t> ranks(count, UINT32_MAX), queue;
    queue.reserve(count);
    for (std::uint32_t seed = 0; seed < count; ++seed) {
        if (ranks[seed] != UINT32_MAX) continue;
        ranks[seed] = std::uint32_t(queue.size());
        queue.push_back(seed);
        for (std::size_t head = queue.size() - 1; head < queue.size(); ++head)
            for (std::uint32_t i = offsets[queue[head]]; i < offsets[queue[head] + 1]; ++i)
                if (const std::uint32_t w = neighbours[i]; ranks[w] == UINT32_MAX) {
                    ranks[w] = std::uint32_t(queue.size());
                    queue.push_back(w);
                }
    }
    return ranks;
}

// Every source of every row names a point of the level before (the ranks index by it), or of
// its own level for readsChild groups (but a VertexFromCentreAndFacePoints row's centre).
void checkSources(const PerLevelTable& table) {
    std::uint32_t sourceCount = table.controlCount;
    for (const StencilLevel& level : table.levels) {
        for (std::uint64_t g = level.groupBegin; g < level.groupEnd; ++g) {
            const RowGroup& group = table.groups[g];
            const std::uint32_t first = firstReadsChild(group) ? level.destinationCount : sourceCount,
                                other = readsChild(group) ? level.destinationCount : sourceCount;
            for (std::uint64_t r = 0; r < group.rowCount; ++r) {
                const std::uint32_t* row = table.indices.data() + group.indexBegin + r * group.width;
                if (row[0] >= first || std::any_of(row + 1, row + group.width, [&](std::uint32_t s) { return s >= other; }))
                    throw std::invalid_argument("orderLevelsByRegion: a row names a point its level does not have");
            }
            for (std::uint64_t r = 0; r < group.rowCount; ++r)
                if (table.destinations[group.rowBegin + r] >= level.destinationCount)
                    throw std::invalid_argument("orderLevelsByRegion: a row writes a point its level does not have");
        }
        sourceCount = level.destinationCount;
    }
}

}  // namespace

void orderLevelsByRegion(PerLevelTable& table, std::uint32_t regions, std::size_t levelCount) {
    if (regions == 0) throw std::invalid_argument("orderLevelsByRegion: regions must be at least 1");
    if (table.regions != 1) throw std::invalid_argument("orderLevelsByRegion: the table is region-ordered already");
    levelCount = std::min(levelCount, table.levels.size());
    if (regions == 1 || levelCount == 0) return;
    checkSources(table);
    // region[v]: the region of the current level's point v (the control points: their breadth-
    // first rank cut into `regions` equal runs; a child point: its row's first source's);
    // position[v]: where that point now lies (the control points stay).
    std::vector<std::uint32_t> region = breadthFirstRanks(table);
    for (std::uint32_t& r : region) r = std::uint32_t(std::uint64_t(r) * regions / table.controlCount);
    std::vector<std::uint32_t> position(table.controlCount), nextRegion, nextPosition, starts, groupIndices,
        groupDestinations, order;
    for (std::uint32_t v = 0; v < table.controlCount; ++v) position[v] = v;
    for (std::size_t k = 0; k < levelCount; ++k) {
        const StencilLevel& level = table.levels[k];
        const bool finest = k + 1 == levelCount;  // the last level ordered: its numbers kept
        nextRegion.assign(level.destinationCount, regions - 1);  // a point no row writes: the last
        for (std::uint64_t g = level.groupBegin; g < level.groupEnd; ++g) {  // readsChild groups last
            const RowGroup& group = table.groups[g];
            const std::vector<std::uint32_t>& from = firstReadsChild(group) ? nextRegion : region;
            for (std::uint64_t r = 0; r < group.rowCount; ++r)
                nextRegion[table.destinations[group.rowBegin + r]] = from[table.indices[group.indexBegin + r * group.width]];
        }
        // The child level's points by region, in their order within each; the last level ordered
        // keeps its numbering (the output order, or what later rows and other tables refer to).
        nextPosition.resize(level.destinationCount);
        if (finest) {
            for (std::uint32_t d = 0; d < level.destinationCount; ++d) nextPosition[d] = d;
        } else {
            starts.assign(std::size_t(regions) + 1, 0);
            for (std::uint32_t d = 0; d < level.destinationCount; ++d) ++starts[nextRegion[d] + 1];
            for (std::uint32_t i = 0; i < regions; ++i) starts[i + 1] += starts[i];
            for (std::uint32_t d = 0; d < level.destinationCount; ++d) nextPosition[d] = starts[nextRegion[d]]++;
        }
        // Each group's rows by their point's region, in their order within each (a table as
        // refined lists a group's rows by destination: the intermediate levels' rows stay in
        // the order of the points they write), sources renumbered.
        for (std::uint64_t g = level.groupBegin; g < level.groupEnd; ++g) {
            const RowGroup& group = table.groups[g];
            const std::uint64_t rowBegin = group.rowBegin, width = group.width;
            starts.assign(std::size_t(regions) + 1, 0);
            for (std::uint64_t r = 0; r < group.rowCount; ++r) ++starts[nextRegion[table.destinations[rowBegin + r]] + 1];
            for (std::uint32_t i = 0; i < regions; ++i) starts[i + 1] += starts[i];
            order.resize(group.rowCount);
            for (std::uint64_t r = 0; r < group.rowCount; ++r)
                order[starts[nextRegion[table.destinations[rowBegin + r]]]++] = std::uint32_t(r);
            groupIndices.assign(table.indices.begin() + std::ptrdiff_t(group.indexBegin),
                                table.indices.begin() + std::ptrdiff_t(group.indexBegin + group.rowCount * width));
            groupDestinations.assign(table.destinations.begin() + std::ptrdiff_t(rowBegin),
                                     table.destinations.begin() + std::ptrdiff_t(rowBegin + group.rowCount));
            const std::vector<std::uint32_t>& sourcePosition = readsChild(group) ? nextPosition : position;
            const std::vector<std::uint32_t>& firstPosition = firstReadsChild(group) ? nextPosition : position;
            for (std::uint64_t i = 0; i < group.rowCount; ++i) {
                const std::uint64_t r = order[i];
                table.destinations[rowBegin + i] = nextPosition[groupDestinations[r]];
                for (std::uint64_t j = 0; j < width; ++j)
                    table.indices[group.indexBegin + i * width + j] = (j == 0 ? firstPosition : sourcePosition)[groupIndices[r * width + j]];
            }
        }
        region.swap(nextRegion);
        position.swap(nextPosition);
    }
    table.regions = regions;
    table.regionLevels = std::uint32_t(levelCount);
}

namespace {

// Per point of level k + 1 by its new number (`position`: old number -> new), the group
// within level k of the row that writes it (`groups`, past the last, where no row does).
std::vector<std::uint32_t> writerGroups(const PerLevelTable& rows, std::size_t k, const std::vector<std::uint32_t>& position) {
    const StencilLevel& writers = rows.levels[k];
    std::vector<std::uint32_t> groupOf(writers.destinationCount, std::uint32_t(writers.groupEnd - writers.groupBegin));
    for (std::uint64_t g = writers.groupBegin; g < writers.groupEnd; ++g) {
        const RowGroup& group = rows.groups[g];
        for (std::uint64_t r = group.rowBegin; r < group.rowBegin + group.rowCount; ++r)
            groupOf[position[rows.destinations[r]]] = std::uint32_t(g - writers.groupBegin);
    }
    return groupOf;
}

// Per point, its number once the points from `from` on are grouped within each run of `chunk`:
// group by group of groupOf (0 .. groups, `groups` last), each group's in their order (points
// before `from` keep their numbers).
std::vector<std::uint32_t> groupedNumbers(const std::vector<std::uint32_t>& groupOf, std::uint32_t groups,
                                          std::uint32_t from, std::uint32_t chunk) {
    const std::uint32_t count = std::uint32_t(groupOf.size());
    std::vector<std::uint32_t> number(count), starts;
    for (std::uint32_t q = 0; q < from; ++q) number[q] = q;
    for (std::uint64_t begin = from; begin < count; begin += chunk) {  // 64-bit: no wrap near 2^32
        const std::uint32_t end = std::uint32_t(std::min<std::uint64_t>(begin + chunk, count));
        starts.assign(std::size_t(groups) + 2, 0);
        for (std::uint32_t q = std::uint32_t(begin); q < end; ++q) ++starts[groupOf[q] + 1];
        starts[0] = std::uint32_t(begin);
        for (std::uint32_t i = 0; i <= groups; ++i) starts[i + 1] += starts[i];
        for (std::uint32_t q = std::uint32_t(begin); q < end; ++q) number[q] = starts[groupOf[q]]++;
    }
    return number;
}

// The finest level's fallback points are grouped within chunks of kFinestChunk walk positions,
// the intermediate levels' whole (groupLevelPoints; in chunks of 1024 too, the cow's rows at 7
// steps were no faster). Chunks of 4096 spread a block of vertices' faces past the one-pass
// normals' window on the cow at 7 steps (the two passes then, normals 2.1 -> 4.5 ms); 256 and 512
// were slower.
constexpr std::uint32_t kFinestChunk = 1024;

// Level k's points (k >= 1), numbered by `position` (old number -> new), renumbered again:
// group by group of the level-(k - 1) rows that write them, each group's in their order by
// `position` (points no row writes last); level k's rows, already rewritten with `position`,
// are remapped, and `position` becomes the composed numbering. So each group of level k - 1
// writes consecutive points, in order: the CPU kernel then reads no destination and stores 16
// bytes a point (docs/tiled.md, "Output order").
void groupLevelPoints(PerLevelTable& rows, std::size_t k, std::vector<std::uint32_t>& position) {
    const StencilLevel& writers = rows.levels[k - 1];
    const std::uint32_t groups = std::uint32_t(writers.groupEnd - writers.groupBegin);
    const std::vector<std::uint32_t> number =
        groupedNumbers(writerGroups(rows, k - 1, position), groups, 0, writers.destinationCount);
    for (std::uint32_t& p : position) p = number[p];
    const StencilLevel& readers = rows.levels[k];
    const auto begin = rows.indices.begin() + std::ptrdiff_t(rows.groups[readers.groupBegin].indexBegin);
    const RowGroup& last = rows.groups[readers.groupEnd - 1];
    const auto end = rows.indices.begin() + std::ptrdiff_t(last.indexBegin + last.rowCount * last.width);
    for (auto it = begin; it != end; ++it) *it = number[*it];
}

// The fallback's finest points (drawing positions from fallbackBegin), numbered in walk order
// by `position` (old position -> new), renumbered within each run of kFinestChunk walk
// positions: group by group of the rows that write them, each group's in walk order (points
// no row writes last). So each group writes runs of consecutive points (the CPU kernel reads no
// destination there and stores 16 bytes a point), while a finest face's corners stay within a
// chunk or two (the normals' passes read them close together).
void groupFinestInChunks(const PerLevelTable& rows, std::uint32_t fallbackBegin, std::vector<std::uint32_t>& position) {
    const StencilLevel& writers = rows.levels.back();
    const std::uint32_t groups = std::uint32_t(writers.groupEnd - writers.groupBegin);
    const std::vector<std::uint32_t> number =
        groupedNumbers(writerGroups(rows, rows.levels.size() - 1, position), groups, fallbackBegin, kFinestChunk);
    for (std::uint32_t& p : position) p = number[p];
}

// Level `level`'s points (level >= 1, rows in the numbering the rules gave them) numbered by
// the breadth-first rank of their ancestor two levels before (each row's first source, level by
// level; the control point from levels 1 and 2), stably: nearby points come first together, so
// the first half of each group of the level, and of the levels numbered from it, is one part of
// the surface. Ranked on the control points instead, the halves' border ran through whole
// control faces, whose points the two halves then shared: on Spot at 9 steps levels 6 to 8 read
// 3-4.7% of their sources from the other half against 1.2-2.2%, and on two threads took as long
// as on one (docs/tiled.md, "Output order").
std::vector<std::uint32_t> numberByAncestor(const PerLevelTable& rows, std::size_t level) {
    const std::size_t at = level >= 2 ? level - 2 : 0;
    std::vector<std::uint32_t> rank = breadthFirstRanks(rows, at), next;
    for (std::size_t k = at; k < level; ++k) {
        const StencilLevel& step = rows.levels[k];
        next.assign(step.destinationCount, UINT32_MAX);  // a point no row writes: last
        for (std::uint64_t g = step.groupBegin; g < step.groupEnd; ++g) {  // readsChild groups last
            const RowGroup& group = rows.groups[g];
            const std::vector<std::uint32_t>& from = firstReadsChild(group) ? next : rank;
            for (std::uint64_t r = 0; r < group.rowCount; ++r)
                next[rows.destinations[group.rowBegin + r]] = from[rows.indices[group.indexBegin + r * group.width]];
        }
        rank.swap(next);
    }
    std::vector<std::uint32_t> order(rank.size());
    for (std::uint32_t v = 0; v < rank.size(); ++v) order[v] = v;
    std::stable_sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) { return rank[a] < rank[b]; });
    std::vector<std::uint32_t> number(rank.size());
    for (std::uint32_t i = 0; i < order.size(); ++i) number[order[i]] = i;
    return number;
}

}  // namespace

std::vector<std::uint32_t> walkFallback(const TiledTable& table, const std::vector<std::uint32_t>& drawOf,
                                        const Faces& finest) {
    if (table.fallbackBegin == table.refinedCount) return {};
    if (finest.vertexCount != table.refinedCount || drawOf.size() != table.refinedCount ||
        table.canonical.size() != table.refinedCount)
        throw std::invalid_argument("walkFallback: the faces are not the table's finest level");
    const Index faceCount = finest.faceCount(), vertexCount = finest.vertexCount;
    // Which faces are walked (those with a fallback corner; without a tile, every one), and
    // the faces around each vertex among them.
    std::vector<char> walked(faceCount, 0);
    if (table.fallbackBegin > 0)
        for (Index f = 0; f < faceCount; ++f) {
            walked[f] = 1;
            for (Index v : finest.face(f))
                if (drawOf[v] >= table.fallbackBegin) walked[f] = 0;
        }
    std::vector<Index> offsets(std::size_t(vertexCount) + 1, 0);
    for (Index f = 0; f < faceCount; ++f)
        if (!walked[f])
            for (Index v : finest.face(f)) ++offsets[v + 1];
    for (Index v = 0; v < vertexCount; ++v) offsets[v + 1] += offsets[v];
    std::vector<Index> faces(offsets.back());
    for (Index f = 0; f < faceCount; ++f)
        if (!walked[f])
            for (Index v : finest.face(f)) faces[offsets[v]++] = f;
    for (Index v = vertexCount; v > 0; --v) offsets[v] = offsets[v - 1];  // back to each list's start
    offsets[0] = 0;
    // The walk: a face's corners placed in corner order as it is taken from the queue; the
    // faces around a corner queued when it is placed (a corner placed before had its queued).
    // placedAt[v]: finest vertex v's new drawing position (a tile's point: its own), kNone
    // until placed. The queue is read ahead (prefetches, at the distances measured best): a
    // face's corner offset 88 faces ahead, its corners and their data 32 ahead, their face
    // lists 8 ahead, so that they are in cache when it is taken (the walk is bound by misses).
    std::vector<std::uint32_t> placedAt(vertexCount);
    for (Index v = 0; v < vertexCount; ++v) placedAt[v] = drawOf[v] < table.fallbackBegin ? drawOf[v] : kNone;
    std::uint32_t placed = table.fallbackBegin;
    std::vector<Index> queue;
    queue.reserve(faceCount);
    const auto readAhead = [&](std::size_t head) {
        if (head + 88 < queue.size()) __builtin_prefetch(&finest.offsets[queue[head + 88]]);
        if (head + 32 < queue.size()) __builtin_prefetch(&finest.verts[finest.offsets[queue[head + 32]]]);
        if (head + 32 < queue.size())
            for (Index v : finest.face(queue[head + 32])) {
                __builtin_prefetch(&placedAt[v]);
                __builtin_prefetch(&offsets[v]);
            }
        if (head + 8 < queue.size())
            for (Index v : finest.face(queue[head + 8])) __builtin_prefetch(&faces[offsets[v]]);
    };
    for (Index seed = 0; seed < faceCount; ++seed) {
        if (walked[seed]) continue;
        walked[seed] = 1;
        queue.push_back(seed);
        for (std::size_t head = queue.size() - 1; head < queue.size(); ++head) {
            readAhead(head);
            for (Index v : finest.face(queue[head])) {
                if (placedAt[v] != kNone) continue;
                placedAt[v] = placed++;
                for (Index i = offsets[v]; i < offsets[v + 1]; ++i)
                    if (!walked[faces[i]]) walked[faces[i]] = 1, queue.push_back(faces[i]);
            }
        }
    }
    std::vector<std::uint32_t> position(table.refinedCount, kNone);
    for (Index v = 0; v < vertexCount; ++v)
        if (placedAt[v] != kNone) position[drawOf[v]] = placedAt[v];
    for (std::uint32_t p = table.fallbackBegin; p < table.refinedCount; ++p)  // on no face
        if (position[p] == kNone) position[p] = placed++;
    return position;
}

std::vector<std::uint32_t> orderFinestByWalk(TiledTable& table, std::vector<std::uint32_t>& drawOf,
                                             std::vector<std::uint32_t> walk) {
    const PerLevelTable& rows = table.rows;
    if (rows.levels.empty() || walk.empty()) return {};
    if (rows.regions != 1) throw std::logic_error("orderFinestByWalk: the rows are region-ordered already");
    if (walk.size() != table.refinedCount || drawOf.size() != table.refinedCount)
        throw std::invalid_argument("orderFinestByWalk: the walk is not of the table's finest points");
    // Per finest point (drawing position), its new one: the fallback's moved.
    std::vector<std::uint32_t> position = std::move(walk);
    groupFinestInChunks(rows, table.fallbackBegin, position);
    const std::vector<std::uint32_t> canonical(table.canonical);
    for (std::uint32_t p = table.fallbackBegin; p < table.refinedCount; ++p) {
        table.canonical[position[p]] = canonical[p];
        drawOf[canonical[p]] = position[p];
    }
    return position;
}

void orderLevelsByWalk(TiledTable& table, std::vector<std::uint32_t> position) {
    PerLevelTable& rows = table.rows;
    const std::size_t levels = rows.levels.size();
    if (position.empty()) return;
    if (position.size() != table.refinedCount)
        throw std::invalid_argument("orderLevelsByWalk: the numbering is not of the table's finest points");
    // Per point of the level being renumbered, its new number (first the finest level's). From
    // the finest level back, each level's rows by their new destination within each group (they
    // ascend again), and the level before's points by first use by them, then grouped by the
    // group of the row that writes them (groupLevelPoints), down to level 1 (only the control
    // points keep their numbers). With tiles, level B's points are not numbered by the
    // fallback's rows (a walk of the fallback alone, in strips between the tiles: its halves
    // interleave across the surface, and two threads then read each other's fresh points at
    // every level up to B) but by their ancestor two levels before (numberByAncestor), and the
    // tiles' gathers renumbered with them.
    const std::size_t base = table.tileCount() > 0 ? std::size_t(table.baseLevel) : SIZE_MAX;
    const std::vector<std::uint32_t> baseNumbers =
        base >= 1 && base < levels ? numberByAncestor(rows, base) : std::vector<std::uint32_t>{};
    rows.walkFrom = 0;
    // rowAt[d]: the row writing new destination d, as its group within the level (high 32 bits)
    // and its row within the level (low 32), or kNoRow.
    constexpr std::uint64_t kNoRow = ~std::uint64_t(0);
    std::vector<std::uint64_t> rowAt, nextRow;
    std::vector<std::uint32_t> sourcePosition, indices;
    for (std::size_t k = levels; k-- > 0;) {
        const StencilLevel& level = rows.levels[k];
        if (level.groupBegin == level.groupEnd) break;  // no row: nothing before it is used
        rowAt.assign(level.destinationCount, kNoRow);
        for (std::uint64_t g = level.groupBegin; g < level.groupEnd; ++g) {
            const RowGroup& group = rows.groups[g];
            for (std::uint64_t r = group.rowBegin; r < group.rowBegin + group.rowCount; ++r)
                rowAt[position[rows.destinations[r]]] = (g - level.groupBegin) << 32 | (r - level.rowBegin);
        }
        const RowGroup& last = rows.groups[level.groupEnd - 1];
        const std::uint64_t indexBegin = rows.groups[level.groupBegin].indexBegin;
        indices.assign(rows.indices.begin() + std::ptrdiff_t(indexBegin),
                       rows.indices.begin() + std::ptrdiff_t(last.indexBegin + last.rowCount * last.width));
        const auto groupAt = [&](std::uint64_t at) -> const RowGroup& { return rows.groups[level.groupBegin + (at >> 32)]; };
        const auto rowSources = [&](std::uint64_t at) {
            const RowGroup& group = groupAt(at);
            return indices.data() + (group.indexBegin - indexBegin) +
                   (level.rowBegin + (at & 0xffffffffu) - group.rowBegin) * group.width;
        };
        // The rows rewritten in order of their new destinations, and (when the level before is
        // renumbered too) its points numbered in order of first use by them, then those no row
        // of this level reads. Read ahead (prefetches): the sources of the row 32 destinations
        // on, the new numbers of the row 16 on (the rows lie in canonical order: misses).
        const bool sources = k >= 1;  // level 0's points (the control points) keep their numbers
        if (sources) sourcePosition.assign(level.sourceCount, kNone);
        if (sources && k == base) sourcePosition = baseNumbers;  // every point numbered already
        std::uint32_t used = 0;
        nextRow.clear();
        for (std::uint64_t g = level.groupBegin; g < level.groupEnd; ++g) nextRow.push_back(rows.groups[g].rowBegin);
        const std::uint32_t count = level.destinationCount;
        for (std::uint32_t d = 0; d < count; ++d) {
            if (d + 32 < count && rowAt[d + 32] != kNoRow) {
                const std::uint32_t* ahead = rowSources(rowAt[d + 32]);
                __builtin_prefetch(ahead);
                __builtin_prefetch(ahead + groupAt(rowAt[d + 32]).width - 1);
            }
            if (sources && d + 16 < count && rowAt[d + 16] != kNoRow) {
                const std::uint32_t* ahead = rowSources(rowAt[d + 16]);
                for (std::uint32_t j = 0; j < groupAt(rowAt[d + 16]).width; ++j) __builtin_prefetch(&sourcePosition[ahead[j]]);
            }
            if (rowAt[d] == kNoRow) continue;
            const RowGroup& group = groupAt(rowAt[d]);
            const std::uint64_t to = nextRow[rowAt[d] >> 32]++;
            rows.destinations[to] = d;
            const std::uint32_t* from = rowSources(rowAt[d]);
            std::uint32_t* ix = rows.indices.data() + group.indexBegin + (to - group.rowBegin) * group.width;
            for (std::uint32_t j = 0; j < group.width; ++j) {
                if (!sources) {
                    ix[j] = from[j];
                    continue;
                }
                std::uint32_t& p = sourcePosition[from[j]];
                if (p == kNone) p = used++;
                ix[j] = p;
            }
        }
        if (sources)
            for (std::uint32_t& p : sourcePosition)
                if (p == kNone) p = used++;
        if (!sources) break;
        groupLevelPoints(rows, k, sourcePosition);
        if (k == base)
            for (std::uint32_t& v : table.gather) v = sourcePosition[v];
        position.swap(sourcePosition);
    }
}

}  // namespace psub
