// The Vulkan core: the context's innards (niagara's device.cpp, kept small): instance with the
// Khronos validation layer and a counting debug messenger, the physical device chosen by
// capability (lavapipe accepted), one queue, and a slot for the compute evaluator's pipelines.
#pragma once

#include "check.h"

#include <atomic>
#include <memory>
#include <mutex>
#include <string>

namespace psub {

namespace vulkan {
class Pipelines;  // the compute evaluator's (compute/vulkan/pipelines.h)
}

struct VulkanContext::Impl {
    VkInstance instance = VK_NULL_HANDLE;
    VkDebugUtilsMessengerEXT messenger = VK_NULL_HANDLE;
    VkPhysicalDevice physical = VK_NULL_HANDLE;
    VkDevice device = VK_NULL_HANDLE;
    VkQueue queue = VK_NULL_HANDLE;
    std::uint32_t queueFamily = 0;
    VkPhysicalDeviceProperties properties{};
    VkPhysicalDeviceMemoryProperties memory{};
    VkDeviceSize maxAllocation = 0;        // maintenance3 maxMemoryAllocationSize
    std::uint32_t timestampValidBits = 0;  // of the queue family; 0: no timestamps
    bool validation = false, log = false;
    bool owned = true;  // false for an adopted device (psub/vulkan_interop.h): nothing destroyed

    std::atomic<std::uint64_t> messages{0};
    // Two locks, never held together: the messenger callback runs inside Vulkan calls,
    // vkQueueSubmit among them, so it must not wait for the lock the submitter holds.
    mutable std::mutex messageLock;  // guards lastMessage (taken by the messenger callback)
    mutable std::mutex submitLock;   // serializes queue submissions
    std::string lastMessage;

    // The compute evaluator's pipelines, made by it on first use (under pipelinesOnce) and kept
    // for the context's lifetime; released before the device.
    std::once_flag pipelinesOnce;
    std::shared_ptr<vulkan::Pipelines> pipelines;

    ~Impl();
    // True when CPU and device share memory (lavapipe, integrated GPUs): no staging copies.
    bool unifiedMemory() const {
        return properties.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU ||
               properties.deviceType == VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU;
    }
};

// The context's innards, for PSub's own libraries (evaluator, renderer, presenter) and tests.
inline VulkanContext::Impl& contextInternals(VulkanContext& context) { return *context.impl_; }

}  // namespace psub
