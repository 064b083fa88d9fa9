// The Vulkan evaluator's command buffers: a frame of each kind recorded once and resubmitted
// (upload barrier, stages of dispatches, normals, copies back, timestamps), and the frames of
// caller-owned buffers (record, submit) with the barriers psub/vulkan_interop.h promises.
#include "vulkan_evaluator_impl.h"

#include "submit.h"

#include <mutex>

namespace psub {

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

void VulkanEvaluator::Impl::runStages(VkCommandBuffer command, const std::vector<Stage>& stages, bool stencils,
                                      bool withNormals) {
    const VkPipelineLayout layout = pipelines->layout();
    for (const Stage& stage : stages) {
        if (stage.dispatches.empty() || !stage.runsIn(stencils, withNormals)) continue;
        for (std::size_t i = 0; i < stage.dispatches.size(); ++i) {
            const Dispatch& d = stage.dispatches[i];
            const Dispatch* previous = i > 0 ? &stage.dispatches[i - 1] : nullptr;
            if (!previous || d.rowN != previous->rowN || d.rowM != previous->rowM ||
                d.implicitDestination != previous->implicitDestination) {
                Specialization specialization = stage.specialization;
                specialization.rowN = d.rowN;
                specialization.rowM = d.rowM;
                specialization.implicitDestination = d.implicitDestination;
                vkCmdBindPipeline(command, VK_PIPELINE_BIND_POINT_COMPUTE, pipelines->get(stage.kernel, specialization));
            }
            // Chunks of one stage write disjoint rows but bind the same windows: order them too
            // (and their reads, where a stage reads the buffer it writes: face points, read by the
            // VertexFromFacePoints rows).
            if (i > 0)
                bufferBarrier(command, stage.written->buffer, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
                              VK_ACCESS_SHADER_WRITE_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
                              d.source == stage.written ? VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT
                                                        : VK_ACCESS_SHADER_WRITE_BIT);
            vkCmdBindDescriptorSets(command, VK_PIPELINE_BIND_POINT_COMPUTE, layout, 0, 1, &d.set, 0, nullptr);
            vkCmdPushConstants(command, layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(PushConstants), &d.push);
            vkCmdDispatch(command, d.groupsX, d.groupsY, 1);
        }
        // Later stages read what this one wrote, or (the heavy vertices' normals) write it again.
        for (const VertexBuffer* written : {stage.written, stage.alsoWritten})
            if (written)
                bufferBarrier(command, written->buffer, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_WRITE_BIT,
                              VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT |
                                  VK_PIPELINE_STAGE_HOST_BIT,
                              VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_READ_BIT |
                                  VK_ACCESS_HOST_READ_BIT);
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
        if ((kind & kStencils) && !controlsInPlace) {
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
    if (queries) vkCmdWriteTimestamp(command, VK_PIPELINE_STAGE_TRANSFER_BIT, queries, kQueryUploaded);
    if (kind & kStencils) runStages(command, stencilStages, true, kind & kNormals);
    if (queries) vkCmdWriteTimestamp(command, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, queries, kQueryStencils);
    if (kind & kNormals) {
        // The zero element after the face normals (see buildNormals).
        vkCmdFillBuffer(command, faceNormals.buffer.buffer, (faceNormals.elements - 1) * faceNormals.stride * 4,
                        faceNormals.stride * 4, 0);
        memoryBarrier(command, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT,
                      VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT);
        runStages(command, normalStages, kind & kStencils, true);
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
        times = {true, span(kQueryStart, kQueryEnd), span(kQueryStart, kQueryStencils), span(kQueryStencils, kQueryNormals),
                 span(kQueryStart, kQueryUploaded)};
    }
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
    runStages(command, stencilStages, true, withNormals);
    if (withNormals) {
        vkCmdFillBuffer(command, faceNormals.buffer.buffer, (faceNormals.elements - 1) * faceNormals.stride * 4,
                        faceNormals.stride * 4, 0);
        memoryBarrier(command, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT,
                      VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT);
        runStages(command, normalStages, true, true);
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

}  // namespace psub
