// The Vulkan evaluator. Construction does all the work that does not change per frame:
// tables uploaded, every buffer bound (in windows no larger than maxStorageBufferRange, rows
// split into chunks whose table ranges fit one binding), one descriptor set per dispatch.
// A frame's command buffer is recorded once per kind of frame and resubmitted: write the
// control points, submit, wait on the fence, copy out what was asked for.
#include "psub/vulkan_evaluator.h"
#include "psub/vulkan_interop.h"

#include "device.h"
#include "dispatch_plan.h"
#include "pipelines.h"
#include "resources.h"

#include <algorithm>
#include <cassert>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <map>
#include <tuple>
#include <string>

namespace psub {

using namespace vulkan;

namespace {

constexpr std::uint32_t kMaxWidth = 16;
constexpr VkBufferUsageFlags kUsage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_UNIFORM_TEXEL_BUFFER_BIT |
                                      VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT |
                                      VK_BUFFER_USAGE_VERTEX_BUFFER_BIT;  // refined positions and normals are drawn

// Frame kinds: which parts a frame's command buffer holds.
enum : unsigned {
    kStencils = 1,       // control points uploaded, stencil tables applied
    kNormals = 2,        // both normal passes
    kReadRefined = 4,    // refined positions copied back
    kReadNormals = 8,    // normals copied back
    kUploadRefined = 16, // refined positions uploaded (normals of given positions)
    kFrameKinds = 32,
};
enum : std::uint32_t { kQueryStart, kQueryStencils, kQueryNormals, kQueryEnd, kQueryCount };

// Copies `count` elements of `width` floats between buffers of `fromStride` and `toStride`
// floats per element; padding values written are 0.
void copyElements(float* to, std::uint32_t toStride, const float* from, std::uint32_t fromStride, std::size_t count,
                  std::uint32_t width) {
    if (toStride == width && fromStride == width) {
        if (count) std::memcpy(to, from, count * width * sizeof(float));
        return;
    }
    for (std::size_t v = 0; v < count; ++v) {
        for (std::uint32_t i = 0; i < width; ++i) to[v * toStride + i] = from[v * fromStride + i];
        for (std::uint32_t i = width; i < toStride; ++i) to[v * toStride + i] = 0.0f;
    }
}

std::string mib(std::uint64_t bytes) {
    return bytes < (1u << 20) ? std::to_string((bytes + 1023) >> 10) + " KiB"
                              : std::to_string((bytes + (1u << 20) - 1) >> 20) + " MiB";
}

// A vertex-like buffer (a level's positions, face normals, normals), bound as up to
// PSUB_VERTEX_WINDOWS consecutive windows of `windowSize` elements.
struct VertexBuffer {
    Buffer buffer;
    std::uint64_t elements = 0;
    std::uint32_t stride = 0;      // floats per element
    std::uint32_t windowSize = 0;  // elements per window
    std::uint32_t windows = 1;
};

// A range of a table array bound to one descriptor: elements from firstElement on.
struct Window {
    VkBuffer buffer = VK_NULL_HANDLE;
    VkDeviceSize offset = 0, range = 0;
    std::uint64_t firstElement = 0;
};

constexpr std::uint32_t kAnyShape = ~0u;

struct Dispatch {
    VkDescriptorSet set = VK_NULL_HANDLE;
    PushConstants push{};
    std::uint32_t groupsX = 0, groupsY = 0;
    std::uint32_t rowN = kAnyShape, rowM = kAnyShape;  // level kernel: the rows' shape, when compiled in
    VkFormat texelFormats[3] = {VK_FORMAT_R32_UINT, VK_FORMAT_R32_UINT, VK_FORMAT_R32_UINT};  // table texel views
    // What the descriptor set binds (written once, at construction).
    const VertexBuffer* source = nullptr;
    const VertexBuffer* destination = nullptr;
    Window tables[3];
};

// Dispatches of one kernel that may run together, then a barrier on what they wrote.
struct Stage {
    Kernel kernel = Kernel::Level;
    Specialization specialization;
    std::vector<Dispatch> dispatches;
    const VertexBuffer* written = nullptr;
};


// Table uploads: written in place where memory is host-visible, else through staging buffers
// copied by one command buffer at the end.
class Uploader {
public:
    Uploader(VulkanContext::Impl& context, bool direct) : context_(context), direct_(direct) {}
    ~Uploader() {
        for (Buffer& b : staging_) destroyBuffer(context_, b);
    }

    template <class T>
    Buffer upload(const std::vector<T>& data, std::vector<Buffer>& owner) {
        const VkDeviceSize bytes = data.size() * sizeof(T);
        owner.push_back(createBuffer(context_, bytes, kUsage, Memory::Device, direct_));
        Buffer& b = owner.back();
        if (direct_) {
            if (bytes) std::memcpy(b.mapped, data.data(), bytes);
        } else if (bytes) {
            staging_.push_back(createBuffer(context_, bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, Memory::Upload, true));
            std::memcpy(staging_.back().mapped, data.data(), bytes);
            copies_.push_back({staging_.back().buffer, b.buffer, bytes});
        }
        return b;
    }

    // A buffer of `count` T written in place by fill(T*) (no copy of the data on the heap).
    template <class T, class Fill>
    Buffer uploadFilled(std::size_t count, Fill fill, std::vector<Buffer>& owner) {
        const VkDeviceSize bytes = count * sizeof(T);
        owner.push_back(createBuffer(context_, bytes, kUsage, Memory::Device, direct_));
        const Buffer b = owner.back();
        if (!bytes) return b;
        if (direct_) {
            fill(static_cast<T*>(b.mapped));
        } else {
            staging_.push_back(createBuffer(context_, bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, Memory::Upload, true));
            fill(static_cast<T*>(staging_.back().mapped));
            copies_.push_back({staging_.back().buffer, b.buffer, bytes});
        }
        return b;
    }

    // Runs the staging copies (if any) and waits for them.
    void finish(VkCommandPool pool, VkFence fence) {
        if (copies_.empty()) return;
        VkCommandBufferAllocateInfo allocate{};
        allocate.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
        allocate.commandPool = pool;
        allocate.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
        allocate.commandBufferCount = 1;
        VkCommandBuffer command = VK_NULL_HANDLE;
        VK_CHECK(vkAllocateCommandBuffers(context_.device, &allocate, &command));
        VkCommandBufferBeginInfo begin{};
        begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
        begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
        VK_CHECK(vkBeginCommandBuffer(command, &begin));
        for (const Copy& c : copies_) {
            const VkBufferCopy region{0, 0, c.bytes};
            vkCmdCopyBuffer(command, c.from, c.to, 1, &region);
        }
        memoryBarrier(command, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT,
                      VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
                      VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_TRANSFER_READ_BIT);
        VK_CHECK(vkEndCommandBuffer(command));
        submitAndWait(context_, command, fence);
        vkFreeCommandBuffers(context_.device, pool, 1, &command);
        copies_.clear();
    }

private:
    struct Copy {
        VkBuffer from, to;
        VkDeviceSize bytes;
    };
    VulkanContext::Impl& context_;
    bool direct_;
    std::vector<Buffer> staging_;
    std::vector<Copy> copies_;
};

}  // namespace

struct VulkanEvaluator::Impl {
    VulkanContext::Impl& context;
    std::uint32_t width, controls, refined;
    bool staging = false;
    bool texels = false;  // kernels read inputs and tables through texel buffers (config.h)
    std::uint64_t limit = 0, alignment = 16, maxRows = 0;

    std::vector<VertexBuffer> levels;   // levels[0]: control points; levels.back(): refined (may be levels[0])
    VertexBuffer faceNormals, normals;
    std::vector<Buffer> tables;         // uploaded once
    Buffer controlUpload, refinedHost, normalsHost;  // staging only
    std::vector<Stage> stencilStages, normalStages;
    bool hasSurface = false;
    const SurfaceTable* drawnSurface = nullptr;  // the contract's drawing order (kept by reference)
    VkCommandBuffer deviceFrame = VK_NULL_HANDLE;  // submit(): re-recorded per call
    VkFence deviceFence = VK_NULL_HANDLE;          // submit(): signalled when its frame is done

    VkDescriptorPool descriptorPool = VK_NULL_HANDLE;
    std::vector<VkBufferView> views;  // the texel-buffer bindings of every dispatch
    VkCommandPool commandPool = VK_NULL_HANDLE;
    VkCommandBuffer frames[kFrameKinds] = {};
    VkFence fence = VK_NULL_HANDLE;
    VkQueryPool queries = VK_NULL_HANDLE;
    GpuFrameTimes times;
    HostFrameTimes hostTimes;

    Impl(VulkanContext::Impl& c, std::uint32_t w) : context(c), width(w), controls(0), refined(0) {}
    ~Impl();

    VertexBuffer& refinedBuffer() { return levels.back(); }

    // Construction steps.
    void makeVertexBuffer(VertexBuffer& v, std::uint64_t elements, std::uint32_t stride, bool mapped);
    Window window(const Buffer& buffer, std::uint64_t elementBytes, std::uint64_t begin, std::uint64_t end) const;
    bool fits(std::uint64_t bytes) const { return bindingLimits().fits(bytes); }
    BindingLimits bindingLimits() const;
    template <class Fits>
    std::vector<std::pair<std::uint64_t, std::uint64_t>> split(std::uint64_t rows, Fits fitsRange, const char* what) const;
    template <class Offset>
    std::vector<CsrChunk> splitCsr(const std::vector<Offset>& offsets, std::vector<std::uint32_t>& relative,
                                   const char* what) const;
    Dispatch dispatch(std::uint64_t rows) const;
    void buildPerLevel(const PerLevelTable& table, Uploader& uploader);
    void buildFactorized(const FactorizedTable& table, Uploader& uploader);
    void buildNormals(const SurfaceTable& surface, Uploader& uploader);
    void writeDescriptorSets();

    // Frames.
    VkCommandBuffer frame(unsigned kind);
    // One frame of `kind`: uploads `control`, submits, waits, copies out what was asked for.
    void frame(std::span<const float> control, unsigned kind, std::span<float> refinedOut, std::span<float> normalsOut);
    void record(VkCommandBuffer command, unsigned kind);
    void runStages(VkCommandBuffer command, const std::vector<Stage>& stages);
    void submit(unsigned kind);
    // Caller-owned buffers (psub/vulkan_interop.h).
    void recordDevice(VkCommandBuffer command, const VulkanDeviceBuffers& buffers);
    void waitDeviceFrame();
};

void VulkanEvaluator::Impl::makeVertexBuffer(VertexBuffer& v, std::uint64_t elements, std::uint32_t stride,
                                             bool mapped) {
    v.elements = elements;
    v.stride = stride;
    // Windows are whole multiples of 64 elements, so each starts at a 256-byte multiple (the
    // largest minStorageBufferOffsetAlignment the specification allows).
    std::uint64_t perWindow = limit / (4ull * stride);
    perWindow -= perWindow % 64;
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

// Row shapes (n edge neighbours, m diagonals) with a pipeline of their own, the loop counts
// compiled in: face quads and triangles, retained vertices, valence 3 and 4 vertices.
bool specialisedShape(std::uint32_t n, std::uint32_t m) {
    return (n == 3 && m == 0) || (n == 4 && m == 4) || (n == 0 && m == 0) || (n == 2 && m == 0) || (n == 3 && m == 3);
}

void VulkanEvaluator::Impl::buildPerLevel(const PerLevelTable& table, Uploader& uploader) {
    // The device's copy of the table: each row's 1 + n + m source indices, then its
    // destination, padded to a multiple of 4 words (fetched as uvec4: one fetch per 4 words).
    // One dispatch per group (per chunk of a group too large for one binding): the group's
    // record gives the weights and where its rows start; its shape picks the pipeline.
    std::uint64_t wordCount = 0;
    std::vector<GroupRecord> records;
    struct Pending {
        std::size_t level;
        Dispatch dispatch;
        std::uint64_t record, wordBegin, wordEnd;
    };
    std::vector<Pending> pending;
    for (std::size_t k = 0; k < table.levels.size(); ++k) {
        const StencilLevel& level = table.levels[k];
        for (std::uint64_t gi = level.groupBegin; gi < level.groupEnd; ++gi) {
            const RowGroup& g = table.groups[gi];
            if (g.rowCount == 0) continue;
            const std::uint64_t stride = (std::uint64_t(g.width) + 4) / 4 * 4;
            const std::uint64_t groupWords = wordCount;
            wordCount += g.rowCount * stride;
            const auto chunks = split(
                g.rowCount, [&](std::uint64_t a, std::uint64_t b) { return fits(4 * stride * (b - a)); }, "per-level table");
            for (const auto& [a, b] : chunks) {
                Pending p{k, dispatch(b - a), records.size(), groupWords + a * stride, groupWords + b * stride};
                p.dispatch.rowN = specialisedShape(g.n, g.m) ? g.n : kAnyShape;
                p.dispatch.rowM = specialisedShape(g.n, g.m) ? g.m : kAnyShape;
                const std::uint64_t wordFirst = p.wordBegin * 4 / alignment * alignment / 4;
                records.push_back({0, std::uint32_t(p.wordBegin - wordFirst), g.n, g.m, float(g.centre), float(g.edge),
                                   float(g.diagonal), 0});
                pending.push_back(p);
            }
        }
    }
    const Buffer groups = uploader.upload(records, tables);
    const Buffer rows = uploader.uploadFilled<std::uint32_t>(
        wordCount,
        [&](std::uint32_t* words) {
            for (const StencilLevel& level : table.levels)
                for (std::uint64_t gi = level.groupBegin; gi < level.groupEnd; ++gi) {
                    const RowGroup& g = table.groups[gi];
                    const std::uint64_t stride = (std::uint64_t(g.width) + 4) / 4 * 4;
                    for (std::uint64_t r = 0; r < g.rowCount; ++r, words += stride) {
                        const std::uint32_t* ix = table.indices.data() + g.indexBegin + r * g.width;
                        std::copy(ix, ix + g.width, words);
                        words[g.width] = table.destinations[g.rowBegin + r];
                        std::fill(words + g.width + 1, words + stride, 0u);
                    }
                }
        },
        tables);
    for (std::size_t k = 0; k < table.levels.size(); ++k) {
        Stage stage;
        stage.kernel = Kernel::Level;
        stage.specialization = {width, levels[k].stride, levels[k + 1].stride, levels[k].windows > 1,
                                levels[k + 1].windows > 1};
        stage.written = &levels[k + 1];
        for (Pending& p : pending) {
            if (p.level != k) continue;
            Dispatch& d = p.dispatch;
            d.source = &levels[k];
            d.destination = &levels[k + 1];
            d.tables[0] = window(groups, sizeof(GroupRecord), p.record, p.record + 1);
            d.tables[1] = window(rows, 4, p.wordBegin, p.wordEnd);
            d.tables[2] = d.tables[1];
            d.texelFormats[2] = VK_FORMAT_R32G32B32A32_UINT;
            d.push.groupBase = std::uint32_t(p.record - d.tables[0].firstElement);
            d.push.groupCount = 1;
            d.push.sourceWindowSize = levels[k].windowSize;
            d.push.destinationWindowSize = levels[k + 1].windowSize;
            stage.dispatches.push_back(d);
        }
        stencilStages.push_back(std::move(stage));
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

void VulkanEvaluator::Impl::buildNormals(const SurfaceTable& surface, Uploader& uploader) {
    const std::uint64_t faces = surface.faceOffsets.size() - 1;
    // Padded: read and written as vec4. One element more, after the faces': zero, cleared by
    // every frame, for the fixed vertex layout's unused slots.
    makeVertexBuffer(faceNormals, faces + 1, 4, false);
    makeVertexBuffer(normals, surface.vertexCount, 4, true);  // padded: written as vec4, read back as xyz
    std::vector<std::uint32_t> faceRelative, vertexRelative;
    const std::vector<CsrChunk> faceChunks = splitCsr(surface.faceOffsets, faceRelative, "surface's faces");
    const Buffer faceOffsets = uploader.upload(faceRelative, tables);
    const Buffer faceVerts = uploader.upload(surface.faceVerts, tables);
    const VertexBuffer& positions = refinedBuffer();
    // Two fixed layouts that save the kernels their offset loads (one uvec4 fetch per 4 words):
    // all faces quads (corners of face f at 4 f), and every vertex in at most 8 faces (vertex
    // v's 8 words at 8 v: its faces in table order, then the zero element's number).
    bool allQuads = faces > 0;
    for (std::uint64_t f = 0; f < faces && allQuads; ++f) allQuads = surface.faceOffsets[f + 1] - surface.faceOffsets[f] == 4;
    constexpr std::uint32_t kVertexWords = 8;
    bool fixedVertices = surface.vertexCount > 0;
    for (std::uint32_t v = 0; v < surface.vertexCount && fixedVertices; ++v)
        fixedVertices = surface.vertexOffsets[v + 1] - surface.vertexOffsets[v] <= kVertexWords;
    Buffer vertexWords;
    std::vector<std::pair<std::uint64_t, std::uint64_t>> vertexRows;
    if (fixedVertices) {
        vertexWords = uploader.uploadFilled<std::uint32_t>(
            std::size_t(surface.vertexCount) * kVertexWords,
            [&](std::uint32_t* words) {
                for (std::uint32_t v = 0; v < surface.vertexCount; ++v, words += kVertexWords) {
                    const std::uint32_t begin = surface.vertexOffsets[v], end = surface.vertexOffsets[v + 1];
                    std::copy(surface.vertexFaces.begin() + begin, surface.vertexFaces.begin() + end, words);
                    std::fill(words + (end - begin), words + kVertexWords, std::uint32_t(faces));
                }
            },
            tables);
        vertexRows = split(
            surface.vertexCount, [&](std::uint64_t a, std::uint64_t b) { return fits(4 * kVertexWords * (b - a)); },
            "surface's vertex faces");
    }
    // Otherwise the CSR table of each vertex's faces.
    const std::vector<CsrChunk> vertexChunks =
        fixedVertices ? std::vector<CsrChunk>{} : splitCsr(surface.vertexOffsets, vertexRelative, "surface's vertex faces");
    const Buffer vertexOffsets = fixedVertices ? Buffer{} : uploader.upload(vertexRelative, tables);
    const Buffer vertexFaces = fixedVertices ? Buffer{} : uploader.upload(surface.vertexFaces, tables);

    // One chunk of a CSR table (row offsets, entries) as a dispatch from `from` to `to`.
    const auto csrDispatch = [&](const CsrChunk& c, const Buffer& offsets, const Buffer& entries,
                                 const VertexBuffer& from, const VertexBuffer& to) {
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
    };
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
        d.tables[0] = window(vertexWords, 4, kVertexWords * a, kVertexWords * b);
        d.tables[1] = d.tables[2] = d.tables[0];
        d.texelFormats[0] = d.texelFormats[1] = d.texelFormats[2] = VK_FORMAT_R32G32B32A32_UINT;
        d.rowN = kVertexWords;
        d.push.groupBase = std::uint32_t(faces);  // the zero element
        d.push.groupCount = kVertexWords / 4;     // uvec4s per vertex
        d.push.rowBase = std::uint32_t(a);
        d.push.tableBase = std::uint32_t(kVertexWords * a - d.tables[1].firstElement);
        d.push.sourceWindowSize = faceNormals.windowSize;
        d.push.destinationWindowSize = normals.windowSize;
        vertexStage.dispatches.push_back(d);
    }
    for (const CsrChunk& c : vertexChunks)
        vertexStage.dispatches.push_back(csrDispatch(c, vertexOffsets, vertexFaces, faceNormals, normals));
    normalStages.push_back(std::move(faceStage));
    normalStages.push_back(std::move(vertexStage));
}

void VulkanEvaluator::Impl::writeDescriptorSets() {
    std::uint32_t sets = 0;
    for (const auto* stages : {&stencilStages, &normalStages})
        for (const Stage& s : *stages) sets += std::uint32_t(s.dispatches.size());
    if (sets == 0) return;
    const VkDescriptorPoolSize sizes[2] = {
        {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, sets * PSUB_BINDING_STORAGE_COUNT},
        {VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER, sets * (PSUB_BINDING_COUNT - PSUB_BINDING_STORAGE_COUNT)}};
    VkDescriptorPoolCreateInfo poolInfo{};
    poolInfo.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
    poolInfo.maxSets = sets;
    poolInfo.poolSizeCount = 2;
    poolInfo.pPoolSizes = sizes;
    VK_CHECK(vkCreateDescriptorPool(context.device, &poolInfo, nullptr, &descriptorPool));
    const VkDescriptorSetLayout layout = context.pipelines->setLayout();
    // A vertex buffer's window w (window 0 again beyond its last: every binding must be valid).
    auto vertexWindow = [&](const VertexBuffer& v, std::uint32_t w) {
        VkDescriptorBufferInfo info{v.buffer.buffer, 0, v.buffer.size};
        if (v.elements == 0) return info;
        if (w >= v.windows) w = 0;
        const std::uint64_t first = std::uint64_t(w) * v.windowSize;
        const std::uint64_t count = std::min<std::uint64_t>(v.windowSize, v.elements - first);
        info.offset = first * v.stride * 4;
        info.range = count * v.stride * 4;
        return info;
    };
    // One view per distinct range and format (the dispatches of a level share their input's).
    std::map<std::tuple<VkBuffer, VkDeviceSize, VkDeviceSize, VkFormat>, VkBufferView> made;
    auto view = [&](const VkDescriptorBufferInfo& info, VkFormat format) {
        VkBufferView& found = made[std::tuple(info.buffer, info.offset, info.range, format)];
        if (found) return found;
        VkBufferViewCreateInfo viewInfo{};
        viewInfo.sType = VK_STRUCTURE_TYPE_BUFFER_VIEW_CREATE_INFO;
        viewInfo.buffer = info.buffer;
        viewInfo.format = format;
        viewInfo.offset = info.offset;
        viewInfo.range = info.range;
        VK_CHECK(vkCreateBufferView(context.device, &viewInfo, nullptr, &found));
        views.push_back(found);
        return found;
    };
    for (auto* stages : {&stencilStages, &normalStages})
        for (Stage& s : *stages)
            for (Dispatch& d : s.dispatches) {
                VkDescriptorSetAllocateInfo allocate{};
                allocate.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
                allocate.descriptorPool = descriptorPool;
                allocate.descriptorSetCount = 1;
                allocate.pSetLayouts = &layout;
                VK_CHECK(vkAllocateDescriptorSets(context.device, &allocate, &d.set));
                VkDescriptorBufferInfo infos[PSUB_BINDING_STORAGE_COUNT];
                for (std::uint32_t w = 0; w < PSUB_VERTEX_WINDOWS; ++w) {
                    infos[PSUB_BINDING_SOURCE + w] = vertexWindow(*d.source, w);
                    infos[PSUB_BINDING_DESTINATION + w] = vertexWindow(*d.destination, w);
                }
                for (int t = 0; t < 3; ++t)
                    infos[PSUB_BINDING_TABLE_A + t] = {d.tables[t].buffer, d.tables[t].offset, d.tables[t].range};
                // The texel-buffer bindings: the input's windows and the three table windows.
                VkBufferView texelViews[PSUB_BINDING_COUNT] = {};
                const VkFormat sourceFormat =
                    d.source->stride == 4 ? VK_FORMAT_R32G32B32A32_SFLOAT : VK_FORMAT_R32_SFLOAT;
                for (std::uint32_t w = 0; w < PSUB_VERTEX_WINDOWS; ++w)
                    texelViews[PSUB_BINDING_SOURCE_TEXELS + w] = view(infos[PSUB_BINDING_SOURCE + w], sourceFormat);
                for (int t = 0; t < 3; ++t)
                    texelViews[PSUB_BINDING_TABLE_A_TEXELS + t] = view(infos[PSUB_BINDING_TABLE_A + t], d.texelFormats[t]);
                VkWriteDescriptorSet writes[PSUB_BINDING_COUNT];
                for (std::uint32_t b = 0; b < PSUB_BINDING_COUNT; ++b) {
                    writes[b] = {};
                    writes[b].sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
                    writes[b].dstSet = d.set;
                    writes[b].dstBinding = b;
                    writes[b].descriptorCount = 1;
                    if (b < PSUB_BINDING_STORAGE_COUNT) {
                        writes[b].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
                        writes[b].pBufferInfo = &infos[b];
                    } else {
                        writes[b].descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER;
                        writes[b].pTexelBufferView = &texelViews[b];
                    }
                }
                vkUpdateDescriptorSets(context.device, PSUB_BINDING_COUNT, writes, 0, nullptr);
            }
}

VulkanEvaluator::Impl::~Impl() {
    if (context.device) vkDeviceWaitIdle(context.device);
    if (queries) vkDestroyQueryPool(context.device, queries, nullptr);
    if (fence) vkDestroyFence(context.device, fence, nullptr);
    if (deviceFence) vkDestroyFence(context.device, deviceFence, nullptr);
    if (commandPool) vkDestroyCommandPool(context.device, commandPool, nullptr);
    if (descriptorPool) vkDestroyDescriptorPool(context.device, descriptorPool, nullptr);
    for (VkBufferView v : views) vkDestroyBufferView(context.device, v, nullptr);
    for (Buffer& b : tables) destroyBuffer(context, b);
    for (std::size_t k = 0; k < levels.size(); ++k)
        if (k == 0 || levels[k].buffer.buffer != levels[0].buffer.buffer) destroyBuffer(context, levels[k].buffer);
    for (Buffer* b : {&faceNormals.buffer, &normals.buffer, &controlUpload, &refinedHost, &normalsHost})
        destroyBuffer(context, *b);
}

VkCommandBuffer VulkanEvaluator::Impl::frame(unsigned kind) {
    if (frames[kind]) return frames[kind];
    VkCommandBufferAllocateInfo allocate{};
    allocate.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
    allocate.commandPool = commandPool;
    allocate.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    allocate.commandBufferCount = 1;
    VkCommandBuffer command = VK_NULL_HANDLE;
    VK_CHECK(vkAllocateCommandBuffers(context.device, &allocate, &command));
    try {
        record(command, kind);
    } catch (...) {
        vkFreeCommandBuffers(context.device, commandPool, 1, &command);
        throw;
    }
    return frames[kind] = command;
}

void VulkanEvaluator::Impl::runStages(VkCommandBuffer command, const std::vector<Stage>& stages) {
    const VkPipelineLayout layout = context.pipelines->layout();
    for (const Stage& stage : stages) {
        if (stage.dispatches.empty()) continue;
        for (std::size_t i = 0; i < stage.dispatches.size(); ++i) {
            const Dispatch& d = stage.dispatches[i];
            if (i == 0 || d.rowN != stage.dispatches[i - 1].rowN || d.rowM != stage.dispatches[i - 1].rowM) {
                Specialization specialization = stage.specialization;
                specialization.rowN = d.rowN;
                specialization.rowM = d.rowM;
                vkCmdBindPipeline(command, VK_PIPELINE_BIND_POINT_COMPUTE, context.pipelines->get(stage.kernel, specialization));
            }
            // Chunks of one stage write disjoint rows but bind the same windows: order them too.
            if (i > 0)
                bufferBarrier(command, stage.written->buffer, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
                              VK_ACCESS_SHADER_WRITE_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
                              VK_ACCESS_SHADER_WRITE_BIT);
            vkCmdBindDescriptorSets(command, VK_PIPELINE_BIND_POINT_COMPUTE, layout, 0, 1, &d.set, 0, nullptr);
            vkCmdPushConstants(command, layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(PushConstants), &d.push);
            vkCmdDispatch(command, d.groupsX, d.groupsY, 1);
        }
        bufferBarrier(command, stage.written->buffer, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_WRITE_BIT,
                      VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT | VK_PIPELINE_STAGE_HOST_BIT,
                      VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_TRANSFER_READ_BIT | VK_ACCESS_HOST_READ_BIT);
    }
}

void VulkanEvaluator::Impl::record(VkCommandBuffer command, unsigned kind) {
    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    VK_CHECK(vkBeginCommandBuffer(command, &begin));
    if (queries) {
        vkCmdResetQueryPool(command, queries, 0, kQueryCount);
        vkCmdWriteTimestamp(command, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, queries, kQueryStart);
    }
    // Upload barrier: the host's writes (and the previous frame's device writes) before this
    // frame's copies and dispatches.
    memoryBarrier(command, VK_PIPELINE_STAGE_HOST_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT | VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
                  VK_ACCESS_HOST_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT | VK_ACCESS_SHADER_WRITE_BIT,
                  VK_PIPELINE_STAGE_TRANSFER_BIT | VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
                  VK_ACCESS_TRANSFER_READ_BIT | VK_ACCESS_TRANSFER_WRITE_BIT | VK_ACCESS_SHADER_READ_BIT |
                      VK_ACCESS_SHADER_WRITE_BIT);
    if (staging && (kind & (kStencils | kUploadRefined))) {
        if (kind & kStencils) {
            const VkBufferCopy region{0, 0, std::uint64_t(controls) * levels.front().stride * 4};
            if (region.size) vkCmdCopyBuffer(command, controlUpload.buffer, levels.front().buffer.buffer, 1, &region);
        }
        if (kind & kUploadRefined) {
            const VkBufferCopy region{0, 0, std::uint64_t(refined) * refinedBuffer().stride * 4};
            if (region.size) vkCmdCopyBuffer(command, refinedHost.buffer, refinedBuffer().buffer.buffer, 1, &region);
        }
        memoryBarrier(command, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT,
                      VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
                      VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_TRANSFER_READ_BIT);
    }
    if (kind & kStencils) runStages(command, stencilStages);
    if (queries) vkCmdWriteTimestamp(command, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, queries, kQueryStencils);
    if (kind & kNormals) {
        // The zero element after the face normals (see buildNormals).
        vkCmdFillBuffer(command, faceNormals.buffer.buffer, (faceNormals.elements - 1) * faceNormals.stride * 4,
                        faceNormals.stride * 4, 0);
        memoryBarrier(command, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT,
                      VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT);
        runStages(command, normalStages);
    }
    if (queries) vkCmdWriteTimestamp(command, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, queries, kQueryNormals);
    if (staging && (kind & (kReadRefined | kReadNormals))) {
        if (kind & kReadRefined) {
            const VkBufferCopy region{0, 0, std::uint64_t(refined) * refinedBuffer().stride * 4};
            if (region.size) vkCmdCopyBuffer(command, refinedBuffer().buffer.buffer, refinedHost.buffer, 1, &region);
        }
        if (kind & kReadNormals) {
            const VkBufferCopy region{0, 0, std::uint64_t(refined) * normals.stride * 4};
            if (region.size) vkCmdCopyBuffer(command, normals.buffer.buffer, normalsHost.buffer, 1, &region);
        }
        memoryBarrier(command, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_HOST_BIT,
                      VK_ACCESS_HOST_READ_BIT);
    }
    // The results drawn straight from these buffers (keptPositions, keptNormals) by later commands.
    memoryBarrier(command, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_WRITE_BIT,
                  VK_PIPELINE_STAGE_VERTEX_INPUT_BIT, VK_ACCESS_VERTEX_ATTRIBUTE_READ_BIT);
    if (queries) vkCmdWriteTimestamp(command, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, queries, kQueryEnd);
    VK_CHECK(vkEndCommandBuffer(command));
}

void VulkanEvaluator::Impl::submit(unsigned kind) {
    submitAndWait(context, frame(kind), fence);
    times = {};
    if (queries) {
        std::uint64_t stamps[kQueryCount];
        VK_CHECK(vkGetQueryPoolResults(context.device, queries, 0, kQueryCount, sizeof stamps, stamps, sizeof stamps[0],
                                       VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT));
        const std::uint64_t mask =
            context.timestampValidBits >= 64 ? ~0ull : (1ull << context.timestampValidBits) - 1;
        const double msPerTick = double(context.properties.limits.timestampPeriod) * 1e-6;
        auto span = [&](int a, int b) { return double((stamps[b] - stamps[a]) & mask) * msPerTick; };
        times = {true, span(kQueryStart, kQueryEnd), span(kQueryStart, kQueryStencils), span(kQueryStencils, kQueryNormals)};
    }
}

VulkanEvaluator::VulkanEvaluator(VulkanContext& context, const PerLevelTable& perLevel,
                                 const FactorizedTable& factorized, const SurfaceTable& surface, TableForm form,
                                 std::uint32_t width, const VulkanEvaluatorOptions& options)
    : impl_(std::make_unique<Impl>(contextInternals(context), width)) {
    if (width == 0 || width > kMaxWidth)
        throw std::invalid_argument("VulkanEvaluator: width must be 1 to " + std::to_string(kMaxWidth));
    if (form == TableForm::Tiled) throw std::invalid_argument("VulkanEvaluator: no tiled form on Vulkan yet");
    if (form == TableForm::Factorized &&
        (factorized.rowCount() != perLevel.refinedCount() || factorized.controlCount != perLevel.controlCount))
        throw std::invalid_argument("VulkanEvaluator: the factorized table was not built for these levels");
    Impl& e = *impl_;
    VulkanContext::Impl& c = e.context;
    e.controls = perLevel.controlCount;
    e.refined = perLevel.refinedCount();
    e.drawnSurface = &surface;
    e.hasSurface = width >= 3 && surface.faceOffsets.size() > 1;
    if (e.hasSurface && (surface.vertexCount != e.refined || surface.vertexOffsets.size() != std::size_t(e.refined) + 1))
        throw std::invalid_argument("VulkanEvaluator: the surface table was not built for these levels");
    const VkPhysicalDeviceLimits& limits = c.properties.limits;
    e.limit = limits.maxStorageBufferRange;
    if (options.maxBindingBytes) e.limit = std::min<std::uint64_t>(e.limit, options.maxBindingBytes);
    e.alignment = std::max<std::uint64_t>({16, limits.minStorageBufferOffsetAlignment, limits.minTexelBufferOffsetAlignment});
    e.limit = e.limit / e.alignment * e.alignment;
    if (e.limit < 4 * e.alignment) throw std::invalid_argument("VulkanEvaluator: maxBindingBytes is too small");
    e.maxRows = std::min<std::uint64_t>(std::uint64_t(limits.maxComputeWorkGroupCount[0]) *
                                            limits.maxComputeWorkGroupCount[1] * PSUB_WORKGROUP_SIZE,
                                        1ull << 31);
    // Texel-buffer reads wherever every window fits a texel buffer (one texel per 4 bytes at
    // most); PSUB_VULKAN_TEXELS=0 turns them off (the storage-buffer path, for comparison).
    const char* texelsEnv = std::getenv("PSUB_VULKAN_TEXELS");
    e.texels = e.limit / 4 <= limits.maxTexelBufferElements && !(texelsEnv && std::string(texelsEnv) == "0");
    e.staging = options.staging == Staging::Always || !c.unifiedMemory() || !hasHostVisibleDeviceMemory(c);

    VkCommandPoolCreateInfo poolInfo{};

    poolInfo.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
    poolInfo.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;  // submit() re-records its buffer
    poolInfo.queueFamilyIndex = c.queueFamily;
    VK_CHECK(vkCreateCommandPool(c.device, &poolInfo, nullptr, &e.commandPool));
    VkFenceCreateInfo fenceInfo{};
    fenceInfo.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
    VK_CHECK(vkCreateFence(c.device, &fenceInfo, nullptr, &e.fence));
    if (c.timestampValidBits > 0) {
        VkQueryPoolCreateInfo queryInfo{};
        queryInfo.sType = VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO;
        queryInfo.queryType = VK_QUERY_TYPE_TIMESTAMP;
        queryInfo.queryCount = kQueryCount;
        VK_CHECK(vkCreateQueryPool(c.device, &queryInfo, nullptr, &e.queries));
    }

    // Vertex buffers: control points, each level (per-level form) or the finest (factorized).
    const std::size_t levelCount = form == TableForm::PerLevel ? perLevel.levels.size() : 1;
    e.levels.resize(levelCount + 1);
    // Every vertex buffer is padded from 3 to 4 floats per element (one vec4 load or store
    // each), the refined positions too: read-backs and uploads convert from and to packed xyz.
    const std::uint32_t padded = width == 3 ? 4 : width;
    e.makeVertexBuffer(e.levels[0], e.controls, padded, true);
    for (std::size_t k = 1; k <= levelCount; ++k)  // none for per-level with no levels: refined == control
            e.makeVertexBuffer(e.levels[k], form == TableForm::Factorized ? e.refined : perLevel.levels[k - 1].destinationCount,
                               padded, k == levelCount);
    if (e.staging) {
        e.controlUpload = createBuffer(c, std::uint64_t(e.controls) * e.levels[0].stride * 4, VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                                       Memory::Upload, true);
        e.refinedHost = createBuffer(c, std::uint64_t(e.refined) * e.refinedBuffer().stride * 4,
                                     VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                     Memory::Readback, true);
    }

    Uploader uploader(c, !e.staging);
    if (form == TableForm::PerLevel) e.buildPerLevel(perLevel, uploader);
    else e.buildFactorized(factorized, uploader);
    if (e.hasSurface) {
        e.buildNormals(surface, uploader);
        if (e.staging)
            e.normalsHost = createBuffer(c, std::uint64_t(e.refined) * e.normals.stride * 4, VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                         Memory::Readback, true);
    }
    uploader.finish(e.commandPool, e.fence);
    for (auto* stages : {&e.stencilStages, &e.normalStages})
        for (Stage& s : *stages) s.specialization.texels = e.texels;
    e.writeDescriptorSets();
}

VulkanEvaluator::~VulkanEvaluator() = default;

std::uint32_t VulkanEvaluator::controlCount() const { return impl_->controls; }
std::uint32_t VulkanEvaluator::refinedCount() const { return impl_->refined; }
std::uint32_t VulkanEvaluator::width() const { return impl_->width; }
GpuFrameTimes VulkanEvaluator::lastFrameTimes() const { return impl_->times; }
HostFrameTimes VulkanEvaluator::lastHostTimes() const { return impl_->hostTimes; }

std::size_t VulkanEvaluator::dispatchCount(bool withNormals) const {
    std::size_t count = 0;
    for (const Stage& s : impl_->stencilStages) count += s.dispatches.size();
    if (withNormals)
        for (const Stage& s : impl_->normalStages) count += s.dispatches.size();
    return count;
}

std::uint64_t VulkanEvaluator::deviceBytes() const {
    const Impl& e = *impl_;
    std::uint64_t bytes = 0;
    for (const Buffer& b : e.tables) bytes += b.size;
    for (std::size_t k = 0; k < e.levels.size(); ++k)
        if (k == 0 || e.levels[k].buffer.buffer != e.levels[0].buffer.buffer) bytes += e.levels[k].buffer.size;
    for (const Buffer* b : {&e.faceNormals.buffer, &e.normals.buffer, &e.controlUpload, &e.refinedHost, &e.normalsHost})
        bytes += b->size;
    return bytes;
}

void VulkanEvaluator::evaluateOnDevice(std::span<const float> control, bool withNormals) {
    Impl& e = *impl_;
    if (withNormals && !e.hasSurface) throw std::invalid_argument("VulkanEvaluator: normals need width >= 3 and a surface table");
    e.frame(control, kStencils | (withNormals ? unsigned(kNormals) : 0u), {}, {});
}

void VulkanEvaluator::evaluate(std::span<const float> control, std::span<float> refined, std::span<float> normals) {
    Impl& e = *impl_;
    if (!normals.empty() && !e.hasSurface) throw std::invalid_argument("VulkanEvaluator: normals need width >= 3 and a surface table");
    const unsigned kind = kStencils | (refined.empty() ? 0u : unsigned(kReadRefined)) |
                          (normals.empty() ? 0u : unsigned(kNormals | kReadNormals));
    e.frame(control, kind, refined, normals);
}

const SurfaceTable& VulkanEvaluator::surface() const { return *impl_->drawnSurface; }
std::string VulkanEvaluator::device() const { return impl_->context.properties.deviceName; }
std::uint32_t VulkanEvaluator::deviceStride() const { return impl_->levels.front().stride; }
VulkanBufferRange VulkanEvaluator::keptPositions() const { return {impl_->refinedBuffer().buffer.buffer, 0}; }
VulkanBufferRange VulkanEvaluator::keptNormals() const { return {impl_->normals.buffer.buffer, 0}; }

StageTimes VulkanEvaluator::lastTimes() const {
    const HostFrameTimes& host = impl_->hostTimes;
    const double normals = impl_->times.valid ? impl_->times.normalsMs : 0.0;  // without timestamps: in evaluate
    return {host.uploadMs, host.waitMs - normals, normals, host.readbackMs};
}

// Caller-owned buffers: copies in and out of the evaluator's own buffers (whose windows and
// descriptor sets were fixed at construction), with the barriers psub/vulkan_interop.h promises.
void VulkanEvaluator::Impl::recordDevice(VkCommandBuffer command, const VulkanDeviceBuffers& buffers) {
    if (!buffers.control.buffer) throw std::invalid_argument("VulkanEvaluator::record: no control buffer");
    const bool withNormals = buffers.normals.buffer != VK_NULL_HANDLE;
    if (withNormals && !hasSurface)
        throw std::invalid_argument("VulkanEvaluator: normals need width >= 3 and a surface table");
    // Every earlier write (the caller's to `control`; an earlier frame's to our buffers) and
    // read (of our buffers) before this frame's copies and dispatches.
    memoryBarrier(command, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, VK_ACCESS_MEMORY_WRITE_BIT,
                  VK_PIPELINE_STAGE_TRANSFER_BIT | VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
                  VK_ACCESS_TRANSFER_READ_BIT | VK_ACCESS_TRANSFER_WRITE_BIT | VK_ACCESS_SHADER_READ_BIT |
                      VK_ACCESS_SHADER_WRITE_BIT);
    const VkDeviceSize controlBytes = std::uint64_t(controls) * levels.front().stride * 4;
    if (controlBytes) {
        const VkBufferCopy region{buffers.control.offset, 0, controlBytes};
        vkCmdCopyBuffer(command, buffers.control.buffer, levels.front().buffer.buffer, 1, &region);
    }
    memoryBarrier(command, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT,
                  VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
                  VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_TRANSFER_READ_BIT);
    runStages(command, stencilStages);
    if (withNormals) {
        vkCmdFillBuffer(command, faceNormals.buffer.buffer, (faceNormals.elements - 1) * faceNormals.stride * 4,
                        faceNormals.stride * 4, 0);
        memoryBarrier(command, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT,
                      VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT);
        runStages(command, normalStages);
    }
    const VkDeviceSize refinedBytes = std::uint64_t(refined) * refinedBuffer().stride * 4;
    if (buffers.refined.buffer && refinedBytes) {
        const VkBufferCopy region{0, buffers.refined.offset, refinedBytes};
        vkCmdCopyBuffer(command, refinedBuffer().buffer.buffer, buffers.refined.buffer, 1, &region);
    }
    if (withNormals && refined) {
        const VkBufferCopy region{0, buffers.normals.offset, std::uint64_t(refined) * normals.stride * 4};
        vkCmdCopyBuffer(command, normals.buffer.buffer, buffers.normals.buffer, 1, &region);
    }
    memoryBarrier(command, VK_PIPELINE_STAGE_TRANSFER_BIT | VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
                  VK_ACCESS_TRANSFER_WRITE_BIT | VK_ACCESS_SHADER_WRITE_BIT, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT,
                  VK_ACCESS_MEMORY_READ_BIT | VK_ACCESS_VERTEX_ATTRIBUTE_READ_BIT | VK_ACCESS_SHADER_READ_BIT |
                      VK_ACCESS_TRANSFER_READ_BIT);
}

void VulkanEvaluator::record(VkCommandBuffer command, const VulkanDeviceBuffers& buffers) {
    impl_->recordDevice(command, buffers);
}

void VulkanEvaluator::Impl::waitDeviceFrame() {
    if (!deviceFence) return;
    VK_CHECK(vkWaitForFences(context.device, 1, &deviceFence, VK_TRUE, UINT64_MAX));
}

void VulkanEvaluator::submit(const VulkanDeviceBuffers& buffers, const VulkanSubmitSync& sync) {
    Impl& e = *impl_;
    if (!e.deviceFrame) {
        VkCommandBufferAllocateInfo allocate{};
        allocate.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
        allocate.commandPool = e.commandPool;
        allocate.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
        allocate.commandBufferCount = 1;
        VK_CHECK(vkAllocateCommandBuffers(e.context.device, &allocate, &e.deviceFrame));
        VkFenceCreateInfo fenceInfo{};
        fenceInfo.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
        fenceInfo.flags = VK_FENCE_CREATE_SIGNALED_BIT;
        VK_CHECK(vkCreateFence(e.context.device, &fenceInfo, nullptr, &e.deviceFence));
    }
    e.waitDeviceFrame();  // the previous submit() is done with the command buffer
    VK_CHECK(vkResetFences(e.context.device, 1, &e.deviceFence));
    VK_CHECK(vkResetCommandBuffer(e.deviceFrame, 0));
    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    VK_CHECK(vkBeginCommandBuffer(e.deviceFrame, &begin));
    e.recordDevice(e.deviceFrame, buffers);
    VK_CHECK(vkEndCommandBuffer(e.deviceFrame));
    VkSubmitInfo info{};
    info.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
    info.waitSemaphoreCount = sync.wait ? 1 : 0;
    info.pWaitSemaphores = &sync.wait;
    info.pWaitDstStageMask = &sync.waitStage;
    info.commandBufferCount = 1;
    info.pCommandBuffers = &e.deviceFrame;
    info.signalSemaphoreCount = sync.signal ? 1 : 0;
    info.pSignalSemaphores = &sync.signal;
    {
        std::lock_guard guard(e.context.submitLock);
        VK_CHECK(vkQueueSubmit(e.context.queue, 1, &info, e.deviceFence));
        if (sync.fence) VK_CHECK(vkQueueSubmit(e.context.queue, 0, nullptr, sync.fence));
    }
}

std::unique_ptr<Evaluator> makeVulkanEvaluator(VulkanContext& context, const EvaluatorTables& tables, TableForm form,
                                               const VulkanEvaluatorOptions& options) {
    if (form == TableForm::Tiled) throw std::invalid_argument("VulkanEvaluator: no tiled form on Vulkan yet");
    return std::make_unique<VulkanEvaluator>(context, tables.perLevel, tables.factorized, tables.surface, form, 3,
                                             options);
}

namespace {

// A Vulkan evaluator with the context it runs on (makeVulkanEvaluator without a context).
class OwningVulkanEvaluator final : public Evaluator {
public:
    OwningVulkanEvaluator(const EvaluatorTables& tables, TableForm form)
        : context_(std::make_unique<VulkanContext>()), evaluator_(makeVulkanEvaluator(*context_, tables, form)) {}
    std::uint32_t controlCount() const override { return evaluator_->controlCount(); }
    std::uint32_t refinedCount() const override { return evaluator_->refinedCount(); }
    const SurfaceTable& surface() const override { return evaluator_->surface(); }
    std::string device() const override { return evaluator_->device(); }
    void evaluate(std::span<const float> control, std::span<float> refined, std::span<float> normals) override {
        evaluator_->evaluate(control, refined, normals);
    }
    void evaluateKept(std::span<const float> control, bool withNormals) override {
        evaluator_->evaluateKept(control, withNormals);
    }
    bool resultsOnHost() const override { return false; }
    StageTimes lastTimes() const override { return evaluator_->lastTimes(); }

private:
    std::unique_ptr<VulkanContext> context_;  // declared first: destroyed after the evaluator
    std::unique_ptr<Evaluator> evaluator_;
};

}  // namespace

std::unique_ptr<Evaluator> makeVulkanEvaluator(const EvaluatorTables& tables, TableForm form) {
    return std::make_unique<OwningVulkanEvaluator>(tables, form);
}

void VulkanEvaluator::Impl::frame(std::span<const float> control, unsigned kind, std::span<float> refinedOut,
                                  std::span<float> normalsOut) {
    Impl& e = *this;
    const std::size_t controlFloats = std::size_t(e.controls) * e.width, refinedFloats = std::size_t(e.refined) * e.width;
    assert(control.size() >= controlFloats);
    (void)controlFloats;
    assert(refinedOut.empty() || refinedOut.size() >= refinedFloats);
    assert(normalsOut.empty() || (e.hasSurface && normalsOut.size() >= 3 * std::size_t(e.refined)));
    using Clock = std::chrono::steady_clock;
    const auto ms = [](Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double, std::milli>(b - a).count(); };
    const Clock::time_point start = Clock::now();
    waitDeviceFrame();  // a submit() of caller buffers still running reads our buffers
    float* upload = static_cast<float*>(e.staging ? e.controlUpload.mapped : e.levels.front().buffer.mapped);
    copyElements(upload, e.levels.front().stride, control.data(), e.width, e.controls, e.width);
    const Clock::time_point uploaded = Clock::now();
    e.submit(kind);
    const Clock::time_point done = Clock::now();
    if (!refinedOut.empty() && refinedFloats)
        copyElements(refinedOut.data(), e.width,
                     static_cast<const float*>(e.staging ? e.refinedHost.mapped : e.refinedBuffer().buffer.mapped),
                     e.refinedBuffer().stride, e.refined, e.width);
    if (!normalsOut.empty() && e.refined)
        copyElements(normalsOut.data(), 3,
                     static_cast<const float*>(e.staging ? e.normalsHost.mapped : e.normals.buffer.mapped),
                     e.normals.stride, e.refined, 3);
    e.hostTimes = {ms(start, uploaded), ms(uploaded, done), ms(done, Clock::now())};
}

void VulkanEvaluator::normals(std::span<const float> refined, std::span<float> normals) {
    Impl& e = *impl_;
    const std::size_t refinedFloats = std::size_t(e.refined) * e.width;
    assert(refined.size() >= refinedFloats && normals.size() >= 3 * std::size_t(e.refined));
    if (!e.hasSurface) throw std::invalid_argument("VulkanEvaluator: normals need width >= 3 and a surface table");
    e.waitDeviceFrame();  // a submit() of caller buffers still running reads our buffers
    if (refinedFloats)
        copyElements(static_cast<float*>(e.staging ? e.refinedHost.mapped : e.refinedBuffer().buffer.mapped),
                     e.refinedBuffer().stride, refined.data(), e.width, e.refined, e.width);
    e.submit(kUploadRefined | kNormals | kReadNormals);
    if (e.refined)
        copyElements(normals.data(), 3,
                     static_cast<const float*>(e.staging ? e.normalsHost.mapped : e.normals.buffer.mapped),
                     e.normals.stride, e.refined, 3);
}

}  // namespace psub
