// The Vulkan evaluator's descriptor sets: one per dispatch, written once at construction
// (vertex-buffer windows, table windows and their texel-buffer views).
#include "vulkan_evaluator_impl.h"

#include <algorithm>
#include <map>
#include <tuple>

namespace psub {

void VulkanEvaluator::Impl::writeDescriptorSets() {
    std::uint32_t sets = 0;
    for (const auto* stages : {&stencilStages, &normalStages})
        for (const Stage& s : *stages) sets += std::uint32_t(s.dispatches.size());
    if (sets == 0) return;
    const VkDescriptorPoolSize sizes[2] = {
        {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, sets * PSUB_BINDING_STORAGE_COUNT},
        {VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER, sets * (PSUB_BINDING_COUNT - PSUB_BINDING_STORAGE_COUNT)}};
    VkDescriptorPoolCreateInfo poolInfo{};
    poolInfo.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
    poolInfo.maxSets = sets;
    poolInfo.poolSizeCount = 2;
    poolInfo.pPoolSizes = sizes;
    VK_CHECK(vkCreateDescriptorPool(context.device, &poolInfo, nullptr, &descriptorPool));
    const VkDescriptorSetLayout layout = pipelines->setLayout();
    // A vertex buffer's window w (window 0 again beyond its last: every binding must be valid).
    auto vertexWindow = [&](const VertexBuffer& v, std::uint32_t w) {
        VkDescriptorBufferInfo info{v.buffer.buffer, 0, v.buffer.size};
        if (v.elements == 0) return info;
        if (w >= v.windows) w = 0;
        const std::uint64_t first = std::uint64_t(w) * v.windowSize;
        const std::uint64_t count = std::min<std::uint64_t>(v.windowSize, v.elements - first);
        info.offset = first * v.stride * 4;
        info.range = count * v.stride * 4;
        return info;
    };
    // One view per distinct range and format (the dispatches of a level share their input's).
    std::map<std::tuple<VkBuffer, VkDeviceSize, VkDeviceSize, VkFormat>, VkBufferView> made;
    auto view = [&](const VkDescriptorBufferInfo& info, VkFormat format) {
        VkBufferView& found = made[std::tuple(info.buffer, info.offset, info.range, format)];
        if (found) return found;
        VkBufferViewCreateInfo viewInfo{};
        viewInfo.sType = VK_STRUCTURE_TYPE_BUFFER_VIEW_CREATE_INFO;
        viewInfo.buffer = info.buffer;
        viewInfo.format = format;
        viewInfo.offset = info.offset;
        viewInfo.range = info.range;
        VK_CHECK(vkCreateBufferView(context.device, &viewInfo, nullptr, &found));
        views.push_back(found);
        return found;
    };
    for (auto* stages : {&stencilStages, &normalStages})
        for (Stage& s : *stages)
            for (Dispatch& d : s.dispatches) {
                VkDescriptorSetAllocateInfo allocate{};
                allocate.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
                allocate.descriptorPool = descriptorPool;
                allocate.descriptorSetCount = 1;
                allocate.pSetLayouts = &layout;
                VK_CHECK(vkAllocateDescriptorSets(context.device, &allocate, &d.set));
                VkDescriptorBufferInfo infos[PSUB_BINDING_STORAGE_COUNT];
                for (std::uint32_t w = 0; w < PSUB_VERTEX_WINDOWS; ++w) {
                    infos[PSUB_BINDING_SOURCE + w] = vertexWindow(*d.source, w);
                    infos[PSUB_BINDING_DESTINATION + w] = vertexWindow(*d.destination, w);
                }
                if (d.secondDestination) infos[PSUB_BINDING_DESTINATION + 1] = vertexWindow(*d.secondDestination, 0);
                for (int t = 0; t < 3; ++t)
                    infos[PSUB_BINDING_TABLE_A + t] = {d.tables[t].buffer, d.tables[t].offset, d.tables[t].range};
                // The texel-buffer bindings: the input's windows and the three table windows.
                VkBufferView texelViews[PSUB_BINDING_COUNT] = {};
                const VkFormat sourceFormat =
                    d.source->stride == 4 ? VK_FORMAT_R32G32B32A32_SFLOAT : VK_FORMAT_R32_SFLOAT;
                for (std::uint32_t w = 0; w < PSUB_VERTEX_WINDOWS; ++w)
                    texelViews[PSUB_BINDING_SOURCE_TEXELS + w] = view(infos[PSUB_BINDING_SOURCE + w], sourceFormat);
                for (int t = 0; t < 3; ++t)
                    texelViews[PSUB_BINDING_TABLE_A_TEXELS + t] = view(infos[PSUB_BINDING_TABLE_A + t], d.texelFormats[t]);
                VkWriteDescriptorSet writes[PSUB_BINDING_COUNT];
                for (std::uint32_t b = 0; b < PSUB_BINDING_COUNT; ++b) {
                    writes[b] = {};
                    writes[b].sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
                    writes[b].dstSet = d.set;
                    writes[b].dstBinding = b;
                    writes[b].descriptorCount = 1;
                    if (b < PSUB_BINDING_STORAGE_COUNT) {
                        writes[b].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
                        writes[b].pBufferInfo = &infos[b];
                    } else {
                        writes[b].descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER;
                        writes[b].pTexelBufferView = &texelViews[b];
                    }
                }
                vkUpdateDescriptorSets(context.device, PSUB_BINDING_COUNT, writes, 0, nullptr);
            }
}

}  // namespace psub
