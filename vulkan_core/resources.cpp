// Buffers (one allocation each: an evaluator holds a dozen), memory-type choice, barriers.
#include "resources.h"

#include <string>

namespace psub::vulkan {
namespace {

std::string mib(VkDeviceSize bytes) { return std::to_string((bytes + (1u << 20) - 1) >> 20) + " MiB"; }

}  // namespace

std::uint32_t findMemoryType(const VkPhysicalDeviceMemoryProperties& memory, std::uint32_t bits,
                             VkMemoryPropertyFlags required, VkMemoryPropertyFlags preferred) {
    std::uint32_t fallback = ~0u;
    for (std::uint32_t i = 0; i < memory.memoryTypeCount; ++i) {
        if (!(bits & (1u << i))) continue;
        const VkMemoryPropertyFlags flags = memory.memoryTypes[i].propertyFlags;
        if ((flags & required) != required) continue;
        if ((flags & preferred) == preferred) return i;
        if (fallback == ~0u) fallback = i;
    }
    return fallback;
}

std::uint32_t deviceMemoryType(const VulkanContext::Impl& context, std::uint32_t bits, const char* what) {
    const std::uint32_t type =
        findMemoryType(context.memory, bits, 0, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
    if (type == ~0u)
        throw VulkanError(std::string("no memory type for ") + what + " on " + context.properties.deviceName);
    return type;
}

bool hasHostVisibleDeviceMemory(const VulkanContext::Impl& context) {
    const VkMemoryPropertyFlags wanted = VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT | VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT |
                                         VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
    for (std::uint32_t i = 0; i < context.memory.memoryTypeCount; ++i)
        if ((context.memory.memoryTypes[i].propertyFlags & wanted) == wanted) return true;
    return false;
}

Buffer createBuffer(const VulkanContext::Impl& context, VkDeviceSize bytes, VkBufferUsageFlags usage,
                    Memory memory, bool map) {
    Buffer b;
    b.size = bytes < 16 ? 16 : (bytes + 15) / 16 * 16;
    if (context.maxAllocation && b.size > context.maxAllocation)
        throw VulkanError("a buffer of " + mib(b.size) + " exceeds the largest allocation of " +
                          context.properties.deviceName + " (" + mib(context.maxAllocation) + ")");
    VkBufferCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
    info.size = b.size;
    info.usage = usage;
    info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
    VK_CHECK(vkCreateBuffer(context.device, &info, nullptr, &b.buffer));
    try {
        VkMemoryRequirements requirements;
        vkGetBufferMemoryRequirements(context.device, b.buffer, &requirements);
        const VkMemoryPropertyFlags host = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
        VkMemoryPropertyFlags required = 0, preferred = 0;
        switch (memory) {
        case Memory::Device:
            required = map ? host : 0;
            preferred = VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT;
            break;
        case Memory::Upload:
            required = host;
            preferred = 0;
            break;
        case Memory::Readback:
            required = host;
            preferred = VK_MEMORY_PROPERTY_HOST_CACHED_BIT;
            break;
        }
        const std::uint32_t type = findMemoryType(context.memory, requirements.memoryTypeBits, required, preferred | required);
        if (type == ~0u)
            throw VulkanError(std::string("no suitable memory type for a buffer on ") + context.properties.deviceName);
        VkMemoryAllocateInfo allocate{};
        allocate.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
        allocate.allocationSize = requirements.size;
        allocate.memoryTypeIndex = type;
        b.flags = context.memory.memoryTypes[type].propertyFlags;
        VK_CHECK(vkAllocateMemory(context.device, &allocate, nullptr, &b.memory));
        VK_CHECK(vkBindBufferMemory(context.device, b.buffer, b.memory, 0));
        if (map) VK_CHECK(vkMapMemory(context.device, b.memory, 0, VK_WHOLE_SIZE, 0, &b.mapped));
    } catch (...) {
        destroyBuffer(context, b);
        throw;
    }
    return b;
}

void destroyBuffer(const VulkanContext::Impl& context, Buffer& buffer) {
    if (buffer.mapped) vkUnmapMemory(context.device, buffer.memory);
    if (buffer.buffer) vkDestroyBuffer(context.device, buffer.buffer, nullptr);
    if (buffer.memory) vkFreeMemory(context.device, buffer.memory, nullptr);
    buffer = Buffer{};
}

void bufferBarrier(VkCommandBuffer command, const Buffer& buffer, VkPipelineStageFlags sourceStage,
                   VkAccessFlags sourceAccess, VkPipelineStageFlags destinationStage,
                   VkAccessFlags destinationAccess) {
    VkBufferMemoryBarrier barrier{};
    barrier.sType = VK_STRUCTURE_TYPE_BUFFER_MEMORY_BARRIER;
    barrier.srcAccessMask = sourceAccess;
    barrier.dstAccessMask = destinationAccess;
    barrier.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    barrier.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    barrier.buffer = buffer.buffer;
    barrier.offset = 0;
    barrier.size = VK_WHOLE_SIZE;
    vkCmdPipelineBarrier(command, sourceStage, destinationStage, 0, 0, nullptr, 1, &barrier, 0, nullptr);
}

void memoryBarrier(VkCommandBuffer command, VkPipelineStageFlags sourceStage, VkAccessFlags sourceAccess,
                   VkPipelineStageFlags destinationStage, VkAccessFlags destinationAccess) {
    VkMemoryBarrier barrier{};
    barrier.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
    barrier.srcAccessMask = sourceAccess;
    barrier.dstAccessMask = destinationAccess;
    vkCmdPipelineBarrier(command, sourceStage, destinationStage, 0, 1, &barrier, 0, nullptr, 0, nullptr);
}

}  // namespace psub::vulkan
