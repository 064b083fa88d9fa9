// The Vulkan context: instance (+ validation layer and a counting debug messenger), device
// choice by capability with an override, one compute queue. Also VK_CHECK's reporting.
#include "device.h"

#include "psub/vulkan_device.h"

#include "config.h"  // shaders/config.h: what the compute kernels need of a device

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

namespace psub {
namespace vulkan {

const char* resultName(VkResult result) {
    switch (result) {
#define PSUB_RESULT(name) \
    case name: return #name;
        PSUB_RESULT(VK_SUCCESS)
        PSUB_RESULT(VK_NOT_READY)
        PSUB_RESULT(VK_TIMEOUT)
        PSUB_RESULT(VK_INCOMPLETE)
        PSUB_RESULT(VK_ERROR_OUT_OF_HOST_MEMORY)
        PSUB_RESULT(VK_ERROR_OUT_OF_DEVICE_MEMORY)
        PSUB_RESULT(VK_ERROR_INITIALIZATION_FAILED)
        PSUB_RESULT(VK_ERROR_DEVICE_LOST)
        PSUB_RESULT(VK_ERROR_MEMORY_MAP_FAILED)
        PSUB_RESULT(VK_ERROR_LAYER_NOT_PRESENT)
        PSUB_RESULT(VK_ERROR_EXTENSION_NOT_PRESENT)
        PSUB_RESULT(VK_ERROR_FEATURE_NOT_PRESENT)
        PSUB_RESULT(VK_ERROR_INCOMPATIBLE_DRIVER)
        PSUB_RESULT(VK_ERROR_TOO_MANY_OBJECTS)
        PSUB_RESULT(VK_ERROR_FORMAT_NOT_SUPPORTED)
        PSUB_RESULT(VK_ERROR_FRAGMENTED_POOL)
        PSUB_RESULT(VK_ERROR_OUT_OF_POOL_MEMORY)
        PSUB_RESULT(VK_ERROR_INVALID_EXTERNAL_HANDLE)
        PSUB_RESULT(VK_ERROR_FRAGMENTATION)
        PSUB_RESULT(VK_ERROR_UNKNOWN)
#undef PSUB_RESULT
    default: return "VkResult (unlisted)";
    }
}

void fail(VkResult result, const char* call, const char* file, int line) {
    const char* base = std::strrchr(file, '/');
    throw VulkanError(std::string(call) + " failed with " + resultName(result) + " (" + std::to_string(int(result)) +
                      ") at " + (base ? base + 1 : file) + ":" + std::to_string(line));
}

}  // namespace vulkan

namespace {

constexpr const char* kValidationLayer = "VK_LAYER_KHRONOS_validation";

std::atomic<std::uint64_t> messageTotal{0};

bool envFlag(const char* name) {
    const char* value = std::getenv(name);
    return value && *value && std::strcmp(value, "0") != 0;
}

const char* typeName(VkPhysicalDeviceType type) {
    switch (type) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return "discrete";
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return "integrated";
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return "virtual";
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return "cpu";
    default: return "other";
    }
}

int typeScore(VkPhysicalDeviceType type) {
    switch (type) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return 4;
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return 3;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return 2;
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return 1;
    default: return 0;
    }
}

bool layerInstalled(const char* name) {
    std::uint32_t count = 0;
    if (vkEnumerateInstanceLayerProperties(&count, nullptr) != VK_SUCCESS) return false;
    std::vector<VkLayerProperties> layers(count);
    if (vkEnumerateInstanceLayerProperties(&count, layers.data()) != VK_SUCCESS) return false;
    return std::any_of(layers.begin(), layers.end(),
                       [&](const VkLayerProperties& l) { return std::strcmp(l.layerName, name) == 0; });
}

VKAPI_ATTR VkBool32 VKAPI_CALL onMessage(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                         VkDebugUtilsMessageTypeFlagsEXT,
                                         const VkDebugUtilsMessengerCallbackDataEXT* data, void* user) {
    auto* context = static_cast<VulkanContext::Impl*>(user);
    const char* level = severity & VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT ? "error" : "warning";
    const std::string text = data && data->pMessage ? data->pMessage : "(no message)";
    context->messages.fetch_add(1);
    messageTotal.fetch_add(1);
    {
        std::lock_guard guard(context->messageLock);
        context->lastMessage = text;
    }
    std::fprintf(stderr, "psub: Vulkan validation %s: %s\n", level, text.c_str());
    return VK_FALSE;
}

bool instanceExtensionInstalled(const std::string& name) {
    std::uint32_t count = 0;
    if (vkEnumerateInstanceExtensionProperties(nullptr, &count, nullptr) != VK_SUCCESS) return false;
    std::vector<VkExtensionProperties> extensions(count);
    if (vkEnumerateInstanceExtensionProperties(nullptr, &count, extensions.data()) != VK_SUCCESS) return false;
    return std::any_of(extensions.begin(), extensions.end(),
                       [&](const VkExtensionProperties& e) { return name == e.extensionName; });
}

VkInstance createInstance(bool validation, bool synchronization, VulkanContext::Impl* messengerOwner,
                          VkDebugUtilsMessengerEXT* messenger, const std::vector<std::string>& extra = {}) {
    VkApplicationInfo app{};
    app.sType = VK_STRUCTURE_TYPE_APPLICATION_INFO;
    app.pApplicationName = "psub";
    app.pEngineName = "psub";
    app.apiVersion = VK_API_VERSION_1_1;
    VkInstanceCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO;
    info.pApplicationInfo = &app;
    const char* layers[] = {kValidationLayer};
    std::vector<const char*> extensions;
    for (const std::string& name : extra) {
        if (!instanceExtensionInstalled(name))
            throw VulkanError("the Vulkan instance extension " + name + " is not available");
        extensions.push_back(name.c_str());
    }
    if (validation) extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
    info.enabledExtensionCount = std::uint32_t(extensions.size());
    info.ppEnabledExtensionNames = extensions.data();
    VkDebugUtilsMessengerCreateInfoEXT messengerInfo{};
    messengerInfo.sType = VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT;
    messengerInfo.messageSeverity =
        VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
    messengerInfo.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT |
                                VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                                VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
    messengerInfo.pfnUserCallback = onMessage;
    messengerInfo.pUserData = messengerOwner;
    // Synchronization validation when asked: a missing barrier is reported like any other error.
    VkValidationFeatureEnableEXT enables[] = {VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT};
    VkValidationFeaturesEXT features{};
    features.sType = VK_STRUCTURE_TYPE_VALIDATION_FEATURES_EXT;
    features.enabledValidationFeatureCount = synchronization ? 1 : 0;
    features.pEnabledValidationFeatures = enables;
    if (validation) {
        info.enabledLayerCount = 1;
        info.ppEnabledLayerNames = layers;
        features.pNext = &messengerInfo;  // also reports on instance creation and destruction
        info.pNext = &features;
    }
    VkInstance instance = VK_NULL_HANDLE;
    const VkResult result = vkCreateInstance(&info, nullptr, &instance);
    if (result == VK_ERROR_INCOMPATIBLE_DRIVER)
        throw VulkanError("no Vulkan driver found (vkCreateInstance: VK_ERROR_INCOMPATIBLE_DRIVER); on Debian "
                          "install mesa-vulkan-drivers for lavapipe, or a GPU's Vulkan driver");
    VK_CHECK(result);
    if (validation) {
        auto create = reinterpret_cast<PFN_vkCreateDebugUtilsMessengerEXT>(
            vkGetInstanceProcAddr(instance, "vkCreateDebugUtilsMessengerEXT"));
        const VkResult made = create ? create(instance, &messengerInfo, nullptr, messenger)
                                     : VK_ERROR_EXTENSION_NOT_PRESENT;
        if (made != VK_SUCCESS) {
            vkDestroyInstance(instance, nullptr);
            VK_CHECK(made);
        }
    }
    return instance;
}

struct Candidate {
    VkPhysicalDevice device = VK_NULL_HANDLE;
    VkPhysicalDeviceProperties properties{};
    std::uint32_t family = ~0u, timestampBits = 0;
    std::string why;  // empty when usable
    VkDeviceSize localBytes = 0;
};

// What a window needs of a device (VulkanOptions): empty filter and list accept every device.
struct PresentNeeds {
    VkInstance instance = VK_NULL_HANDLE;
    const std::vector<std::string>* deviceExtensions = nullptr;
    const std::function<bool(void*, void*, std::uint32_t)>* filter = nullptr;
};

// The first of `names` the device lacks, or empty.
std::string missingDeviceExtension(VkPhysicalDevice device, const std::vector<std::string>& names) {
    std::uint32_t count = 0;
    vkEnumerateDeviceExtensionProperties(device, nullptr, &count, nullptr);
    std::vector<VkExtensionProperties> extensions(count);
    vkEnumerateDeviceExtensionProperties(device, nullptr, &count, extensions.data());
    for (const std::string& name : names)
        if (std::none_of(extensions.begin(), extensions.end(),
                         [&](const VkExtensionProperties& e) { return name == e.extensionName; }))
            return name;
    return {};
}

Candidate examine(VkPhysicalDevice device, const PresentNeeds& needs) {
    Candidate c;
    c.device = device;
    vkGetPhysicalDeviceProperties(device, &c.properties);
    std::uint32_t count = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(device, &count, nullptr);
    std::vector<VkQueueFamilyProperties> families(count);
    vkGetPhysicalDeviceQueueFamilyProperties(device, &count, families.data());
    // A compute family; one with timestamps first, then one that can also draw (the offscreen
    // renderer, psub_render, shares the context's queue; every GPU has such a family).
    int best = -1;
    for (std::uint32_t i = 0; i < count; ++i) {
        if (!(families[i].queueFlags & VK_QUEUE_COMPUTE_BIT) || families[i].queueCount == 0) continue;
        if (needs.filter && *needs.filter && !(*needs.filter)(needs.instance, device, i)) continue;
        const int score = (families[i].timestampValidBits > 0 ? 2 : 0) + (families[i].queueFlags & VK_QUEUE_GRAPHICS_BIT ? 1 : 0);
        if (score > best) best = score, c.family = i, c.timestampBits = families[i].timestampValidBits;
    }
    VkPhysicalDeviceMemoryProperties memory;
    vkGetPhysicalDeviceMemoryProperties(device, &memory);
    for (std::uint32_t h = 0; h < memory.memoryHeapCount; ++h)
        if (memory.memoryHeaps[h].flags & VK_MEMORY_HEAP_DEVICE_LOCAL_BIT) c.localBytes += memory.memoryHeaps[h].size;
    const VkPhysicalDeviceLimits& limits = c.properties.limits;
    if (c.properties.apiVersion < VK_API_VERSION_1_1) c.why = "Vulkan 1.1 not supported";
    else if (c.family == ~0u) c.why = needs.filter && *needs.filter ? "no compute queue that can present" : "no compute queue";
    else if (limits.maxPerStageDescriptorStorageBuffers < std::uint32_t(PSUB_BINDING_COUNT))
        c.why = "fewer than " + std::to_string(PSUB_BINDING_COUNT) + " storage buffers per stage";
    else if (limits.maxComputeWorkGroupSize[0] < std::uint32_t(PSUB_WORKGROUP_SIZE) ||
             limits.maxComputeWorkGroupInvocations < std::uint32_t(PSUB_WORKGROUP_SIZE))
        c.why = "workgroups of " + std::to_string(PSUB_WORKGROUP_SIZE) + " not supported";
    else if (needs.deviceExtensions) {
        const std::string missing = missingDeviceExtension(device, *needs.deviceExtensions);
        if (!missing.empty()) c.why = "no " + missing;
    }
    return c;
}

std::string describe(std::size_t index, const Candidate& c) {
    std::string text = std::to_string(index) + ": " + c.properties.deviceName + " [" + typeName(c.properties.deviceType) + "]";
    if (!c.why.empty()) text += " (unusable: " + c.why + ")";
    return text;
}

std::string lower(std::string text) {
    for (char& ch : text) ch = char(std::tolower(static_cast<unsigned char>(ch)));
    return text;
}

std::vector<Candidate> candidates(VkInstance instance, const PresentNeeds& needs = {}) {
    std::uint32_t count = 0;
    VK_CHECK(vkEnumeratePhysicalDevices(instance, &count, nullptr));
    std::vector<VkPhysicalDevice> devices(count);
    VK_CHECK(vkEnumeratePhysicalDevices(instance, &count, devices.data()));
    devices.resize(count);
    std::vector<Candidate> list;
    for (VkPhysicalDevice d : devices) list.push_back(examine(d, needs));
    return list;
}

std::string listing(const std::vector<Candidate>& list) {
    if (list.empty()) return "none";
    std::string text;
    for (std::size_t i = 0; i < list.size(); ++i) text += (i ? "; " : "") + describe(i, list[i]);
    return text;
}

// The device asked for (`selector`: index or name substring) or the best usable one.
std::size_t choose(const std::vector<Candidate>& list, const std::string& selector, const std::string& origin) {
    if (list.empty())
        throw VulkanError("no Vulkan device found (the loader reports none; on Debian install "
                          "mesa-vulkan-drivers for lavapipe, or a GPU's Vulkan driver)");
    if (!selector.empty()) {
        std::size_t pick = list.size();
        const bool numeric = std::all_of(selector.begin(), selector.end(),
                                         [](char ch) { return std::isdigit(static_cast<unsigned char>(ch)) != 0; });
        if (numeric) {
            const unsigned long index = std::strtoul(selector.c_str(), nullptr, 10);
            if (index < list.size()) pick = index;
        } else {
            for (std::size_t i = 0; i < list.size() && pick == list.size(); ++i)
                if (lower(list[i].properties.deviceName).find(lower(selector)) != std::string::npos) pick = i;
        }
        if (pick == list.size())
            throw VulkanError(origin + "=\"" + selector + "\" matches no Vulkan device (devices: " + listing(list) + ")");
        if (!list[pick].why.empty())
            throw VulkanError(origin + "=\"" + selector + "\" names a device that cannot run PSub: " + describe(pick, list[pick]));
        return pick;
    }
    std::size_t best = list.size();
    for (std::size_t i = 0; i < list.size(); ++i) {
        if (!list[i].why.empty()) continue;
        if (best == list.size()) {
            best = i;
            continue;
        }
        const int a = typeScore(list[i].properties.deviceType), b = typeScore(list[best].properties.deviceType);
        if (a > b || (a == b && list[i].localBytes > list[best].localBytes)) best = i;
    }
    if (best == list.size()) throw VulkanError("no usable Vulkan device (devices: " + listing(list) + ")");
    return best;
}

// The largest single allocation the device allows (Vulkan 1.1's maintenance3 property).
VkDeviceSize maxAllocationSize(VkPhysicalDevice physical) {
    VkPhysicalDeviceMaintenance3Properties maintenance3{};
    maintenance3.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MAINTENANCE_3_PROPERTIES;
    VkPhysicalDeviceProperties2 properties2{};
    properties2.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2;
    properties2.pNext = &maintenance3;
    vkGetPhysicalDeviceProperties2(physical, &properties2);
    return maintenance3.maxMemoryAllocationSize;
}

}  // namespace

VulkanContext::Impl::~Impl() {
    pipelines.reset();
    if (!owned) return;
    if (device) vkDestroyDevice(device, nullptr);
    if (messenger) {
        auto destroy = reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(
            vkGetInstanceProcAddr(instance, "vkDestroyDebugUtilsMessengerEXT"));
        if (destroy) destroy(instance, messenger, nullptr);
    }
    if (instance) vkDestroyInstance(instance, nullptr);
}

VulkanContext::VulkanContext(const VulkanOptions& options) : impl_(std::make_unique<Impl>()) {
    Impl& c = *impl_;
    c.log = options.log || envFlag("PSUB_VULKAN_LOG");
    bool validation = false;
    switch (options.validation) {
    case Validation::Off: break;
    case Validation::On:
        if (!layerInstalled(kValidationLayer))
            throw VulkanError(std::string(kValidationLayer) +
                              " was asked for but is not installed (Debian: vulkan-validationlayers)");
        validation = true;
        break;
    case Validation::Default: {
#ifndef NDEBUG
        const bool wanted = true;
#else
        const bool wanted = envFlag("PSUB_VULKAN_VALIDATION");
#endif
        validation = wanted && layerInstalled(kValidationLayer);
        if (wanted && !validation)
            std::fprintf(stderr, "psub: %s is not installed; running without validation\n", kValidationLayer);
        break;
    }
    }
    c.validation = validation;
    c.instance = createInstance(validation, options.synchronizationValidation || envFlag("PSUB_VULKAN_SYNC_VALIDATION"),
                                &c, &c.messenger, options.instanceExtensions);

    const std::vector<Candidate> list =
        candidates(c.instance, {c.instance, &options.deviceExtensions, &options.queueFamilyFilter});
    const char* env = std::getenv("PSUB_VULKAN_DEVICE");
    const std::string selector = !options.device.empty() ? options.device : env ? env : "";
    const std::size_t pick = choose(list, selector, !options.device.empty() ? "device" : "PSUB_VULKAN_DEVICE");
    const Candidate& chosen = list[pick];
    if (c.log)
        for (std::size_t i = 0; i < list.size(); ++i)
            std::fprintf(stderr, "psub: Vulkan device %s%s\n", describe(i, list[i]).c_str(),
                         i == pick ? ", chosen" : "");
    c.physical = chosen.device;
    c.properties = chosen.properties;
    c.queueFamily = chosen.family;
    c.timestampValidBits = chosen.timestampBits;
    vkGetPhysicalDeviceMemoryProperties(c.physical, &c.memory);
    c.maxAllocation = maxAllocationSize(c.physical);

    const float priority = 1.0f;
    VkDeviceQueueCreateInfo queueInfo{};
    queueInfo.sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO;
    queueInfo.queueFamilyIndex = c.queueFamily;
    queueInfo.queueCount = 1;
    queueInfo.pQueuePriorities = &priority;
    VkDeviceCreateInfo deviceInfo{};
    deviceInfo.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
    deviceInfo.queueCreateInfoCount = 1;
    deviceInfo.pQueueCreateInfos = &queueInfo;
    std::vector<const char*> deviceExtensions;
    for (const std::string& name : options.deviceExtensions) deviceExtensions.push_back(name.c_str());
    deviceInfo.enabledExtensionCount = std::uint32_t(deviceExtensions.size());
    deviceInfo.ppEnabledExtensionNames = deviceExtensions.data();
    VK_CHECK(vkCreateDevice(c.physical, &deviceInfo, nullptr, &c.device));
    vkGetDeviceQueue(c.device, c.queueFamily, 0, &c.queue);
}

VulkanContext::VulkanContext(const VulkanDeviceHandles& adopted) : impl_(std::make_unique<Impl>()) {
    Impl& c = *impl_;
    c.owned = false;
    if (!adopted.instance || !adopted.physicalDevice || !adopted.device || !adopted.queue)
        throw VulkanError("VulkanContext: an adopted instance, physical device, device and queue must all be given");
    c.instance = adopted.instance;
    c.physical = adopted.physicalDevice;
    c.device = adopted.device;
    c.queue = adopted.queue;
    c.queueFamily = adopted.queueFamily;
    vkGetPhysicalDeviceProperties(c.physical, &c.properties);
    if (c.properties.apiVersion < VK_API_VERSION_1_1)
        throw VulkanError(std::string("VulkanContext: adopted device ") + c.properties.deviceName + " is not Vulkan 1.1");
    std::uint32_t familyCount = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(c.physical, &familyCount, nullptr);
    std::vector<VkQueueFamilyProperties> families(familyCount);
    vkGetPhysicalDeviceQueueFamilyProperties(c.physical, &familyCount, families.data());
    if (c.queueFamily >= familyCount || !(families[c.queueFamily].queueFlags & VK_QUEUE_COMPUTE_BIT))
        throw VulkanError("VulkanContext: adopted queue family " + std::to_string(c.queueFamily) + " of " +
                          c.properties.deviceName + " has no compute");
    c.timestampValidBits = families[c.queueFamily].timestampValidBits;
    vkGetPhysicalDeviceMemoryProperties(c.physical, &c.memory);
    c.maxAllocation = maxAllocationSize(c.physical);
}

VulkanContext::~VulkanContext() = default;

std::string VulkanContext::deviceName() const { return impl_->properties.deviceName; }
bool VulkanContext::cpuDevice() const { return impl_->properties.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU; }
bool VulkanContext::validationEnabled() const { return impl_->validation; }
std::uint64_t VulkanContext::validationMessageCount() const { return impl_->messages.load(); }
std::string VulkanContext::lastValidationMessage() const {
    std::lock_guard guard(impl_->messageLock);
    return impl_->lastMessage;
}

std::uint64_t vulkanValidationMessageTotal() { return messageTotal.load(); }

std::vector<std::string> listVulkanDevices() {
    VulkanContext::Impl scratch;
    scratch.instance = createInstance(false, false, nullptr, nullptr);
    const std::vector<Candidate> list = candidates(scratch.instance);
    std::vector<std::string> names;
    for (std::size_t i = 0; i < list.size(); ++i) names.push_back(describe(i, list[i]));
    return names;
}

}  // namespace psub
