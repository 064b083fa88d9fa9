// The Vulkan core: uploads into device memory (written in place where the memory is
// host-visible, else through staging buffers copied by one one-shot command buffer) and
// one-shot read-backs into host memory.
#pragma once

#include "resources.h"

#include <functional>
#include <vector>

namespace psub::vulkan {

// One batch of uploads. `direct`: new buffers are host-visible and written in place (the
// caller knows the device shares memory); otherwise each is written into a staging buffer and
// copied by finish(). Staging buffers live until the batch is destroyed.
class StagedUploads {
public:
    StagedUploads(VulkanContext::Impl& context, bool direct) : context_(context), direct_(direct) {}
    ~StagedUploads();
    StagedUploads(const StagedUploads&) = delete;
    StagedUploads& operator=(const StagedUploads&) = delete;

    // A device buffer of `bytes` with `usage` (TRANSFER_DST must be in it when not direct),
    // its contents written by fill(bytes pointer) (not called when bytes is 0). The caller owns
    // the buffer; it holds the data once finish() has returned.
    Buffer createFilled(VkDeviceSize bytes, VkBufferUsageFlags usage, const std::function<void(void*)>& fill);
    // A staging buffer of `bytes` written by fill, for copies the caller records (record()).
    VkBuffer stage(VkDeviceSize bytes, const std::function<void(void*)>& fill);
    // Commands run by finish() after the buffer copies (image copies with their barriers).
    void record(std::function<void(VkCommandBuffer)> commands);
    // Runs the copies, then a barrier making them visible to compute shaders and transfers,
    // then the recorded commands, in one command buffer; waits. Nothing to do: returns at once.
    void finish();

private:
    struct Copy {
        VkBuffer from, to;
        VkDeviceSize bytes;
    };
    VulkanContext::Impl& context_;
    bool direct_;
    std::vector<Buffer> staging_;
    std::vector<Copy> copies_;
    std::vector<std::function<void(VkCommandBuffer)>> commands_;
};

// Copies `bytes` from the device into `out`: record(command, buffer) records the transfer
// writes into `buffer` (a host-readable buffer of at least `bytes`, TRANSFER_DST), then a
// barrier to the host is recorded, the commands run once and are waited for.
void readBack(VulkanContext::Impl& context, VkDeviceSize bytes,
              const std::function<void(VkCommandBuffer, VkBuffer)>& record, void* out);

}  // namespace psub::vulkan
