// psub/vulkan_interop.h: bring your own device and buffers (as OpenSubdiv's GPU evaluators
// allow). A VulkanContext adopts the caller's instance, device and queue; a VulkanEvaluator on
// it reads control points from, and writes results to, the caller's VkBuffers, recording into
// the caller's command buffer (VulkanEvaluator::record) or submitting with the caller's
// semaphores (VulkanEvaluator::submit). Nothing passes through host memory.
#pragma once

#include "psub/vulkan_device.h"
#include "psub/vulkan_evaluator.h"

#include <vulkan/vulkan.h>

#include <cstdint>

namespace psub {

// A range of a caller-owned buffer starting at `offset` bytes (a multiple of 4).
struct VulkanBufferRange {
    VkBuffer buffer = VK_NULL_HANDLE;
    VkDeviceSize offset = 0;
};

// Layout in every buffer: VulkanEvaluator::deviceStride() floats per vertex (for width 3: x, y,
// z and a padding float, 16 bytes, usable as a vertex attribute of format
// VK_FORMAT_R32G32B32_SFLOAT with stride 16). Normals: 4 floats per vertex (x, y, z, 0).
// - control: controlCount() vertices, read (needs VK_BUFFER_USAGE_TRANSFER_SRC_BIT);
// - refined: refinedCount() vertices, written (needs VK_BUFFER_USAGE_TRANSFER_DST_BIT); or none;
// - normals: refinedCount() normals, written (TRANSFER_DST as well); or none (no normals pass;
//   normals need a surface table and width 3).
// Barriers recorded by the evaluator: on entry, every earlier write on the queue (any stage)
// before its reads of `control` and before it overwrites its own buffers; on exit, its writes to
// `refined` and `normals` before any later read (vertex input, shaders, transfers, host after a
// fence). The caller needs no barrier of its own around record().
struct VulkanDeviceBuffers {
    VulkanBufferRange control, refined, normals;
};

// For VulkanEvaluator::submit: the submission waits for `wait` (when not null) at `waitStage`,
// then signals `signal` (when not null) and `fence` (when not null) on completion.
struct VulkanSubmitSync {
    VkSemaphore wait = VK_NULL_HANDLE;
    VkPipelineStageFlags waitStage = VK_PIPELINE_STAGE_ALL_COMMANDS_BIT;
    VkSemaphore signal = VK_NULL_HANDLE;
    VkFence fence = VK_NULL_HANDLE;
};

}  // namespace psub
