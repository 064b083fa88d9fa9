// Internal, GPU-free: how table rows become compute dispatches. Rows are split into the
// longest chunks whose table ranges fit one descriptor binding (bindings start at multiples
// of the device's offset alignment), and a chunk's rows into a 2D grid of workgroups within
// maxComputeWorkGroupCount. Plain arithmetic on numbers taken from the device's limits, so
// tests/test_dispatch_plan.cpp checks it without a device.
#pragma once

#include <cstdint>
#include <functional>
#include <utility>
#include <vector>

namespace psub::vulkan {

struct BindingLimits {
    std::uint64_t bytes = 0;      // largest range bound to one descriptor (a multiple of alignment)
    std::uint64_t alignment = 16; // of a binding's offset
    std::uint64_t maxRows = 0;    // rows one dispatch may cover

    // True when `bytes` starting anywhere (rounded down to the alignment) fit one binding.
    bool fits(std::uint64_t rangeBytes) const { return rangeBytes + alignment <= bytes; }
};

using RowChunk = std::pair<std::uint64_t, std::uint64_t>;  // rows [first, second)

// Greedy split of rows [0, rows) into the longest chunks [a, b), at most maxRows each, for
// which fitsRange(a, b). Throws VulkanError naming `what` when one row alone does not fit.
std::vector<RowChunk> splitRows(std::uint64_t rows, const BindingLimits& limits,
                                const std::function<bool(std::uint64_t, std::uint64_t)>& fitsRange, const char* what);

// One chunk of a CSR table (row offsets, entries): its rows, its entries, and where its
// offsets (relative to the aligned start of its entries' binding) begin in the uploaded array.
struct CsrChunk {
    std::uint64_t rowBegin, rowEnd, entryBegin, entryEnd, offsetsBegin;
};

// Splits a CSR table (offsets: rows + 1 values) into chunks whose entries and offsets each fit
// one binding; appends each chunk's offsets, relative to the aligned start of its entries'
// binding, to `relative`.
template <class Offset>
std::vector<CsrChunk> splitCsr(const std::vector<Offset>& offsets, const BindingLimits& limits,
                               std::vector<std::uint32_t>& relative, const char* what) {
    const std::uint64_t rows = offsets.size() - 1;
    const auto ranges = splitRows(
        rows, limits,
        [&](std::uint64_t a, std::uint64_t b) {
            return limits.fits(4 * (std::uint64_t(offsets[b]) - std::uint64_t(offsets[a]))) && limits.fits(4 * (b - a + 1));
        },
        what);
    std::vector<CsrChunk> chunks;
    for (const auto& [a, b] : ranges) {
        CsrChunk c{a, b, std::uint64_t(offsets[a]), std::uint64_t(offsets[b]), relative.size()};
        const std::uint64_t first =
            c.entryBegin < c.entryEnd ? c.entryBegin * 4 / limits.alignment * limits.alignment / 4 : 0;
        for (std::uint64_t r = a; r <= b; ++r) relative.push_back(std::uint32_t(std::uint64_t(offsets[r]) - first));
        chunks.push_back(c);
    }
    return chunks;
}

// Workgroups for `rows` rows of `workgroupSize` each: x up to maxGroupsX, y as many as needed.
struct WorkgroupGrid {
    std::uint32_t x = 0, y = 0;
};
WorkgroupGrid workgroupsFor(std::uint64_t rows, std::uint32_t workgroupSize, std::uint32_t maxGroupsX);

}  // namespace psub::vulkan
