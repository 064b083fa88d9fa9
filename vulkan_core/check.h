// The Vulkan core: VK_CHECK, which turns any failing VkResult into a VulkanError naming the call,
// the result, the file and the line, in every build.
#pragma once

#include "psub/vulkan_context.h"

#include <vulkan/vulkan.h>

namespace psub::vulkan {

const char* resultName(VkResult result);

[[noreturn]] void fail(VkResult result, const char* call, const char* file, int line);

inline void check(VkResult result, const char* call, const char* file, int line) {
    if (result != VK_SUCCESS) fail(result, call, file, line);
}

}  // namespace psub::vulkan

#define VK_CHECK(call) ::psub::vulkan::check((call), #call, __FILE__, __LINE__)
