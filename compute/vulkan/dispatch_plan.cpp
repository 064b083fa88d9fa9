// GPU-free dispatch planning (dispatch_plan.h): row chunks that fit a binding, workgroup grids.
#include "dispatch_plan.h"

#include "psub/vulkan_evaluator.h"

#include <algorithm>
#include <string>

namespace psub::vulkan {

namespace {

std::string mib(std::uint64_t bytes) {
    return bytes < (1u << 20) ? std::to_string((bytes + 1023) >> 10) + " KiB"
                              : std::to_string((bytes + (1u << 20) - 1) >> 20) + " MiB";
}

}  // namespace

std::vector<RowChunk> splitRows(std::uint64_t rows, const BindingLimits& limits,
                                const std::function<bool(std::uint64_t, std::uint64_t)>& fitsRange, const char* what) {
    std::vector<RowChunk> chunks;
    for (std::uint64_t a = 0; a < rows;) {
        std::uint64_t b = std::min(rows, a + limits.maxRows);
        if (!fitsRange(a, b)) {
            std::uint64_t lo = a, hi = b;  // fitsRange(a, lo), !fitsRange(a, hi)
            while (hi - lo > 1) {
                const std::uint64_t mid = lo + (hi - lo) / 2;
                (fitsRange(a, mid) ? lo : hi) = mid;
            }
            b = lo;
        }
        if (b == a)
            throw VulkanError(std::string("one row of the ") + what + " needs more than one binding of " +
                              mib(limits.bytes));
        chunks.emplace_back(a, b);
        a = b;
    }
    return chunks;
}

WorkgroupGrid workgroupsFor(std::uint64_t rows, std::uint32_t workgroupSize, std::uint32_t maxGroupsX) {
    const std::uint64_t groups = (rows + workgroupSize - 1) / workgroupSize;
    WorkgroupGrid grid;
    grid.x = std::uint32_t(std::min<std::uint64_t>(groups, maxGroupsX));
    grid.y = grid.x ? std::uint32_t((groups + grid.x - 1) / grid.x) : 0;
    return grid;
}

}  // namespace psub::vulkan
