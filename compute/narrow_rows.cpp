// narrowRows: the CPU evaluator's 16-bit copy of a table's four-source rows' indices (psub/evaluator.h,
// NarrowRows; docs/design.md, "Narrow rows"), and the bytes it spares a frame. Reads the table alone.
#include "psub/evaluator.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace psub {

NarrowRows narrowRows(const PerLevelTable& table, std::span<const std::uint8_t> copied) {
    NarrowRows narrow;
    narrow.firstBlock.assign(table.groups.size(), kNoNarrowRows);
    std::uint64_t blocks = 0;
    for (std::size_t g = 0; g < table.groups.size(); ++g) {
        const RowGroup& group = table.groups[g];
        if (group.n != 3 || group.m != 0 || group.rowCount == 0 || (!copied.empty() && !copied[g])) continue;
        narrow.firstBlock[g] = std::uint32_t(blocks);
        blocks += (group.rowCount + kNarrowBlock - 1) / kNarrowBlock;
        if (blocks >= kNoNarrowRows) {  // more than 2^32 blocks: past what a table holds
            narrow.firstBlock.assign(table.groups.size(), kNoNarrowRows);
            return narrow;
        }
    }
    narrow.offsets.assign(4 * blocks * kNarrowBlock, 0);
    narrow.bases.assign(4 * blocks, 0);
    narrow.firstDestination.assign(blocks, kScattered);
    for (std::size_t g = 0; g < table.groups.size(); ++g) {
        if (narrow.firstBlock[g] == kNoNarrowRows) continue;
        const RowGroup& group = table.groups[g];
        const std::uint32_t* indices = table.indices.data() + group.indexBegin;
        const std::uint32_t* destinations = table.destinations.data() + group.rowBegin;
        const std::int64_t groupBlocks = std::int64_t((group.rowCount + kNarrowBlock - 1) / kNarrowBlock);
#pragma omp parallel for schedule(static)
        for (std::int64_t b = 0; b < groupBlocks; ++b) {
            const std::uint64_t begin = std::uint64_t(b) * kNarrowBlock;
            const std::uint64_t end = std::min(begin + kNarrowBlock, group.rowCount);
            std::array<std::uint32_t, 4> least{UINT32_MAX, UINT32_MAX, UINT32_MAX, UINT32_MAX}, most{};
            for (std::uint64_t r = begin; r < end; ++r)
                for (int j = 0; j < 4; ++j) {
                    least[j] = std::min(least[j], indices[4 * r + j]);
                    most[j] = std::max(most[j], indices[4 * r + j]);
                }
            const std::uint64_t block = narrow.firstBlock[g] + std::uint64_t(b);
            bool consecutive = true;
            for (std::uint64_t r = begin + 1; r < end; ++r) consecutive = consecutive && destinations[r] == destinations[r - 1] + 1;
            if (consecutive) narrow.firstDestination[block] = destinations[begin];
            std::uint32_t* bases = narrow.bases.data() + 4 * block;
            bool fits = true;
            for (int j = 0; j < 4; ++j) fits = fits && most[j] - least[j] <= 0xffff;
            if (!fits) {
                bases[0] = kWideBlock;
                continue;
            }
            std::copy(least.begin(), least.end(), bases);
            std::uint16_t* offsets = narrow.offsets.data() + 4 * kNarrowBlock * std::uint64_t(narrow.firstBlock[g]);
            for (std::uint64_t r = begin; r < end; ++r)
                for (int j = 0; j < 4; ++j) offsets[4 * r + j] = std::uint16_t(indices[4 * r + j] - least[j]);
        }
    }
    return narrow;
}

bool readsNarrowRows(const RowGroup& group, const RowReads& reads) {
    // A VertexFromCentreAndFacePoints row's centre is the parent level's, its other sources the
    // level's own: both buffers padded.
    const bool padded = group.kind == RowKind::VertexFromCentreAndFacePoints ? reads.destinationPadded && reads.sourcePadded
                        : readsOwnLevel(group.kind)                           ? reads.destinationPadded
                                                                               : reads.sourcePadded;
    return group.n == 3 && group.m == 0 && !std::signbit(group.diagonal) && padded;
}

std::uint64_t narrowBytesSaved(const PerLevelTable& table, const NarrowRows& narrow) {
    std::uint64_t saved = 0, blocks = 0;
    for (std::size_t g = 0; g < narrow.firstBlock.size(); ++g) {
        if (narrow.firstBlock[g] == kNoNarrowRows) continue;
        const std::uint64_t rowCount = table.groups[g].rowCount;
        for (std::uint64_t begin = 0; begin < rowCount; begin += kNarrowBlock, ++blocks) {
            const std::uint64_t rows = std::min<std::uint64_t>(kNarrowBlock, rowCount - begin);
            const std::uint64_t b = narrow.firstBlock[g] + begin / kNarrowBlock;
            if (narrow.bases[4 * b] != kWideBlock) saved += (16 - 8) * rows;
            if (narrow.firstDestination[b] != kScattered) saved += 4 * rows;
        }
    }
    return saved > 20 * blocks ? saved - 20 * blocks : 0;
}

}  // namespace psub
