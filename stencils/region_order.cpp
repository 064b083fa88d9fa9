// orderLevelsByRegion: renumbers a per-level table's intermediate levels by region of the
// control mesh and orders each row group's rows by region (docs/design.md, "Threads and
// regions"), so that threads taking even shares of every group each work on one region at every
// level and read mostly the points they wrote themselves. Reads the table only.
#include "psub/stencils.h"

#include <algorithm>
#include <climits>
#include <cstdint>
#include <stdexcept>
#include <utility>
#include <vector>

namespace psub {
namespace {

// Breadth-first ranks of the control points, over the pairs each level-0 row joins (its first
// source with each other one); each connected component's points follow one another.
std::vector<std::uint32_t> breadthFirstRanks(const PerLevelTable& table) {
    const std::uint32_t count = table.controlCount;
    const StencilLevel& level = table.levels.front();
    const auto forEachPair = [&](auto&& visit) {
        for (std::uint64_t g = level.groupBegin; g < level.groupEnd; ++g) {
            const RowGroup& group = table.groups[g];
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

// Every source of every row names a point of the level before (the ranks index by it).
void checkSources(const PerLevelTable& table) {
    std::uint32_t sourceCount = table.controlCount;
    for (const StencilLevel& level : table.levels) {
        for (std::uint64_t g = level.groupBegin; g < level.groupEnd; ++g) {
            const RowGroup& group = table.groups[g];
            const auto begin = table.indices.begin() + std::ptrdiff_t(group.indexBegin);
            const auto end = begin + std::ptrdiff_t(group.rowCount * group.width);
            if (std::any_of(begin, end, [&](std::uint32_t s) { return s >= sourceCount; }))
                throw std::invalid_argument("orderLevelsByRegion: a row names a point its level does not have");
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
        for (std::uint64_t g = level.groupBegin; g < level.groupEnd; ++g) {
            const RowGroup& group = table.groups[g];
            for (std::uint64_t r = 0; r < group.rowCount; ++r)
                nextRegion[table.destinations[group.rowBegin + r]] =
                    region[table.indices[group.indexBegin + r * group.width]];
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
            for (std::uint64_t i = 0; i < group.rowCount; ++i) {
                const std::uint64_t r = order[i];
                table.destinations[rowBegin + i] = nextPosition[groupDestinations[r]];
                for (std::uint64_t j = 0; j < width; ++j)
                    table.indices[group.indexBegin + i * width + j] = position[groupIndices[r * width + j]];
            }
        }
        region.swap(nextRegion);
        position.swap(nextPosition);
    }
    table.regions = regions;
    table.regionLevels = std::uint32_t(levelCount);
}

}  // namespace psub
