// Dispatch planning (compute/vulkan/dispatch_plan.h) without a device: chunks cover every row
// once, in order, each within its binding; CSR offsets are rebased on the aligned start of the
// chunk's entries; workgroup grids cover the rows within the device's x limit.
#include "dispatch_plan.h"

#include "psub/vulkan_evaluator.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

namespace psub::vulkan {
namespace {

TEST(DispatchPlan, ChunksCoverEveryRowOnceWithinMaxRows) {
    const BindingLimits limits{1024, 16, 100};
    const auto chunks = splitRows(
        250, limits, [](std::uint64_t, std::uint64_t) { return true; }, "test table");
    ASSERT_EQ(chunks.size(), 3u);  // 100 + 100 + 50
    EXPECT_EQ(chunks[0], RowChunk(0, 100));
    EXPECT_EQ(chunks[1], RowChunk(100, 200));
    EXPECT_EQ(chunks[2], RowChunk(200, 250));
    EXPECT_TRUE(splitRows(0, limits, [](std::uint64_t, std::uint64_t) { return true; }, "t").empty());
}

TEST(DispatchPlan, ChunksAreTheLongestThatFit) {
    // 16 bytes per row, 1024-byte bindings less the 16-byte alignment slack: 63 rows per chunk.
    const BindingLimits limits{1024, 16, 1u << 20};
    const auto chunks = splitRows(
        200, limits, [&](std::uint64_t a, std::uint64_t b) { return limits.fits(16 * (b - a)); }, "t");
    ASSERT_EQ(chunks.size(), 4u);  // ceil(200 / 63): 63 + 63 + 63 + 11
    std::uint64_t next = 0;
    for (const auto& [a, b] : chunks) {
        EXPECT_EQ(a, next);
        EXPECT_TRUE(limits.fits(16 * (b - a)));
        if (b < 200) {
            EXPECT_FALSE(limits.fits(16 * (b + 1 - a)));  // one more row would not fit
        }
        next = b;
    }
    EXPECT_EQ(next, 200u);
}

TEST(DispatchPlan, ARowLargerThanABindingIsAClearError) {
    const BindingLimits limits{64, 16, 100};
    try {
        splitRows(3, limits, [](std::uint64_t, std::uint64_t) { return false; }, "per-level table");
        FAIL() << "no error";
    } catch (const VulkanError& e) {
        EXPECT_NE(std::string(e.what()).find("one row of the per-level table"), std::string::npos) << e.what();
    }
}

TEST(DispatchPlan, CsrOffsetsAreRebasedOnTheAlignedStartOfEachChunk) {
    // Rows of 5 entries (20 bytes); bindings of 64 bytes: at most 2 rows' entries (40 + 16 <= 64).
    std::vector<std::uint32_t> offsets;
    for (std::uint32_t r = 0; r <= 5; ++r) offsets.push_back(5 * r);
    const BindingLimits limits{64, 16, 1000};
    std::vector<std::uint32_t> relative;
    const auto chunks = splitCsr(offsets, limits, relative, "t");
    ASSERT_EQ(chunks.size(), 3u);  // rows 0-1, 2-3, 4
    for (const CsrChunk& c : chunks) {
        EXPECT_EQ(c.entryBegin, offsets[c.rowBegin]);
        EXPECT_EQ(c.entryEnd, offsets[c.rowEnd]);
        const std::uint64_t first = c.entryBegin * 4 / 16 * 16 / 4;  // the binding's first entry
        for (std::uint64_t r = c.rowBegin; r <= c.rowEnd; ++r)
            EXPECT_EQ(relative[c.offsetsBegin + (r - c.rowBegin)], offsets[r] - first);
    }
    EXPECT_EQ(relative.size(), 3u + 3u + 2u);  // each chunk's rows + 1 offsets
}

TEST(DispatchPlan, WorkgroupGridCoversTheRowsWithinTheXLimit) {
    EXPECT_EQ(workgroupsFor(0, 64, 65535).x, 0u);
    EXPECT_EQ(workgroupsFor(0, 64, 65535).y, 0u);
    const WorkgroupGrid small = workgroupsFor(65, 64, 65535);
    EXPECT_EQ(small.x, 2u);  // ceil(65 / 64)
    EXPECT_EQ(small.y, 1u);
    const WorkgroupGrid wide = workgroupsFor(64ull * 70000, 64, 65535);  // 70000 groups
    EXPECT_EQ(wide.x, 65535u);
    EXPECT_EQ(wide.y, 2u);  // ceil(70000 / 65535)
    EXPECT_GE(std::uint64_t(wide.x) * wide.y * 64, 64ull * 70000);
}

}  // namespace
}  // namespace psub::vulkan
