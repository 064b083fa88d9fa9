// The Vulkan core: shader modules from embedded SPIR-V, and what a module declares (read from
// its instructions, to check it against what its pipeline layout expects).
#pragma once

#include "check.h"

#include <cstdint>
#include <span>
#include <vector>

namespace psub::vulkan {

// What a SPIR-V module declares, read from its instructions.
struct ShaderInfo {
    std::uint32_t localSize[3] = {0, 0, 0};
    std::vector<std::uint32_t> bindings;   // of descriptor set 0
    std::vector<std::uint32_t> sets;       // every descriptor set used
    std::uint32_t pushConstantBytes = 0;   // 0 when there is no push-constant block
};
// Throws VulkanError for a truncated module or one that is not SPIR-V.
ShaderInfo reflectSpirv(std::span<const std::uint32_t> code);

// A shader module of `code`; the caller destroys it. Throws VulkanError.
VkShaderModule createShaderModule(VkDevice device, std::span<const std::uint32_t> code);

}  // namespace psub::vulkan
