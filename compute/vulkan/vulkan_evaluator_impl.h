// The Vulkan evaluator's private parts, shared by its files: the buffers and dispatches it
// builds (vulkan_evaluator_uploads.cpp), binds (vulkan_evaluator_descriptors.cpp) and records
// and submits (vulkan_evaluator_commands.cpp); vulkan_evaluator.cpp holds the public API.
#pragma once

#include "psub/vulkan_evaluator.h"
#include "psub/vulkan_interop.h"

#include "device.h"
#include "dispatch_plan.h"
#include "pipelines.h"
#include "resources.h"
#include "staging.h"

#include <cstring>
#include <string>
#include <utility>
#include <vector>

namespace psub {
namespace vulkan {

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
enum : std::uint32_t { kQueryStart, kQueryUploaded, kQueryStencils, kQueryNormals, kQueryEnd, kQueryCount };

inline std::string mib(std::uint64_t bytes) {
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
    bool implicitDestination = false;                  // level kernel: row r writes push.rowBase + r
    VkFormat texelFormats[3] = {VK_FORMAT_R32_UINT, VK_FORMAT_R32_UINT, VK_FORMAT_R32_UINT};  // table texel views
    // What the descriptor set binds (written once, at construction).
    const VertexBuffer* source = nullptr;
    const VertexBuffer* destination = nullptr;
    const VertexBuffer* secondDestination = nullptr;  // bound as the destination's window 1 (tile.comp's normals)
    Window tables[3];
};

// Which frames run a stage: every frame that runs its list, or (the tiled form with its normals
// in the tile kernel) only frames with normals, only frames without, only frames that upload
// positions instead of refining them.
enum class StageRuns { Always, WithNormals, WithoutNormals, WithoutStencils };

// Dispatches of one kernel that may run together, then a barrier on what they wrote.
struct Stage {
    Kernel kernel = Kernel::Level;
    Specialization specialization;
    std::vector<Dispatch> dispatches;
    const VertexBuffer* written = nullptr;
    const VertexBuffer* alsoWritten = nullptr;
    StageRuns runs = StageRuns::Always;

    bool runsIn(bool stencils, bool normals) const {
        return runs == StageRuns::Always || (runs == StageRuns::WithNormals && normals) ||
               (runs == StageRuns::WithoutNormals && !normals) || (runs == StageRuns::WithoutStencils && !stencils);
    }
};

// Table arrays uploaded once, into buffers the evaluator keeps (the core's staged uploads:
// in place where memory is host-visible, else one command buffer of copies at finish()).
class Uploader {
public:
    Uploader(VulkanContext::Impl& context, bool direct) : uploads_(context, direct) {}

    template <class T>
    Buffer upload(const std::vector<T>& data, std::vector<Buffer>& owner) {
        return uploadFilled<T>(
            data.size(), [&](T* to) { std::memcpy(to, data.data(), data.size() * sizeof(T)); }, owner);
    }

    // A buffer of `count` T written in place by fill(T*) (no copy of the data on the heap).
    template <class T, class Fill>
    Buffer uploadFilled(std::size_t count, Fill fill, std::vector<Buffer>& owner) {
        owner.push_back(uploads_.createFilled(count * sizeof(T), kUsage, [&](void* to) { fill(static_cast<T*>(to)); }));
        return owner.back();
    }

    // Runs the staging copies (if any) and waits for them.
    void finish() { uploads_.finish(); }

private:
    StagedUploads uploads_;
};

}  // namespace vulkan

using namespace vulkan;

struct VulkanEvaluator::Impl {
    VulkanContext::Impl& context;
    Pipelines* pipelines = nullptr;  // the context's (pipelinesFor)
    std::uint32_t width, controls, refined;
    bool staging = false;
    bool controlsInPlace = false;  // levels[0] is mapped and written by the host (no staging copy)
    bool texels = false;  // kernels read inputs and tables through texel buffers (config.h)
    std::uint64_t limit = 0, alignment = 16, maxRows = 0;

    std::vector<VertexBuffer> levels;   // levels[0]: control points; levels.back(): refined (may be levels[0])
    VertexBuffer faceNormals, normals;
    std::vector<Buffer> tables;         // uploaded once
    Buffer controlUpload, refinedHost, normalsHost;  // staging only
    std::vector<Stage> stencilStages, normalStages;
    bool hasSurface = false;
    bool tileNormals = false;  // the tiled form's normals split (buildTileNormals)
    std::uint32_t tileBlockSide = 0;  // the widest tile block (buildTiles)
    std::uint32_t tileThreads = 0;    // option: the workgroup tile kernel's invocations (0: buildTiles chooses)
    std::size_t tileStage = ~std::size_t(0);  // the tile kernel's stage in stencilStages (buildTiles)
    bool fusedTileNormals = true;   // option: the workgroup tile kernel writes the inner points' normals
    std::uint32_t tileKeptSide = 0, tileFusedGrid = 0;  // where it can (buildTiles): its kept and step grids' sides
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
    std::uint64_t windowElements(std::uint32_t stride) const;  // elements of `stride` floats per binding window
    // With staging: levels[0] moved to mapped device-local memory where the device has some
    // (any host-visible memory when `force`), so the host writes the control points in place.
    void placeControlsInHostVisibleMemory(bool force);
    Window window(const Buffer& buffer, std::uint64_t elementBytes, std::uint64_t begin, std::uint64_t end) const;
    bool fits(std::uint64_t bytes) const { return bindingLimits().fits(bytes); }
    BindingLimits bindingLimits() const;
    template <class Fits>
    std::vector<std::pair<std::uint64_t, std::uint64_t>> split(std::uint64_t rows, Fits fitsRange, const char* what) const;
    template <class Offset>
    std::vector<CsrChunk> splitCsr(const std::vector<Offset>& offsets, std::vector<std::uint32_t>& relative,
                                   const char* what) const;
    Dispatch dispatch(std::uint64_t rows) const;
    // The dispatch of one CSR chunk's rows (TABLE_A offsets, TABLE_B and TABLE_C entries), from
    // `from` to `to`.
    Dispatch csrDispatch(const CsrChunk& c, const Buffer& offsets, const Buffer& entries, const VertexBuffer& from,
                         const VertexBuffer& to) const;
    void buildPerLevel(const PerLevelTable& table, Uploader& uploader);
    void buildFactorized(const FactorizedTable& table, Uploader& uploader);
    void buildTiles(const TiledTable& table, bool unrolled, std::uint32_t blockLimit, Uploader& uploader);  // after buildPerLevel(table.rows)
    void buildNormals(const SurfaceTable& surface, const TiledTable* tiled, Uploader& uploader);  // tiled: its split
    Stage heavyVertexStage(const SurfaceTable& surface, const std::vector<std::uint32_t>& heavy, Uploader& uploader);
    bool buildTileNormals(const TiledTable& tiled, const SurfaceTable& surface, Uploader& uploader);
    void writeDescriptorSets();

    // Frames.
    VkCommandBuffer frame(unsigned kind);
    // One frame of `kind`: uploads `control`, submits, waits, copies out what was asked for.
    void frame(std::span<const float> control, unsigned kind, std::span<float> refinedOut, std::span<float> normalsOut);
    void record(VkCommandBuffer command, unsigned kind);
    // The stages that run in a frame that refines (`stencils`) or not, with normals or not.
    void runStages(VkCommandBuffer command, const std::vector<Stage>& stages, bool stencils, bool withNormals);
    void submit(unsigned kind);
    // Caller-owned buffers (psub/vulkan_interop.h).
    void recordDevice(VkCommandBuffer command, const VulkanDeviceBuffers& buffers);
    void waitDeviceFrame();
};

}  // namespace psub
