// The window presenter: a GLFW window's VkSurfaceKHR and swapchain (re-created on resize), two
// frame slots (staging buffer, command buffer, fence, acquire semaphore) and one release
// semaphore per swapchain image. A present copies the caller's picture into the staging
// buffer, records buffer -> swapchain image (and, to capture, image -> readback buffer),
// submits and presents; a slot's fence is waited on only when the slot comes round again.
#include "psub/presenter.h"

#include "device.h"
#include "resources.h"

#define GLFW_INCLUDE_VULKAN
#include <GLFW/glfw3.h>

#include <algorithm>
#include <cstring>
#include <string>
#include <vector>

namespace psub {
namespace {

using namespace vulkan;

constexpr std::uint32_t kFramesInFlight = 2;

struct Slot {
    Buffer staging;
    VkCommandBuffer commands = VK_NULL_HANDLE;
    VkFence fence = VK_NULL_HANDLE;
    VkSemaphore acquired = VK_NULL_HANDLE;
};

void imageBarrier(VkCommandBuffer command, VkImage image, VkImageLayout from, VkImageLayout to,
                  VkPipelineStageFlags sourceStage, VkAccessFlags sourceAccess, VkPipelineStageFlags destinationStage,
                  VkAccessFlags destinationAccess) {
    VkImageMemoryBarrier barrier{};
    barrier.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER;
    barrier.srcAccessMask = sourceAccess;
    barrier.dstAccessMask = destinationAccess;
    barrier.oldLayout = from;
    barrier.newLayout = to;
    barrier.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    barrier.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    barrier.image = image;
    barrier.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    vkCmdPipelineBarrier(command, sourceStage, destinationStage, 0, 0, nullptr, 0, nullptr, 1, &barrier);
}

}  // namespace

VulkanOptions presentableOptions(VulkanOptions base) {
    std::uint32_t count = 0;
    const char** names = glfwGetRequiredInstanceExtensions(&count);
    if (!names) throw VulkanError("GLFW finds no Vulkan surface support (glfwGetRequiredInstanceExtensions)");
    for (std::uint32_t i = 0; i < count; ++i) base.instanceExtensions.emplace_back(names[i]);
    base.deviceExtensions.emplace_back(VK_KHR_SWAPCHAIN_EXTENSION_NAME);
    base.queueFamilyFilter = [](void* instance, void* physical, std::uint32_t family) {
        return glfwGetPhysicalDevicePresentationSupport(static_cast<VkInstance>(instance),
                                                        static_cast<VkPhysicalDevice>(physical), family) == GLFW_TRUE;
    };
    return base;
}

struct Presenter::Impl {
    VulkanContext::Impl& context;
    GLFWwindow* window;
    bool vsync;
    VkSurfaceKHR surface = VK_NULL_HANDLE;
    VkSwapchainKHR swapchain = VK_NULL_HANDLE;
    VkFormat format = VK_FORMAT_UNDEFINED;
    VkPresentModeKHR mode = VK_PRESENT_MODE_FIFO_KHR;
    VkExtent2D extent{0, 0};
    std::vector<VkImage> images;
    std::vector<VkSemaphore> released;  // per swapchain image: its copy is done, present may start
    std::vector<VkFence> imageFence;    // per swapchain image: the slot fence of its last use
    VkCommandPool pool = VK_NULL_HANDLE;
    Slot slots[kFramesInFlight];
    Buffer readback;
    VkFence captureFence = VK_NULL_HANDLE;  // the slot fence of the last capture
    std::uint32_t frame = 0;

    Impl(VulkanContext::Impl& c, GLFWwindow* w, bool v) : context(c), window(w), vsync(v) {}
    ~Impl();
    void createSwapchain();
    void destroySwapchain();
    void waitIdle();
    void record(Slot& slot, std::uint32_t index, std::uint32_t width, std::uint32_t height, bool capture, Rgba background);
};

void Presenter::Impl::waitIdle() {
    std::lock_guard guard(context.submitLock);
    VK_CHECK(vkQueueWaitIdle(context.queue));
}

void Presenter::Impl::destroySwapchain() {
    const VkDevice d = context.device;
    for (VkSemaphore s : released) vkDestroySemaphore(d, s, nullptr);
    released.clear();
    imageFence.clear();
    images.clear();
    for (Slot& slot : slots) destroyBuffer(context, slot.staging);
    destroyBuffer(context, readback);
    captureFence = VK_NULL_HANDLE;
    if (swapchain) vkDestroySwapchainKHR(d, swapchain, nullptr);
    swapchain = VK_NULL_HANDLE;
}

Presenter::Impl::~Impl() {
    const VkDevice d = context.device;
    try {
        waitIdle();
    } catch (const VulkanError&) {
    }
    destroySwapchain();
    for (Slot& slot : slots) {
        if (slot.fence) vkDestroyFence(d, slot.fence, nullptr);
        if (slot.acquired) vkDestroySemaphore(d, slot.acquired, nullptr);
    }
    if (pool) vkDestroyCommandPool(d, pool, nullptr);
    if (surface) vkDestroySurfaceKHR(context.instance, surface, nullptr);
}

void Presenter::Impl::createSwapchain() {
    const VkPhysicalDevice physical = context.physical;
    VkSurfaceCapabilitiesKHR caps;
    VK_CHECK(vkGetPhysicalDeviceSurfaceCapabilitiesKHR(physical, surface, &caps));
    int width = 0, height = 0;
    glfwGetFramebufferSize(window, &width, &height);
    extent = caps.currentExtent.width != 0xffffffffu ? caps.currentExtent
                                                     : VkExtent2D{std::uint32_t(std::max(1, width)), std::uint32_t(std::max(1, height))};
    extent.width = std::clamp(extent.width, std::max(1u, caps.minImageExtent.width), caps.maxImageExtent.width);
    extent.height = std::clamp(extent.height, std::max(1u, caps.minImageExtent.height), caps.maxImageExtent.height);
    const VkImageUsageFlags usage = VK_IMAGE_USAGE_TRANSFER_DST_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
    if ((caps.supportedUsageFlags & usage) != usage)
        throw VulkanError("the window surface's images cannot be copied to and from (no TRANSFER_SRC/DST usage)");

    std::uint32_t count = 0;
    VK_CHECK(vkGetPhysicalDeviceSurfaceFormatsKHR(physical, surface, &count, nullptr));
    std::vector<VkSurfaceFormatKHR> formats(count);
    VK_CHECK(vkGetPhysicalDeviceSurfaceFormatsKHR(physical, surface, &count, formats.data()));
    format = VK_FORMAT_UNDEFINED;
    for (VkFormat wanted : {VK_FORMAT_B8G8R8A8_UNORM, VK_FORMAT_R8G8B8A8_UNORM})
        for (const VkSurfaceFormatKHR& f : formats)
            if (format == VK_FORMAT_UNDEFINED && f.format == wanted && f.colorSpace == VK_COLOR_SPACE_SRGB_NONLINEAR_KHR)
                format = wanted;
    if (format == VK_FORMAT_UNDEFINED)
        throw VulkanError("the window surface offers neither B8G8R8A8_UNORM nor R8G8B8A8_UNORM in sRGB colour space");

    VK_CHECK(vkGetPhysicalDeviceSurfacePresentModesKHR(physical, surface, &count, nullptr));
    std::vector<VkPresentModeKHR> modes(count);
    VK_CHECK(vkGetPhysicalDeviceSurfacePresentModesKHR(physical, surface, &count, modes.data()));
    mode = VK_PRESENT_MODE_FIFO_KHR;
    if (!vsync)
        for (VkPresentModeKHR wanted : {VK_PRESENT_MODE_IMMEDIATE_KHR, VK_PRESENT_MODE_MAILBOX_KHR})
            if (mode == VK_PRESENT_MODE_FIFO_KHR && std::find(modes.begin(), modes.end(), wanted) != modes.end())
                mode = wanted;

    VkSwapchainCreateInfoKHR info{};
    info.sType = VK_STRUCTURE_TYPE_SWAPCHAIN_CREATE_INFO_KHR;
    info.surface = surface;
    info.minImageCount = std::max(caps.minImageCount, kFramesInFlight + 1);
    if (caps.maxImageCount) info.minImageCount = std::min(info.minImageCount, caps.maxImageCount);
    info.imageFormat = format;
    info.imageColorSpace = VK_COLOR_SPACE_SRGB_NONLINEAR_KHR;
    info.imageExtent = extent;
    info.imageArrayLayers = 1;
    info.imageUsage = usage;
    info.imageSharingMode = VK_SHARING_MODE_EXCLUSIVE;
    info.preTransform = caps.currentTransform;
    info.compositeAlpha = (caps.supportedCompositeAlpha & VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR)
                              ? VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR
                              : VkCompositeAlphaFlagBitsKHR(caps.supportedCompositeAlpha & -caps.supportedCompositeAlpha);
    info.presentMode = mode;
    info.clipped = VK_TRUE;
    VK_CHECK(vkCreateSwapchainKHR(context.device, &info, nullptr, &swapchain));
    VK_CHECK(vkGetSwapchainImagesKHR(context.device, swapchain, &count, nullptr));
    images.resize(count);
    VK_CHECK(vkGetSwapchainImagesKHR(context.device, swapchain, &count, images.data()));
    imageFence.assign(count, VK_NULL_HANDLE);
    VkSemaphoreCreateInfo semaphoreInfo{};
    semaphoreInfo.sType = VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO;
    released.resize(count, VK_NULL_HANDLE);
    for (VkSemaphore& s : released) VK_CHECK(vkCreateSemaphore(context.device, &semaphoreInfo, nullptr, &s));
    const VkDeviceSize bytes = 4ull * extent.width * extent.height;
    for (Slot& slot : slots)
        slot.staging = createBuffer(context, bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, Memory::Upload, true);
    readback = createBuffer(context, bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT, Memory::Readback, true);
}

void Presenter::Impl::record(Slot& slot, std::uint32_t index, std::uint32_t width, std::uint32_t height, bool capture,
                             Rgba background) {
    const VkCommandBuffer c = slot.commands;
    const VkImage image = images[index];
    VK_CHECK(vkResetCommandBuffer(c, 0));
    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    VK_CHECK(vkBeginCommandBuffer(c, &begin));
    imageBarrier(c, image, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                 VK_PIPELINE_STAGE_TRANSFER_BIT, 0, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT);
    const VkImageSubresourceRange range{VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    if (width != extent.width || height != extent.height) {
        VkClearColorValue clear{};
        const bool bgra = format == VK_FORMAT_B8G8R8A8_UNORM;
        clear.float32[0] = float(bgra ? background.b : background.r) / 255.0f;
        clear.float32[1] = float(background.g) / 255.0f;
        clear.float32[2] = float(bgra ? background.r : background.b) / 255.0f;
        clear.float32[3] = 1.0f;
        vkCmdClearColorImage(c, image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, &clear, 1, &range);
        imageBarrier(c, image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                     VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT,
                     VK_ACCESS_TRANSFER_WRITE_BIT);
    }
    if (width && height) {
        VkBufferImageCopy region{};
        region.bufferRowLength = extent.width;
        region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
        region.imageExtent = {width, height, 1};
        vkCmdCopyBufferToImage(c, slot.staging.buffer, image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
    }
    VkImageLayout layout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
    if (capture) {
        imageBarrier(c, image, layout, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, VK_PIPELINE_STAGE_TRANSFER_BIT,
                     VK_ACCESS_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_READ_BIT);
        layout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
        VkBufferImageCopy region{};
        region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
        region.imageExtent = {extent.width, extent.height, 1};
        vkCmdCopyImageToBuffer(c, image, layout, readback.buffer, 1, &region);
        bufferBarrier(c, readback, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_HOST_BIT,
                      VK_ACCESS_HOST_READ_BIT);
    }
    imageBarrier(c, image, layout, VK_IMAGE_LAYOUT_PRESENT_SRC_KHR, VK_PIPELINE_STAGE_TRANSFER_BIT,
                 VK_ACCESS_TRANSFER_WRITE_BIT | VK_ACCESS_TRANSFER_READ_BIT, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, 0);
    VK_CHECK(vkEndCommandBuffer(c));
}

Presenter::Presenter(VulkanContext& context, GLFWwindow* window, bool vsync)
    : impl_(std::make_unique<Impl>(contextInternals(context), window, vsync)) {
    Impl& p = *impl_;
    const VkDevice d = p.context.device;
    VK_CHECK(glfwCreateWindowSurface(p.context.instance, window, nullptr, &p.surface));
    VkBool32 supported = VK_FALSE;
    VK_CHECK(vkGetPhysicalDeviceSurfaceSupportKHR(p.context.physical, p.context.queueFamily, p.surface, &supported));
    if (!supported)
        throw VulkanError(std::string("the Vulkan context's queue cannot present to this window (") +
                          p.context.properties.deviceName + "); create the context with presentableOptions()");
    VkCommandPoolCreateInfo poolInfo{};
    poolInfo.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
    poolInfo.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
    poolInfo.queueFamilyIndex = p.context.queueFamily;
    VK_CHECK(vkCreateCommandPool(d, &poolInfo, nullptr, &p.pool));
    VkCommandBufferAllocateInfo allocate{};
    allocate.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
    allocate.commandPool = p.pool;
    allocate.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    allocate.commandBufferCount = 1;
    VkFenceCreateInfo fenceInfo{};
    fenceInfo.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
    fenceInfo.flags = VK_FENCE_CREATE_SIGNALED_BIT;
    VkSemaphoreCreateInfo semaphoreInfo{};
    semaphoreInfo.sType = VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO;
    for (Slot& slot : p.slots) {
        VK_CHECK(vkAllocateCommandBuffers(d, &allocate, &slot.commands));
        VK_CHECK(vkCreateFence(d, &fenceInfo, nullptr, &slot.fence));
        VK_CHECK(vkCreateSemaphore(d, &semaphoreInfo, nullptr, &slot.acquired));
    }
    p.createSwapchain();
}

Presenter::~Presenter() = default;

std::array<std::uint32_t, 2> Presenter::extent() const { return {impl_->extent.width, impl_->extent.height}; }

const char* Presenter::presentMode() const {
    switch (impl_->mode) {
    case VK_PRESENT_MODE_IMMEDIATE_KHR: return "immediate";
    case VK_PRESENT_MODE_MAILBOX_KHR: return "mailbox";
    default: return "fifo";
    }
}

void Presenter::recreate() {
    Impl& p = *impl_;
    p.waitIdle();
    for (Slot& slot : p.slots) VK_CHECK(vkWaitForFences(p.context.device, 1, &slot.fence, VK_TRUE, UINT64_MAX));
    // An acquire semaphore may still be signalled by an acquire whose frame was dropped:
    // fresh ones keep every wait paired with its signal.
    VkSemaphoreCreateInfo semaphoreInfo{};
    semaphoreInfo.sType = VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO;
    for (Slot& slot : p.slots) {
        vkDestroySemaphore(p.context.device, slot.acquired, nullptr);
        slot.acquired = VK_NULL_HANDLE;
        VK_CHECK(vkCreateSemaphore(p.context.device, &semaphoreInfo, nullptr, &slot.acquired));
    }
    p.destroySwapchain();
    p.createSwapchain();
}

bool Presenter::present(const Image& image, bool capture, Rgba background) {
    Impl& p = *impl_;
    const VkDevice d = p.context.device;
    Slot& slot = p.slots[p.frame % kFramesInFlight];
    VK_CHECK(vkWaitForFences(d, 1, &slot.fence, VK_TRUE, UINT64_MAX));
    std::uint32_t index = 0;
    const VkResult acquired = vkAcquireNextImageKHR(d, p.swapchain, UINT64_MAX, slot.acquired, VK_NULL_HANDLE, &index);
    if (acquired == VK_ERROR_OUT_OF_DATE_KHR) {
        recreate();
        return false;
    }
    if (acquired != VK_SUBOPTIMAL_KHR) VK_CHECK(acquired);
    if (p.imageFence[index] && p.imageFence[index] != slot.fence)
        VK_CHECK(vkWaitForFences(d, 1, &p.imageFence[index], VK_TRUE, UINT64_MAX));
    p.imageFence[index] = slot.fence;

    // The overlap of the picture and the swapchain image, swizzled to the swapchain's format.
    const std::uint32_t width = std::min(image.width, p.extent.width), height = std::min(image.height, p.extent.height);
    auto* staging = static_cast<std::uint8_t*>(slot.staging.mapped);
    const bool bgra = p.format == VK_FORMAT_B8G8R8A8_UNORM;
    for (std::uint32_t y = 0; y < height; ++y) {
        const std::uint8_t* from = image.rgba.data() + 4ull * y * image.width;
        std::uint8_t* to = staging + 4ull * y * p.extent.width;
        if (!bgra) {
            std::memcpy(to, from, 4ull * width);
            continue;
        }
        for (std::uint32_t x = 0; x < width; ++x, from += 4, to += 4) to[0] = from[2], to[1] = from[1], to[2] = from[0], to[3] = 255;
    }
    p.record(slot, index, width, height, capture, background);
    VK_CHECK(vkResetFences(d, 1, &slot.fence));
    const VkPipelineStageFlags waitStage = VK_PIPELINE_STAGE_TRANSFER_BIT;
    VkSubmitInfo submit{};
    submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
    submit.waitSemaphoreCount = 1;
    submit.pWaitSemaphores = &slot.acquired;
    submit.pWaitDstStageMask = &waitStage;
    submit.commandBufferCount = 1;
    submit.pCommandBuffers = &slot.commands;
    submit.signalSemaphoreCount = 1;
    submit.pSignalSemaphores = &p.released[index];
    VkPresentInfoKHR presentInfo{};
    presentInfo.sType = VK_STRUCTURE_TYPE_PRESENT_INFO_KHR;
    presentInfo.waitSemaphoreCount = 1;
    presentInfo.pWaitSemaphores = &p.released[index];
    presentInfo.swapchainCount = 1;
    presentInfo.pSwapchains = &p.swapchain;
    presentInfo.pImageIndices = &index;
    VkResult presented;
    {
        std::lock_guard guard(p.context.submitLock);
        VK_CHECK(vkQueueSubmit(p.context.queue, 1, &submit, slot.fence));
        presented = vkQueuePresentKHR(p.context.queue, &presentInfo);
    }
    ++p.frame;
    if (capture) p.captureFence = slot.fence;
    if (presented == VK_ERROR_OUT_OF_DATE_KHR || presented == VK_SUBOPTIMAL_KHR || acquired == VK_SUBOPTIMAL_KHR) {
        recreate();  // a capture is lost with the old swapchain: the caller draws again
        return false;
    }
    VK_CHECK(presented);
    return true;
}

Image Presenter::screenshot() {
    Impl& p = *impl_;
    if (!p.captureFence) throw VulkanError("Presenter::screenshot: no frame was presented with capture");
    VK_CHECK(vkWaitForFences(p.context.device, 1, &p.captureFence, VK_TRUE, UINT64_MAX));
    Image out;
    out.width = p.extent.width, out.height = p.extent.height;
    out.rgba.resize(4ull * out.width * out.height);
    const auto* from = static_cast<const std::uint8_t*>(p.readback.mapped);
    const bool bgra = p.format == VK_FORMAT_B8G8R8A8_UNORM;
    for (std::size_t i = 0; i < out.rgba.size(); i += 4) {
        out.rgba[i + 0] = from[i + (bgra ? 2 : 0)];
        out.rgba[i + 1] = from[i + 1];
        out.rgba[i + 2] = from[i + (bgra ? 0 : 2)];
        out.rgba[i + 3] = 255;
    }
    return out;
}

}  // namespace psub
