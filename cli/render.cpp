// psub render: load and check a mesh, refine it (P-S tables or OpenSubdiv's Catmull-Clark),
// evaluate positions and normals on the CPU or with Vulkan, draw it offscreen with
// psub::Renderer and write the PNG atomically. Also the subcommand's CLI11 definition.
#include "render.h"

#include "evaluators.h"
#include "options.h"

#include "psub/catmark.h"
#include "psub/evaluator.h"
#include "psub/stencils.h"
#include "psub/vulkan_evaluator.h"

#include <CLI/CLI.hpp>

#include <algorithm>
#include <cmath>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <map>
#include <optional>
#include <vector>

namespace psub::cli {
namespace {

// Beyond this many refined faces the picture is refused (memory, and lavapipe's patience).
constexpr double kMaxFaces = 32.0 * 1024 * 1024;

const std::map<std::string, TableForm> kRenderForms = {{"tiled", TableForm::Tiled}, {"per-level", TableForm::PerLevel}};

const std::map<std::string, Wireframe> kWireframe = {
    {"none", Wireframe::None}, {"refined", Wireframe::Refined}, {"control", Wireframe::Control}};

// Throws InputError when the refined surface would have more than kMaxFaces faces.
void guardFaces(const Mesh& mesh, const Connectivity& connectivity, const RenderCommandOptions& o) {
    auto faces = [&](int levels) {
        if (o.scheme == Scheme::CatmullClark)  // level 1: one quad per corner, then 4x per level
            return levels == 0 ? double(mesh.faces.faceCount())
                               : double(mesh.faces.verts.size()) * std::pow(4.0, levels - 1);
        const bool preprocess = needsPreprocessing(mesh.faces, connectivity, Preprocess::Auto);
        return double(countsAfterSteps(countMesh(mesh.faces, connectivity), levels + (preprocess ? 1 : 0)).faces);
    };
    if (faces(o.levels) <= kMaxFaces) return;
    int most = 0;
    while (most + 1 < o.levels && faces(most + 1) <= kMaxFaces) ++most;
    throw InputError(mesh.source.path + ": --levels " + std::to_string(o.levels) + " would draw " +
                     std::to_string(std::uint64_t(faces(o.levels))) + " faces (limit " +
                     std::to_string(std::uint64_t(kMaxFaces)) + "); --levels " + std::to_string(most) +
                     " is the most that fits");
}

// Positions (from `control`, on the chosen backend) and normals of `tables`' surface for
// `form` (the tiled form's in its drawing order).
void evaluate(VulkanContext& context, Backend backend, const EvaluatorTables& tables, TableForm form,
              std::span<const float> control, Drawable& d) {
    const std::unique_ptr<Evaluator> evaluator =
        makeEvaluator(backend, tables, form, backend == Backend::Vulkan ? &context : nullptr);
    d.positions.resize(3 * std::size_t(evaluator->refinedCount()));
    d.normals.resize(d.positions.size());
    evaluator->evaluate(control, d.positions, d.normals);
    d.what += backend == Backend::Vulkan ? "; evaluated with Vulkan" : "; evaluated on the CPU";
}

}  // namespace

Drawable drawablePS(VulkanContext& context, Backend backend, const Mesh& mesh, const CheckedMesh& checked, int levels,
                    Rules rules, TableForm form) {
    RefineOptions options;
    options.levels = levels;
    options.rules = rules;
    options.tiled = form == TableForm::Tiled;
    options.perLevel = form != TableForm::Tiled;  // the tiled form alone: the lean build
    options.canonicalOrder = false;               // drawn, never written in canonical order
    Refinement r = refine(mesh, checked.connectivity, options);
    Drawable d;
    d.what = "P-S, " + std::to_string(levels) + (levels == 1 ? " step" : " steps");
    if (rules != Rules::Paper) d.what += rules == Rules::Robust ? ", robust rules" : ", shape rules";
    if (form == TableForm::Tiled) d.what += ", tiled form";
    const std::vector<float> control(mesh.positions.begin(), mesh.positions.end());
    evaluate(context, backend, tablesOf(r), form, control, d);
    requireFinite(d.positions, mesh.source.path, "refined");
    requireFinite(d.normals, mesh.source.path, "refined normal of");
    d.uv = std::move(r.uv);
    if (form == TableForm::Tiled) {
        d.surface = std::move(r.tiled.surface);
        d.tiled = std::move(r.tiled);
    } else {
        d.surface = std::move(r.surface);
    }
    return d;
}

// OpenSubdiv refines the positions; normals come from a table of no levels over its faces.
Drawable drawableCC(VulkanContext& context, Backend backend, const Mesh& mesh, int levels) {
    std::vector<CatmarkLevel> refined = refineCatmark(mesh.faces, mesh.positions, levels);
    CatmarkLevel& finest = refined.back();
    Drawable d;
    d.surface = buildSurfaceTable(std::move(finest.faces));
    d.what = "Catmull-Clark (OpenSubdiv), " + std::to_string(levels) + (levels == 1 ? " level" : " levels");
    PerLevelTable identity;
    identity.controlCount = d.surface.vertexCount;
    const FactorizedTable none;
    const TiledTable noTiles;
    const std::vector<float> positions(finest.positions.begin(), finest.positions.end());
    evaluate(context, backend, {identity, none, d.surface, noTiles}, TableForm::PerLevel, positions, d);
    requireFinite(d.positions, mesh.source.path, "refined");
    requireFinite(d.normals, mesh.source.path, "refined normal of");
    return d;
}

SurfaceTexture TextureData::surfaceTexture() const {
    SurfaceTexture t;
    t.faceOffsets = faceOffsets, t.faceVerts = faceVerts, t.faceValues = faceValues;
    t.uv = uv;
    t.image = &image;
    t.factor = factor;
    return t;
}

std::optional<MaterialTexture> materialTexture(const Mesh& mesh, const std::optional<GltfMaterial>& material) {
    if (!material || !material->baseColorTexture) return std::nullopt;
    const GltfImage& source = *material->baseColorTexture;
    std::string image = "base colour image " + std::to_string(source.index);
    if (!source.name.empty()) image += " '" + source.name + "'";
    std::string owner = "material";
    if (!material->name.empty()) owner += " '" + material->name + "'";
    MaterialTexture t;
    try {
        t.image = decodeImage(std::span<const std::uint8_t>(source.bytes.data(), source.bytes.size()),
                              mesh.source.path + ": " + owner + ": " + image);
    } catch (const std::runtime_error& e) {
        throw InputError(e.what());
    }
    if (mesh.uv.empty()) {
        std::fprintf(stderr, "psub: warning: %s: %s: the %s is not drawn: the mesh has no TEXCOORD_0\n",
                     mesh.source.path.c_str(), owner.c_str(), image.c_str());
        return std::nullopt;
    }
    for (std::size_t k = 0; k < 4; ++k) t.factor[k] = float(material->baseColorFactor[k]);
    t.label = "the " + image + " of " + owner;
    return t;
}

std::optional<Rgba> materialColour(const std::optional<GltfMaterial>& material) {
    if (!material || material->baseColorTexture) return std::nullopt;
    const std::array<double, 4>& f = material->baseColorFactor;
    if (f[0] == 1 && f[1] == 1 && f[2] == 1) return std::nullopt;
    const auto byte = [](double x) { return std::uint8_t(std::lround(255 * std::clamp(x, 0.0, 1.0))); };
    return Rgba{byte(f[0]), byte(f[1]), byte(f[2]), 255};
}

Image readTextureImage(const std::string& imagePath) {
    try {
        return readImage(imagePath);
    } catch (const std::runtime_error& e) {
        throw InputError(e.what());
    }
}

void requireUvs(const Mesh& mesh) {
    if (mesh.uv.empty())
        throw InputError(mesh.source.path + ": --texture needs texture coordinates (OBJ `vt` and `f v/vt`, glTF "
                         "TEXCOORD_0) and this mesh has none");
}

TextureData textureData(Image image, const Mesh& mesh, const FaceVaryingTable& table, const TiledTable* drawing) {
    requireUvs(mesh);
    if (table.empty() || table.width != 2 || mesh.uv.width != 2 || (drawing && drawing->uvFaceVerts.empty()))
        throw InputError(mesh.source.path + ": --texture: the refinement produced no UVs for this mesh");
    TextureData t;
    t.image = std::move(image);
    if (drawing) t.faceOffsets = drawing->uvFaceOffsets, t.faceVerts = drawing->uvFaceVerts, t.faceValues = drawing->uvFaceValues;
    else t.faceOffsets = table.faceOffsets, t.faceVerts = table.faceVerts, t.faceValues = table.faceValues;
    const std::vector<float> control(mesh.uv.values.begin(), mesh.uv.values.end());
    t.uv.resize(2 * std::size_t(table.valueCount()));
    evaluateFaceVarying<float>(table, control, t.uv);
    std::string extension = std::filesystem::path(mesh.source.path).extension().string();
    std::transform(extension.begin(), extension.end(), extension.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    if (extension == ".obj")  // OBJ's v runs up from the image's bottom row; the renderer's down from the top
        for (std::size_t i = 1; i < t.uv.size(); i += 2) t.uv[i] = 1.0f - t.uv[i];
    for (std::size_t i = 0; i < t.uv.size(); ++i)
        if (!std::isfinite(t.uv[i]))
            throw InputError(mesh.source.path + ": refined UV " + std::to_string(i / 2 + 1) + " is not finite");
    return t;
}

namespace {

double median(std::vector<double> values) {
    std::sort(values.begin(), values.end());
    return values.empty() ? 0.0 : values[values.size() / 2];
}

int drawAndWrite(VulkanContext& context, const RenderCommandOptions& o, const Mesh& mesh, const Drawable& d,
                 const TextureData* texture, const std::string& textureLabel, std::optional<Rgba> colour) {
    RenderOptions ro;
    ro.width = o.width, ro.height = o.height, ro.wireframe = o.wireframe, ro.samples = o.samples;
    if (colour) ro.surface = *colour;
    const Polygons control{mesh.faces.vertexCount, mesh.faces.offsets, mesh.faces.verts};
    Renderer renderer(context, polygonsOf(d.surface), ro, control,
                      texture ? texture->surfaceTexture() : SurfaceTexture{});
    const std::vector<float> controlPositions(mesh.positions.begin(), mesh.positions.end());
    if (o.wireframe == Wireframe::Control) renderer.setControlPositions(controlPositions);
    // What is drawn fills the picture: the surface, and the cage when it is drawn.
    Box box;
    box.extend(d.positions);
    if (o.wireframe == Wireframe::Control) box.extend(controlPositions);
    const Camera camera = frameBox(box, float(o.width) / float(o.height));
    Image image;
    std::vector<double> renderMs, readbackMs;
    for (int frame = 0; frame < o.frames; ++frame) {
        renderer.draw(d.positions, d.normals, camera, image);
        renderMs.push_back(renderer.lastTimes().renderMs);
        readbackMs.push_back(renderer.lastTimes().readbackMs);
    }
    writePng(o.output, image);
    // The summary goes to stderr when the PNG itself went to standard output (-o -).
    std::fprintf(o.output == "-" ? stderr : stdout, "%s: %ux%u, %u faces (%s%s), %u triangles%s on %s: render %.2f ms, readback %.2f ms%s\n",
                o.output.c_str(), o.width, o.height, std::uint32_t(d.surface.faceOffsets.size() - 1), d.what.c_str(),
                texture ? ("; textured with " + textureLabel).c_str() : "",
                renderer.triangleCount(),
                renderer.lineCount() ? (" + " + std::to_string(renderer.lineCount()) + " lines").c_str() : "",
                context.deviceName().c_str(), median(renderMs), median(readbackMs),
                o.frames > 1 ? (" (median of " + std::to_string(o.frames) + " draws)").c_str() : "");
    return 0;
}

}  // namespace

CLI::App* addRenderCommand(CLI::App& app, RenderCommandOptions& o) {
    CLI::App* re = app.add_subcommand("render", "Draw a refined mesh offscreen with Vulkan into a PNG");
    re->add_option("input", o.input, "input mesh (.obj, or .gltf / .glb in its static pose)")->required();
    re->add_option("-o,--output", o.output, "output image (.png), written atomically; - for standard output")->required();
    addInteger(re, "-l,--levels", o.levels, 0, 30, "refinement steps (P-S) or levels (--scheme cc)", 4);
    addChoice(re, "--scheme", o.scheme, kSchemeNames, "ps: P-S; cc: Catmull-Clark through OpenSubdiv", "ps");
    addChoice(re, "--rules", o.rules, kRulesNames, "P-S rules: paper, robust or shape (both beyond the paper; --scheme ps only)",
              "paper");
    addChoice(re, "--form", o.form, kRenderForms,
              "P-S table form: per-level (every level's rows; canonical vertex order) or tiled (regular tiles "
              "where the mesh has them, rows elsewhere; its own vertex order). The same surface within float "
              "rounding; per-level is the quicker for one picture, tiled the quicker per frame (psub play)",
              "per-level");
    addChoice(re, "--wireframe", o.wireframe, kWireframe,
              "none; refined: the refined faces' edges; control: the input faces' edges (the cage)", "none");
    addSize(re, "--size", o.width, o.height, "image size in pixels", 1, "1280x720");
    addSamples(re, o.samples);
    addChoice(re, "--backend", o.backend, kCpuOrVulkan,
              "where positions and normals are evaluated: cpu or vulkan (drawing is always Vulkan)", "cpu");
    addInteger(re, "--frames", o.frames, 1, 10000, "draw this many times and report the median render and readback times", 1);
    re->add_option("--texture", o.texture,
                   "base-colour image (.png or .jpg) sampled with the mesh's refined UVs (OBJ vt, glTF TEXCOORD_0; "
                   "--scheme ps); overrides a glTF material's texture");
    re->footer("Needs a Vulkan device (Mesa's lavapipe will do; no display). The camera looks from the front,\n"
               "a bit right and above, and frames what is drawn (the surface, and the cage with\n"
               "--wireframe control).\n"
               "Textures: --texture IMAGE colours the surface with IMAGE (PNG or JPEG, mip-mapped, repeated\n"
               "outside [0, 1]) at the mesh's UVs, refined with the positions; each face keeps the UVs of its\n"
               "own island, so seams do not smear. A mesh without UVs is refused; an OBJ with UVs and no\n"
               "--texture is drawn in one colour. A glTF whose material has a base colour texture (PNG or\n"
               "JPEG, embedded or external) is drawn with it and its factor, unless --texture is given; one\n"
               "with a factor and no texture is drawn in the factor's colour.\n"
               "Examples:\n  psub render data/cube.obj -o cube.png --levels 4\n"
               "  psub render data/spot_control_mesh.obj -o spot.png --levels 4 --wireframe control --size 800x800\n"
               "  psub render data/cow.obj -o cow_cc.png --levels 2 --scheme cc --wireframe refined\n"
               "  psub render data/spot_control_mesh_uv.obj -o spot.png --levels 6 --texture data/spot_texture.png\n"
               "  psub render data/CesiumMan.glb -o cesium.png --levels 3 --size 480x480");
    return re;
}

int runRender(const RenderCommandOptions& o) {
    if (!o.texture.empty() && o.scheme != Scheme::PS) {
        std::fprintf(stderr, "psub render: --texture applies to --scheme ps only\n");
        return 2;
    }
    const Loaded loaded = load(o.input);  // OBJ, or a glTF cage in its static pose
    const Mesh& mesh = loaded.mesh;
    const CheckedMesh& checked = loaded.checked;
    checkCoordinateRange(mesh, Precision::Float);
    guardFaces(mesh, checked.connectivity, o);
    Image image;
    std::array<float, 4> factor{1.0f, 1.0f, 1.0f, 1.0f};
    std::string textureLabel;
    if (!o.texture.empty()) {
        image = readTextureImage(o.texture);
        requireUvs(mesh);
        textureLabel = o.texture;
    } else if (o.scheme == Scheme::PS) {
        if (std::optional<MaterialTexture> material = materialTexture(mesh, loaded.material)) {
            image = std::move(material->image);
            factor = material->factor;
            textureLabel = material->label;
        }
    }
    try {
        VulkanContext context;
        const Drawable d = o.scheme == Scheme::PS ? drawablePS(context, o.backend, mesh, checked, o.levels, o.rules, o.form)
                                                  : drawableCC(context, o.backend, mesh, o.levels);
        std::optional<TextureData> texture;
        if (!textureLabel.empty()) {
            texture = textureData(std::move(image), mesh, d.uv, d.tiled.refinedCount ? &d.tiled : nullptr);
            texture->factor = factor;
        }
        // Untextured: a glTF material's base colour factor, when it has one (materialColour).
        const std::optional<Rgba> colour = texture ? std::nullopt : materialColour(loaded.material);
        return drawAndWrite(context, o, mesh, d, texture ? &*texture : nullptr, textureLabel, colour);
    } catch (const VulkanError& e) {
        std::fprintf(stderr, "psub: error: render: %s\n", e.what());
    } catch (const InputError&) {
        throw;
    } catch (const std::runtime_error& e) {  // the PNG could not be written
        std::fprintf(stderr, "psub: error: %s\n", e.what());
    }
    return 1;
}

}  // namespace psub::cli
