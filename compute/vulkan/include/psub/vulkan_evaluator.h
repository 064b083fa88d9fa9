// psub/vulkan_evaluator.h: the Vulkan compute twin of psub/evaluator.h's CpuEvaluator: the same
// tables in, the same numbers out (float, within rounding), on any Vulkan 1.1 device with a
// compute queue, lavapipe (VK_PHYSICAL_DEVICE_TYPE_CPU) included. Tables are uploaded once;
// a frame writes the control points through a persistently mapped buffer, runs one command
// buffer (upload barrier, a few dispatches per level, normals, fence) and reads back only what
// was asked for. Link psub::vulkan; a CPU-only program never needs Vulkan. No Vulkan types
// here: a caller that brings its own device and buffers includes psub/vulkan_interop.h.
// It is the Vulkan backend of the evaluator contract (psub/evaluate.h).
#pragma once

#include "psub/evaluate.h"
#include "psub/evaluator.h"
#include "psub/vulkan_context.h"
#include "psub/tables.h"

#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

// The one Vulkan type used below (a dispatchable handle: the same declaration as vulkan_core.h's).
typedef struct VkCommandBuffer_T* VkCommandBuffer;

namespace psub {

struct VulkanDeviceBuffers;  // psub/vulkan_interop.h: the caller's control and result buffers
struct VulkanSubmitSync;     // psub/vulkan_interop.h: the caller's semaphores
struct VulkanBufferRange;    // psub/vulkan_interop.h: a VkBuffer and an offset

enum class Staging {
    // CPU and integrated devices: every buffer written and read in place. Discrete devices: the
    // control points written in place where device-local memory is host-visible (a resizable
    // BAR; where the allocation fails or lands in host memory, a staging copy instead), the
    // results read back through staging copies.
    Auto,
    Always,   // staging buffers and copy commands for everything, even where memory is host-visible
    Results,  // a discrete device's Auto forced anywhere: control points in place, results staged
};

// The tiled form's kernel for its regular tiles (docs/tiled.md, "On Vulkan").
enum class TileKernel {
    Auto,       // Unrolled on a CPU device (lavapipe), Workgroup on any other
    Workgroup,  // shaders/tile.comp: one workgroup per block, grids in workgroup-shared memory
    Unrolled,   // shaders/tile_unrolled.comp: one invocation per block, grids unrolled into registers
                // (at most 4 values per vertex; wider vertices take the workgroup kernel)
};

struct VulkanEvaluatorOptions {
    Staging staging = Staging::Auto;
    // Largest byte range bound to one descriptor: 0 means the device's maxStorageBufferRange.
    // Smaller values force the windowed path (bound ranges, split dispatches) on small meshes.
    std::uint64_t maxBindingBytes = 0;
    TileKernel tileKernel = TileKernel::Auto;
    // The workgroup tile kernel's largest block side: 0 means 32 where the device's shared memory
    // holds that block's grids (t <= 3: 27.7 KiB), else 16; 16 or 32 ask for that side.
    std::uint32_t tileBlock = 0;
    // The workgroup tile kernel also writes its tiles' inner points' normals, from the last fine
    // grid it holds (the design's one pass), instead of the tile_normals.comp pass reading the
    // positions back (at t = 1 and 2 from a block window one level-B cell wider): where the
    // normals split (normalsInTilePass), the vertices have 3 or 4 values and the grids fit the
    // shared memory; elsewhere as without it. The same bits either way; on an NVIDIA H200 never
    // slower, and 0.14 ms of 1.09 faster at 16.8M faces (bench/README.md, "Session 22").
    bool fusedTileNormals = true;
    // The workgroup tile kernel's invocations per workgroup (one block each): 0 means 512 for
    // blocks of 32 and 256 for blocks of 16 (halved while the device runs fewer); 64, 128, 256,
    // 512 or 1024 ask for that many.
    std::uint32_t tileThreads = 0;
};

// GPU-side time of the last frame, from timestamp queries (valid is false when the queue has
// no timestamps). levels: upload barrier and stencil dispatches; normals: both normal passes;
// upload: the part of levels before the first dispatch (the control points' staging copy on a
// discrete device, the barrier alone elsewhere).
struct GpuFrameTimes {
    bool valid = false;
    double totalMs = 0, levelsMs = 0, normalsMs = 0, uploadMs = 0;
};

// Host-side time of the last evaluate(): writing the control points into the mapped buffer,
// submitting and waiting for the fence, copying the results out of mapped memory.
struct HostFrameTimes {
    double uploadMs = 0, waitMs = 0, readbackMs = 0;
};

// Out-of-range or non-finite control points: as for CpuEvaluator (psub/evaluator.h), the
// results are NaN, infinite or zero where such points reach; never a device fault or a read
// or write outside the buffers (the shaders index by the tables only, never by values).
class VulkanEvaluator final : public Evaluator {
public:
    // Uploads the tables. The contract's ownership rule holds (psub/evaluate.h): they must
    // outlive the evaluator (surface() returns `surface`). `factorized` may be empty when
    // form is PerLevel; `surface` may be empty when normals are never asked for. Throws
    // std::invalid_argument for the Tiled form (the next constructor takes it), inconsistent
    // tables or width 0 (or above 16), VulkanError on device failure or buffers beyond the
    // device's limits.
    VulkanEvaluator(VulkanContext& context, const PerLevelTable& perLevel,
                    const FactorizedTable& factorized, const SurfaceTable& surface, TableForm form,
                    std::uint32_t width = 3, const VulkanEvaluatorOptions& options = {});
    // The tiled form (psub/tiled.h): positions and normals in its drawing order, surface() is
    // tiled.surface. Its per-level rows run as above; each regular tile's last 2t steps run in
    // workgroup-shared memory (shaders/tile.comp), only the finest points written.
    VulkanEvaluator(VulkanContext& context, const TiledTable& tiled, std::uint32_t width = 3,
                    const VulkanEvaluatorOptions& options = {});
    ~VulkanEvaluator();
    VulkanEvaluator(const VulkanEvaluator&) = delete;
    VulkanEvaluator& operator=(const VulkanEvaluator&) = delete;

    std::uint32_t controlCount() const override;
    std::uint32_t refinedCount() const override;
    std::uint32_t width() const;
    const SurfaceTable& surface() const override;
    std::string device() const override;
    // Host times of the last evaluate() in the contract's stages: upload, evaluate (submit to
    // fence, less the normals' GPU time where timestamps exist), normals (GPU time), readback.
    StageTimes lastTimes() const override;

    // One frame. control: controlCount() * width() floats, packed. refined: empty (results stay
    // on the device) or refinedCount() * width() floats. normals: empty (no normals pass) or
    // 3 * refinedCount() floats, unit vertex normals of the refined surface as
    // CpuEvaluator::normals computes them (needs width() >= 3 and a surface table).
    void evaluate(std::span<const float> control, std::span<float> refined,
                  std::span<float> normals = {}) override;

    // Caller-owned buffers (psub/vulkan_interop.h, which documents layouts and barriers):
    // records one frame into `command` (a primary command buffer in the recording state, for a
    // queue of the context's queue family): control points read from buffers.control, results
    // written to buffers.refined and (when given) buffers.normals. No host access, no submit.
    void record(VkCommandBuffer command, const VulkanDeviceBuffers& buffers);
    // The same frame recorded into the evaluator's own command buffer and submitted to the
    // context's queue, waiting for and signalling the caller's semaphores; returns without
    // waiting (the next submit() or evaluate() waits for this one first).
    void submit(const VulkanDeviceBuffers& buffers, const VulkanSubmitSync& sync);
    // Floats per vertex in device buffers: 4 for width 3 (x, y, z, padding), else width().
    std::uint32_t deviceStride() const;
    // Where evaluateKept() leaves its results on the device (deviceStride() floats per position,
    // 4 per normal; the buffers have vertex-buffer usage): what a renderer on the same context
    // draws from with no read-back. Valid for the evaluator's lifetime; normals only when a
    // surface table was given. Barriers: each frame ends with its writes visible to vertex input.
    VulkanBufferRange keptPositions() const;
    VulkanBufferRange keptNormals() const;

    // One frame whose results stay on the device (nothing read back): the stencils and, with
    // `withNormals`, the normals pass. For a playback loop that draws on the device.
    void evaluateOnDevice(std::span<const float> control, bool withNormals);
    void evaluateKept(std::span<const float> control, bool withNormals) override { evaluateOnDevice(control, withNormals); }
    bool resultsOnHost() const override { return false; }

    // CpuEvaluator's contract: normals of the given refined positions (uploaded first).
    void normals(std::span<const float> refined, std::span<float> normals);

    GpuFrameTimes lastFrameTimes() const;
    HostFrameTimes lastHostTimes() const;
    // The tiled form's normals split as CpuEvaluator's (normalsInTilePass): its tiles' inner
    // points' from their lattices by implicit addressing (shaders/tile_normals.comp), the same
    // bits as the CPU tile pass's; the other points' through listed faces and vertices. False
    // for the other forms, and where the CPU would not split, a face is no quad, a vertex is in
    // more than 8 faces or a buffer needs more than one binding window.
    bool normalsInTilePass() const;
    // The tiled form's widest tile block, in lattice intervals a side: the workgroup kernel's
    // (at most 16, or 32 where the device's shared memory holds it: VulkanEvaluatorOptions::
    // tileBlock), the unrolled kernel's 16; 0 without tiles.
    std::uint32_t tileBlockSide() const;
    // The control points are written straight into the device's buffer (no copy in a frame).
    bool controlsWrittenInPlace() const;
    // The workgroup tile kernel's invocations per workgroup (tileThreads); 0 without it.
    std::uint32_t tileThreads() const;
    // The tile kernel writes the tiles' inner points' normals itself (fusedTileNormals, where it can).
    bool normalsInTileKernel() const;
    // Dispatches in a frame's command buffer: stencils only, and with normals.
    std::size_t dispatchCount(bool withNormals = false) const;
    // Bytes of device buffers held (tables, levels, normals, staging).
    std::uint64_t deviceBytes() const;

    struct Impl;

private:
    VulkanEvaluator(VulkanContext& context, const PerLevelTable& perLevel, const FactorizedTable& factorized,
                    const SurfaceTable& surface, TableForm form, const TiledTable* tiled, std::uint32_t width,
                    const VulkanEvaluatorOptions& options);

    std::unique_ptr<Impl> impl_;
};

// Makes a Vulkan evaluator (width 3) on `context` from a refinement's tables: the contract's
// factory (psub/evaluate.h).
std::unique_ptr<Evaluator> makeVulkanEvaluator(VulkanContext& context, const EvaluatorTables& tables, TableForm form,
                                               const VulkanEvaluatorOptions& options = {});
// The same on a context of its own (VulkanContext with default options), owned by the evaluator:
// the one-line switch from makeCpuEvaluator. Throws VulkanError when no device is usable.
std::unique_ptr<Evaluator> makeVulkanEvaluator(const EvaluatorTables& tables, TableForm form);

}  // namespace psub
