// psub/vulkan_device.h: the caller's instance, physical device, device and queue, which a
// VulkanContext (psub/vulkan_context.h) adopts instead of creating its own.
#pragma once

#include "psub/vulkan_context.h"

#include <vulkan/vulkan.h>

#include <cstdint>

namespace psub {

// What VulkanContext(const VulkanDeviceHandles&) adopts. The device must be Vulkan 1.1 or
// later and `queue` a queue of `queueFamily`, which must support compute. Nothing is destroyed
// by PSub; submissions to `queue` by PSub are serialized among PSub's own users of the context
// only: the caller must not submit to the same queue from another thread at the same time.
struct VulkanDeviceHandles {
    VkInstance instance = VK_NULL_HANDLE;
    VkPhysicalDevice physicalDevice = VK_NULL_HANDLE;
    VkDevice device = VK_NULL_HANDLE;
    std::uint32_t queueFamily = 0;
    VkQueue queue = VK_NULL_HANDLE;
};

}  // namespace psub
