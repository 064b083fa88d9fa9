// The renderer's base-colour texture: upload through the Vulkan core's staged uploads, the mip
// chain made by linear blits on the device (or on the CPU where the format cannot be blitted),
// the view and the sampler.
#include "texture.h"

#include "staging.h"

#include <algorithm>
#include <cstring>
#include <string>
#include <vector>

namespace psub::render_detail {
namespace {

using namespace vulkan;

constexpr VkFormat kFormat = VK_FORMAT_R8G8B8A8_UNORM;

// The barrier moving mip levels [level, level + count) of `image` from `from` to `to`.
void imageBarrier(VkCommandBuffer command, VkImage image, std::uint32_t level, std::uint32_t levelCount,
                  VkImageLayout from, VkImageLayout to, VkPipelineStageFlags sourceStage, VkAccessFlags sourceAccess,
                  VkPipelineStageFlags destinationStage, VkAccessFlags destinationAccess) {
    vulkan::imageBarrier(command, image,
                         {from, to, sourceStage, sourceAccess, destinationStage, destinationAccess, level, levelCount,
                          VK_IMAGE_ASPECT_COLOR_BIT});
}

std::int32_t half(std::uint32_t side) { return std::int32_t(std::max(1u, side / 2)); }

// Level 0 copied from `staging`; each further level blitted (linear) from the one above.
// Every level ends in SHADER_READ_ONLY_OPTIMAL.
void recordBlittedMips(VkCommandBuffer command, VkBuffer staging, const DeviceTexture& t, std::uint32_t width,
                       std::uint32_t height) {
    imageBarrier(command, t.image.image, 0, t.mipLevels, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                 VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, 0, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT);
    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.imageExtent = {width, height, 1};
    vkCmdCopyBufferToImage(command, staging, t.image.image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
    std::int32_t w = std::int32_t(width), h = std::int32_t(height);
    for (std::uint32_t level = 1; level < t.mipLevels; ++level) {
        imageBarrier(command, t.image.image, level - 1, 1, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                     VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, VK_PIPELINE_STAGE_TRANSFER_BIT,
                     VK_ACCESS_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_READ_BIT);
        VkImageBlit blit{};
        blit.srcSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, level - 1, 0, 1};
        blit.srcOffsets[1] = {w, h, 1};
        blit.dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, level, 0, 1};
        blit.dstOffsets[1] = {half(std::uint32_t(w)), half(std::uint32_t(h)), 1};
        vkCmdBlitImage(command, t.image.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, t.image.image,
                       VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &blit, VK_FILTER_LINEAR);
        imageBarrier(command, t.image.image, level - 1, 1, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                     VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, VK_PIPELINE_STAGE_TRANSFER_BIT,
                     VK_ACCESS_TRANSFER_READ_BIT, VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT, VK_ACCESS_SHADER_READ_BIT);
        w = half(std::uint32_t(w)), h = half(std::uint32_t(h));
    }
    imageBarrier(command, t.image.image, t.mipLevels - 1, 1, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                 VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, VK_PIPELINE_STAGE_TRANSFER_BIT,
                 VK_ACCESS_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT, VK_ACCESS_SHADER_READ_BIT);
}

// Every level copied from `staging`, where `offsets` says where each begins.
void recordCopiedMips(VkCommandBuffer command, VkBuffer staging, const DeviceTexture& t,
                      const std::vector<Image>& levels, const std::vector<VkDeviceSize>& offsets) {
    imageBarrier(command, t.image.image, 0, t.mipLevels, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                 VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, 0, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT);
    std::vector<VkBufferImageCopy> regions(levels.size());
    for (std::size_t level = 0; level < levels.size(); ++level) {
        regions[level].bufferOffset = offsets[level];
        regions[level].imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, std::uint32_t(level), 0, 1};
        regions[level].imageExtent = {levels[level].width, levels[level].height, 1};
    }
    vkCmdCopyBufferToImage(command, staging, t.image.image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                           std::uint32_t(regions.size()), regions.data());
    imageBarrier(command, t.image.image, 0, t.mipLevels, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                 VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, VK_PIPELINE_STAGE_TRANSFER_BIT,
                 VK_ACCESS_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT, VK_ACCESS_SHADER_READ_BIT);
}

void createImageAndSampler(const VulkanContext::Impl& c, DeviceTexture& t, std::uint32_t width, std::uint32_t height) {
    ImageSpec spec;
    spec.format = kFormat;
    spec.usage = VK_IMAGE_USAGE_TRANSFER_SRC_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT | VK_IMAGE_USAGE_SAMPLED_BIT;
    spec.width = width, spec.height = height, spec.mipLevels = t.mipLevels;
    t.image = createImage(c, spec);
    VkSamplerCreateInfo sampler{};
    sampler.sType = VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO;
    sampler.magFilter = sampler.minFilter = VK_FILTER_LINEAR;
    sampler.mipmapMode = VK_SAMPLER_MIPMAP_MODE_LINEAR;
    sampler.addressModeU = sampler.addressModeV = sampler.addressModeW = VK_SAMPLER_ADDRESS_MODE_REPEAT;
    sampler.anisotropyEnable = VK_FALSE;
    sampler.maxLod = float(t.mipLevels);
    VK_CHECK(vkCreateSampler(c.device, &sampler, nullptr, &t.sampler));
}

}  // namespace

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
    try {
        StagedUploads uploads(c, false);
        const VkBuffer staging = uploads.stage(bytes, [&](void* to) {
            auto* mapped = static_cast<std::uint8_t*>(to);
            if (t.mipsBlitted)
                std::memcpy(mapped, image.rgba.data(), image.rgba.size());
            for (std::size_t level = 0; level < cpuLevels.size(); ++level)
                std::memcpy(mapped + offsets[level], cpuLevels[level].rgba.data(), cpuLevels[level].rgba.size());
        });
        createImageAndSampler(c, t, image.width, image.height);
        uploads.record([&](VkCommandBuffer command) {
            if (t.mipsBlitted)
                recordBlittedMips(command, staging, t, image.width, image.height);
            else
                recordCopiedMips(command, staging, t, cpuLevels, offsets);
        });
        uploads.finish();
    } catch (...) {
        destroyTexture(c, t);
        throw;
    }
    return t;
}

void destroyTexture(const VulkanContext::Impl& c, DeviceTexture& t) {
    if (t.sampler) vkDestroySampler(c.device, t.sampler, nullptr);
    destroyImage(c, t.image);
    t = DeviceTexture{};
}

}  // namespace psub::render_detail
