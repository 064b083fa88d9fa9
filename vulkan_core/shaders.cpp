// Shader modules, and SPIR-V reflection (local size, bindings, sets, push-constant size).
#include "shaders.h"

#include <map>

namespace psub::vulkan {
namespace {

// SPIR-V opcodes and enumerants used by reflectSpirv.
enum : std::uint32_t {
    OpExecutionMode = 16, OpTypeInt = 21, OpTypeFloat = 22, OpTypeVector = 23, OpTypeStruct = 30,
    OpTypePointer = 32, OpVariable = 59, OpDecorate = 71, OpMemberDecorate = 72,
    ExecutionModeLocalSize = 17, DecorationBinding = 33, DecorationDescriptorSet = 34,
    DecorationOffset = 35, StorageClassPushConstant = 9,
};

}  // namespace

ShaderInfo reflectSpirv(std::span<const std::uint32_t> code) {
    ShaderInfo info;
    if (code.size() < 5 || code[0] != 0x07230203u) throw VulkanError("not a SPIR-V module");
    std::map<std::uint32_t, std::uint32_t> scalarBytes;                 // type id -> bytes
    std::map<std::uint32_t, std::vector<std::uint32_t>> structMembers;  // struct id -> member type ids
    std::map<std::uint32_t, std::map<std::uint32_t, std::uint32_t>> memberOffsets;
    std::map<std::uint32_t, std::uint32_t> pointee;                     // pointer id -> type id
    std::uint32_t pushPointer = 0;
    for (std::size_t at = 5; at < code.size();) {
        const std::uint32_t op = code[at] & 0xffffu, count = code[at] >> 16;
        if (count == 0 || at + count > code.size()) throw VulkanError("truncated SPIR-V module");
        const std::uint32_t* w = &code[at];
        switch (op) {
        case OpExecutionMode:
            if (count >= 6 && w[2] == ExecutionModeLocalSize) info.localSize[0] = w[3], info.localSize[1] = w[4], info.localSize[2] = w[5];
            break;
        case OpDecorate:
            if (count >= 4 && w[2] == DecorationBinding) info.bindings.push_back(w[3]);
            if (count >= 4 && w[2] == DecorationDescriptorSet) info.sets.push_back(w[3]);
            break;
        case OpMemberDecorate:
            if (count >= 5 && w[3] == DecorationOffset) memberOffsets[w[1]][w[2]] = w[4];
            break;
        case OpTypeInt:
        case OpTypeFloat: scalarBytes[w[1]] = w[2] / 8; break;
        case OpTypeVector: scalarBytes[w[1]] = scalarBytes[w[2]] * w[3]; break;
        case OpTypeStruct: structMembers[w[1]].assign(w + 2, w + count); break;
        case OpTypePointer: pointee[w[1]] = w[3]; break;
        case OpVariable:
            if (count >= 4 && w[3] == StorageClassPushConstant) pushPointer = w[1];
            break;
        default: break;
        }
        at += count;
    }
    if (pushPointer) {
        const std::uint32_t block = pointee[pushPointer];
        const std::vector<std::uint32_t>& members = structMembers[block];
        for (std::uint32_t m = 0; m < members.size(); ++m) {
            const std::uint32_t end = memberOffsets[block][m] + scalarBytes[members[m]];
            if (end > info.pushConstantBytes) info.pushConstantBytes = end;
        }
    }
    return info;
}

VkShaderModule createShaderModule(VkDevice device, std::span<const std::uint32_t> code) {
    VkShaderModuleCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO;
    info.codeSize = code.size_bytes();
    info.pCode = code.data();
    VkShaderModule module = VK_NULL_HANDLE;
    VK_CHECK(vkCreateShaderModule(device, &info, nullptr, &module));
    return module;
}

}  // namespace psub::vulkan
