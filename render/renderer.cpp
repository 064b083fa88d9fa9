// The offscreen renderer: graphics pipelines from the SPIR-V of shaders/render_* (embedded at
// build time), colour (+ MSAA) and depth images, persistently mapped vertex buffers, index
// buffers of fan triangles and unique edges (per wireframe mode prepared), a readback buffer,
// and command buffers recorded once: render (one render pass per wireframe mode prepared),
// readback (copy -> host barrier). A draw writes buffers, submits, waits on the fence and
// copies the pixels out.
#include "psub/render.h"
#include "psub/vulkan_interop.h"

#include "device.h"
#include "images.h"
#include "resources.h"
#include "shaders.h"
#include "submit.h"
#include "texture.h"

#include "render_lines_frag.spv.h"
#include "render_lines_vert.spv.h"
#include "render_mesh_frag.spv.h"
#include "render_mesh_vert.spv.h"
#include "render_textured_frag.spv.h"
#include "render_textured_vert.spv.h"

#include <algorithm>
#include <array>
#include <cassert>
#include <cstddef>
#include <chrono>
#include <cmath>
#include <cstring>
#include <utility>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

namespace psub {
namespace {

using namespace vulkan;
using render_detail::DeviceTexture;
using Clock = std::chrono::steady_clock;

// Mirrors shaders/render_frame.glsl (std140).
struct FrameUniforms {
    float view[16], projection[16];
    float surfaceColour[4], lineColour[4], keyLight[4], params[4], baseColourFactor[4];
};
static_assert(sizeof(FrameUniforms) == 208);

// A textured corner (render_textured.vert's vertex input): its surface vertex and UV.
struct TexturedCorner {
    std::uint32_t vertex;
    float u, v;
};
static_assert(sizeof(TexturedCorner) == 12);

enum class PipelineKind { Mesh, Textured, Lines };

// Lines are pulled this fraction of their distance towards the eye (render_lines.vert).
constexpr float kLinePull = 0.0015f;

double msBetween(Clock::time_point a, Clock::time_point b) {
    return std::chrono::duration<double, std::milli>(b - a).count();
}

// Throws std::invalid_argument unless `p` is a consistent CSR face list.
void checkPolygons(Polygons p, const char* what) {
    if (p.offsets.empty()) {
        if (!p.verts.empty()) throw std::invalid_argument(std::string("Renderer: ") + what + " has corners but no offsets");
        return;
    }
    if (p.offsets.front() != 0 || p.offsets.back() != p.verts.size())
        throw std::invalid_argument(std::string("Renderer: ") + what + " offsets do not span the corner list");
    for (std::size_t f = 0; f + 1 < p.offsets.size(); ++f)
        if (p.offsets[f] > p.offsets[f + 1])
            throw std::invalid_argument(std::string("Renderer: ") + what + " offsets decrease at face " + std::to_string(f));
    for (std::uint32_t v : p.verts)
        if (v >= p.vertexCount)
            throw std::invalid_argument(std::string("Renderer: ") + what + " corner " + std::to_string(v) +
                                        " is beyond its " + std::to_string(p.vertexCount) + " vertices");
}

// Throws std::invalid_argument unless `t`'s faces are consistent CSR polygons over
// `vertexCount` vertices with a value of finite UVs per corner.
void checkTexture(const SurfaceTexture& t, std::uint32_t vertexCount) {
    checkPolygons({vertexCount, t.faceOffsets, t.faceVerts}, "texture faces");
    if (t.faceValues.size() != t.faceVerts.size())
        throw std::invalid_argument("Renderer: texture faces have " + std::to_string(t.faceVerts.size()) +
                                    " corners but " + std::to_string(t.faceValues.size()) + " UV values");
    if (t.uv.size() % 2 != 0) throw std::invalid_argument("Renderer: texture UVs are not pairs of floats");
    for (std::uint32_t value : t.faceValues)
        if (value >= t.uv.size() / 2)
            throw std::invalid_argument("Renderer: texture corner value " + std::to_string(value) + " is beyond its " +
                                        std::to_string(t.uv.size() / 2) + " UVs");
    for (float x : t.uv)
        if (!std::isfinite(x)) throw std::invalid_argument("Renderer: texture UVs are not all finite");
}

// Every face of 3 or more corners as a fan of triangles from its first corner.
std::vector<std::uint32_t> fanTriangles(Polygons p) {
    std::vector<std::uint32_t> indices;
    for (std::size_t f = 0; f + 1 < p.offsets.size(); ++f) {
        const std::uint32_t begin = p.offsets[f], end = p.offsets[f + 1];
        for (std::uint32_t i = begin + 1; i + 1 < end; ++i)
            indices.insert(indices.end(), {p.verts[begin], p.verts[i], p.verts[i + 1]});
    }
    return indices;
}

// Each edge of the faces (of 3 or more corners) once, as index pairs.
std::vector<std::uint32_t> uniqueEdges(Polygons p) {
    std::vector<std::uint64_t> keys;
    for (std::size_t f = 0; f + 1 < p.offsets.size(); ++f) {
        const std::uint32_t begin = p.offsets[f], end = p.offsets[f + 1];
        if (end - begin < 3) continue;
        for (std::uint32_t i = begin; i < end; ++i) {
            const std::uint32_t a = p.verts[i], b = p.verts[i + 1 < end ? i + 1 : begin];
            keys.push_back(std::uint64_t(std::min(a, b)) << 32 | std::max(a, b));
        }
    }
    std::sort(keys.begin(), keys.end());
    keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
    std::vector<std::uint32_t> pairs;
    pairs.reserve(2 * keys.size());
    for (std::uint64_t k : keys) pairs.insert(pairs.end(), {std::uint32_t(k >> 32), std::uint32_t(k)});
    return pairs;
}

void toFloats(Rgba c, float out[4]) {
    out[0] = float(c.r) / 255.0f, out[1] = float(c.g) / 255.0f, out[2] = float(c.b) / 255.0f, out[3] = float(c.a) / 255.0f;
}

// A render target of one mip level; its out-of-memory message names the options that shrink it.
Image2D createAttachment(const VulkanContext::Impl& c, VkFormat format, VkImageUsageFlags usage,
                         VkSampleCountFlagBits samples, VkImageAspectFlags aspect, std::uint32_t width, std::uint32_t height) {
    ImageSpec spec;
    spec.format = format, spec.usage = usage, spec.samples = samples, spec.aspect = aspect;
    spec.width = width, spec.height = height;
    spec.outOfMemoryHint = "use a smaller --size or --msaa 1";
    return vulkan::createImage(c, spec);
}

VkFormat chooseDepthFormat(VkPhysicalDevice physical) {
    for (VkFormat format : {VK_FORMAT_D32_SFLOAT, VK_FORMAT_X8_D24_UNORM_PACK32, VK_FORMAT_D16_UNORM}) {
        VkFormatProperties properties;
        vkGetPhysicalDeviceFormatProperties(physical, format, &properties);
        if (properties.optimalTilingFeatures & VK_FORMAT_FEATURE_DEPTH_STENCIL_ATTACHMENT_BIT) return format;
    }
    throw VulkanError("no depth format usable as an attachment");
}

// The largest sample count up to `wanted` that colour and depth attachments both support.
VkSampleCountFlagBits chooseSamples(const VkPhysicalDeviceLimits& limits, std::uint32_t wanted) {
    const VkSampleCountFlags supported = limits.framebufferColorSampleCounts & limits.framebufferDepthSampleCounts;
    for (std::uint32_t s = 64; s > 1; s /= 2)
        if (s <= wanted && (supported & s)) return VkSampleCountFlagBits(s);
    return VK_SAMPLE_COUNT_1_BIT;
}

bool queueHasGraphics(const VulkanContext::Impl& c) {
    std::uint32_t count = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(c.physical, &count, nullptr);
    std::vector<VkQueueFamilyProperties> families(count);
    vkGetPhysicalDeviceQueueFamilyProperties(c.physical, &count, families.data());
    return c.queueFamily < count && (families[c.queueFamily].queueFlags & VK_QUEUE_GRAPHICS_BIT);
}

}  // namespace

struct Renderer::Impl {
    VulkanContext::Impl& context;
    RenderOptions options;
    VkSampleCountFlagBits samples = VK_SAMPLE_COUNT_1_BIT;
    std::uint32_t vertexCount = 0, controlVertexCount = 0, triangleIndices = 0;
    Buffer positions, normals, triangles, controlPositions, uniforms, readback;
    // Per Wireframe mode (None's stay empty): edge index pairs, and the recorded render pass.
    std::array<Buffer, 3> lines;
    std::array<std::uint32_t, 3> lineIndices{};
    std::array<bool, 3> prepared{};  // the modes setWireframe may pick
    Wireframe wireframe = Wireframe::None;  // the one drawn
    bool textured = false;
    std::array<float, 4> baseColourFactor{1, 1, 1, 1};
    Buffer corners;  // textured: a TexturedCorner per face corner; `triangles` index them
    DeviceTexture texture;
    Image2D colour, multisampled, depth;  // colour: single-sample, read back; multisampled: when samples > 1
    VkRenderPass renderPass = VK_NULL_HANDLE;
    VkFramebuffer framebuffer = VK_NULL_HANDLE;
    VkDescriptorSetLayout setLayout = VK_NULL_HANDLE;
    VkDescriptorPool descriptorPool = VK_NULL_HANDLE;
    VkDescriptorSet descriptorSet = VK_NULL_HANDLE;
    VkPipelineLayout pipelineLayout = VK_NULL_HANDLE;
    VkPipeline meshPipeline = VK_NULL_HANDLE, linePipeline = VK_NULL_HANDLE;  // mesh: flat or textured
    VkCommandPool commandPool = VK_NULL_HANDLE;
    std::array<VkCommandBuffer, 3> renderCommands{};  // per Wireframe mode prepared
    VkCommandBuffer readbackCommands = VK_NULL_HANDLE;
    VkFence fence = VK_NULL_HANDLE;
    DrawTimes times;
    // The vertex buffers drawn: our own (12 bytes per vertex), or an evaluator's (drawsKept).
    VkBuffer drawnPositions = VK_NULL_HANDLE, drawnNormals = VK_NULL_HANDLE;
    std::uint32_t vertexStride = 12;
    bool drawsKept = false;

    Impl(VulkanContext::Impl& c, const RenderOptions& o) : context(c), options(o) {}
    ~Impl();

    void createBuffers(Polygons surface, Polygons control, const SurfaceTexture& surfaceTexture);
    void createImages();
    void createRenderPass();
    void createDescriptors();
    VkPipeline createPipeline(std::span<const std::uint32_t> vertex, std::span<const std::uint32_t> fragment,
                              PipelineKind kind);
    void recordCommands();
    void recordRender(VkCommandBuffer commands, Wireframe mode);
    void writeUniforms(const Camera& camera);
    // Everything after the options: buffers, texture, images, descriptors, pipelines, commands.
    void build(Polygons surface, Polygons control, const SurfaceTexture& surfaceTexture);
    void createPipelines();
    // The rest of a frame whose vertex uploads began at `start`: uniforms, render, read back.
    void renderAndReadBack(const Camera& camera, Clock::time_point start, Image& out);
};

Renderer::Impl::~Impl() {
    const VkDevice d = context.device;
    if (fence) vkDestroyFence(d, fence, nullptr);
    if (commandPool) vkDestroyCommandPool(d, commandPool, nullptr);
    for (VkPipeline p : {meshPipeline, linePipeline})
        if (p) vkDestroyPipeline(d, p, nullptr);
    if (pipelineLayout) vkDestroyPipelineLayout(d, pipelineLayout, nullptr);
    if (descriptorPool) vkDestroyDescriptorPool(d, descriptorPool, nullptr);
    if (setLayout) vkDestroyDescriptorSetLayout(d, setLayout, nullptr);
    if (framebuffer) vkDestroyFramebuffer(d, framebuffer, nullptr);
    if (renderPass) vkDestroyRenderPass(d, renderPass, nullptr);
    for (Image2D* image : {&colour, &multisampled, &depth}) destroyImage(context, *image);
    for (Buffer* b : {&positions, &normals, &triangles, &controlPositions, &uniforms, &readback, &corners})
        destroyBuffer(context, *b);
    for (Buffer& b : lines) destroyBuffer(context, b);
    render_detail::destroyTexture(context, texture);
}

// Textured: the corners' buffer, and fan triangles over the corners (not the vertices).
void Renderer::Impl::createBuffers(Polygons surface, Polygons control, const SurfaceTexture& surfaceTexture) {
    const VulkanContext::Impl& c = context;
    std::vector<std::uint32_t> cornerIds;
    if (textured) {
        cornerIds.resize(surfaceTexture.faceVerts.size());
        for (std::uint32_t i = 0; i < cornerIds.size(); ++i) cornerIds[i] = i;
        corners = createBuffer(c, sizeof(TexturedCorner) * cornerIds.size(), VK_BUFFER_USAGE_VERTEX_BUFFER_BIT,
                               Memory::Device, true);
        auto* corner = static_cast<TexturedCorner*>(corners.mapped);
        for (std::size_t i = 0; i < cornerIds.size(); ++i) {
            const std::uint32_t value = surfaceTexture.faceValues[i];
            corner[i] = {surfaceTexture.faceVerts[i], surfaceTexture.uv[2 * value], surfaceTexture.uv[2 * value + 1]};
        }
    }
    const Polygons drawn = textured ? Polygons{std::uint32_t(cornerIds.size()), surfaceTexture.faceOffsets, cornerIds}
                                    : surface;
    const std::vector<std::uint32_t> fan = fanTriangles(drawn);
    if (fan.size() > 0xffffffffu) throw std::invalid_argument("Renderer: more than 2^32 indices in one draw");
    triangleIndices = std::uint32_t(fan.size());
    const VkBufferUsageFlags vertexUsage = VK_BUFFER_USAGE_VERTEX_BUFFER_BIT;
    const VkBufferUsageFlags pulled = textured ? VK_BUFFER_USAGE_STORAGE_BUFFER_BIT : 0;  // render_textured.vert
    if (!drawsKept) {  // else the evaluator's buffers are drawn
        // Cached: host-visible, coherent, host-cached where there is such a type (Readback prefers it).
        const Memory vertexMemory = options.cachedVertices ? Memory::Readback : Memory::Device;
        positions = createBuffer(c, 12ull * vertexCount, vertexUsage | pulled, vertexMemory, true);
        normals = createBuffer(c, 12ull * vertexCount, vertexUsage | pulled, vertexMemory, true);
    }
    if (prepared[std::size_t(Wireframe::Control)])
        controlPositions = createBuffer(c, 12ull * controlVertexCount, vertexUsage, Memory::Device, true);
    triangles = createBuffer(c, 4ull * fan.size(), VK_BUFFER_USAGE_INDEX_BUFFER_BIT, Memory::Device, true);
    if (!fan.empty()) std::memcpy(triangles.mapped, fan.data(), 4 * fan.size());
    for (Wireframe mode : {Wireframe::Refined, Wireframe::Control}) {
        const std::size_t m = std::size_t(mode);
        if (!prepared[m]) continue;
        const std::vector<std::uint32_t> edges = uniqueEdges(mode == Wireframe::Refined ? surface : control);
        if (edges.size() > 0xffffffffu) throw std::invalid_argument("Renderer: more than 2^32 indices in one draw");
        lineIndices[m] = std::uint32_t(edges.size());
        lines[m] = createBuffer(c, 4ull * edges.size(), VK_BUFFER_USAGE_INDEX_BUFFER_BIT, Memory::Device, true);
        if (!edges.empty()) std::memcpy(lines[m].mapped, edges.data(), 4 * edges.size());
    }
    uniforms = createBuffer(c, sizeof(FrameUniforms), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT, Memory::Upload, true);
    readback = createBuffer(c, 4ull * options.width * options.height, VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                            Memory::Readback, true);
    // Zeros until the caller writes positions: every draw is of defined data.
    for (Buffer* b : {&positions, &normals, &controlPositions})
        if (b->mapped) std::memset(b->mapped, 0, b->size);
}

void Renderer::Impl::createImages() {
    const VulkanContext::Impl& c = context;
    const VkFormat depthFormat = chooseDepthFormat(c.physical);
    colour = createAttachment(c, VK_FORMAT_R8G8B8A8_UNORM,
                              VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                              VK_SAMPLE_COUNT_1_BIT, VK_IMAGE_ASPECT_COLOR_BIT, options.width, options.height);
    if (samples != VK_SAMPLE_COUNT_1_BIT)
        multisampled = createAttachment(c, VK_FORMAT_R8G8B8A8_UNORM,
                                        VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSIENT_ATTACHMENT_BIT,
                                        samples, VK_IMAGE_ASPECT_COLOR_BIT, options.width, options.height);
    depth = createAttachment(c, depthFormat, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT, samples,
                             VK_IMAGE_ASPECT_DEPTH_BIT, options.width, options.height);
    createRenderPass();
    const bool msaa = samples != VK_SAMPLE_COUNT_1_BIT;
    const VkImageView views[3] = {msaa ? multisampled.view : colour.view, depth.view, colour.view};
    VkFramebufferCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO;
    info.renderPass = renderPass;
    info.attachmentCount = msaa ? 3 : 2;
    info.pAttachments = views;
    info.width = options.width;
    info.height = options.height;
    info.layers = 1;
    VK_CHECK(vkCreateFramebuffer(c.device, &info, nullptr, &framebuffer));
}

// Attachments: colour (multisampled or the image read back), depth, and with MSAA the
// single-sample resolve target. The image read back ends in TRANSFER_SRC_OPTIMAL.
void Renderer::Impl::createRenderPass() {
    const bool msaa = samples != VK_SAMPLE_COUNT_1_BIT;
    VkAttachmentDescription attachments[3]{};
    attachments[0].format = VK_FORMAT_R8G8B8A8_UNORM;
    attachments[0].samples = samples;
    attachments[0].loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
    attachments[0].storeOp = msaa ? VK_ATTACHMENT_STORE_OP_DONT_CARE : VK_ATTACHMENT_STORE_OP_STORE;
    attachments[0].stencilLoadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
    attachments[0].stencilStoreOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
    attachments[0].initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    attachments[0].finalLayout = msaa ? VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL : VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    attachments[1] = attachments[0];
    attachments[1].format = chooseDepthFormat(context.physical);
    attachments[1].storeOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
    attachments[1].finalLayout = VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL;
    attachments[2] = attachments[0];
    attachments[2].samples = VK_SAMPLE_COUNT_1_BIT;
    attachments[2].loadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
    attachments[2].storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    attachments[2].finalLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    const VkAttachmentReference colourRef{0, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
    const VkAttachmentReference depthRef{1, VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL};
    const VkAttachmentReference resolveRef{2, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
    VkSubpassDescription subpass{};
    subpass.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
    subpass.colorAttachmentCount = 1;
    subpass.pColorAttachments = &colourRef;
    subpass.pResolveAttachments = msaa ? &resolveRef : nullptr;
    subpass.pDepthStencilAttachment = &depthRef;
    // Before: the previous frame's copy and attachment writes. After: the copy to the host.
    const VkPipelineStageFlags attachmentStages = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT |
                                                  VK_PIPELINE_STAGE_EARLY_FRAGMENT_TESTS_BIT |
                                                  VK_PIPELINE_STAGE_LATE_FRAGMENT_TESTS_BIT;
    const VkAccessFlags attachmentWrites =
        VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT | VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
    VkSubpassDependency dependencies[2]{};
    dependencies[0] = {VK_SUBPASS_EXTERNAL, 0, attachmentStages | VK_PIPELINE_STAGE_TRANSFER_BIT, attachmentStages,
                       attachmentWrites, attachmentWrites | VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_READ_BIT, 0};
    dependencies[1] = {0, VK_SUBPASS_EXTERNAL, VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT,
                       VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT,
                       VK_ACCESS_TRANSFER_READ_BIT, 0};
    VkRenderPassCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO;
    info.attachmentCount = msaa ? 3 : 2;
    info.pAttachments = attachments;
    info.subpassCount = 1;
    info.pSubpasses = &subpass;
    info.dependencyCount = 2;
    info.pDependencies = dependencies;
    VK_CHECK(vkCreateRenderPass(context.device, &info, nullptr, &renderPass));
}

// Binding 0: the frame's uniforms. Textured, also (render_textured.*) 1: positions, 2:
// normals (storage buffers), 3: the texture and its sampler.
void Renderer::Impl::createDescriptors() {
    const VkDevice d = context.device;
    const VkDescriptorSetLayoutBinding bindings[4] = {
        {0, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, nullptr},
        {1, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_VERTEX_BIT, nullptr},
        {2, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_VERTEX_BIT, nullptr},
        {3, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_FRAGMENT_BIT, nullptr}};
    const std::uint32_t bindingCount = textured ? 4 : 1;
    VkDescriptorSetLayoutCreateInfo setInfo{};
    setInfo.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO;
    setInfo.bindingCount = bindingCount;
    setInfo.pBindings = bindings;
    VK_CHECK(vkCreateDescriptorSetLayout(d, &setInfo, nullptr, &setLayout));
    const VkDescriptorPoolSize sizes[3] = {{VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1},
                                           {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 2},
                                           {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1}};
    VkDescriptorPoolCreateInfo poolInfo{};
    poolInfo.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
    poolInfo.maxSets = 1;
    poolInfo.poolSizeCount = textured ? 3 : 1;
    poolInfo.pPoolSizes = sizes;
    VK_CHECK(vkCreateDescriptorPool(d, &poolInfo, nullptr, &descriptorPool));
    VkDescriptorSetAllocateInfo allocate{};
    allocate.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
    allocate.descriptorPool = descriptorPool;
    allocate.descriptorSetCount = 1;
    allocate.pSetLayouts = &setLayout;
    VK_CHECK(vkAllocateDescriptorSets(d, &allocate, &descriptorSet));
    const VkDescriptorBufferInfo bufferInfos[3] = {{uniforms.buffer, 0, sizeof(FrameUniforms)},
                                                   {positions.buffer, 0, VK_WHOLE_SIZE},
                                                   {normals.buffer, 0, VK_WHOLE_SIZE}};
    const VkDescriptorImageInfo imageInfo{texture.sampler, texture.image.view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
    VkWriteDescriptorSet writes[4]{};
    for (std::uint32_t i = 0; i < 4; ++i) {
        writes[i].sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
        writes[i].dstSet = descriptorSet;
        writes[i].dstBinding = i;
        writes[i].descriptorCount = 1;
        writes[i].descriptorType = bindings[i].descriptorType;
        if (i < 3) writes[i].pBufferInfo = &bufferInfos[i];
    }
    writes[3].pImageInfo = &imageInfo;
    vkUpdateDescriptorSets(d, bindingCount, writes, 0, nullptr);
    VkPipelineLayoutCreateInfo layoutInfo{};
    layoutInfo.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
    layoutInfo.setLayoutCount = 1;
    layoutInfo.pSetLayouts = &setLayout;
    VK_CHECK(vkCreatePipelineLayout(d, &layoutInfo, nullptr, &pipelineLayout));
}

// Mesh: triangles with positions (binding 0) and normals (binding 1), depth written.
// Textured: triangles of corners (binding 0: vertex index, UV), depth written. Lines:
// positions only, depth tested (less or equal) but not written.
VkPipeline Renderer::Impl::createPipeline(std::span<const std::uint32_t> vertex, std::span<const std::uint32_t> fragment,
                                          PipelineKind kind) {
    const bool mesh = kind != PipelineKind::Lines;
    const VkDevice d = context.device;
    VkShaderModule modules[2] = {createShaderModule(d, vertex), VK_NULL_HANDLE};
    VkPipeline pipeline = VK_NULL_HANDLE;
    try {
        modules[1] = createShaderModule(d, fragment);
        VkPipelineShaderStageCreateInfo stages[2]{};
        for (int i = 0; i < 2; ++i) {
            stages[i].sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
            stages[i].stage = i == 0 ? VK_SHADER_STAGE_VERTEX_BIT : VK_SHADER_STAGE_FRAGMENT_BIT;
            stages[i].module = modules[i];
            stages[i].pName = "main";
        }
        const VkVertexInputBindingDescription bindings[2] = {{0, vertexStride, VK_VERTEX_INPUT_RATE_VERTEX},
                                                             {1, vertexStride, VK_VERTEX_INPUT_RATE_VERTEX}};
        const VkVertexInputAttributeDescription attributes[2] = {{0, 0, VK_FORMAT_R32G32B32_SFLOAT, 0},
                                                                 {1, 1, VK_FORMAT_R32G32B32_SFLOAT, 0}};
        const VkVertexInputBindingDescription cornerBinding{0, sizeof(TexturedCorner), VK_VERTEX_INPUT_RATE_VERTEX};
        const VkVertexInputAttributeDescription cornerAttributes[2] = {
            {0, 0, VK_FORMAT_R32_UINT, offsetof(TexturedCorner, vertex)},
            {1, 0, VK_FORMAT_R32G32_SFLOAT, offsetof(TexturedCorner, u)}};
        const bool pulled = kind == PipelineKind::Textured;
        VkPipelineVertexInputStateCreateInfo input{};
        input.sType = VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO;
        input.vertexBindingDescriptionCount = pulled ? 1 : mesh ? 2 : 1;
        input.pVertexBindingDescriptions = pulled ? &cornerBinding : bindings;
        input.vertexAttributeDescriptionCount = mesh ? 2 : 1;
        input.pVertexAttributeDescriptions = pulled ? cornerAttributes : attributes;
        VkPipelineInputAssemblyStateCreateInfo assembly{};
        assembly.sType = VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO;
        assembly.topology = mesh ? VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST : VK_PRIMITIVE_TOPOLOGY_LINE_LIST;
        const VkViewport viewport{0, 0, float(options.width), float(options.height), 0, 1};
        const VkRect2D scissor{{0, 0}, {options.width, options.height}};
        VkPipelineViewportStateCreateInfo viewportState{};
        viewportState.sType = VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO;
        viewportState.viewportCount = 1;
        viewportState.pViewports = &viewport;
        viewportState.scissorCount = 1;
        viewportState.pScissors = &scissor;
        VkPipelineRasterizationStateCreateInfo raster{};
        raster.sType = VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO;
        raster.polygonMode = VK_POLYGON_MODE_FILL;
        raster.cullMode = VK_CULL_MODE_NONE;  // two-sided
        raster.frontFace = VK_FRONT_FACE_COUNTER_CLOCKWISE;
        raster.lineWidth = 1.0f;
        VkPipelineMultisampleStateCreateInfo multisample{};
        multisample.sType = VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO;
        multisample.rasterizationSamples = samples;
        VkPipelineDepthStencilStateCreateInfo depthState{};
        depthState.sType = VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO;
        depthState.depthTestEnable = VK_TRUE;
        depthState.depthWriteEnable = mesh ? VK_TRUE : VK_FALSE;
        depthState.depthCompareOp = mesh ? VK_COMPARE_OP_LESS : VK_COMPARE_OP_LESS_OR_EQUAL;
        VkPipelineColorBlendAttachmentState blendAttachment{};
        blendAttachment.colorWriteMask = VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_G_BIT |
                                         VK_COLOR_COMPONENT_B_BIT | VK_COLOR_COMPONENT_A_BIT;
        VkPipelineColorBlendStateCreateInfo blend{};
        blend.sType = VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO;
        blend.attachmentCount = 1;
        blend.pAttachments = &blendAttachment;
        VkGraphicsPipelineCreateInfo info{};
        info.sType = VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO;
        info.stageCount = 2;
        info.pStages = stages;
        info.pVertexInputState = &input;
        info.pInputAssemblyState = &assembly;
        info.pViewportState = &viewportState;
        info.pRasterizationState = &raster;
        info.pMultisampleState = &multisample;
        info.pDepthStencilState = &depthState;
        info.pColorBlendState = &blend;
        info.layout = pipelineLayout;
        info.renderPass = renderPass;
        VK_CHECK(vkCreateGraphicsPipelines(d, VK_NULL_HANDLE, 1, &info, nullptr, &pipeline));
    } catch (...) {
        for (VkShaderModule m : modules)
            if (m) vkDestroyShaderModule(d, m, nullptr);
        throw;
    }
    for (VkShaderModule m : modules) vkDestroyShaderModule(d, m, nullptr);
    return pipeline;
}

void Renderer::Impl::recordCommands() {
    const VkDevice d = context.device;
    VkCommandPoolCreateInfo poolInfo{};
    poolInfo.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
    poolInfo.queueFamilyIndex = context.queueFamily;
    VK_CHECK(vkCreateCommandPool(d, &poolInfo, nullptr, &commandPool));
    VkCommandBufferAllocateInfo allocate{};
    allocate.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
    allocate.commandPool = commandPool;
    allocate.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    allocate.commandBufferCount = 4;
    VkCommandBuffer commands[4];
    VK_CHECK(vkAllocateCommandBuffers(d, &allocate, commands));
    readbackCommands = commands[3];
    VkFenceCreateInfo fenceInfo{};
    fenceInfo.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
    VK_CHECK(vkCreateFence(d, &fenceInfo, nullptr, &fence));
    for (Wireframe mode : {Wireframe::None, Wireframe::Refined, Wireframe::Control}) {
        const std::size_t m = std::size_t(mode);
        if (!prepared[m]) continue;
        renderCommands[m] = commands[m];
        recordRender(renderCommands[m], mode);
    }

    // Readback: the render pass left the image in TRANSFER_SRC_OPTIMAL, its writes made
    // visible to transfers by the pass's outgoing dependency.
    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    VK_CHECK(vkBeginCommandBuffer(readbackCommands, &begin));
    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.imageExtent = {options.width, options.height, 1};
    vkCmdCopyImageToBuffer(readbackCommands, colour.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, readback.buffer, 1,
                           &region);
    bufferBarrier(readbackCommands, readback, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT,
                  VK_PIPELINE_STAGE_HOST_BIT, VK_ACCESS_HOST_READ_BIT);
    VK_CHECK(vkEndCommandBuffer(readbackCommands));
}

// One render pass: the surface, then the lines of `mode`.
void Renderer::Impl::recordRender(VkCommandBuffer commands, Wireframe mode) {
    const std::uint32_t lineCount = lineIndices[std::size_t(mode)];
    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    VK_CHECK(vkBeginCommandBuffer(commands, &begin));
    VkClearValue clears[3]{};
    toFloats(options.background, clears[0].color.float32);
    clears[1].depthStencil = {1.0f, 0};
    VkRenderPassBeginInfo pass{};
    pass.sType = VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO;
    pass.renderPass = renderPass;
    pass.framebuffer = framebuffer;
    pass.renderArea = {{0, 0}, {options.width, options.height}};
    pass.clearValueCount = 2;
    pass.pClearValues = clears;
    vkCmdBeginRenderPass(commands, &pass, VK_SUBPASS_CONTENTS_INLINE);
    vkCmdBindDescriptorSets(commands, VK_PIPELINE_BIND_POINT_GRAPHICS, pipelineLayout, 0, 1, &descriptorSet, 0,
                            nullptr);
    const VkDeviceSize zero[2] = {0, 0};
    if (triangleIndices) {
        const VkBuffer meshBuffers[2] = {drawnPositions, drawnNormals};
        vkCmdBindPipeline(commands, VK_PIPELINE_BIND_POINT_GRAPHICS, meshPipeline);
        if (textured)
            vkCmdBindVertexBuffers(commands, 0, 1, &corners.buffer, zero);
        else
            vkCmdBindVertexBuffers(commands, 0, 2, meshBuffers, zero);
        vkCmdBindIndexBuffer(commands, triangles.buffer, 0, VK_INDEX_TYPE_UINT32);
        vkCmdDrawIndexed(commands, triangleIndices, 1, 0, 0, 0);
    }
    if (lineCount) {
        const VkBuffer lineSource = mode == Wireframe::Control ? controlPositions.buffer : drawnPositions;
        vkCmdBindPipeline(commands, VK_PIPELINE_BIND_POINT_GRAPHICS, linePipeline);
        vkCmdBindVertexBuffers(commands, 0, 1, &lineSource, zero);
        vkCmdBindIndexBuffer(commands, lines[std::size_t(mode)].buffer, 0, VK_INDEX_TYPE_UINT32);
        vkCmdDrawIndexed(commands, lineCount, 1, 0, 0, 0);
    }
    vkCmdEndRenderPass(commands);
    VK_CHECK(vkEndCommandBuffer(commands));
}


void Renderer::Impl::writeUniforms(const Camera& camera) {
    FrameUniforms u{};
    std::memcpy(u.view, camera.view.data(), sizeof u.view);
    std::memcpy(u.projection, camera.projection.data(), sizeof u.projection);
    toFloats(options.surface, u.surfaceColour);
    toFloats(options.lines, u.lineColour);
    // The key light: from the upper left, in front (view space, towards the light).
    const float key[3] = {-0.45f, 0.65f, 0.61f};
    const float length = std::sqrt(key[0] * key[0] + key[1] * key[1] + key[2] * key[2]);
    for (int i = 0; i < 3; ++i) u.keyLight[i] = key[i] / length;
    u.params[0] = kLinePull;
    std::memcpy(u.baseColourFactor, baseColourFactor.data(), sizeof u.baseColourFactor);
    std::memcpy(uniforms.mapped, &u, sizeof u);
}

Renderer::Renderer(VulkanContext& context, Polygons surface, const RenderOptions& options, Polygons control,
                   const SurfaceTexture& texture)
    : impl_(std::make_unique<Impl>(contextInternals(context), options)) {
    impl_->build(surface, control, texture);
}

// The renderer of an evaluator's kept results: no vertex buffers of its own; the pipelines
// read the evaluator's buffers with their stride.
Renderer::Renderer(VulkanContext& context, const VulkanEvaluator& source, const RenderOptions& options, Polygons control)
    : impl_(std::make_unique<Impl>(contextInternals(context), options)) {
    if (source.deviceStride() != 4 || !source.keptNormals().buffer)
        throw std::invalid_argument("Renderer: the evaluator must have width 3 and normals to be drawn from");
    Impl& r = *impl_;
    r.drawsKept = true;
    r.vertexStride = 4 * source.deviceStride();
    r.drawnPositions = source.keptPositions().buffer;
    r.drawnNormals = source.keptNormals().buffer;
    r.build(polygonsOf(source.surface()), control, {});
}

Renderer::~Renderer() = default;

void Renderer::Impl::build(Polygons surface, Polygons control, const SurfaceTexture& surfaceTexture) {
    const VulkanContext::Impl& c = context;
    const std::uint32_t maxSize = c.properties.limits.maxImageDimension2D;
    if (options.width == 0 || options.height == 0 || options.width > maxSize || options.height > maxSize)
        throw std::invalid_argument("Renderer: image size " + std::to_string(options.width) + "x" +
                                    std::to_string(options.height) + " is outside 1.." + std::to_string(maxSize));
    checkPolygons(surface, "surface");
    checkPolygons(control, "control");
    if (!surfaceTexture.empty()) checkTexture(surfaceTexture, surface.vertexCount);
    if (options.wireframe == Wireframe::Control && control.offsets.size() < 2)
        throw std::invalid_argument("Renderer: Wireframe::Control needs the control faces");
    if (!queueHasGraphics(c))
        throw VulkanError(std::string("the Vulkan context's queue (family ") + std::to_string(c.queueFamily) + " of " +
                          c.properties.deviceName + ") cannot do graphics, which rendering needs");
    vertexCount = surface.vertexCount;
    controlVertexCount = control.vertexCount;
    wireframe = options.wireframe;
    prepared[std::size_t(wireframe)] = true;
    if (options.everyWireframe) {
        prepared[std::size_t(Wireframe::None)] = prepared[std::size_t(Wireframe::Refined)] = true;
        prepared[std::size_t(Wireframe::Control)] = control.offsets.size() >= 2;
    }
    samples = chooseSamples(c.properties.limits, std::max(1u, options.samples));
    options.samples = std::uint32_t(samples);
    textured = !surfaceTexture.empty();
    baseColourFactor = surfaceTexture.factor;
    createBuffers(surface, control, surfaceTexture);
    if (!drawsKept) drawnPositions = positions.buffer, drawnNormals = normals.buffer;
    if (textured) texture = render_detail::uploadTexture(context, *surfaceTexture.image);
    createImages();
    createDescriptors();
    createPipelines();
    recordCommands();
}

void Renderer::Impl::createPipelines() {
    meshPipeline = textured ? createPipeline(psub_spirv_render_textured_vert, psub_spirv_render_textured_frag,
                                             PipelineKind::Textured)
                            : createPipeline(psub_spirv_render_mesh_vert, psub_spirv_render_mesh_frag, PipelineKind::Mesh);
    linePipeline = createPipeline(psub_spirv_render_lines_vert, psub_spirv_render_lines_frag, PipelineKind::Lines);
}

void Renderer::Impl::renderAndReadBack(const Camera& camera, Clock::time_point start, Image& out) {
    writeUniforms(camera);
    const auto uploaded = Clock::now();
    submitAndWait(context, renderCommands[std::size_t(wireframe)], fence);
    const auto rendered = Clock::now();
    submitAndWait(context, readbackCommands, fence);
    const std::size_t bytes = 4 * std::size_t(options.width) * options.height;
    if (out.width != options.width || out.height != options.height || out.rgba.size() != bytes) {
        out.width = options.width, out.height = options.height;
        out.rgba.resize(bytes);
    }
    std::memcpy(out.rgba.data(), readback.mapped, bytes);
    times = {msBetween(start, uploaded), msBetween(uploaded, rendered), msBetween(rendered, Clock::now())};
}

void Renderer::drawKept(const Camera& camera, Image& out) {
    Impl& r = *impl_;
    if (!r.drawsKept) throw std::logic_error("Renderer::drawKept: this renderer draws host vertices (use draw)");
    r.renderAndReadBack(camera, Clock::now(), out);
}

const RenderOptions& Renderer::options() const { return impl_->options; }
DrawTimes Renderer::lastTimes() const { return impl_->times; }
std::uint32_t Renderer::triangleCount() const { return impl_->triangleIndices / 3; }
std::uint32_t Renderer::lineCount() const { return impl_->lineIndices[std::size_t(impl_->wireframe)] / 2; }

void Renderer::setWireframe(Wireframe wireframe) {
    if (!impl_->prepared[std::size_t(wireframe)])
        throw std::invalid_argument("Renderer::setWireframe: this renderer has no lines for that mode "
                                    "(needs options.everyWireframe, and control faces for Control)");
    impl_->wireframe = wireframe;
}

std::span<float> Renderer::mappedPositions() {
    Impl& r = *impl_;
    return r.drawsKept ? std::span<float>() : std::span<float>(static_cast<float*>(r.positions.mapped), 3 * std::size_t(r.vertexCount));
}

std::span<float> Renderer::mappedNormals() {
    Impl& r = *impl_;
    return r.drawsKept ? std::span<float>() : std::span<float>(static_cast<float*>(r.normals.mapped), 3 * std::size_t(r.vertexCount));
}

bool Renderer::verticesCached() const {
    const Impl& r = *impl_;
    return !r.drawsKept && (r.positions.flags & r.normals.flags & VK_MEMORY_PROPERTY_HOST_CACHED_BIT);
}

void Renderer::drawWritten(const Camera& camera, Image& out) {
    Impl& r = *impl_;
    if (r.drawsKept) throw std::logic_error("Renderer::drawWritten: this renderer draws an evaluator's buffers (use drawKept)");
    r.renderAndReadBack(camera, Clock::now(), out);
}

void Renderer::setControlPositions(std::span<const float> xyz) {
    Impl& r = *impl_;
    const std::size_t floats = 3 * std::size_t(r.controlVertexCount);
    assert(xyz.size() >= floats);
    if (r.controlPositions.mapped) std::memcpy(r.controlPositions.mapped, xyz.data(), std::min(floats, xyz.size()) * 4);
}

void Renderer::draw(std::span<const float> positions, std::span<const float> normals, const Camera& camera, Image& out) {
    Impl& r = *impl_;
    if (r.drawsKept)
        throw std::logic_error("Renderer::draw: this renderer draws an evaluator's buffers (use drawKept)");
    const std::size_t floats = 3 * std::size_t(r.vertexCount);
    assert(positions.size() >= floats && normals.size() >= floats);
    const auto start = Clock::now();
    std::memcpy(r.positions.mapped, positions.data(), std::min(floats, positions.size()) * 4);
    std::memcpy(r.normals.mapped, normals.data(), std::min(floats, normals.size()) * 4);
    r.renderAndReadBack(camera, start, out);
}

}  // namespace psub
