// The Vulkan evaluator's construction work on buffers: vertex buffers in binding-sized windows,
// the tables of each form uploaded once, and the stages of dispatches over them (rows split
// by dispatch_plan.h into chunks whose table ranges fit one binding).
#include "vulkan_evaluator_impl.h"

#include <algorithm>
#include <cassert>
#include <stdexcept>

namespace psub {
namespace {

// The vertex normals' fixed layout: 8 words a vertex (its faces, then the zero element's number).
constexpr std::uint32_t kVertexWords = 8;

}  // namespace

void VulkanEvaluator::Impl::makeVertexBuffer(VertexBuffer& v, std::uint64_t elements, std::uint32_t stride,
                                             bool mapped) {
    v.elements = elements;
    v.stride = stride;
    const std::uint64_t perWindow = windowElements(stride);
    if (perWindow == 0) throw VulkanError("binding limit of " + std::to_string(limit) + " bytes is too small");
    const std::uint64_t windows = std::max<std::uint64_t>(1, (elements + perWindow - 1) / perWindow);
    if (windows > PSUB_VERTEX_WINDOWS)
        throw VulkanError("a vertex buffer of " + mib(elements * stride * 4) + " needs " + std::to_string(windows) +
                          " bindings of at most " + mib(limit) + " on " + context.properties.deviceName +
                          "; PSub binds at most " + std::to_string(PSUB_VERTEX_WINDOWS));
    v.windows = std::uint32_t(windows);
    v.windowSize = std::uint32_t(std::min<std::uint64_t>(perWindow, 0xffffffffu));
    const bool map = mapped && !staging;
    v.buffer = createBuffer(context, elements * stride * 4, kUsage, Memory::Device, map);
}

// Windows are whole multiples of 64 elements, so each starts at a 256-byte multiple (the largest
// minStorageBufferOffsetAlignment the specification allows).
std::uint64_t VulkanEvaluator::Impl::windowElements(std::uint32_t stride) const {
    const std::uint64_t perWindow = limit / (4ull * stride);
    return perWindow - perWindow % 64;
}

void VulkanEvaluator::Impl::placeControlsInHostVisibleMemory(bool force) {
    if (!force && !hasHostVisibleDeviceMemory(context)) return;
    Buffer mapped;
    try {
        mapped = createBuffer(context, levels[0].buffer.size, kUsage, Memory::Device, true);
    } catch (const VulkanError&) {
        return;  // that memory is full (a small BAR): the staging copy
    }
    if (!force && !(mapped.flags & VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT)) {
        destroyBuffer(context, mapped);  // host memory: the shaders would read it across the bus
        return;
    }
    destroyBuffer(context, levels[0].buffer);
    levels[0].buffer = mapped;
    controlsInPlace = true;
}

Window VulkanEvaluator::Impl::window(const Buffer& buffer, std::uint64_t elementBytes, std::uint64_t begin,
                                     std::uint64_t end) const {
    Window w;
    w.buffer = buffer.buffer;
    if (begin >= end) {  // nothing is read: any valid range
        w.offset = 0;
        w.range = std::min<VkDeviceSize>(buffer.size, limit);
        return w;
    }
    w.offset = begin * elementBytes / alignment * alignment;
    w.range = end * elementBytes - w.offset;
    w.firstElement = w.offset / elementBytes;
    assert(w.offset % elementBytes == 0 && w.range <= limit && w.offset + w.range <= buffer.size);
    return w;
}

BindingLimits VulkanEvaluator::Impl::bindingLimits() const { return {limit, alignment, maxRows}; }

template <class Fits>
std::vector<std::pair<std::uint64_t, std::uint64_t>> VulkanEvaluator::Impl::split(std::uint64_t rows, Fits fitsRange,
                                                                                   const char* what) const {
    return splitRows(rows, bindingLimits(), fitsRange, what);
}

template <class Offset>
std::vector<CsrChunk> VulkanEvaluator::Impl::splitCsr(const std::vector<Offset>& offsets,
                                                      std::vector<std::uint32_t>& relative, const char* what) const {
    return vulkan::splitCsr(offsets, bindingLimits(), relative, what);
}

Dispatch VulkanEvaluator::Impl::dispatch(std::uint64_t rows) const {
    Dispatch d;
    d.push.rowCount = std::uint32_t(rows);
    const WorkgroupGrid grid =
        workgroupsFor(rows, PSUB_WORKGROUP_SIZE, context.properties.limits.maxComputeWorkGroupCount[0]);
    d.groupsX = grid.x, d.groupsY = grid.y;
    return d;
}

Dispatch VulkanEvaluator::Impl::csrDispatch(const CsrChunk& c, const Buffer& offsets, const Buffer& entries,
                                            const VertexBuffer& from, const VertexBuffer& to) const {
    Dispatch d = dispatch(c.rowEnd - c.rowBegin);
    d.source = &from;
    d.destination = &to;
    d.tables[0] = window(offsets, 4, c.offsetsBegin, c.offsetsBegin + (c.rowEnd - c.rowBegin) + 1);
    d.tables[1] = window(entries, 4, c.entryBegin, c.entryEnd);
    d.tables[2] = d.tables[1];
    d.push.rowBase = std::uint32_t(c.rowBegin);
    d.push.tableBase = std::uint32_t(c.offsetsBegin - d.tables[0].firstElement);
    d.push.sourceWindowSize = from.windowSize;
    d.push.destinationWindowSize = to.windowSize;
    return d;
}

namespace {

// Row shapes (n edge neighbours, m diagonals) with a pipeline of their own, the loop counts
// compiled in: face quads and triangles, retained vertices, valence 3 and 4 vertices.
bool specialisedShape(std::uint32_t n, std::uint32_t m) {
    return (n == 3 && m == 0) || (n == 4 && m == 4) || (n == 0 && m == 0) || (n == 2 && m == 0) || (n == 3 && m == 3);
}

}  // namespace


void VulkanEvaluator::Impl::buildPerLevel(const PerLevelTable& table, Uploader& uploader) {
    // The device's copy of the table: each row's 1 + n + m source indices, then its
    // destination, padded to a multiple of 4 words (fetched as uvec4: one fetch per 4 words).
    // A group of kMergedRows rows or more runs as dispatches of its own (one per chunk that fits
    // a binding), its record giving the weights and where its rows start, its shape picking the
    // pipeline. The smaller groups of a level's stage run together, in as few dispatches of any
    // shape as their words' windows allow: each group's rows from a multiple of the workgroup
    // size of the dispatch, found from the records' first rows (level.comp). The cow at 7 steps
    // has ten such groups a level (its extraordinary vertices by valence, 1 to 5807 rows): 93
    // dispatches a frame before, 21 now, a barrier after each. A dispatch of one group whose
    // destinations are consecutive (a level's face points; in the tiled form's walk order, every
    // group of its intermediate levels) writes row r at its first destination + r, its rows'
    // words the sources alone (PSUB_SPEC_IMPLICIT_DESTINATION).
    constexpr std::uint64_t kMergedRows = 1 << 14;
    // A VertexFromCentreAndFacePoints row, whose centre is the parent level's and its other
    // sources the level's own, runs here as two (level.comp reads one level a dispatch): in the
    // first stage a copy of its centre to its destination (`CentreCopy`: a retained row's shape,
    // words [P]), in the second the row reading that copy (`InPlace`: words [its destination, its
    // face points]; each invocation reads it before it writes it). The same products and sums in
    // the same order as the CPU's row: the same bits.
    enum class Words { AsTable, CentreCopy, InPlace };
    struct Part {
        const RowGroup* group;
        std::uint64_t a, b;  // its rows [a, b)
        Words words = Words::AsTable;
        std::uint32_t n() const { return words == Words::CentreCopy ? 0 : group->n; }
        std::uint32_t m() const { return words == Words::CentreCopy ? 0 : group->m; }
        std::uint32_t width() const { return 1 + n() + m(); }
    };
    struct Pending {
        std::size_t level;
        bool readsChild;  // readsOwnLevel groups: read the level they write
        std::vector<Part> parts;
        bool implicitDestination = false;  // one part, its destinations consecutive
    };
    const auto strideOf = [](const Part& part, bool implicit = false) {
        return (std::uint64_t(part.width()) + (implicit ? 3 : 4)) / 4 * 4;
    };
    const auto consecutive = [&](const RowGroup& g, std::uint64_t a, std::uint64_t b) {
        const std::uint32_t* d = table.destinations.data() + g.rowBegin;
        for (std::uint64_t r = a + 1; r < b; ++r)
            if (d[r] != d[a] + (r - a)) return false;
        return true;
    };
    const auto padded = [](std::uint64_t rows) { return (rows + PSUB_WORKGROUP_SIZE - 1) / PSUB_WORKGROUP_SIZE * PSUB_WORKGROUP_SIZE; };
    std::vector<Pending> pending;
    for (std::size_t k = 0; k < table.levels.size(); ++k) {
        const StencilLevel& level = table.levels[k];
        for (const bool readsChild : {false, true}) {
            Pending merged{k, readsChild, {}};
            std::uint64_t mergedWords = 0, mergedRows = 0;
            for (std::uint64_t gi = level.groupBegin; gi < level.groupEnd; ++gi) {
                const RowGroup& g = table.groups[gi];
                const bool twoStages = g.kind == RowKind::VertexFromCentreAndFacePoints;
                if (g.rowCount == 0 || (readsOwnLevel(g.kind) != readsChild && !twoStages)) continue;
                const Words shape = !twoStages ? Words::AsTable : readsChild ? Words::InPlace : Words::CentreCopy;
                const std::uint64_t stride = strideOf({&g, 0, 0, shape}), words = g.rowCount * stride;
                const bool alone = !fits(4 * words) || padded(g.rowCount) > maxRows;
                if (g.rowCount < kMergedRows && !alone) {
                    if (!fits(4 * (mergedWords + words)) || mergedRows + padded(g.rowCount) > maxRows) {
                        pending.push_back(std::move(merged));
                        merged = {k, readsChild, {}}, mergedWords = 0, mergedRows = 0;
                    }
                    merged.parts.push_back({&g, 0, g.rowCount, shape});
                    mergedWords += words, mergedRows += padded(g.rowCount);
                    continue;
                }
                for (const auto& [a, b] : split(
                         g.rowCount, [&](std::uint64_t x, std::uint64_t y) { return fits(4 * stride * (y - x)); },
                         "per-level table"))
                    pending.push_back({k, readsChild, {{&g, a, b, shape}}, consecutive(g, a, b)});
            }
            if (!merged.parts.empty()) pending.push_back(std::move(merged));
        }
    }
    // The words and records in the order of the dispatches (a dispatch's contiguous).
    std::vector<GroupRecord> records;
    std::vector<std::uint64_t> firstRecord, firstWord;
    std::uint64_t wordCount = 0;
    for (const Pending& p : pending) {
        firstRecord.push_back(records.size());
        firstWord.push_back(wordCount);
        const std::uint64_t wordFirst = wordCount * 4 / alignment * alignment / 4;  // the window's start
        std::uint32_t row = 0;
        for (const Part& part : p.parts) {
            const RowGroup& g = *part.group;
            const bool copy = part.words == Words::CentreCopy;
            records.push_back({row, std::uint32_t(wordCount - wordFirst), part.n(), part.m(), copy ? 1.0f : float(g.centre),
                               copy ? 0.0f : float(g.edge), copy ? 0.0f : float(g.diagonal), std::uint32_t(part.b - part.a)});
            wordCount += (part.b - part.a) * strideOf(part, p.implicitDestination);
            row += std::uint32_t(p.parts.size() > 1 ? padded(part.b - part.a) : part.b - part.a);
        }
    }
    firstRecord.push_back(records.size());
    firstWord.push_back(wordCount);
    const Buffer groups = uploader.upload(records, tables);
    const Buffer rows = uploader.uploadFilled<std::uint32_t>(
        wordCount,
        [&](std::uint32_t* words) {
            for (const Pending& p : pending)
                for (const Part& part : p.parts) {
                    const RowGroup& g = *part.group;
                    const std::uint64_t stride = strideOf(part, p.implicitDestination);
                    for (std::uint64_t r = part.a; r < part.b; ++r, words += stride) {
                        const std::uint32_t* ix = table.indices.data() + g.indexBegin + r * g.width;
                        std::uint32_t* end = std::copy(ix, ix + part.width(), words);
                        if (part.words == Words::InPlace) words[0] = table.destinations[g.rowBegin + r];
                        if (!p.implicitDestination) *end++ = table.destinations[g.rowBegin + r];
                        std::fill(end, words + stride, 0u);
                    }
                }
        },
        tables);
    // Per level, a stage of the rows that read the parent level, then (after its barrier) one of
    // the rows that read the level's own points (readsOwnLevel), which the first wrote.
    for (std::size_t k = 0; k < table.levels.size(); ++k)
        for (const bool readsChild : {false, true}) {
            const VertexBuffer& from = levels[readsChild ? k + 1 : k];
            Stage stage;
            stage.kernel = Kernel::Level;
            stage.specialization = {width, from.stride, levels[k + 1].stride, from.windows > 1, levels[k + 1].windows > 1};
            stage.written = &levels[k + 1];
            for (std::size_t i = 0; i < pending.size(); ++i) {
                const Pending& p = pending[i];
                if (p.level != k || p.readsChild != readsChild) continue;
                const Part& front = p.parts.front();
                const RowGroup& g = *front.group;
                const GroupRecord& last = records[firstRecord[i + 1] - 1];
                Dispatch d = dispatch(last.rowBegin + last.rowCount);
                const bool shaped = p.parts.size() == 1 && specialisedShape(front.n(), front.m());
                d.rowN = shaped ? front.n() : kAnyShape;
                d.rowM = shaped ? front.m() : kAnyShape;
                d.implicitDestination = p.implicitDestination;
                if (p.implicitDestination) d.push.rowBase = table.destinations[g.rowBegin + p.parts.front().a];
                d.source = &from;
                d.destination = &levels[k + 1];
                d.tables[0] = window(groups, sizeof(GroupRecord), firstRecord[i], firstRecord[i + 1]);
                d.tables[1] = window(rows, 4, firstWord[i], firstWord[i + 1]);
                d.tables[2] = d.tables[1];
                d.texelFormats[2] = VK_FORMAT_R32G32B32A32_UINT;
                d.push.groupBase = std::uint32_t(firstRecord[i] - d.tables[0].firstElement);
                d.push.groupCount = std::uint32_t(p.parts.size());
                const GroupRecord& first = records[firstRecord[i]];  // one group's, read from here
                d.push.groupN = first.n, d.push.groupM = first.m;
                d.push.groupIndexBegin = first.indexBegin;
                d.push.groupCentre = first.centre, d.push.groupEdge = first.edge, d.push.groupDiagonal = first.diagonal;
                d.push.sourceWindowSize = from.windowSize;
                d.push.destinationWindowSize = levels[k + 1].windowSize;
                stage.dispatches.push_back(d);
            }
            if (!stage.dispatches.empty()) stencilStages.push_back(std::move(stage));
        }
}

void VulkanEvaluator::Impl::buildFactorized(const FactorizedTable& table, Uploader& uploader) {
    std::vector<std::uint32_t> relative;
    const std::vector<CsrChunk> chunks = splitCsr(table.offsets, relative, "factorized table");
    const Buffer offsets = uploader.upload(relative, tables);
    const Buffer indices = uploader.upload(table.indices, tables);
    const Buffer weights = uploader.upload(table.weights, tables);
    Stage stage;
    stage.kernel = Kernel::Factorized;
    stage.specialization = {width, levels.front().stride, refinedBuffer().stride, levels.front().windows > 1,
                            refinedBuffer().windows > 1};
    stage.written = &refinedBuffer();
    for (const CsrChunk& c : chunks) {
        Dispatch d = dispatch(c.rowEnd - c.rowBegin);
        d.source = &levels.front();
        d.destination = &refinedBuffer();
        d.tables[0] = window(offsets, 4, c.offsetsBegin, c.offsetsBegin + (c.rowEnd - c.rowBegin) + 1);
        d.tables[1] = window(indices, 4, c.entryBegin, c.entryEnd);
        d.tables[2] = window(weights, 4, c.entryBegin, c.entryEnd);
        d.push.rowBase = std::uint32_t(c.rowBegin);
        d.push.tableBase = std::uint32_t(c.offsetsBegin - d.tables[0].firstElement);
        d.push.sourceWindowSize = levels.front().windowSize;
        d.push.destinationWindowSize = refinedBuffer().windowSize;
        stage.dispatches.push_back(d);
    }
    stencilStages.push_back(std::move(stage));
}

void VulkanEvaluator::Impl::buildTiles(const TiledTable& table, bool unrolled, std::uint32_t blockLimit,
                                       Uploader& uploader) {
    // One workgroup (unrolled: one invocation) per block of at most `side` lattice intervals a
    // side; a tile's blocks in order. Dispatches cover whole tiles whose gathered grids, border
    // entries and block records each fit one binding.
    if (blockLimit != 0 && blockLimit != PSUB_TILE_BLOCK && blockLimit != PSUB_TILE_WIDE_BLOCK)
        throw std::invalid_argument("VulkanEvaluator: the tile block side is 16 or 32, not " + std::to_string(blockLimit));
    if (table.tileCount() == 0) return;
    const std::uint32_t t = table.doubleSteps, halo = table.halo;
    // The largest grid a block of side M keeps (its window, then each double step's but the
    // last's) with a halo of h level-B cells.
    const auto gridFor = [&](std::uint32_t M, std::uint32_t h) {
        std::uint32_t n = (M >> t) + 2 * h + 1, largest = n;
        for (std::uint32_t s = 0; s + 1 < t; ++s) largest = std::max(largest, n = 2 * n - 9);
        return largest;
    };
    const auto sharedBytes = [](std::uint32_t g) { return 16 * (g * g + (g - 1) * (g - 1) + (g - 2) * (g - 2)); };
    const std::uint32_t sharedLimit = context.properties.limits.maxComputeSharedMemorySize;
    std::uint32_t side = PSUB_TILE_BLOCK;
    if (!unrolled && blockLimit != PSUB_TILE_BLOCK &&
        (blockLimit == PSUB_TILE_WIDE_BLOCK || sharedBytes(gridFor(PSUB_TILE_WIDE_BLOCK, halo)) <= sharedLimit))
        side = PSUB_TILE_WIDE_BLOCK;
    // Workgroup kernel: a tile of side L is cut into (L / M)^2 blocks, M the largest multiple of
    // 2^t dividing L and at most `side` (whole level-B cells, so a block's window is a part of
    // the tile's gathered grid). Unrolled kernel: M = PSUB_TILE_BLOCK, compiled in, the last
    // block of a row or column cut by the tile's side.
    const auto blockSide = [&](std::uint32_t L) {
        if (unrolled) return std::uint32_t(PSUB_TILE_BLOCK);
        std::uint32_t M = std::min<std::uint32_t>(L, side) >> t << t;
        while (L % M != 0) M -= 1u << t;
        return M;
    };
    std::uint32_t widest = 1u << t;  // the shared grids are sized for the widest block used
    for (std::size_t k = 0; k < table.tileCount(); ++k) widest = std::max(widest, blockSide(table.lattice(k)));
    const std::uint32_t grid = gridFor(widest, halo);
    tileBlockSide = widest;
    // The unrolled kernel compiles in the halo of t, t + 1 (docs/tiled.md).
    if (t == 0 || t > 3 || grid > (widest <= PSUB_TILE_BLOCK ? PSUB_TILE_GRID : PSUB_TILE_WIDE_GRID) ||
        (unrolled && halo != t + 1))
        throw std::invalid_argument("VulkanEvaluator: the tiled table's " + std::to_string(t) + " double steps and halo " +
                                    std::to_string(halo) + " need grids beyond the tile kernel's");
    if (!unrolled && sharedBytes(grid) > sharedLimit)
        throw std::invalid_argument("VulkanEvaluator: tile blocks of " + std::to_string(widest) + " need " +
                                    std::to_string(sharedBytes(grid)) + " bytes of shared memory, the device has " +
                                    std::to_string(sharedLimit));
    // The normals in the tile kernel (VulkanEvaluatorOptions::fusedTileNormals): its last fine
    // pass keeps lattice points -2 .. M of each side (tile.comp, emitWithNormals), so the last
    // fine grid must reach two points before the block and past it: r0 >= 2 (t = 3), or at
    // t = 1, 2 a halo one level-B cell wider (r0 = 2^t then); the shared memory must hold that
    // grid and those of the steps; positions of 3 or 4 values in one binding window.
    const auto firstPoint = [&](std::uint32_t h) { return int(h << t) + 4 - int(4u << t); };  // r0
    const std::uint32_t fusedHalo = firstPoint(halo) >= 2 ? halo : halo + 1;
    bool reaches = fusedTileNormals && !unrolled && (width == 3 || width == 4) && refinedBuffer().windows == 1;
    for (std::size_t k = 0; k < table.tileCount() && reaches; ++k) {
        const std::uint32_t M = blockSide(table.lattice(k));
        std::uint32_t n = (M >> t) + 2 * fusedHalo + 1;
        for (std::uint32_t s = 0; s + 1 < t; ++s) n = 2 * n - 9;
        reaches = std::uint32_t(firstPoint(fusedHalo)) - 2 + M + 3 <= 2 * n - 9;  // the last fine grid's valid side
    }
    const std::uint32_t fusedGrid = gridFor(widest, fusedHalo), kept = widest + 3;
    if (reaches && sharedBytes(fusedGrid) + 16 * (kept * kept - std::min(kept * kept, fusedGrid * fusedGrid)) <= sharedLimit)
        tileKeptSide = kept, tileFusedGrid = fusedGrid;
    const auto blocksOf = [&](std::size_t k) {
        const std::uint64_t L = table.lattice(k), M = blockSide(table.lattice(k)), perSide = (L + M - 1) / M;
        return perSide * perSide;
    };
    std::vector<std::uint64_t> blockBegin{0};  // per tile: its first block
    for (std::size_t k = 0; k < table.tileCount(); ++k) blockBegin.push_back(blockBegin.back() + blocksOf(k));
    BindingLimits limits = bindingLimits();
    limits.maxRows = std::max<std::uint64_t>(1, limits.maxRows / (std::uint64_t(PSUB_WORKGROUP_SIZE) * PSUB_TILE_BLOCK *
                                                                   PSUB_TILE_BLOCK));  // tiles, not rows
    const std::vector<RowChunk> chunks = splitRows(
        table.tileCount(), limits,
        [&](std::uint64_t a, std::uint64_t b) {
            return fits(4 * (table.gatherBegin[b] - table.gatherBegin[a])) &&
                   fits(4 * (table.borderBegin[b] - table.borderBegin[a])) &&
                   fits(sizeof(TileRecord) * (blockBegin[b] - blockBegin[a]));
        },
        "tiled table");
    const Buffer gather = uploader.upload(table.gather, tables);
    const Buffer border = uploader.upload(table.border, tables);
    // First element of a window starting at `begin` (window() rounds its offset down).
    const auto firstElement = [&](std::uint64_t begin, std::uint64_t bytes) { return begin * bytes / alignment * alignment / bytes; };
    const Buffer records = uploader.uploadFilled<TileRecord>(
        blockBegin.back(),
        [&](TileRecord* out) {
            for (const auto& [a, b] : chunks) {
                const std::uint64_t gatherFirst = firstElement(table.gatherBegin[a], 4);
                const std::uint64_t borderFirst = firstElement(table.borderBegin[a], 4);
                for (std::size_t k = a; k < b; ++k) {
                    const std::uint32_t L = table.lattice(k), M = blockSide(L), g = table.gridSize(k);
                    const std::uint32_t end = k + 1 < table.tileCount() ? table.output[k + 1] : table.fallbackBegin;
                    for (std::uint32_t Y0 = 0; Y0 < L; Y0 += M)
                        for (std::uint32_t X0 = 0; X0 < L; X0 += M)
                            *out++ = {std::uint32_t(table.gatherBegin[k] - gatherFirst + (Y0 >> t) * g + (X0 >> t)), g, L, M,
                                      X0 | Y0 << 16, table.output[k], end,
                                      std::uint32_t(table.borderBegin[k] - borderFirst)};
                }
            }
        },
        tables);
    Stage stage;
    stage.kernel = unrolled ? Kernel::TileUnrolled : Kernel::Tile;
    const VertexBuffer& base = levels[table.baseLevel];
    stage.specialization = {width, base.stride, refinedBuffer().stride, base.windows > 1, refinedBuffer().windows > 1};
    stage.specialization.tileSteps = t;
    stage.specialization.tileGrid = grid;
    if (!unrolled) {
        // Unless asked for: 512 invocations for blocks of 32, 256 for blocks of 16 (the fastest
        // on an NVIDIA H200, bench/README.md "Session 22": more invocations keep more lanes busy
        // on the small grids), at most what the device runs.
        const VkPhysicalDeviceLimits& device = context.properties.limits;
        std::uint32_t threads = tileThreads ? tileThreads : widest > PSUB_TILE_BLOCK ? 512 : 256;
        while (threads > PSUB_WORKGROUP_SIZE &&
               (threads > device.maxComputeWorkGroupInvocations || threads > device.maxComputeWorkGroupSize[0]))
            threads /= 2;
        stage.specialization.tileThreads = threads;
    }
    stage.written = &refinedBuffer();
    for (const auto& [a, b] : chunks) {
        const std::uint64_t blocks = blockBegin[b] - blockBegin[a];
        Dispatch d = dispatch(unrolled ? blocks : blocks * PSUB_WORKGROUP_SIZE);
        d.source = &base;
        d.destination = &refinedBuffer();
        d.tables[0] = window(records, sizeof(TileRecord), blockBegin[a], blockBegin[b]);
        d.tables[1] = window(gather, 4, table.gatherBegin[a], table.gatherBegin[b]);
        d.tables[2] = window(border, 4, table.borderBegin[a], table.borderBegin[b]);
        assert(d.tables[1].firstElement == firstElement(table.gatherBegin[a], 4) &&
               d.tables[2].firstElement == firstElement(table.borderBegin[a], 4));
        d.texelFormats[0] = VK_FORMAT_R32G32B32A32_UINT;
        d.push.rowCount = std::uint32_t(blocks);
        d.push.groupBase = t;
        d.push.groupCount = halo;
        d.push.tableBase = std::uint32_t(blockBegin[a] - d.tables[0].firstElement);
        d.push.sourceWindowSize = base.windowSize;
        d.push.destinationWindowSize = refinedBuffer().windowSize;
        stage.dispatches.push_back(d);
    }
    tileStage = stencilStages.size();
    stencilStages.push_back(std::move(stage));
}

void VulkanEvaluator::Impl::buildNormals(const SurfaceTable& surface, const TiledTable* tiled, Uploader& uploader) {
    const std::uint64_t faces = surface.faceOffsets.size() - 1;
    makeVertexBuffer(normals, surface.vertexCount, 4, true);  // padded: written as vec4, read back as xyz
    // Two fixed layouts that save the kernels their offset loads (one uvec4 fetch per 4 words):
    // all faces quads (corners of face f at 4 f), and vertices in at most 8 faces (vertex v's 8
    // words at 8 v: its faces in table order, then the zero element's number; or 4, below). A
    // few vertices in more faces (`heavy`: the cow's 38 of 1.1M at 7 steps, valences up to 14)
    // do not stop the fixed layout: their sums are overwritten after it by their own CSR rows
    // (listed).
    bool allQuads = faces > 0;
    for (std::uint64_t f = 0; f < faces && allQuads; ++f) allQuads = surface.faceOffsets[f + 1] - surface.faceOffsets[f] == 4;
    const auto inMoreFacesThan = [&](std::uint32_t words) {
        std::vector<std::uint32_t> vertices;
        for (std::uint32_t v = 0; v < surface.vertexCount; ++v)
            if (surface.vertexOffsets[v + 1] - surface.vertexOffsets[v] > words) vertices.push_back(v);
        return vertices;
    };
    std::vector<std::uint32_t> heavy = inMoreFacesThan(kVertexWords);
    const bool fixedVertices = surface.vertexCount > 0 && heavy.size() <= surface.vertexCount / 64;
    if (tiled && allQuads && fixedVertices && heavy.empty() && buildTileNormals(*tiled, surface, uploader)) return;
    // Four words a vertex where as few are in more faces (a quad mesh's vertices are mostly in
    // four): one uvec4 fetch a vertex instead of two, half the table (the cow at 7 steps: 2,800
    // of 1.1M vertices heavy then; 18 MB less).
    std::uint32_t words = kVertexWords;
    if (fixedVertices)
        if (std::vector<std::uint32_t> four = inMoreFacesThan(4); four.size() <= surface.vertexCount / 64)
            heavy = std::move(four), words = 4;
    // Padded: read and written as vec4. One element more, after the faces': zero, cleared by
    // every frame, for the fixed vertex layout's unused slots.
    makeVertexBuffer(faceNormals, faces + 1, 4, false);
    std::vector<std::uint32_t> faceRelative, vertexRelative;
    const std::vector<CsrChunk> faceChunks = splitCsr(surface.faceOffsets, faceRelative, "surface's faces");
    const Buffer faceVerts = uploader.upload(surface.faceVerts, tables);
    // Quads need no offsets: the face kernel then reads none, and its offsets binding gets the
    // corners (any valid range).
    const Buffer faceOffsets = allQuads ? faceVerts : uploader.upload(faceRelative, tables);
    const VertexBuffer& positions = refinedBuffer();
    Buffer vertexWords;
    std::vector<std::pair<std::uint64_t, std::uint64_t>> vertexRows;
    if (fixedVertices) {
        vertexWords = uploader.uploadFilled<std::uint32_t>(
            std::size_t(surface.vertexCount) * words,
            [&](std::uint32_t* to) {
                for (std::uint32_t v = 0; v < surface.vertexCount; ++v, to += words) {
                    const std::uint32_t begin = surface.vertexOffsets[v];
                    const std::uint32_t end = std::min(surface.vertexOffsets[v + 1], begin + words);
                    std::copy(surface.vertexFaces.begin() + begin, surface.vertexFaces.begin() + end, to);
                    std::fill(to + (end - begin), to + words, std::uint32_t(faces));
                }
            },
            tables);
        vertexRows = split(
            surface.vertexCount, [&](std::uint64_t a, std::uint64_t b) { return fits(4 * words * (b - a)); },
            "surface's vertex faces");
    }
    // Otherwise the CSR table of each vertex's faces.
    const std::vector<CsrChunk> vertexChunks =
        fixedVertices ? std::vector<CsrChunk>{} : splitCsr(surface.vertexOffsets, vertexRelative, "surface's vertex faces");
    const Buffer vertexOffsets = fixedVertices ? Buffer{} : uploader.upload(vertexRelative, tables);
    const Buffer vertexFaces = fixedVertices ? Buffer{} : uploader.upload(surface.vertexFaces, tables);

    Stage faceStage;
    faceStage.kernel = Kernel::FaceNormals;
    faceStage.specialization = {3, positions.stride, faceNormals.stride, positions.windows > 1, faceNormals.windows > 1};
    faceStage.written = &faceNormals;
    for (const CsrChunk& c : faceChunks) {
        Dispatch d = csrDispatch(c, faceOffsets, faceVerts, positions, faceNormals);
        if (allQuads) {  // corners of row r at 4 r from tableBase, fetched as one uvec4
            d.rowN = 4;
            d.texelFormats[1] = VK_FORMAT_R32G32B32A32_UINT;
            d.push.tableBase = std::uint32_t(c.entryBegin - d.tables[1].firstElement);
        }
        faceStage.dispatches.push_back(d);
    }
    Stage vertexStage;
    vertexStage.kernel = Kernel::VertexNormals;
    vertexStage.specialization = {3, faceNormals.stride, normals.stride, faceNormals.windows > 1, normals.windows > 1};
    vertexStage.written = &normals;
    for (const auto& [a, b] : vertexRows) {
        Dispatch d = dispatch(b - a);
        d.source = &faceNormals;
        d.destination = &normals;
        d.tables[0] = window(vertexWords, 4, words * a, words * b);
        d.tables[1] = d.tables[2] = d.tables[0];
        d.texelFormats[0] = d.texelFormats[1] = d.texelFormats[2] = VK_FORMAT_R32G32B32A32_UINT;
        d.rowN = words;
        d.push.groupBase = std::uint32_t(faces);  // the zero element
        d.push.groupCount = words / 4;            // uvec4s per vertex
        d.push.rowBase = std::uint32_t(a);
        d.push.tableBase = std::uint32_t(words * a - d.tables[1].firstElement);
        d.push.sourceWindowSize = faceNormals.windowSize;
        d.push.destinationWindowSize = normals.windowSize;
        vertexStage.dispatches.push_back(d);
    }
    for (const CsrChunk& c : vertexChunks)
        vertexStage.dispatches.push_back(csrDispatch(c, vertexOffsets, vertexFaces, faceNormals, normals));
    normalStages.push_back(std::move(faceStage));
    normalStages.push_back(std::move(vertexStage));
    if (fixedVertices && !heavy.empty()) normalStages.push_back(heavyVertexStage(surface, heavy, uploader));
}

// The vertex normals of the vertices in more faces than the fixed layout holds, after it: CSR
// rows of only those vertices (TABLE_A offsets, TABLE_B faces), row r written at vertex
// heavy[r] (TABLE_C; vertex_normals.comp with PSUB_SPEC_LISTED).
Stage VulkanEvaluator::Impl::heavyVertexStage(const SurfaceTable& surface, const std::vector<std::uint32_t>& heavy,
                                              Uploader& uploader) {
    std::vector<std::uint64_t> offsets{0};
    std::vector<std::uint32_t> heavyFaces, relative;
    for (std::uint32_t v : heavy) {
        heavyFaces.insert(heavyFaces.end(), surface.vertexFaces.begin() + surface.vertexOffsets[v],
                          surface.vertexFaces.begin() + surface.vertexOffsets[v + 1]);
        offsets.push_back(heavyFaces.size());
    }
    const std::vector<CsrChunk> chunks = splitCsr(offsets, relative, "surface's vertex faces");
    const Buffer offsetTable = uploader.upload(relative, tables), faceTable = uploader.upload(heavyFaces, tables);
    const Buffer ids = uploader.upload(heavy, tables);
    Stage stage;
    stage.kernel = Kernel::VertexNormals;
    stage.specialization = {3, faceNormals.stride, normals.stride, faceNormals.windows > 1, normals.windows > 1};
    stage.specialization.listed = true;
    stage.written = &normals;
    for (const CsrChunk& c : chunks) {
        Dispatch d = csrDispatch(c, offsetTable, faceTable, faceNormals, normals);
        d.tables[2] = window(ids, 4, c.rowBegin, c.rowEnd);  // row r's vertex
        d.push.rowBase = std::uint32_t(c.rowBegin - d.tables[2].firstElement);
        stage.dispatches.push_back(d);
    }
    return stage;
}

// The tiled form's normals split as CpuEvaluator splits them (tileNormalSets): the tiles' inner
// points by implicit addressing (tile_normals.comp), the faces that touch the other points and
// those points listed, in tables of their own sized by them: the listed faces' corners, 4 a face
// in the list's order (face_normals.comp's quad layout: a face's normal written at its place in
// the list), and each listed vertex's 8 words (vertex_normals.comp, PSUB_SPEC_LISTED), its faces'
// places in that list. So the face normals, corners and words take 64 bytes per listed face and
// vertex, not per face and vertex of the surface (1 GB less on a 16.8M-face torus). Only where
// the tile pass is worth it (the tiles' inner points are most points) and the positions,
// normals, face normals and border list each fit one binding; false, with nothing built,
// otherwise.
bool VulkanEvaluator::Impl::buildTileNormals(const TiledTable& tiled, const SurfaceTable& surface, Uploader& uploader) {
    const VertexBuffer& positions = refinedBuffer();
    if (positions.windows > 1 || normals.windows > 1 || !fits(4 * std::uint64_t(tiled.border.size()))) return false;
    const TileNormalSets sets = tileNormalSets(tiled);
    if (!sets.worthIt) return false;
    std::vector<std::uint32_t> faces = sets.restFaces;  // every face that touches a listed vertex
    faces.insert(faces.end(), sets.ringFaces.begin(), sets.ringFaces.end());
    std::sort(faces.begin(), faces.end());
    faces.erase(std::unique(faces.begin(), faces.end()), faces.end());
    const std::uint64_t listedFaces = faces.size(), listedVertices = sets.restVertices.size();
    if (listedFaces + 1 > windowElements(4)) return false;  // the face normals in one window
    const Buffer corners = uploader.uploadFilled<std::uint32_t>(
        4 * faces.size(),
        [&](std::uint32_t* to) {
            for (std::uint32_t f : faces)
                to = std::copy_n(surface.faceVerts.begin() + surface.faceOffsets[f], 4, to);
        },
        tables);
    const Buffer words = uploader.uploadFilled<std::uint32_t>(
        std::size_t(listedVertices) * kVertexWords,
        [&](std::uint32_t* to) {
            for (std::uint32_t v : sets.restVertices) {
                assert(surface.vertexOffsets[v + 1] - surface.vertexOffsets[v] <= kVertexWords);  // no heavy vertex
                std::uint32_t* end = to + kVertexWords;
                for (std::uint32_t j = surface.vertexOffsets[v]; j < surface.vertexOffsets[v + 1]; ++j) {
                    const auto at = std::lower_bound(faces.begin(), faces.end(), surface.vertexFaces[j]);
                    if (at == faces.end() || *at != surface.vertexFaces[j])
                        throw std::logic_error("buildTileNormals: a listed vertex's face is not listed");
                    *to++ = std::uint32_t(at - faces.begin());
                }
                to = std::fill_n(to, end - to, std::uint32_t(listedFaces));  // the zero element
            }
        },
        tables);
    makeVertexBuffer(faceNormals, listedFaces + 1, 4, false);  // padded; the zero element last
    // Runs of PSUB_NORMAL_RUN x PSUB_NORMAL_ROWS inner points of each tile (config.h).
    std::vector<std::uint32_t> runs;
    for (std::size_t k = 0; k < tiled.tileCount(); ++k) {
        const std::uint32_t L = tiled.lattice(k);
        for (std::uint32_t y = 1; y < L; y += PSUB_NORMAL_ROWS)
            for (std::uint32_t x = 1; x < L; x += PSUB_NORMAL_RUN)
                runs.insert(runs.end(), {tiled.output[k], L | y << 16, std::uint32_t(tiled.borderBegin[k]), x});
    }
    const Buffer border = uploader.upload(tiled.border, tables);
    const Buffer runTable = uploader.upload(runs, tables);
    const Buffer vertexList = uploader.upload(sets.restVertices, tables);

    // Rows [0, count) of a list or run table of `bytes` per row, in dispatches whose window of it fits.
    const auto chunks = [&](std::uint64_t count, std::uint64_t bytes, const char* what) {
        return split(count, [&](std::uint64_t a, std::uint64_t b) { return fits(bytes * (b - a)); }, what);
    };
    // The normals in the tile kernel where it can (buildTiles): a second tile stage, with them,
    // for frames with normals; the plain one for frames without; the pass below only for the
    // normals of uploaded positions (frames that run no tile kernel).
    if (tileKeptSide != 0 && tileStage < stencilStages.size()) {
        Stage fused = stencilStages[tileStage];
        fused.specialization.tileKeptSide = tileKeptSide;
        fused.specialization.tileGrid = tileFusedGrid;
        fused.alsoWritten = &normals;
        fused.runs = StageRuns::WithNormals;
        for (Dispatch& d : fused.dispatches) d.secondDestination = &normals;
        stencilStages[tileStage].runs = StageRuns::WithoutNormals;
        stencilStages.insert(stencilStages.begin() + std::ptrdiff_t(tileStage) + 1, std::move(fused));
    }
    Stage runStage;
    runStage.kernel = Kernel::TileNormals;
    if (tileKeptSide != 0) runStage.runs = StageRuns::WithoutStencils;
    runStage.specialization = {3, positions.stride, normals.stride, false, false};
    runStage.written = &normals;
    for (const auto& [a, b] : chunks(runs.size() / 4, 16, "tile normal runs")) {
        Dispatch d = dispatch(b - a);
        d.source = &positions;
        d.destination = &normals;
        d.tables[0] = window(runTable, 16, a, b);
        d.tables[1] = d.tables[2] = window(border, 4, 0, tiled.border.size());
        d.texelFormats[0] = VK_FORMAT_R32G32B32A32_UINT;
        d.push.tableBase = std::uint32_t(a - d.tables[0].firstElement);
        runStage.dispatches.push_back(d);
    }
    // The listed faces' normals: row r (face faces[r]) from its corners at 4 r, written at r.
    Stage faceStage;
    faceStage.kernel = Kernel::FaceNormals;
    faceStage.specialization = {3, positions.stride, faceNormals.stride, false, false};
    faceStage.written = &faceNormals;
    for (const auto& [a, b] : chunks(listedFaces, 16, "listed faces")) {
        Dispatch d = dispatch(b - a);
        d.source = &positions;
        d.destination = &faceNormals;
        d.tables[0] = d.tables[1] = d.tables[2] = window(corners, 4, 4 * a, 4 * b);  // TABLE_A unread (quads)
        d.texelFormats[1] = VK_FORMAT_R32G32B32A32_UINT;
        d.rowN = 4;
        d.push.rowBase = std::uint32_t(a);
        d.push.tableBase = std::uint32_t(4 * a - d.tables[1].firstElement);
        faceStage.dispatches.push_back(d);
    }
    // The listed vertices' normals: row r (vertex restVertices[r], TABLE_A) from its 8 words at 8 r.
    Stage vertexStage;
    vertexStage.kernel = Kernel::VertexNormals;
    vertexStage.specialization = {3, faceNormals.stride, normals.stride, false, false};
    vertexStage.specialization.listed = true;
    vertexStage.written = &normals;
    for (const auto& [a, b] : chunks(listedVertices, 4 * kVertexWords, "listed vertices")) {
        Dispatch d = dispatch(b - a);
        d.source = &faceNormals;
        d.destination = &normals;
        d.tables[0] = window(vertexList, 4, a, b);
        d.tables[1] = d.tables[2] = window(words, 4, kVertexWords * a, kVertexWords * b);
        d.texelFormats[1] = d.texelFormats[2] = VK_FORMAT_R32G32B32A32_UINT;
        d.rowN = kVertexWords;
        d.push.rowBase = std::uint32_t(a - d.tables[0].firstElement);
        d.push.tableBase = std::uint32_t(kVertexWords * a - d.tables[1].firstElement);
        d.push.groupBase = std::uint32_t(listedFaces);  // the zero element
        d.push.groupCount = kVertexWords / 4;           // uvec4s per vertex
        vertexStage.dispatches.push_back(d);
    }
    normalStages.push_back(std::move(faceStage));
    normalStages.push_back(std::move(vertexStage));
    normalStages.push_back(std::move(runStage));
    tileNormals = true;
    return true;
}

}  // namespace psub
