// Submission: one command buffer and a fence under the context's submit lock, and one-shot
// command buffers (uploads, read-backs, layout changes done once).
#include "submit.h"

#include <mutex>

namespace psub::vulkan {

void submitAndWait(VulkanContext::Impl& context, VkCommandBuffer command, VkFence fence) {
    VkSubmitInfo info{};
    info.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
    info.commandBufferCount = 1;
    info.pCommandBuffers = &command;
    {
        std::lock_guard guard(context.submitLock);
        VK_CHECK(vkQueueSubmit(context.queue, 1, &info, fence));
    }
    VK_CHECK(vkWaitForFences(context.device, 1, &fence, VK_TRUE, UINT64_MAX));
    VK_CHECK(vkResetFences(context.device, 1, &fence));
}

void runOnce(VulkanContext::Impl& c, const std::function<void(VkCommandBuffer)>& record) {
    VkCommandPool pool = VK_NULL_HANDLE;
    VkFence fence = VK_NULL_HANDLE;
    try {
        VkCommandPoolCreateInfo poolInfo{};
        poolInfo.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
        poolInfo.flags = VK_COMMAND_POOL_CREATE_TRANSIENT_BIT;
        poolInfo.queueFamilyIndex = c.queueFamily;
        VK_CHECK(vkCreateCommandPool(c.device, &poolInfo, nullptr, &pool));
        VkCommandBufferAllocateInfo allocate{};
        allocate.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
        allocate.commandPool = pool;
        allocate.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
        allocate.commandBufferCount = 1;
        VkCommandBuffer command = VK_NULL_HANDLE;
        VK_CHECK(vkAllocateCommandBuffers(c.device, &allocate, &command));
        VkFenceCreateInfo fenceInfo{};
        fenceInfo.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
        VK_CHECK(vkCreateFence(c.device, &fenceInfo, nullptr, &fence));
        VkCommandBufferBeginInfo begin{};
        begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
        begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
        VK_CHECK(vkBeginCommandBuffer(command, &begin));
        record(command);
        VK_CHECK(vkEndCommandBuffer(command));
        submitAndWait(c, command, fence);
    } catch (...) {
        if (fence) vkDestroyFence(c.device, fence, nullptr);
        if (pool) vkDestroyCommandPool(c.device, pool, nullptr);
        throw;
    }
    vkDestroyFence(c.device, fence, nullptr);
    vkDestroyCommandPool(c.device, pool, nullptr);
}

}  // namespace psub::vulkan
