// psub/render.h: offscreen pictures of refined surfaces with Vulkan (no window, no display;
// Mesa's lavapipe is enough): a renderer built once per surface and a camera that frames a
// box; the images it draws into are psub/image.h's. Link psub::render. Reads face lists only,
// never topology. No Vulkan types here.
#pragma once

#include "psub/image.h"
#include "psub/tables.h"
#include "psub/vulkan_evaluator.h"

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace psub {

// An axis-aligned box; empty until extended.
struct Box {
    std::array<float, 3> min{1e30f, 1e30f, 1e30f}, max{-1e30f, -1e30f, -1e30f};

    // Grows the box over xyz triples (a multiple of 3 floats).
    void extend(std::span<const float> xyz);
    bool empty() const { return min[0] > max[0]; }
};

// A perspective camera. Matrices are column-major (GLM's and GLSL's order) and map world
// points straight to Vulkan clip space: a point p lands at ndc = (clip.xyz / clip.w) with
// clip = viewProjection * (p, 1); pixel x = (ndc.x + 1) / 2 * width, pixel y = (ndc.y + 1)
// / 2 * height counted from the top row; depth ndc.z in [0, 1].
struct Camera {
    std::array<float, 16> view{}, projection{}, viewProjection{};
    std::array<float, 3> eye{}, target{};
    float verticalFovDegrees = 30;
};

// The default viewing direction (from the target towards the eye): in front (+z), a bit to
// the right (+x) and above (+y).
inline constexpr std::array<float, 3> kFrontRightAbove{0.45f, 0.35f, 1.0f};

// Frames the box [min, max] (a point or an empty box gets a unit-sized neighbourhood) for
// images of width/height `aspect`, looking along -`towardsEye` (any length, not parallel to
// y), y up. The whole box is in view; the same camera for several meshes keeps their sizes
// comparable.
Camera frameBox(std::array<float, 3> min, std::array<float, 3> max, float aspect,
                std::array<float, 3> towardsEye = kFrontRightAbove);
inline Camera frameBox(const Box& box, float aspect, std::array<float, 3> towardsEye = kFrontRightAbove) {
    return frameBox(box.min, box.max, aspect, towardsEye);
}

// A camera at `eye` looking at `target`, y up, with frameBox's field of view; the near and far
// planes hold the sphere of `radius` around `target` (for interactive orbit, zoom and pan).
// frameBox(...) is lookAt(its eye, the box centre, the framed radius, aspect).
Camera lookAt(std::array<float, 3> eye, std::array<float, 3> target, float radius, float aspect);

// Polygons as CSR arrays: face f has the corners verts[offsets[f] .. offsets[f + 1]),
// counter-clockwise; corners index vertices 0 .. vertexCount - 1. Faces with fewer than 3
// corners are skipped. The arrays need only live through the renderer's constructor.
struct Polygons {
    std::uint32_t vertexCount = 0;
    std::span<const std::uint32_t> offsets, verts;
};
inline Polygons polygonsOf(const SurfaceTable& surface) {
    return {surface.vertexCount, surface.faceOffsets, surface.faceVerts};
}

// A base-colour texture on the surface. The faces here are the ones drawn (instead of the
// Renderer's surface faces, which still give the vertex count and the refined wireframe):
// CSR polygons over the surface vertices with a UV per corner, as a face-varying table's
// finest faces (psub/tables.h FaceVaryingTable: faceOffsets, faceVerts, faceValues), so a
// face at a seam has the UVs of its own island. uv: 2 floats per value, glTF's convention
// (u right, v down: v = 0 is the image's top row; an OBJ `vt` v is 1 - this), repeating
// outside [0, 1]. Colour = image (mip-mapped, filtered linearly) * factor, then lit as the
// untextured surface is. The spans and the image need only live through the constructor.
struct SurfaceTexture {
    std::span<const std::uint32_t> faceOffsets, faceVerts, faceValues;
    std::span<const float> uv;
    const Image* image = nullptr;                   // RGBA, values meant as sRGB (as PNG/JPEG hold them)
    std::array<float, 4> factor{1.0f, 1.0f, 1.0f, 1.0f};  // glTF's baseColorFactor

    bool empty() const { return image == nullptr; }
};

enum class Wireframe {
    None,
    Refined,  // the refined faces' edges over the surface
    Control,  // the control faces' edges (their own positions: setControlPositions)
};

struct RenderOptions {
    std::uint32_t width = 1280, height = 720;  // 1 .. the device's maxImageDimension2D
    Wireframe wireframe = Wireframe::None;
    std::uint32_t samples = 4;  // MSAA samples per pixel (1, 2, 4 or 8; lowered to what the device has)
    Rgba background{255, 255, 255, 255};
    Rgba surface{170, 190, 215, 255};
    Rgba lines{25, 25, 35, 255};
    // Lines for every Wireframe mode are made up front (the refined edges, and the control
    // edges when control faces are given), so setWireframe() switches without creating
    // anything; costs an index buffer of 8 bytes per refined edge (about 16 bytes per face).
    bool everyWireframe = false;
    // Host-vertex renderers: put the persistently mapped vertex buffers in host-visible,
    // coherent and host-cached memory where the device has such a type (a caller that writes
    // them itself and reads them back, psub view's CPU path); verticesCached() says if it did.
    bool cachedVertices = false;
};

// Milliseconds of the last draw: copying positions and normals into the mapped vertex
// buffers, rendering (submit to fence), and reading back (copy to the host buffer, fence,
// copy into the caller's image).
struct DrawTimes {
    double uploadMs = 0, renderMs = 0, readbackMs = 0;
    double totalMs() const { return uploadMs + renderMs + readbackMs; }
};

// Draws one surface again and again. Everything is created here: graphics pipelines (shaded
// surface: headlight + key light, Lambert on per-vertex normals, two-sided, of a flat colour or
// a texture; the textured faces pull positions and normals by index from storage buffers, so
// their corners' UVs stay on the device and a frame uploads only positions and normals; lines drawn over
// it pulled slightly towards the eye), colour and depth images, vertex, index and readback
// buffers, pre-recorded command buffers (a render pass per wireframe mode prepared, a
// read-back) and a fence. A draw allocates nothing and
// creates nothing. Needs a context whose queue can do graphics (lavapipe's can; on devices
// where the context picked a compute-only queue family it throws VulkanError). Must not
// outlive the context; not thread-safe.
class Renderer {
public:
    // surface: the faces drawn (triangulated as fans). control: the control faces, used only
    // for Wireframe::Control (required then). texture: when not empty, its faces are drawn
    // textured (the image is uploaded once, with its full mip chain). Throws
    // std::invalid_argument for inconsistent polygons, UVs or options, VulkanError on device
    // failure or limits (an image larger than the device's maxImageDimension2D).
    Renderer(VulkanContext& context, Polygons surface, const RenderOptions& options, Polygons control = {},
             const SurfaceTexture& texture = {});
    // Draws straight from `source`'s device buffers (keptPositions, keptNormals, after
    // source.evaluateKept(control, true)) with drawKept(): no upload, no read-back of vertices.
    // `source` must be on `context`, have normals, and outlive the renderer; its surface() is
    // the face list drawn. Untextured.
    Renderer(VulkanContext& context, const VulkanEvaluator& source, const RenderOptions& options,
             Polygons control = {});
    ~Renderer();
    Renderer(const Renderer&) = delete;
    Renderer& operator=(const Renderer&) = delete;

    const RenderOptions& options() const;

    // The control cage's positions (3 floats per control vertex) for the following draws.
    void setControlPositions(std::span<const float> xyz);

    // One frame: positions and normals (3 floats per surface vertex each; normals need not be
    // unit length) seen through `camera`, into `out` (resized only when its size differs, so
    // a caller that keeps `out` allocates once).
    void draw(std::span<const float> positions, std::span<const float> normals, const Camera& camera, Image& out);

    // The persistently mapped vertex buffers draw() copies into (3 floats per surface vertex
    // each; empty for a renderer of an evaluator's buffers). A caller may write them itself
    // and call drawWritten(): the same picture as draw() of the same values, one copy less.
    // Not while a draw runs.
    std::span<float> mappedPositions();
    std::span<float> mappedNormals();
    // True when both live in host-cached memory (reading them back is fast).
    bool verticesCached() const;
    // One frame of what mappedPositions() and mappedNormals() hold now.
    void drawWritten(const Camera& camera, Image& out);

    // The wireframe of the following draws: options().wireframe, or with everyWireframe any
    // mode (Control only when control faces were given); std::invalid_argument otherwise.
    void setWireframe(Wireframe wireframe);

    // One frame from the evaluator given to the constructor, as it was left by its last
    // evaluateKept(control, true) (std::logic_error for a renderer of host vertices).
    void drawKept(const Camera& camera, Image& out);

    DrawTimes lastTimes() const;
    // Triangles and line segments drawn per frame (the lines of the current wireframe).
    std::uint32_t triangleCount() const;
    std::uint32_t lineCount() const;

    struct Impl;

private:
    std::unique_ptr<Impl> impl_;
};

}  // namespace psub
