// Bring your own device and buffers (psub/vulkan_interop.h): the test creates its own instance
// (validation layer on, failing on any message), device, queue, buffers and command buffer with
// raw Vulkan; PSub adopts them, reads control points from the test's buffer and writes the
// refined positions and normals into the test's buffers, recorded into the test's command
// buffer or submitted with the test's semaphore. Results are checked against the CPU evaluator.
#include "psub/evaluator.h"
#include "psub/stencils.h"
#include "psub/vulkan_interop.h"

#include "test_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <memory>
#include <string>
#include <vector>

namespace psub {
namespace {

#define CHECK_VK(call) ASSERT_EQ((call), VK_SUCCESS) << #call

int messages = 0;
std::string lastMessage;

VKAPI_ATTR VkBool32 VKAPI_CALL onMessage(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                         VkDebugUtilsMessageTypeFlagsEXT, const VkDebugUtilsMessengerCallbackDataEXT* data,
                                         void*) {
    if (severity >= VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT) {
        ++messages;
        lastMessage = data->pMessage;
    }
    return VK_FALSE;
}

using test::noVulkanAllowed;

// A host-visible buffer the test owns.
struct OwnBuffer {
    VkBuffer buffer = VK_NULL_HANDLE;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    float* mapped = nullptr;
};

// The test's own Vulkan objects, raw.
class OwnDevice : public ::testing::Test {
protected:
    VkInstance instance = VK_NULL_HANDLE;
    VkDebugUtilsMessengerEXT messenger = VK_NULL_HANDLE;
    VkPhysicalDevice physical = VK_NULL_HANDLE;
    VkDevice device = VK_NULL_HANDLE;
    VkQueue queue = VK_NULL_HANDLE;
    std::uint32_t family = 0;
    VkCommandPool pool = VK_NULL_HANDLE;
    VkFence fence = VK_NULL_HANDLE;
    std::deque<OwnBuffer> buffers;  // references to its elements stay valid

    void SetUp() override {
        messages = 0;
        createInstance();
        if (HasFatalFailure() || IsSkipped()) return;
        pickDevice();
        if (HasFatalFailure() || IsSkipped()) return;
        createDevice();
    }

    // An instance with the validation layer and a messenger that counts its messages.
    void createInstance() {
        VkApplicationInfo app{};
        app.sType = VK_STRUCTURE_TYPE_APPLICATION_INFO;
        app.apiVersion = VK_API_VERSION_1_1;
        const char* layer = "VK_LAYER_KHRONOS_validation";
        const char* extension = VK_EXT_DEBUG_UTILS_EXTENSION_NAME;
        VkInstanceCreateInfo info{};
        info.sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO;
        info.pApplicationInfo = &app;
        info.enabledLayerCount = 1;
        info.ppEnabledLayerNames = &layer;
        info.enabledExtensionCount = 1;
        info.ppEnabledExtensionNames = &extension;
        const VkResult made = vkCreateInstance(&info, nullptr, &instance);
        if (made != VK_SUCCESS) {
            if (noVulkanAllowed()) GTEST_SKIP() << "no Vulkan instance with validation (PSUB_ALLOW_NO_VULKAN=1)";
            FAIL() << "vkCreateInstance with VK_LAYER_KHRONOS_validation failed: " << made
                   << " (set PSUB_ALLOW_NO_VULKAN=1 to skip)";
        }
        VkDebugUtilsMessengerCreateInfoEXT messengerInfo{};
        messengerInfo.sType = VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT;
        messengerInfo.messageSeverity =
            VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
        messengerInfo.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT |
                                    VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                                    VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
        messengerInfo.pfnUserCallback = onMessage;
        auto create = reinterpret_cast<PFN_vkCreateDebugUtilsMessengerEXT>(
            vkGetInstanceProcAddr(instance, "vkCreateDebugUtilsMessengerEXT"));
        ASSERT_NE(create, nullptr);
        CHECK_VK(create(instance, &messengerInfo, nullptr, &messenger));
    }

    // The first device with a compute queue (lavapipe in CI).
    void pickDevice() {
        std::uint32_t count = 0;
        vkEnumeratePhysicalDevices(instance, &count, nullptr);
        std::vector<VkPhysicalDevice> devices(count);
        vkEnumeratePhysicalDevices(instance, &count, devices.data());
        for (VkPhysicalDevice d : devices) {
            std::uint32_t families = 0;
            vkGetPhysicalDeviceQueueFamilyProperties(d, &families, nullptr);
            std::vector<VkQueueFamilyProperties> properties(families);
            vkGetPhysicalDeviceQueueFamilyProperties(d, &families, properties.data());
            for (std::uint32_t f = 0; f < families && !physical; ++f)
                if (properties[f].queueFlags & VK_QUEUE_COMPUTE_BIT) physical = d, family = f;
            if (physical) break;
        }
        if (!physical) {
            if (noVulkanAllowed()) GTEST_SKIP() << "no Vulkan device (PSUB_ALLOW_NO_VULKAN=1)";
            FAIL() << "no Vulkan device with a compute queue (set PSUB_ALLOW_NO_VULKAN=1 to skip)";
        }
    }

    // The device with one queue of that family, a command pool and a fence for submitAndWait.
    void createDevice() {
        const float priority = 1.0f;
        VkDeviceQueueCreateInfo queueInfo{};
        queueInfo.sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO;
        queueInfo.queueFamilyIndex = family;
        queueInfo.queueCount = 1;
        queueInfo.pQueuePriorities = &priority;
        VkDeviceCreateInfo deviceInfo{};
        deviceInfo.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
        deviceInfo.queueCreateInfoCount = 1;
        deviceInfo.pQueueCreateInfos = &queueInfo;
        CHECK_VK(vkCreateDevice(physical, &deviceInfo, nullptr, &device));
        vkGetDeviceQueue(device, family, 0, &queue);
        VkCommandPoolCreateInfo poolInfo{};
        poolInfo.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
        poolInfo.queueFamilyIndex = family;
        CHECK_VK(vkCreateCommandPool(device, &poolInfo, nullptr, &pool));
        VkFenceCreateInfo fenceInfo{};
        fenceInfo.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
        CHECK_VK(vkCreateFence(device, &fenceInfo, nullptr, &fence));
    }

    // Submits `submit` to the queue and waits for it (the fence is reset for the next one).
    void submitAndWait(const VkSubmitInfo& submit) {
        CHECK_VK(vkQueueSubmit(queue, 1, &submit, fence));
        CHECK_VK(vkWaitForFences(device, 1, &fence, VK_TRUE, UINT64_MAX));
        CHECK_VK(vkResetFences(device, 1, &fence));
    }

    void TearDown() override {
        if (device) vkDeviceWaitIdle(device);
        for (OwnBuffer& b : buffers) {
            vkDestroyBuffer(device, b.buffer, nullptr);
            vkFreeMemory(device, b.memory, nullptr);
        }
        if (fence) vkDestroyFence(device, fence, nullptr);
        if (pool) vkDestroyCommandPool(device, pool, nullptr);
        if (device) vkDestroyDevice(device, nullptr);
        if (messenger) {
            auto destroy = reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(
                vkGetInstanceProcAddr(instance, "vkDestroyDebugUtilsMessengerEXT"));
            destroy(instance, messenger, nullptr);
        }
        if (instance) vkDestroyInstance(instance, nullptr);
        EXPECT_EQ(messages, 0) << "validation: " << lastMessage;
    }

    OwnBuffer& makeBuffer(VkDeviceSize bytes, VkBufferUsageFlags usage) {
        OwnBuffer b;
        VkBufferCreateInfo info{};
        info.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
        info.size = bytes;
        info.usage = usage;
        EXPECT_EQ(vkCreateBuffer(device, &info, nullptr, &b.buffer), VK_SUCCESS);
        VkMemoryRequirements needs;
        vkGetBufferMemoryRequirements(device, b.buffer, &needs);
        VkPhysicalDeviceMemoryProperties memory;
        vkGetPhysicalDeviceMemoryProperties(physical, &memory);
        const VkMemoryPropertyFlags wanted = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
        std::uint32_t type = 0;
        while (type < memory.memoryTypeCount &&
               !((needs.memoryTypeBits >> type & 1) && (memory.memoryTypes[type].propertyFlags & wanted) == wanted))
            ++type;
        EXPECT_LT(type, memory.memoryTypeCount);
        VkMemoryAllocateInfo allocate{};
        allocate.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
        allocate.allocationSize = needs.size;
        allocate.memoryTypeIndex = type;
        EXPECT_EQ(vkAllocateMemory(device, &allocate, nullptr, &b.memory), VK_SUCCESS);
        EXPECT_EQ(vkBindBufferMemory(device, b.buffer, b.memory, 0), VK_SUCCESS);
        void* mapped = nullptr;
        EXPECT_EQ(vkMapMemory(device, b.memory, 0, VK_WHOLE_SIZE, 0, &mapped), VK_SUCCESS);
        b.mapped = static_cast<float*>(mapped);
        buffers.push_back(b);
        return buffers.back();
    }
};

struct Model {
    test::Loaded loaded;
    Refinement r;
};

Model spot() {
    Model m{test::load(test::dataPath("spot_control_mesh.obj")), {}};
    RefineOptions options;
    options.factorized = true;
    m.r = refine(m.loaded.mesh, m.loaded.checked.connectivity, options);
    return m;
}

// Control points of a pose: `t` moves them so two frames differ.
std::vector<float> pose(const Mesh& mesh, float t) {
    std::vector<float> control;
    for (std::size_t i = 0; i < mesh.positions.size(); ++i)
        control.push_back(float(mesh.positions[i]) + (i % 3 == 1 ? t * std::sin(float(i)) : 0.0f));
    return control;
}

// Largest difference between the CPU's packed xyz and a device buffer of `stride` floats.
float largestDifference(const std::vector<float>& cpu, const float* device, std::uint32_t stride) {
    float worst = 0;
    for (std::size_t v = 0; v < cpu.size() / 3; ++v)
        for (std::size_t i = 0; i < 3; ++i) worst = std::max(worst, std::abs(cpu[3 * v + i] - device[v * stride + i]));
    return worst;
}

constexpr VkDeviceSize kControlOffset = 256, kRefinedOffset = 64, kNormalsOffset = 32;  // any multiple of 4

TEST_F(OwnDevice, EvaluatorRecordsIntoTheCallersCommandBufferAndBuffers) {
    const Model m = spot();
    VulkanContext context(VulkanDeviceHandles{instance, physical, device, family, queue});
    VulkanEvaluator gpu(context, m.r.perLevel, m.r.factorized, m.r.surface, TableForm::PerLevel);
    const std::uint32_t stride = gpu.deviceStride();
    ASSERT_EQ(stride, 4u);
    OwnBuffer& control = makeBuffer(kControlOffset + 16ull * gpu.controlCount(), VK_BUFFER_USAGE_TRANSFER_SRC_BIT);
    OwnBuffer& refined = makeBuffer(kRefinedOffset + 16ull * gpu.refinedCount(),
                                    VK_BUFFER_USAGE_TRANSFER_DST_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT);
    OwnBuffer& normals = makeBuffer(kNormalsOffset + 16ull * gpu.refinedCount(), VK_BUFFER_USAGE_TRANSFER_DST_BIT);
    const std::vector<float> points = pose(m.loaded.mesh, 0.1f);
    float* in = control.mapped + kControlOffset / 4;
    for (std::uint32_t v = 0; v < gpu.controlCount(); ++v) std::memcpy(in + 4 * v, &points[3 * v], 12);

    VkCommandBufferAllocateInfo allocate{};
    allocate.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
    allocate.commandPool = pool;
    allocate.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    allocate.commandBufferCount = 1;
    VkCommandBuffer command = VK_NULL_HANDLE;
    CHECK_VK(vkAllocateCommandBuffers(device, &allocate, &command));
    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    CHECK_VK(vkBeginCommandBuffer(command, &begin));
    gpu.record(command, {{control.buffer, kControlOffset}, {refined.buffer, kRefinedOffset}, {normals.buffer, kNormalsOffset}});
    // The caller's own work after the evaluator's, in the same command buffer: the evaluator's
    // exit barrier makes its results visible to it (here a transfer that reads the positions).
    OwnBuffer& copy = makeBuffer(16ull * gpu.refinedCount(), VK_BUFFER_USAGE_TRANSFER_DST_BIT);
    const VkBufferCopy region{kRefinedOffset, 0, 16ull * gpu.refinedCount()};
    vkCmdCopyBuffer(command, refined.buffer, copy.buffer, 1, &region);
    VkMemoryBarrier toHost{};
    toHost.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
    toHost.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    toHost.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
    vkCmdPipelineBarrier(command, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_HOST_BIT, 0, 1, &toHost, 0, nullptr,
                         0, nullptr);
    CHECK_VK(vkEndCommandBuffer(command));
    VkSubmitInfo submit{};
    submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
    submit.commandBufferCount = 1;
    submit.pCommandBuffers = &command;
    submitAndWait(submit);

    CpuEvaluator<float> cpu(m.r.perLevel, m.r.factorized, m.r.surface, TableForm::PerLevel);
    std::vector<float> positions(3 * std::size_t(cpu.refinedCount())), cpuNormals(positions.size());
    cpu.evaluate(points, positions);
    cpu.normals(positions, cpuNormals);
    EXPECT_LE(largestDifference(positions, refined.mapped + kRefinedOffset / 4, stride), 1e-5f);
    EXPECT_LE(largestDifference(cpuNormals, normals.mapped + kNormalsOffset / 4, 4), 1e-4f);
    EXPECT_LE(largestDifference(positions, copy.mapped, stride), 1e-5f);
}

TEST_F(OwnDevice, EvaluatorSubmitsSignallingTheCallersSemaphore) {
    const Model m = spot();
    VulkanContext context(VulkanDeviceHandles{instance, physical, device, family, queue});
    VulkanEvaluator gpu(context, m.r.perLevel, m.r.factorized, m.r.surface, TableForm::Factorized);
    OwnBuffer& control = makeBuffer(16ull * gpu.controlCount(), VK_BUFFER_USAGE_TRANSFER_SRC_BIT);
    OwnBuffer& refined = makeBuffer(16ull * gpu.refinedCount(), VK_BUFFER_USAGE_TRANSFER_DST_BIT);
    VkSemaphoreCreateInfo semaphoreInfo{};
    semaphoreInfo.sType = VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO;
    VkSemaphore done = VK_NULL_HANDLE;
    CHECK_VK(vkCreateSemaphore(device, &semaphoreInfo, nullptr, &done));
    CpuEvaluator<float> cpu(m.r.perLevel, m.r.factorized, m.r.surface, TableForm::Factorized);
    std::vector<float> positions(3 * std::size_t(cpu.refinedCount()));
    for (float t : {0.0f, 0.2f}) {  // two frames: the second overwrites the first
        const std::vector<float> points = pose(m.loaded.mesh, t);
        for (std::uint32_t v = 0; v < gpu.controlCount(); ++v) std::memcpy(control.mapped + 4 * v, &points[3 * v], 12);
        gpu.submit({{control.buffer, 0}, {refined.buffer, 0}, {}}, {VK_NULL_HANDLE, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, done});
        // The caller's next submission waits for the semaphore, then signals the caller's fence.
        const VkPipelineStageFlags stage = VK_PIPELINE_STAGE_ALL_COMMANDS_BIT;
        VkSubmitInfo wait{};
        wait.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
        wait.waitSemaphoreCount = 1;
        wait.pWaitSemaphores = &done;
        wait.pWaitDstStageMask = &stage;
        submitAndWait(wait);
        cpu.evaluate(points, positions);
        EXPECT_LE(largestDifference(positions, refined.mapped, 4), 1e-5f) << "pose " << t;
    }
    vkDeviceWaitIdle(device);
    vkDestroySemaphore(device, done, nullptr);
}

TEST_F(OwnDevice, AdoptedContextRefusesMissingHandles) {
    EXPECT_THROW(VulkanContext(VulkanDeviceHandles{instance, physical, VK_NULL_HANDLE, family, queue}), VulkanError);
}

}  // namespace
}  // namespace psub
