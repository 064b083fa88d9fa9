// The Vulkan core: 2D images (image, device memory, view) and image barriers with layout
// transitions. An Image2D is plain data; its user owns it and destroys it.
#pragma once

#include "device.h"

#include <cstdint>

namespace psub::vulkan {

struct Image2D {
    VkImage image = VK_NULL_HANDLE;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    VkImageView view = VK_NULL_HANDLE;
};

struct ImageSpec {
    VkFormat format = VK_FORMAT_R8G8B8A8_UNORM;
    VkImageUsageFlags usage = 0;
    std::uint32_t width = 1, height = 1, mipLevels = 1;
    VkSampleCountFlagBits samples = VK_SAMPLE_COUNT_1_BIT;
    VkImageAspectFlags aspect = VK_IMAGE_ASPECT_COLOR_BIT;  // of the view
    const char* outOfMemoryHint = nullptr;  // appended to the out-of-memory message ("; hint")
};

// An optimally tiled image in device-local memory (when there is such a type) with a view of
// every mip level (so `usage` must allow a view: sampled, storage or attachment), in
// VK_IMAGE_LAYOUT_UNDEFINED. Throws VulkanError; when the device cannot
// allocate the memory, the message says how many bytes the image needed.
Image2D createImage(const VulkanContext::Impl& context, const ImageSpec& spec);
void destroyImage(const VulkanContext::Impl& context, Image2D& image);

// One image memory barrier over `levelCount` mip levels from `level` (colour aspect unless
// `aspect` says otherwise), moving the image from layout `from` to `to`.
struct ImageLayoutChange {
    VkImageLayout from = VK_IMAGE_LAYOUT_UNDEFINED, to = VK_IMAGE_LAYOUT_UNDEFINED;
    VkPipelineStageFlags sourceStage = VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT;
    VkAccessFlags sourceAccess = 0;
    VkPipelineStageFlags destinationStage = VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT;
    VkAccessFlags destinationAccess = 0;
    std::uint32_t level = 0, levelCount = 1;
    VkImageAspectFlags aspect = VK_IMAGE_ASPECT_COLOR_BIT;
};
void imageBarrier(VkCommandBuffer command, VkImage image, const ImageLayoutChange& change);

}  // namespace psub::vulkan
