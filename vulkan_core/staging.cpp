// Staged uploads (one command buffer of copies per batch) and one-shot read-backs.
#include "staging.h"

#include "submit.h"

#include <cstring>

namespace psub::vulkan {

StagedUploads::~StagedUploads() {
    for (Buffer& b : staging_) destroyBuffer(context_, b);
}

VkBuffer StagedUploads::stage(VkDeviceSize bytes, const std::function<void(void*)>& fill) {
    staging_.push_back(createBuffer(context_, bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, Memory::Upload, true));
    if (bytes) fill(staging_.back().mapped);
    return staging_.back().buffer;
}

Buffer StagedUploads::createFilled(VkDeviceSize bytes, VkBufferUsageFlags usage,
                                   const std::function<void(void*)>& fill) {
    Buffer b = createBuffer(context_, bytes, usage, Memory::Device, direct_);
    if (!bytes) return b;
    try {
        if (direct_) {
            fill(b.mapped);
        } else {
            const VkBuffer from = stage(bytes, fill);
            copies_.push_back({from, b.buffer, bytes});
        }
    } catch (...) {
        destroyBuffer(context_, b);
        throw;
    }
    return b;
}

void StagedUploads::record(std::function<void(VkCommandBuffer)> commands) { commands_.push_back(std::move(commands)); }

void StagedUploads::finish() {
    if (copies_.empty() && commands_.empty()) return;
    runOnce(context_, [&](VkCommandBuffer command) {
        for (const Copy& c : copies_) {
            const VkBufferCopy region{0, 0, c.bytes};
            vkCmdCopyBuffer(command, c.from, c.to, 1, &region);
        }
        if (!copies_.empty())
            memoryBarrier(command, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT,
                          VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
                          VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_TRANSFER_READ_BIT);
        for (const auto& commands : commands_) commands(command);
    });
    copies_.clear();
    commands_.clear();
}

void readBack(VulkanContext::Impl& context, VkDeviceSize bytes,
              const std::function<void(VkCommandBuffer, VkBuffer)>& record, void* out) {
    Buffer host = createBuffer(context, bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT, Memory::Readback, true);
    try {
        runOnce(context, [&](VkCommandBuffer command) {
            record(command, host.buffer);
            bufferBarrier(command, host, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT,
                          VK_PIPELINE_STAGE_HOST_BIT, VK_ACCESS_HOST_READ_BIT);
        });
        if (bytes) std::memcpy(out, host.mapped, bytes);
    } catch (...) {
        destroyBuffer(context, host);
        throw;
    }
    destroyBuffer(context, host);
}

}  // namespace psub::vulkan
