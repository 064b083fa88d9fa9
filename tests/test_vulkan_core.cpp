// The Vulkan core (vulkan_core/): memory-type choice without a device; on a device (lavapipe
// in CI, validation layer on), staged uploads and read-backs of a buffer and of an image's mip
// levels round-trip every byte, one-shot submission cleans up after a failed recording, and
// none of it raises a validation message.
#include "psub/vulkan_context.h"
#include "test_support.h"

#include "device.h"
#include "images.h"
#include "resources.h"
#include "staging.h"
#include "submit.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <vector>

namespace psub {
namespace {

using namespace vulkan;

// Memory types as a discrete GPU lists them: host-only, device-only, and both.
VkPhysicalDeviceMemoryProperties threeTypes() {
    VkPhysicalDeviceMemoryProperties memory{};
    memory.memoryTypeCount = 3;
    memory.memoryTypes[0].propertyFlags = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
    memory.memoryTypes[1].propertyFlags = VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT;
    memory.memoryTypes[2].propertyFlags = VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT | VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT |
                                          VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
    return memory;
}

TEST(VulkanCoreMemory, ThePreferredTypeWinsAmongTheAllowedOnes) {
    const VkPhysicalDeviceMemoryProperties memory = threeTypes();
    const VkMemoryPropertyFlags host = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
    EXPECT_EQ(findMemoryType(memory, 0b111, 0, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT), 1u);  // first device-local
    EXPECT_EQ(findMemoryType(memory, 0b111, host, host | VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT), 2u);
    EXPECT_EQ(findMemoryType(memory, 0b101, host, host), 0u);  // type 1 not allowed; 0 is first
}

TEST(VulkanCoreMemory, WithoutThePreferredFlagsTheFirstAllowedTypeIsTaken) {
    const VkPhysicalDeviceMemoryProperties memory = threeTypes();
    EXPECT_EQ(findMemoryType(memory, 0b001, 0, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT), 0u);
    EXPECT_EQ(findMemoryType(memory, 0b110, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT, VK_MEMORY_PROPERTY_HOST_CACHED_BIT), 2u);
}

TEST(VulkanCoreMemory, NoAllowedTypeWithTheRequiredFlagsIsNone) {
    const VkPhysicalDeviceMemoryProperties memory = threeTypes();
    EXPECT_EQ(findMemoryType(memory, 0b010, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT, 0), ~0u);
    EXPECT_EQ(findMemoryType(memory, 0, 0, 0), ~0u);
    EXPECT_EQ(findMemoryType(memory, 0b1000, 0, 0), ~0u);  // beyond memoryTypeCount
}

class VulkanCore : public ::testing::Test {
protected:
    void SetUp() override {
        VulkanOptions options;
        options.validation = Validation::On;
        try {
            context_ = std::make_unique<VulkanContext>(options);
        } catch (const VulkanError& e) {
            if (test::noVulkanAllowed()) GTEST_SKIP() << "no Vulkan device (allowed by PSUB_ALLOW_NO_VULKAN=1): " << e.what();
            FAIL() << "no Vulkan device: " << e.what() << " (set PSUB_ALLOW_NO_VULKAN=1 to skip)";
        }
    }
    void TearDown() override {
        if (context_) {
            EXPECT_EQ(context_->validationMessageCount(), 0u) << context_->lastValidationMessage();
        }
    }
    VulkanContext::Impl& c() { return contextInternals(*context_); }

    std::unique_ptr<VulkanContext> context_;
};

// 4-byte words no two alike (a multiplicative hash of the index), so a shifted, truncated or
// zero-filled copy differs.
std::vector<std::uint32_t> pattern(std::size_t count, std::uint32_t seed) {
    std::vector<std::uint32_t> words(count);
    for (std::size_t i = 0; i < count; ++i) words[i] = std::uint32_t(i + seed) * 2654435761u;
    return words;
}

std::vector<std::uint32_t> uploadAndReadBack(VulkanContext::Impl& context, bool direct,
                                             const std::vector<std::uint32_t>& words) {
    const VkDeviceSize bytes = words.size() * 4;
    StagedUploads uploads(context, direct);
    Buffer device = uploads.createFilled(
        bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
        [&](void* to) { std::memcpy(to, words.data(), bytes); });
    std::vector<std::uint32_t> back(words.size(), 0);
    try {
        uploads.finish();
        readBack(context, bytes, [&](VkCommandBuffer command, VkBuffer host) {
            // Host writes (direct) or the staging copies (finish) before this copy.
            memoryBarrier(command, VK_PIPELINE_STAGE_HOST_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
                          VK_ACCESS_HOST_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT,
                          VK_ACCESS_TRANSFER_READ_BIT);
            const VkBufferCopy region{0, 0, bytes};
            vkCmdCopyBuffer(command, device.buffer, host, 1, &region);
        }, back.data());
    } catch (...) {
        destroyBuffer(context, device);
        throw;
    }
    destroyBuffer(context, device);
    return back;
}

TEST_F(VulkanCore, AStagedBufferUploadReadsBackByteForByte) {
    const std::vector<std::uint32_t> words = pattern(10007, 1);  // not a multiple of 16 bytes
    EXPECT_EQ(uploadAndReadBack(c(), false, words), words);
}

TEST_F(VulkanCore, ADirectBufferUploadReadsBackByteForByte) {
    if (!hasHostVisibleDeviceMemory(c()))
        GTEST_SKIP() << c().properties.deviceName << " has no host-visible device-local memory (lavapipe has)";
    const std::vector<std::uint32_t> words = pattern(4099, 7);
    EXPECT_EQ(uploadAndReadBack(c(), true, words), words);
}

TEST_F(VulkanCore, AnImageUploadedLevelByLevelReadsBackEachLevel) {
    // Two mip levels of an odd-sized RGBA8 image, one staging buffer: level 0, then level 1.
    const std::uint32_t width = 37, height = 23, width1 = 18, height1 = 11;
    const std::vector<std::uint32_t> level0 = pattern(std::size_t(width) * height, 3);
    const std::vector<std::uint32_t> level1 = pattern(std::size_t(width1) * height1, 50000);
    ImageSpec spec;
    spec.usage = VK_IMAGE_USAGE_TRANSFER_DST_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT | VK_IMAGE_USAGE_SAMPLED_BIT;
    spec.width = width, spec.height = height, spec.mipLevels = 2;
    Image2D image = createImage(c(), spec);
    std::vector<std::uint32_t> back0(level0.size(), 0), back1(level1.size(), 0);
    auto copyRegion = [](std::uint32_t level, std::uint32_t w, std::uint32_t h, VkDeviceSize offset) {
        VkBufferImageCopy region{};
        region.bufferOffset = offset;
        region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, level, 0, 1};
        region.imageExtent = {w, h, 1};
        return region;
    };
    try {
        StagedUploads uploads(c(), false);
        const VkDeviceSize bytes0 = level0.size() * 4, bytes1 = level1.size() * 4;
        const VkBuffer staging = uploads.stage(bytes0 + bytes1, [&](void* to) {
            std::memcpy(to, level0.data(), bytes0);
            std::memcpy(static_cast<char*>(to) + bytes0, level1.data(), bytes1);
        });
        uploads.record([&](VkCommandBuffer command) {
            imageBarrier(command, image.image,
                         {VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT,
                          0, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT, 0, 2, VK_IMAGE_ASPECT_COLOR_BIT});
            const VkBufferImageCopy regions[2] = {copyRegion(0, width, height, 0), copyRegion(1, width1, height1, bytes0)};
            vkCmdCopyBufferToImage(command, staging, image.image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 2, regions);
            // Each level on its own: the barrier's level range must be honoured.
            for (std::uint32_t level = 0; level < 2; ++level)
                imageBarrier(command, image.image,
                             {VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                              VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT,
                              VK_ACCESS_TRANSFER_READ_BIT, level, 1, VK_IMAGE_ASPECT_COLOR_BIT});
        });
        uploads.finish();
        readBack(c(), bytes1, [&](VkCommandBuffer command, VkBuffer host) {
            const VkBufferImageCopy region = copyRegion(1, width1, height1, 0);
            vkCmdCopyImageToBuffer(command, image.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, host, 1, &region);
        }, back1.data());
        readBack(c(), bytes0, [&](VkCommandBuffer command, VkBuffer host) {
            const VkBufferImageCopy region = copyRegion(0, width, height, 0);
            vkCmdCopyImageToBuffer(command, image.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, host, 1, &region);
        }, back0.data());
    } catch (...) {
        destroyImage(c(), image);
        throw;
    }
    destroyImage(c(), image);
    EXPECT_EQ(back0, level0);
    EXPECT_EQ(back1, level1);
}

TEST_F(VulkanCore, AOneShotSubmissionWhoseRecordingThrowsLeavesNothingBehind) {
    const std::uint64_t before = vulkanValidationMessageTotal();  // of every context of this process
    EXPECT_THROW(runOnce(c(), [](VkCommandBuffer) { throw std::runtime_error("recording failed"); }),
                 std::runtime_error);
    // The queue still works afterwards, and the context's destruction reports no object left
    // alive (TearDown: no validation message; the layer reports leaked pools and fences).
    bool ran = false;
    runOnce(c(), [&](VkCommandBuffer) { ran = true; });
    EXPECT_TRUE(ran);
    context_.reset();
    EXPECT_EQ(vulkanValidationMessageTotal(), before);
}

}  // namespace
}  // namespace psub
