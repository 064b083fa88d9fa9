// The Vulkan evaluator. Construction does all the work that does not change per frame:
// tables uploaded, every buffer bound (in windows no larger than maxStorageBufferRange, rows
// split into chunks whose table ranges fit one binding), one descriptor set per dispatch.
// A frame's command buffer is recorded once per kind of frame and resubmitted: write the
// control points, submit, wait on the fence, copy out what was asked for.
// The other jobs live beside it: vulkan_evaluator_uploads.cpp (buffers, tables, stages),
// vulkan_evaluator_descriptors.cpp, vulkan_evaluator_commands.cpp (recording, submitting).
#include "vulkan_evaluator_impl.h"

#include <algorithm>
#include <cassert>
#include <chrono>
#include <cstdlib>

#if defined(__SSE2__)
#include <immintrin.h>
#endif

namespace psub {

namespace {

// Copies `count` elements of `width` floats between buffers of `fromStride` and `toStride`
// floats per element; padding values written are 0.
void copyElements(float* to, std::uint32_t toStride, const float* from, std::uint32_t fromStride, std::size_t count,
                  std::uint32_t width) {
    if (toStride == width && fromStride == width) {
        if (count) std::memcpy(to, from, count * width * sizeof(float));
        return;
    }
#if defined(__SSE2__)
    if (fromStride == 3 && width == 3 && toStride == 4) {
        // Positions padded to vec4 with one 16-byte store each (GCC makes two 8-byte stores of the
        // plain loop): a discrete GPU's host-visible memory is write-combined or uncached, where
        // narrow stores cost more (on an H200's host the plain loop took 2 ms for 262,144 points).
        for (std::size_t v = 0; v < count; ++v)
            _mm_storeu_ps(to + 4 * v, _mm_setr_ps(from[3 * v], from[3 * v + 1], from[3 * v + 2], 0.0f));
        return;
    }
#endif
    for (std::size_t v = 0; v < count; ++v) {
        for (std::uint32_t i = 0; i < width; ++i) to[v * toStride + i] = from[v * fromStride + i];
        for (std::uint32_t i = width; i < toStride; ++i) to[v * toStride + i] = 0.0f;
    }
}

}  // namespace

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

namespace {
const FactorizedTable& noFactorizedTable() {
    static const FactorizedTable none;
    return none;
}
}  // namespace

VulkanEvaluator::VulkanEvaluator(VulkanContext& context, const PerLevelTable& perLevel,
                                 const FactorizedTable& factorized, const SurfaceTable& surface, TableForm form,
                                 std::uint32_t width, const VulkanEvaluatorOptions& options)
    : VulkanEvaluator(context, perLevel, factorized, surface, form, nullptr, width, options) {}

VulkanEvaluator::VulkanEvaluator(VulkanContext& context, const TiledTable& tiled, std::uint32_t width,
                                 const VulkanEvaluatorOptions& options)
    : VulkanEvaluator(context, tiled.rows, noFactorizedTable(), tiled.surface, TableForm::Tiled, &tiled, width, options) {}

VulkanEvaluator::VulkanEvaluator(VulkanContext& context, const PerLevelTable& perLevel,
                                 const FactorizedTable& factorized, const SurfaceTable& surface, TableForm form,
                                 const TiledTable* tiled, std::uint32_t width, const VulkanEvaluatorOptions& options)
    : impl_(std::make_unique<Impl>(contextInternals(context), width)) {
    if (width == 0 || width > kMaxWidth)
        throw std::invalid_argument("VulkanEvaluator: width must be 1 to " + std::to_string(kMaxWidth));
    if ((form == TableForm::Tiled) != (tiled != nullptr))
        throw std::invalid_argument("VulkanEvaluator: the tiled form takes its TiledTable");
    if (form == TableForm::Factorized &&
        (factorized.rowCount() != perLevel.refinedCount() || factorized.controlCount != perLevel.controlCount))
        throw std::invalid_argument("VulkanEvaluator: the factorized table was not built for these levels");
    Impl& e = *impl_;
    VulkanContext::Impl& c = e.context;
    e.pipelines = &pipelinesFor(c);
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
    e.staging = options.staging != Staging::Auto || !c.unifiedMemory() || !hasHostVisibleDeviceMemory(c);

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

    // Vertex buffers: control points, each level (per-level and tiled forms: the tiled form's
    // levels after its base level hold only the fallback's points) or the finest (factorized).
    const std::size_t levelCount = form == TableForm::Factorized ? 1 : perLevel.levels.size();
    e.levels.resize(levelCount + 1);
    // Every vertex buffer is padded from 3 to 4 floats per element (one vec4 load or store
    // each), the refined positions too: read-backs and uploads convert from and to packed xyz.
    const std::uint32_t padded = width == 3 ? 4 : width;
    e.makeVertexBuffer(e.levels[0], e.controls, padded, true);
    for (std::size_t k = 1; k <= levelCount; ++k)  // none for per-level with no levels: refined == control
            e.makeVertexBuffer(e.levels[k], form == TableForm::Factorized ? e.refined : perLevel.levels[k - 1].destinationCount,
                               padded, k == levelCount);
    e.controlsInPlace = !e.staging;
    if (e.staging && options.staging != Staging::Always) e.placeControlsInHostVisibleMemory(options.staging == Staging::Results);
    if (!e.controlsInPlace)
        e.controlUpload = createBuffer(c, std::uint64_t(e.controls) * e.levels[0].stride * 4, VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                                       Memory::Upload, true);
    if (e.staging)
        e.refinedHost = createBuffer(c, std::uint64_t(e.refined) * e.refinedBuffer().stride * 4,
                                     VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                     Memory::Readback, true);

    e.fusedTileNormals = options.fusedTileNormals;
    e.tileThreads = options.tileThreads;  // 0: chosen with the block side (buildTiles)
    if (e.tileThreads != 0 && (e.tileThreads < 64 || e.tileThreads > 1024 || (e.tileThreads & (e.tileThreads - 1)) != 0))
        throw std::invalid_argument("VulkanEvaluator: the tile kernel's workgroup has 64, 128, 256, 512 or 1024 invocations, not " +
                                    std::to_string(e.tileThreads));
    if (e.tileThreads > limits.maxComputeWorkGroupInvocations || e.tileThreads > limits.maxComputeWorkGroupSize[0])
        throw std::invalid_argument("VulkanEvaluator: " + std::string(c.properties.deviceName) + " runs at most " +
                                    std::to_string(limits.maxComputeWorkGroupInvocations) + " invocations a workgroup");
    Uploader uploader(c, !e.staging);
    if (form == TableForm::Factorized) e.buildFactorized(factorized, uploader);
    else e.buildPerLevel(perLevel, uploader);
    // The unrolled tile kernel takes at most 4 values per vertex (one vec4 per grid point: wider
    // vertices' loops over the values did not unroll, and lavapipe took minutes to compile).
    if (tiled)
        e.buildTiles(*tiled,
                     width <= 4 && (options.tileKernel == TileKernel::Unrolled ||
                                    (options.tileKernel == TileKernel::Auto &&
                                     c.properties.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU)),
                     options.tileBlock, uploader);
    if (e.hasSurface) {
        e.buildNormals(surface, tiled, uploader);
        if (e.staging)
            e.normalsHost = createBuffer(c, std::uint64_t(e.refined) * e.normals.stride * 4, VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                         Memory::Readback, true);
    }
    uploader.finish();
    for (auto* stages : {&e.stencilStages, &e.normalStages})
        for (Stage& s : *stages) s.specialization.texels = e.texels;
    e.writeDescriptorSets();
}

VulkanEvaluator::~VulkanEvaluator() = default;

std::uint32_t VulkanEvaluator::controlCount() const { return impl_->controls; }
std::uint32_t VulkanEvaluator::refinedCount() const { return impl_->refined; }
std::uint32_t VulkanEvaluator::width() const { return impl_->width; }
GpuFrameTimes VulkanEvaluator::lastFrameTimes() const { return impl_->times; }
bool VulkanEvaluator::normalsInTilePass() const { return impl_->tileNormals; }
std::uint32_t VulkanEvaluator::tileBlockSide() const { return impl_->tileBlockSide; }
bool VulkanEvaluator::controlsWrittenInPlace() const { return impl_->controlsInPlace; }
std::uint32_t VulkanEvaluator::tileThreads() const {
    for (const Stage& s : impl_->stencilStages)
        if (s.kernel == Kernel::Tile) return s.specialization.tileThreads;
    return 0;
}
bool VulkanEvaluator::normalsInTileKernel() const {
    for (const Stage& s : impl_->stencilStages)
        if (s.specialization.tileKeptSide != 0) return true;
    return false;
}
HostFrameTimes VulkanEvaluator::lastHostTimes() const { return impl_->hostTimes; }

std::size_t VulkanEvaluator::dispatchCount(bool withNormals) const {
    std::size_t count = 0;
    for (const Stage& s : impl_->stencilStages)
        if (s.runsIn(true, withNormals)) count += s.dispatches.size();
    if (withNormals)
        for (const Stage& s : impl_->normalStages)
            if (s.runsIn(true, true)) count += s.dispatches.size();
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

std::unique_ptr<Evaluator> makeVulkanEvaluator(VulkanContext& context, const EvaluatorTables& tables, TableForm form,
                                               const VulkanEvaluatorOptions& options) {
    if (form == TableForm::Tiled) return std::make_unique<VulkanEvaluator>(context, tables.tiled, 3, options);
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
    float* upload = static_cast<float*>(e.controlsInPlace ? e.levels.front().buffer.mapped : e.controlUpload.mapped);
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
