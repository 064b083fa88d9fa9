// Compute pipelines from the SPIR-V embedded at build time (shaders/*.comp), checked against
// shaders/config.h, specialised and cached; made once per context (pipelinesFor).
#include "pipelines.h"

#include <cstdint>
#include <memory>
#include <mutex>
#include <string>

#include "face_normals.spv.h"
#include "factorized.spv.h"
#include "level.spv.h"
#include "tile.spv.h"
#include "tile_normals.spv.h"
#include "tile_unrolled.spv.h"
#include "vertex_normals.spv.h"

namespace psub::vulkan {
namespace {

struct Code {
    const char* name;
    std::span<const std::uint32_t> words;
};

Code code(Kernel kernel) {
    switch (kernel) {
    case Kernel::Level: return {"level.comp", psub_spirv_level};
    case Kernel::Factorized: return {"factorized.comp", psub_spirv_factorized};
    case Kernel::FaceNormals: return {"face_normals.comp", psub_spirv_face_normals};
    case Kernel::VertexNormals: return {"vertex_normals.comp", psub_spirv_vertex_normals};
    case Kernel::Tile: return {"tile.comp", psub_spirv_tile};
    case Kernel::TileUnrolled: return {"tile_unrolled.comp", psub_spirv_tile_unrolled};
    case Kernel::TileNormals: return {"tile_normals.comp", psub_spirv_tile_normals};
    }
    return {"?", {}};
}

// Throws VulkanError when a module disagrees with shaders/config.h.
void checkContract(const char* name, const ShaderInfo& info) {
    auto fail = [&](const std::string& what) {
        throw VulkanError(std::string("shader ") + name + " does not match shaders/config.h: " + what);
    };
    if (info.localSize[0] != PSUB_WORKGROUP_SIZE || info.localSize[1] != 1 || info.localSize[2] != 1)
        fail("local size " + std::to_string(info.localSize[0]) + "x" + std::to_string(info.localSize[1]) + "x" +
             std::to_string(info.localSize[2]) + ", expected " + std::to_string(PSUB_WORKGROUP_SIZE) + "x1x1");
    for (uint set : info.sets)
        if (set != 0) fail("descriptor set " + std::to_string(set) + " (only set 0 exists)");
    for (uint binding : info.bindings)
        if (binding >= PSUB_BINDING_COUNT) fail("binding " + std::to_string(binding) + " beyond the layout");
    if (info.pushConstantBytes != sizeof(PushConstants))
        fail("push constants of " + std::to_string(info.pushConstantBytes) + " bytes, expected " +
             std::to_string(sizeof(PushConstants)));
}

}  // namespace

Pipelines::Pipelines(VkDevice device) : device_(device) {
    try {
        VkDescriptorSetLayoutBinding bindings[PSUB_BINDING_COUNT];
        for (uint i = 0; i < PSUB_BINDING_COUNT; ++i)
            bindings[i] = {i,
                           i < PSUB_BINDING_STORAGE_COUNT ? VK_DESCRIPTOR_TYPE_STORAGE_BUFFER
                                                          : VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER,
                           1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
        VkDescriptorSetLayoutCreateInfo setInfo{};
        setInfo.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO;
        setInfo.bindingCount = PSUB_BINDING_COUNT;
        setInfo.pBindings = bindings;
        VK_CHECK(vkCreateDescriptorSetLayout(device_, &setInfo, nullptr, &setLayout_));
        const VkPushConstantRange push{VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(PushConstants)};
        VkPipelineLayoutCreateInfo layoutInfo{};
        layoutInfo.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
        layoutInfo.setLayoutCount = 1;
        layoutInfo.pSetLayouts = &setLayout_;
        layoutInfo.pushConstantRangeCount = 1;
        layoutInfo.pPushConstantRanges = &push;
        VK_CHECK(vkCreatePipelineLayout(device_, &layoutInfo, nullptr, &layout_));
        VkPipelineCacheCreateInfo cacheInfo{};
        cacheInfo.sType = VK_STRUCTURE_TYPE_PIPELINE_CACHE_CREATE_INFO;
        VK_CHECK(vkCreatePipelineCache(device_, &cacheInfo, nullptr, &cache_));
        for (int k = 0; k < kKernelCount; ++k) {
            const Code c = code(Kernel(k));
            checkContract(c.name, reflectSpirv(c.words));
            modules_[k] = createShaderModule(device_, c.words);
        }
    } catch (...) {
        release();
        throw;
    }
}

Pipelines::~Pipelines() { release(); }

void Pipelines::release() {
    for (auto& entry : pipelines_) vkDestroyPipeline(device_, entry.second, nullptr);
    pipelines_.clear();
    for (VkShaderModule& m : modules_) {
        if (m) vkDestroyShaderModule(device_, m, nullptr);
        m = VK_NULL_HANDLE;
    }
    if (cache_) vkDestroyPipelineCache(device_, cache_, nullptr);
    if (layout_) vkDestroyPipelineLayout(device_, layout_, nullptr);
    if (setLayout_) vkDestroyDescriptorSetLayout(device_, setLayout_, nullptr);
    cache_ = VK_NULL_HANDLE;
    layout_ = VK_NULL_HANDLE;
    setLayout_ = VK_NULL_HANDLE;
}

VkPipeline Pipelines::get(Kernel kernel, const Specialization& s) {
    const auto values = s.values();
    const auto key = std::pair(kernel, values);
    std::lock_guard guard(lock_);
    if (auto found = pipelines_.find(key); found != pipelines_.end()) return found->second;

    constexpr std::uint32_t count = std::uint32_t(std::tuple_size_v<decltype(values)>);
    constexpr std::uint32_t ids[count] = {PSUB_SPEC_COMPONENTS,      PSUB_SPEC_SOURCE_STRIDE,        PSUB_SPEC_DESTINATION_STRIDE,
                                          PSUB_SPEC_SOURCE_WINDOWED, PSUB_SPEC_DESTINATION_WINDOWED, PSUB_SPEC_TEXELS,
                                          PSUB_SPEC_ROW_N,           PSUB_SPEC_ROW_M,                PSUB_SPEC_TILE_STEPS,
                                          PSUB_SPEC_LISTED,          PSUB_SPEC_TILE_GRID,            PSUB_SPEC_TILE_NORMALS,
                                          PSUB_SPEC_TILE_THREADS,    PSUB_SPEC_IMPLICIT_DESTINATION};
    VkSpecializationMapEntry entries[count];
    for (std::uint32_t i = 0; i < count; ++i) entries[i] = {ids[i], 4 * i, 4};
    VkSpecializationInfo specialization{count, entries, sizeof values, values.data()};
    VkComputePipelineCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO;
    info.stage.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
    info.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
    info.stage.module = modules_[int(kernel)];
    info.stage.pName = "main";
    info.stage.pSpecializationInfo = &specialization;
    info.layout = layout_;
    VkPipeline pipeline = VK_NULL_HANDLE;
    VK_CHECK(vkCreateComputePipelines(device_, cache_, 1, &info, nullptr, &pipeline));
    pipelines_.emplace(key, pipeline);
    return pipeline;
}

Pipelines& pipelinesFor(VulkanContext::Impl& context) {
    std::call_once(context.pipelinesOnce, [&] { context.pipelines = std::make_shared<Pipelines>(context.device); });
    return *context.pipelines;
}

}  // namespace psub::vulkan
