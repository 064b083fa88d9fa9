// psub/vulkan_context.h: the Vulkan context (instance, validation messages, device choice,
// one queue) that the compute evaluator (psub/vulkan_evaluator.h) and the renderer
// (psub/render.h) share, and VulkanError. No Vulkan types here; psub/vulkan_device.h holds the
// caller's handles a context can adopt. Link psub::vulkan (or psub::vulkan_core alone).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace psub {

struct VulkanDeviceHandles;  // psub/vulkan_device.h: the caller's instance, device and queue

// Any Vulkan failure: what() names the failing call, its result, file and line, or why no
// device could be used (no driver, no device with a compute queue, an override that matches
// nothing: each with the list of devices seen).
class VulkanError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

enum class Validation {
    Default,  // on in debug builds of the library or when PSUB_VULKAN_VALIDATION=1, if installed
    Off,
    On,       // required: VulkanError when VK_LAYER_KHRONOS_validation is not installed
};

struct VulkanOptions {
    Validation validation = Validation::Default;
    // Device choice: an index into vkEnumeratePhysicalDevices or a case-insensitive substring
    // of the device name. Empty: $PSUB_VULKAN_DEVICE when set, else the most capable device
    // (discrete > integrated > virtual > CPU) that has a compute queue.
    std::string device;
    // Print the device chosen (and the ones passed over) on stderr; also $PSUB_VULKAN_LOG=1.
    bool log = false;
    // With validation: also synchronization validation (missing barriers are errors); also
    // $PSUB_VULKAN_SYNC_VALIDATION=1. Off by default: Debian's layer (1.3.239) leaks memory
    // with it (KhronosGroup/Vulkan-ValidationLayers#6033), which LeakSanitizer reports.
    bool synchronizationValidation = false;
    // For presenting to a window: instance extensions enabled besides the context's own (such
    // as GLFW's surface extensions), device extensions every usable device must have (such as
    // VK_KHR_swapchain), and a test each queue family must pass to be chosen, called with the
    // VkInstance, the VkPhysicalDevice and the family index (handles as opaque pointers). A
    // missing instance extension throws VulkanError naming it; a device without the device
    // extensions or a passing family is unusable (listed with the reason).
    std::vector<std::string> instanceExtensions{}, deviceExtensions{};
    std::function<bool(void* instance, void* physicalDevice, std::uint32_t family)> queueFamilyFilter{};
};

// One device and its compute queue, shared by evaluators (which must not outlive it).
// Validation messages (warnings and errors) are printed on stderr and counted.
class VulkanContext {
public:
    // Throws VulkanError when no usable device is found.
    explicit VulkanContext(const VulkanOptions& options = {});
    // Adopts the caller's instance, physical device, device and queue without owning them (they
    // must outlive the context; nothing of them is destroyed). No validation messenger of its
    // own: the caller's instance reports. Throws VulkanError when the device is not Vulkan 1.1
    // or the queue family has no compute.
    explicit VulkanContext(const VulkanDeviceHandles& adopted);
    ~VulkanContext();
    VulkanContext(const VulkanContext&) = delete;
    VulkanContext& operator=(const VulkanContext&) = delete;

    std::string deviceName() const;
    // The device runs on this machine's CPU cores (lavapipe): host threads compete with it.
    bool cpuDevice() const;
    bool validationEnabled() const;
    // Validation-layer messages of warning or error severity since the context was created.
    std::uint64_t validationMessageCount() const;
    std::string lastValidationMessage() const;

    struct Impl;  // PSub's own code reaches it through vulkan_core/device.h only

private:
    friend Impl& contextInternals(VulkanContext& context);
    std::unique_ptr<Impl> impl_;
};

// Validation-layer messages (warnings and errors) of every context of this process, including
// those reported while a context is destroyed (objects left alive).
std::uint64_t vulkanValidationMessageTotal();

// "index: name [type]" for every device the loader reports (for messages and logs).
// Throws VulkanError when there is no Vulkan driver at all.
std::vector<std::string> listVulkanDevices();

}  // namespace psub
