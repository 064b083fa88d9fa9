// 2D images in device memory with their views, and image barriers (layout transitions).
#include "images.h"

#include "resources.h"

#include <string>

namespace psub::vulkan {

Image2D createImage(const VulkanContext::Impl& c, const ImageSpec& spec) {
    Image2D made;
    VkImageCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO;
    info.imageType = VK_IMAGE_TYPE_2D;
    info.format = spec.format;
    info.extent = {spec.width, spec.height, 1};
    info.mipLevels = spec.mipLevels;
    info.arrayLayers = 1;
    info.samples = spec.samples;
    info.tiling = VK_IMAGE_TILING_OPTIMAL;
    info.usage = spec.usage;
    info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
    info.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    VK_CHECK(vkCreateImage(c.device, &info, nullptr, &made.image));
    try {
        VkMemoryRequirements requirements;
        vkGetImageMemoryRequirements(c.device, made.image, &requirements);
        VkMemoryAllocateInfo allocate{};
        allocate.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
        allocate.allocationSize = requirements.size;
        allocate.memoryTypeIndex = deviceMemoryType(c, requirements.memoryTypeBits);
        const VkResult allocated = vkAllocateMemory(c.device, &allocate, nullptr, &made.memory);
        if (allocated == VK_ERROR_OUT_OF_DEVICE_MEMORY || allocated == VK_ERROR_OUT_OF_HOST_MEMORY)
            throw VulkanError("a " + std::to_string(spec.width) + "x" + std::to_string(spec.height) + " image with " +
                              std::to_string(int(spec.samples)) + " sample(s) per pixel needs " +
                              std::to_string(requirements.size) + " bytes of device memory, more than the device "
                              "could allocate (" + resultName(allocated) + ")" +
                              (spec.outOfMemoryHint ? std::string("; ") + spec.outOfMemoryHint : std::string()));
        VK_CHECK(allocated);
        VK_CHECK(vkBindImageMemory(c.device, made.image, made.memory, 0));
        VkImageViewCreateInfo viewInfo{};
        viewInfo.sType = VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO;
        viewInfo.image = made.image;
        viewInfo.viewType = VK_IMAGE_VIEW_TYPE_2D;
        viewInfo.format = spec.format;
        viewInfo.subresourceRange = {spec.aspect, 0, spec.mipLevels, 0, 1};
        VK_CHECK(vkCreateImageView(c.device, &viewInfo, nullptr, &made.view));
    } catch (...) {
        destroyImage(c, made);
        throw;
    }
    return made;
}

void destroyImage(const VulkanContext::Impl& c, Image2D& image) {
    if (image.view) vkDestroyImageView(c.device, image.view, nullptr);
    if (image.image) vkDestroyImage(c.device, image.image, nullptr);
    if (image.memory) vkFreeMemory(c.device, image.memory, nullptr);
    image = Image2D{};
}

void imageBarrier(VkCommandBuffer command, VkImage image, const ImageLayoutChange& change) {
    VkImageMemoryBarrier barrier{};
    barrier.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER;
    barrier.srcAccessMask = change.sourceAccess;
    barrier.dstAccessMask = change.destinationAccess;
    barrier.oldLayout = change.from;
    barrier.newLayout = change.to;
    barrier.srcQueueFamilyIndex = barrier.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    barrier.image = image;
    barrier.subresourceRange = {change.aspect, change.level, change.levelCount, 0, 1};
    vkCmdPipelineBarrier(command, change.sourceStage, change.destinationStage, 0, 0, nullptr, 0, nullptr, 1, &barrier);
}

}  // namespace psub::vulkan
