// The Vulkan core: buffers, the memory-type choice and buffer/memory barriers (niagara's
// resources.cpp, kept small). A Buffer is plain data; its user owns it and destroys it.
#pragma once

#include "device.h"

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
    VkMemoryPropertyFlags flags = 0;  // of the memory type it got
};

// A buffer of at least `bytes` (rounded up to 16) with `usage`; mapped when `map`. Throws
// VulkanError beyond the device's allocation limit or when no memory type fits.
Buffer createBuffer(const VulkanContext::Impl& context, VkDeviceSize bytes, VkBufferUsageFlags usage,
                    Memory memory, bool map);
void destroyBuffer(const VulkanContext::Impl& context, Buffer& buffer);

// The first memory type allowed by `bits` with all `required` flags, preferring one with all
// `preferred` flags too; ~0u when none is allowed.
std::uint32_t findMemoryType(const VkPhysicalDeviceMemoryProperties& memory, std::uint32_t bits,
                             VkMemoryPropertyFlags required, VkMemoryPropertyFlags preferred);
// A device-local memory type among `bits` (any allowed one when none is device-local), for
// images; VulkanError naming `what` when none is allowed.
std::uint32_t deviceMemoryType(const VulkanContext::Impl& context, std::uint32_t bits, const char* what = "an image");

// True when a memory type is device-local, host-visible and coherent (buffers can be written
// in place).
bool hasHostVisibleDeviceMemory(const VulkanContext::Impl& context);

void bufferBarrier(VkCommandBuffer command, const Buffer& buffer, VkPipelineStageFlags sourceStage,
                   VkAccessFlags sourceAccess, VkPipelineStageFlags destinationStage,
                   VkAccessFlags destinationAccess);
void memoryBarrier(VkCommandBuffer command, VkPipelineStageFlags sourceStage, VkAccessFlags sourceAccess,
                   VkPipelineStageFlags destinationStage, VkAccessFlags destinationAccess);

}  // namespace psub::vulkan
