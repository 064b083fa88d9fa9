// The renderer's base-colour texture: upload through a staging buffer, the mip chain made by
// linear blits on the device (or on the CPU where the format cannot be blitted), the view and
// the sampler. One short-lived command pool and fence per upload.
#include "texture.h"

#include "resources.h"

#include <algorithm>
#include <cstring>
#include <string>
#include <vector>

namespace psub::render_detail {
namespace {

using namespace vulkan;

constexpr VkFormat kFormat = VK_FORMAT_R8G8B8A8_UNORM;

void imageBarrier(VkCommandBuffer command, VkImage image, std::uint32_t level, std::uint32_t levelCount,
                  VkImageLayout from, VkImageLayout to, VkPipelineStageFlags sourceStage, VkAccessFlags sourceAccess,
                  VkPipelineStageFlags destinationStage, VkAccessFlags destinationAccess) {
    VkImageMemoryBarrier barrier{};
    barrier.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER;
    barrier.srcAccessMask = sourceAccess;
    barrier.dstAccessMask = destinationAccess;
    barrier.oldLayout = from;
    barrier.newLayout = to;
    barrier.srcQueueFamilyIndex = barrier.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    barrier.image = image;
    barrier.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, level, levelCount, 0, 1};
    vkCmdPipelineBarrier(command, sourceStage, destinationStage, 0, 0, nullptr, 0, nullptr, 1, &barrier);
}

std::int32_t half(std::uint32_t side) { return std::int32_t(std::max(1u, side / 2)); }

// Level 0 copied from `staging`; each further level blitted (linear) from the one above.
// Every level ends in SHADER_READ_ONLY_OPTIMAL.
void recordBlittedMips(VkCommandBuffer command, const Buffer& staging, const DeviceTexture& t, std::uint32_t width,
                       std::uint32_t height) {
    imageBarrier(command, t.image, 0, t.mipLevels, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                 VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, 0, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT);
    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.imageExtent = {width, height, 1};
    vkCmdCopyBufferToImage(command, staging.buffer, t.image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
    std::int32_t w = std::int32_t(width), h = std::int32_t(height);
    for (std::uint32_t level = 1; level < t.mipLevels; ++level) {
        imageBarrier(command, t.image, level - 1, 1, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                     VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, VK_PIPELINE_STAGE_TRANSFER_BIT,
                     VK_ACCESS_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_READ_BIT);
        VkImageBlit blit{};
        blit.srcSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, level - 1, 0, 1};
        blit.srcOffsets[1] = {w, h, 1};
        blit.dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, level, 0, 1};
        blit.dstOffsets[1] = {half(std::uint32_t(w)), half(std::uint32_t(h)), 1};
        vkCmdBlitImage(command, t.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, t.image,
                       VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &blit, VK_FILTER_LINEAR);
        imageBarrier(command, t.image, level - 1, 1, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                     VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, VK_PIPELINE_STAGE_TRANSFER_BIT,
                     VK_ACCESS_TRANSFER_READ_BIT, VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT, VK_ACCESS_SHADER_READ_BIT);
        w = half(std::uint32_t(w)), h = half(std::uint32_t(h));
    }
    imageBarrier(command, t.image, t.mipLevels - 1, 1, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                 VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, VK_PIPELINE_STAGE_TRANSFER_BIT,
                 VK_ACCESS_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT, VK_ACCESS_SHADER_READ_BIT);
}

// Every level copied from `staging`, where `offsets` says where each begins.
void recordCopiedMips(VkCommandBuffer command, const Buffer& staging, const DeviceTexture& t,
                      const std::vector<Image>& levels, const std::vector<VkDeviceSize>& offsets) {
    imageBarrier(command, t.image, 0, t.mipLevels, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                 VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, 0, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT);
    std::vector<VkBufferImageCopy> regions(levels.size());
    for (std::size_t level = 0; level < levels.size(); ++level) {
        regions[level].bufferOffset = offsets[level];
        regions[level].imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, std::uint32_t(level), 0, 1};
        regions[level].imageExtent = {levels[level].width, levels[level].height, 1};
    }
    vkCmdCopyBufferToImage(command, staging.buffer, t.image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                           std::uint32_t(regions.size()), regions.data());
    imageBarrier(command, t.image, 0, t.mipLevels, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                 VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, VK_PIPELINE_STAGE_TRANSFER_BIT,
                 VK_ACCESS_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT, VK_ACCESS_SHADER_READ_BIT);
}

void createImageAndView(const VulkanContext::Impl& c, DeviceTexture& t, std::uint32_t width, std::uint32_t height) {
    VkImageCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO;
    info.imageType = VK_IMAGE_TYPE_2D;
    info.format = kFormat;
    info.extent = {width, height, 1};
    info.mipLevels = t.mipLevels;
    info.arrayLayers = 1;
    info.samples = VK_SAMPLE_COUNT_1_BIT;
    info.tiling = VK_IMAGE_TILING_OPTIMAL;
    info.usage = VK_IMAGE_USAGE_TRANSFER_SRC_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT | VK_IMAGE_USAGE_SAMPLED_BIT;
    info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
    info.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    VK_CHECK(vkCreateImage(c.device, &info, nullptr, &t.image));
    VkMemoryRequirements requirements;
    vkGetImageMemoryRequirements(c.device, t.image, &requirements);
    VkMemoryAllocateInfo allocate{};
    allocate.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
    allocate.allocationSize = requirements.size;
    allocate.memoryTypeIndex = deviceMemoryType(c, requirements.memoryTypeBits);
    VK_CHECK(vkAllocateMemory(c.device, &allocate, nullptr, &t.memory));
    VK_CHECK(vkBindImageMemory(c.device, t.image, t.memory, 0));
    VkImageViewCreateInfo view{};
    view.sType = VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO;
    view.image = t.image;
    view.viewType = VK_IMAGE_VIEW_TYPE_2D;
    view.format = kFormat;
    view.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, t.mipLevels, 0, 1};
    VK_CHECK(vkCreateImageView(c.device, &view, nullptr, &t.view));
    VkSamplerCreateInfo sampler{};
    sampler.sType = VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO;
    sampler.magFilter = sampler.minFilter = VK_FILTER_LINEAR;
    sampler.mipmapMode = VK_SAMPLER_MIPMAP_MODE_LINEAR;
    sampler.addressModeU = sampler.addressModeV = sampler.addressModeW = VK_SAMPLER_ADDRESS_MODE_REPEAT;
    sampler.anisotropyEnable = VK_FALSE;
    sampler.maxLod = float(t.mipLevels);
    VK_CHECK(vkCreateSampler(c.device, &sampler, nullptr, &t.sampler));
}

// Records `record(command)` into a one-time command buffer, submits it and waits.
template <class Record>
void runOnce(VulkanContext::Impl& c, Record record) {
    VkCommandPool pool = VK_NULL_HANDLE;
    VkFence fence = VK_NULL_HANDLE;
    try {
        VkCommandPoolCreateInfo poolInfo{};
        poolInfo.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
        poolInfo.flags = VK_COMMAND_POOL_CREATE_TRANSIENT_BIT;
        poolInfo.queueFamilyIndex = c.queueFamily;
        VK_CHECK(vkCreateCommandPool(c.device, &poolInfo, nullptr, &pool));
        VkCommandBufferAllocateInfo allocate{};
        allocate.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
        allocate.commandPool = pool;
        allocate.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
        allocate.commandBufferCount = 1;
        VkCommandBuffer command = VK_NULL_HANDLE;
        VK_CHECK(vkAllocateCommandBuffers(c.device, &allocate, &command));
        VkFenceCreateInfo fenceInfo{};
        fenceInfo.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
        VK_CHECK(vkCreateFence(c.device, &fenceInfo, nullptr, &fence));
        VkCommandBufferBeginInfo begin{};
        begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
        begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
        VK_CHECK(vkBeginCommandBuffer(command, &begin));
        record(command);
        VK_CHECK(vkEndCommandBuffer(command));
        submitAndWait(c, command, fence);
    } catch (...) {
        if (fence) vkDestroyFence(c.device, fence, nullptr);
        if (pool) vkDestroyCommandPool(c.device, pool, nullptr);
        throw;
    }
    vkDestroyFence(c.device, fence, nullptr);
    vkDestroyCommandPool(c.device, pool, nullptr);
}

}  // namespace

std::uint32_t deviceMemoryType(const VulkanContext::Impl& c, std::uint32_t bits) {
    std::uint32_t fallback = ~0u;
    for (std::uint32_t i = 0; i < c.memory.memoryTypeCount; ++i) {
        if (!(bits & (1u << i))) continue;
        if (c.memory.memoryTypes[i].propertyFlags & VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT) return i;
        if (fallback == ~0u) fallback = i;
    }
    if (fallback == ~0u) throw VulkanError(std::string("no memory type for an image on ") + c.properties.deviceName);
    return fallback;
}

std::uint32_t mipLevelCount(std::uint32_t width, std::uint32_t height) {
    std::uint32_t levels = 1;
    for (std::uint32_t side = std::max(width, height); side > 1; side /= 2) ++levels;
    return levels;
}

Image halveImage(const Image& image) {
    Image half{std::max(1u, image.width / 2), std::max(1u, image.height / 2), {}};
    half.rgba.resize(4 * std::size_t(half.width) * half.height);
    const std::uint32_t stepX = image.width > 1 ? 2 : 1, stepY = image.height > 1 ? 2 : 1;
    for (std::uint32_t y = 0; y < half.height; ++y)
        for (std::uint32_t x = 0; x < half.width; ++x)
            for (std::size_t channel = 0; channel < 4; ++channel) {
                unsigned sum = 0;
                for (std::uint32_t dy = 0; dy < stepY; ++dy)
                    for (std::uint32_t dx = 0; dx < stepX; ++dx)
                        sum += image.rgba[4 * (std::size_t(y * stepY + dy) * image.width + x * stepX + dx) + channel];
                const unsigned count = stepX * stepY;
                half.rgba[4 * (std::size_t(y) * half.width + x) + channel] = std::uint8_t((sum + count / 2) / count);
            }
    return half;
}

DeviceTexture uploadTexture(VulkanContext::Impl& c, const Image& image) {
    const std::uint32_t maxSide = c.properties.limits.maxImageDimension2D;
    if (image.width == 0 || image.height == 0 || image.rgba.size() != 4 * std::size_t(image.width) * image.height)
        throw std::invalid_argument("Renderer: the texture's pixels do not match its size");
    if (image.width > maxSide || image.height > maxSide)
        throw VulkanError("a " + std::to_string(image.width) + "x" + std::to_string(image.height) +
                          " texture is larger than " + c.properties.deviceName + " allows (" +
                          std::to_string(maxSide) + " a side)");
    VkFormatProperties properties;
    vkGetPhysicalDeviceFormatProperties(c.physical, kFormat, &properties);
    const VkFormatFeatureFlags features = properties.optimalTilingFeatures;
    if (!(features & VK_FORMAT_FEATURE_SAMPLED_IMAGE_FILTER_LINEAR_BIT))
        throw VulkanError(std::string(c.properties.deviceName) + " cannot filter R8G8B8A8_UNORM images linearly");
    const VkFormatFeatureFlags blit = VK_FORMAT_FEATURE_BLIT_SRC_BIT | VK_FORMAT_FEATURE_BLIT_DST_BIT;
    DeviceTexture t;
    t.mipLevels = mipLevelCount(image.width, image.height);
    t.mipsBlitted = (features & blit) == blit;
    // The CPU's levels (level 0 only when blitting) one after another in the staging buffer.
    std::vector<Image> cpuLevels;
    std::vector<VkDeviceSize> offsets{0};
    VkDeviceSize bytes = image.rgba.size();
    if (!t.mipsBlitted) {
        cpuLevels.push_back(image);
        while (cpuLevels.size() < t.mipLevels) {
            cpuLevels.push_back(halveImage(cpuLevels.back()));
            offsets.push_back(bytes);
            bytes += cpuLevels.back().rgba.size();
        }
    }
    Buffer staging;
    try {
        staging = createBuffer(c, bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, Memory::Upload, true);
        auto* mapped = static_cast<std::uint8_t*>(staging.mapped);
        if (t.mipsBlitted)
            std::memcpy(mapped, image.rgba.data(), image.rgba.size());
        for (std::size_t level = 0; level < cpuLevels.size(); ++level)
            std::memcpy(mapped + offsets[level], cpuLevels[level].rgba.data(), cpuLevels[level].rgba.size());
        createImageAndView(c, t, image.width, image.height);
        runOnce(c, [&](VkCommandBuffer command) {
            if (t.mipsBlitted)
                recordBlittedMips(command, staging, t, image.width, image.height);
            else
                recordCopiedMips(command, staging, t, cpuLevels, offsets);
        });
    } catch (...) {
        destroyBuffer(c, staging);
        destroyTexture(c, t);
        throw;
    }
    destroyBuffer(c, staging);
    return t;
}

void destroyTexture(const VulkanContext::Impl& c, DeviceTexture& t) {
    if (t.sampler) vkDestroySampler(c.device, t.sampler, nullptr);
    if (t.view) vkDestroyImageView(c.device, t.view, nullptr);
    if (t.image) vkDestroyImage(c.device, t.image, nullptr);
    if (t.memory) vkFreeMemory(c.device, t.memory, nullptr);
    t = DeviceTexture{};
}

}  // namespace psub::render_detail
