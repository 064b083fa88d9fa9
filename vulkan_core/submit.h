// The Vulkan core: submission to the context's queue, under its submit lock: one recorded
// command buffer and a fence, or a one-shot command buffer recorded by a callback.
#pragma once

#include "device.h"

#include <functional>

namespace psub::vulkan {

// Submits one recorded command buffer to the context's queue (under its submit lock; a
// validation message raised meanwhile is still recorded: the messenger has its own lock), waits for
// `fence` and resets it.
void submitAndWait(VulkanContext::Impl& context, VkCommandBuffer command, VkFence fence);

// Records `record(command)` into a one-time command buffer of a transient pool of its own,
// submits it, waits for it and frees the pool and fence (also when `record` throws).
void runOnce(VulkanContext::Impl& context, const std::function<void(VkCommandBuffer)>& record);

}  // namespace psub::vulkan
