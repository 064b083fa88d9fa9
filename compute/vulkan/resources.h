// Internal: buffers and barriers (niagara's resources.cpp, kept small). A Buffer is plain
// data; the evaluator owns its buffers and destroys them.
#pragma once

#include "check.h"

#include <cstdint>

namespace psub::vulkan {

enum class Memory {
    Device,    // device-local; host-visible too when `mapped` is asked for
    Upload,    // host-visible and coherent, written by the CPU
    Readback,  // host-visible and coherent (cached when possible), read by the CPU
};

struct Buffer {
    VkBuffer buffer = VK_NULL_HANDLE;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    VkDeviceSize size = 0;    // bytes, at least 16
    void* mapped = nullptr;   // persistently mapped when host-visible memory was asked for
};

// A buffer of at least `bytes` (rounded up to 16) with `usage`; mapped when `map`. Throws
// VulkanError beyond the device's allocation limit or when no memory type fits.
Buffer createBuffer(const VulkanContext::Impl& context, VkDeviceSize bytes, VkBufferUsageFlags usage,
                    Memory memory, bool map);
void destroyBuffer(const VulkanContext::Impl& context, Buffer& buffer);

// True when a memory type is device-local, host-visible and coherent (buffers can be written
// in place).
bool hasHostVisibleDeviceMemory(const VulkanContext::Impl& context);

void bufferBarrier(VkCommandBuffer command, const Buffer& buffer, VkPipelineStageFlags sourceStage,
                   VkAccessFlags sourceAccess, VkPipelineStageFlags destinationStage,
                   VkAccessFlags destinationAccess);
void memoryBarrier(VkCommandBuffer command, VkPipelineStageFlags sourceStage, VkAccessFlags sourceAccess,
                   VkPipelineStageFlags destinationStage, VkAccessFlags destinationAccess);

// Submits one recorded command buffer to the context's queue (under its submit lock; a
// validation message raised meanwhile is still recorded: the messenger has its own lock), waits for
// `fence` and resets it.
void submitAndWait(VulkanContext::Impl& context, VkCommandBuffer command, VkFence fence);

}  // namespace psub::vulkan
