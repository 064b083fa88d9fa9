// psub render: a refined mesh drawn offscreen with Vulkan into a PNG (psub_render). Its
// options, its CLI11 subcommand, and the command itself; main.cpp only registers it.
#pragma once

#include "commands.h"

#include "psub/evaluator.h"
#include "psub/render.h"
#include "psub/tiled.h"

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace CLI {
class App;
}

namespace psub::cli {

struct RenderCommandOptions {
    std::string input, output;
    int levels = 4;
    Scheme scheme = Scheme::PS;
    Rules rules = Rules::Paper;  // --scheme ps only
    Wireframe wireframe = Wireframe::None;
    std::uint32_t width = 1280, height = 720;
    Backend backend = Backend::Cpu;  // where the surface is evaluated: Cpu or Vulkan
    int frames = 1;                  // draws timed (the last one is written)
    std::uint32_t samples = 4;       // MSAA samples per pixel
    std::string texture;             // base-colour image (.png, .jpg) sampled with the mesh's UVs
                                     // (overrides a glTF material's texture)
    TableForm form = TableForm::PerLevel;  // --scheme ps: PerLevel or Tiled (its lean build, drawing order)
};

// A refined surface with positions and normals, ready to draw.
struct Drawable {
    SurfaceTable surface;
    std::vector<float> positions, normals;
    std::string what;  // "P-S, 4 steps" and where it was evaluated
    FaceVaryingTable uv;  // the refined UVs' table (P-S; empty when the mesh has none)
    // The tiled form's table when `surface` and the positions are in its drawing order (P-S
    // with TableForm::Tiled; its uvFace... name the textured faces), else empty.
    TiledTable tiled;
};

// A base-colour texture ready for the Renderer: the image and the refined UVs per corner of
// the finest faces (psub::SurfaceTexture points into this and into the faces' table; keep both
// alive through the Renderer's constructor).
struct TextureData {
    Image image;
    std::vector<float> uv;  // 2 floats per refined UV value, glTF's convention (v down)
    // The faces drawn: the channel's (canonical order) or the tiled form's (drawing order).
    std::span<const std::uint32_t> faceOffsets, faceVerts, faceValues;
    std::array<float, 4> factor{1.0f, 1.0f, 1.0f, 1.0f};  // glTF's baseColorFactor

    SurfaceTexture surfaceTexture() const;
};

// A glTF material's base colour texture, decoded, with its factor.
struct MaterialTexture {
    Image image;
    std::array<float, 4> factor{1.0f, 1.0f, 1.0f, 1.0f};
    std::string label;  // "the base colour image 0 'I' of material 'M'", for summaries
};

// The base colour texture of `material` (the glTF material of `mesh`), decoded; nullopt when
// there is none, or (after a warning on stderr) when `mesh` has no UVs to sample it with.
// InputError naming the mesh's file, the material and the image when the image is broken.
std::optional<MaterialTexture> materialTexture(const Mesh& mesh, const std::optional<GltfMaterial>& material);

// The flat colour of a glTF material drawn without a texture: its baseColorFactor's red, green
// and blue (what the textured path gives for a white texture: factor x texture), rounded to
// bytes; nullopt without a material, with a base colour texture, or when the factor is glTF's
// default white (1, 1, 1) (absent and white cannot be told apart once read), which keeps the
// renderer's default colour. Alpha is not drawn (the textured path ignores it too).
std::optional<Rgba> materialColour(const std::optional<GltfMaterial>& material);

// Reads the image at `imagePath` (PNG or JPEG). InputError naming the file when it is missing
// or broken.
Image readTextureImage(const std::string& imagePath);

// InputError naming the mesh's file when it has no UVs for --texture.
void requireUvs(const Mesh& mesh);

// The image and `mesh`'s UVs refined through `table`; an OBJ's `vt` (v up) becomes v down.
// The faces are the table's (over canonical positions) or, with `drawing`, the tiled form's
// (TiledTable::uvFace..., over its drawing positions; the UVs are the same values).
// InputError naming the mesh's file when it has no UVs (or `table` is empty).
TextureData textureData(Image image, const Mesh& mesh, const FaceVaryingTable& table,
                        const TiledTable* drawing = nullptr);

// P-S after `levels` steps (after the paired method when needed) of a checked mesh with
// `rules`, evaluated on `backend` (Cpu or Vulkan on `context`) through `form`: PerLevel builds
// the per-level table and draws in the canonical order; Tiled builds the tiled form alone (the
// lean build) and draws in its drawing order.
Drawable drawablePS(VulkanContext& context, Backend backend, const Mesh& mesh, const CheckedMesh& checked, int levels,
                    Rules rules = Rules::Paper, TableForm form = TableForm::PerLevel);

// OpenSubdiv's Catmull-Clark after `levels` levels (0: the mesh itself), normals on `backend`.
Drawable drawableCC(VulkanContext& context, Backend backend, const Mesh& mesh, int levels);

// Adds `psub render` to `app`, parsing into `options`; returns the subcommand.
CLI::App* addRenderCommand(CLI::App& app, RenderCommandOptions& options);

// Returns the exit status: 0, or 1 with one line on stderr (no Vulkan device, unwritable
// output). Bad input throws InputError (exit 1 in main).
int runRender(const RenderCommandOptions& options);

}  // namespace psub::cli
