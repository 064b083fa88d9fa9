// The compute evaluator's pipelines (niagara's shaders.cpp, kept small). SPIR-V embedded at
// build time; each module is checked against shaders/config.h when it is created (local size,
// bindings, push-constant size); pipelines are specialised per width, strides and windowing
// and cached for the context's lifetime.
#pragma once

#include "device.h"
#include "shaders.h"

#include <array>
#include <cstdint>
#include <map>
#include <mutex>
#include <span>
#include <utility>
#include <vector>

namespace psub::vulkan {

using uint = std::uint32_t;
#include "config.h"

struct PushConstants {
    PSUB_PUSH_CONSTANT_MEMBERS
};
struct GroupRecord {
    PSUB_GROUP_RECORD_MEMBERS
};
struct TileRecord {
    PSUB_TILE_RECORD_MEMBERS
};
static_assert(sizeof(PushConstants) == 52 && sizeof(GroupRecord) == 32 && sizeof(TileRecord) == 32);

enum class Kernel { Level, Factorized, FaceNormals, VertexNormals, Tile, TileUnrolled, TileNormals };
inline constexpr int kKernelCount = 7;

struct Specialization {
    uint components = 3, sourceStride = 3, destinationStride = 3;
    bool sourceWindowed = false, destinationWindowed = false;
    bool texels = false;  // inputs and tables read through the texel-buffer bindings
    uint rowN = ~0u, rowM = ~0u;  // level kernel: the rows' shape when compiled in (~0u: any)
    uint tileSteps = 1;           // unrolled tile kernel: t
    bool listed = false;          // vertex normals: written at listed vertices
    uint tileGrid = PSUB_TILE_GRID;  // workgroup tile kernel: its shared grids' side
    uint tileKeptSide = 0;           // workgroup tile kernel: non-zero, also the inner points' normals
    uint tileThreads = PSUB_WORKGROUP_SIZE;  // workgroup tile kernel: its workgroup's invocations
    bool implicitDestination = false;        // level kernel: row r writes element rowBase + r

    // The specialization constants' values, in the order of their ids in Pipelines::get; with
    // the kernel, the pipeline cache's key.
    std::array<uint, 14> values() const {
        return {components, sourceStride, destinationStride, uint(sourceWindowed), uint(destinationWindowed),
                uint(texels), rowN, rowM, tileSteps, uint(listed), tileGrid, tileKeptSide, tileThreads,
                uint(implicitDestination)};
    }
};

class Pipelines {
public:
    explicit Pipelines(VkDevice device);
    ~Pipelines();
    Pipelines(const Pipelines&) = delete;
    Pipelines& operator=(const Pipelines&) = delete;

    VkDescriptorSetLayout setLayout() const { return setLayout_; }
    VkPipelineLayout layout() const { return layout_; }
    // Created on first use, then cached. Thread-safe.
    VkPipeline get(Kernel kernel, const Specialization& specialization);

private:
    void release();

    VkDevice device_;
    VkDescriptorSetLayout setLayout_ = VK_NULL_HANDLE;
    VkPipelineLayout layout_ = VK_NULL_HANDLE;
    VkPipelineCache cache_ = VK_NULL_HANDLE;
    VkShaderModule modules_[kKernelCount] = {};
    std::mutex lock_;
    std::map<std::pair<Kernel, std::array<uint, 14>>, VkPipeline> pipelines_;
};

// The context's compute pipelines, made on first use (thread-safe) and kept with the context.
Pipelines& pipelinesFor(VulkanContext::Impl& context);

}  // namespace psub::vulkan
