// Internal to psub::render: a base-colour texture on the device (image with its full mip
// chain, view, sampler) uploaded once through the Vulkan core's staged uploads.
#pragma once

#include "images.h"

#include "psub/image.h"

#include <cstdint>

namespace psub::render_detail {

struct DeviceTexture {
    vulkan::Image2D image;  // every mip level in the view
    VkSampler sampler = VK_NULL_HANDLE;
    std::uint32_t mipLevels = 0;
    bool mipsBlitted = false;  // true: vkCmdBlitImage made the mips; false: the CPU did
};

// `image` as R8G8B8A8_UNORM (its bytes sampled as they are: the renderer lights and writes
// sRGB-encoded values, as for its flat colour) with every mip level down to 1x1, in
// SHADER_READ_ONLY_OPTIMAL; sampler: linear filtering within and between mips, repeat wrap,
// no anisotropy. Waits for the upload. VulkanError beyond the device's limits.
DeviceTexture uploadTexture(VulkanContext::Impl& context, const Image& image);
void destroyTexture(const VulkanContext::Impl& context, DeviceTexture& texture);

// The mip chain's length for a `width` x `height` image: floor(log2(max side)) + 1.
std::uint32_t mipLevelCount(std::uint32_t width, std::uint32_t height);

// The next mip level below `image` (each side halved, rounded down, at least 1), each pixel
// the rounded mean of the up to 2x2 pixels it covers (a box filter; an odd last row or column
// is left out). For devices whose R8G8B8A8_UNORM cannot be blitted.
Image halveImage(const Image& image);

}  // namespace psub::render_detail
