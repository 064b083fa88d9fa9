// glTF texture coordinates, materials and touching shells in (readGltf), glTF out
// (formatGltf, checked by the Khronos validator), and psub subdivide's glTF path (--at).
#include "gltf_models.h"
#include "test_support.h"

#include "psub/animation.h"
#include "psub/stencils.h"

#include <nlohmann/json.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <map>

using namespace psub;
using namespace psub::test;

namespace {

// A 2 x 1 RGB PNG (valid: the validator reads its header).
const std::vector<unsigned char> kPng = {
    0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a, 0x00, 0x00, 0x00, 0x0d, 0x49, 0x48, 0x44, 0x52, 0x00, 0x00,
    0x00, 0x02, 0x00, 0x00, 0x00, 0x01, 0x08, 0x02, 0x00, 0x00, 0x00, 0x7b, 0x40, 0xe8, 0xdd, 0x00, 0x00, 0x00,
    0x0f, 0x49, 0x44, 0x41, 0x54, 0x78, 0x9c, 0x63, 0xf8, 0xdf, 0xc0, 0xc0, 0xd0, 0xf0, 0x1f, 0x00, 0x0a, 0x80,
    0x02, 0xff, 0x94, 0x37, 0xd4, 0xae, 0x00, 0x00, 0x00, 0x00, 0x49, 0x45, 0x4e, 0x44, 0xae, 0x42, 0x60, 0x82};

// Two triangles over the unit square, split along the diagonal 0-2 as a UV seam: the second
// triangle has its own copies of vertices 0 and 2 with other UVs (6 glTF vertices, 4 positions).
struct SeamSquare {
    ModelBuilder builder;
    int uvAccessor = -1;
};

SeamSquare makeSeamSquare(const std::vector<float>& uvs) {
    SeamSquare square;
    ModelBuilder& b = square.builder;
    const std::vector<float> positions = {0, 0, 0, 1, 0, 0, 1, 1, 0, /**/ 0, 0, 0, 1, 1, 0, 0, 1, 0};
    tinygltf::Primitive primitive;
    primitive.mode = TINYGLTF_MODE_TRIANGLES;
    primitive.attributes["POSITION"] = b.positions(positions);
    square.uvAccessor = b.attribute(uvs, TINYGLTF_TYPE_VEC2, 2);
    primitive.attributes["TEXCOORD_0"] = square.uvAccessor;
    primitive.indices = b.indices({0, 1, 2, 3, 4, 5});
    tinygltf::Mesh mesh;
    mesh.primitives.push_back(primitive);
    b.model.meshes.push_back(mesh);
    tinygltf::Node node;
    node.mesh = 0;
    b.model.nodes.push_back(node);
    tinygltf::Scene scene;
    scene.nodes = {0};
    b.model.scenes.push_back(scene);
    b.model.defaultScene = 0;
    return square;
}

const std::vector<float> kSeamUvs = {0, 0, 0.5f, 0, 0.5f, 0.5f, /**/ 0.6f, 0.6f, 1, 1, 0.6f, 1};

// Adds a material with base colour factor and a texture whose image is `image` (its bytes in
// a buffer view when `inBuffer`).
void addTexturedMaterial(ModelBuilder& b, const std::vector<unsigned char>& image) {
    tinygltf::Image gltfImage;
    gltfImage.name = "checker";
    gltfImage.mimeType = "image/png";
    gltfImage.bufferView = b.view(image.data(), image.size());
    b.model.images.push_back(gltfImage);
    tinygltf::Sampler sampler;
    sampler.wrapS = TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE;
    sampler.wrapT = TINYGLTF_TEXTURE_WRAP_MIRRORED_REPEAT;
    sampler.magFilter = TINYGLTF_TEXTURE_FILTER_NEAREST;
    b.model.samplers.push_back(sampler);
    tinygltf::Texture texture;
    texture.source = 0;
    texture.sampler = 0;
    b.model.textures.push_back(texture);
    tinygltf::Material material;
    material.name = "skin";
    material.pbrMetallicRoughness.baseColorFactor = {0.5, 0.25, 1, 1};
    material.pbrMetallicRoughness.baseColorTexture.index = 0;
    b.model.materials.push_back(material);
    for (auto& primitive : b.model.meshes[0].primitives) primitive.material = 0;
}

// A closed axis-aligned box [lo, lo + 1]^3 as 12 outward triangles appended to `positions`
// and `indices`.
void addBox(std::array<float, 3> lo, std::vector<float>& positions, std::vector<std::uint32_t>& indices) {
    const std::uint32_t first = std::uint32_t(positions.size() / 3);
    for (int v = 0; v < 8; ++v)
        positions.insert(positions.end(), {lo[0] + float(v & 1), lo[1] + float((v >> 1) & 1), lo[2] + float((v >> 2) & 1)});
    const std::uint32_t quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
    for (const auto& q : quads)
        indices.insert(indices.end(), {first + q[0], first + q[1], first + q[2], first + q[0], first + q[2], first + q[3]});
}

class GltfIo : public ::testing::Test {
protected:
    fs::path path(const std::string& name) const { return dir_ / name; }
    std::string write(const tinygltf::Model& model, const std::string& name) {
        const std::string file = path(name).string();
        EXPECT_TRUE(writeGltf(model, file, name.ends_with(".glb"))) << file;
        return file;
    }
    // Replaces images[0] of the .gltf at `file` by `image` (JSON).
    void setImage(const std::string& file, const nlohmann::json& image) {
        nlohmann::json json = nlohmann::json::parse(readFile(file));
        json["images"][0] = image;
        writeFile(file, json.dump());
    }
    void expectError(const std::string& file, const std::vector<std::string>& parts) {
        const std::string message = inputErrorOf([&] { readGltf(file); });
        EXPECT_TRUE(contains(message, file + ": ")) << message;
        for (const std::string& part : parts) EXPECT_TRUE(contains(message, part)) << message << " / " << part;
    }
    ScratchDir dir_;
};

// The Khronos validator's verdict on `files` (exit status 0: no error and no warning).
int validate(const std::vector<std::string>& files, std::string& report) {
    std::string command = "'" PSUB_NODE "' '" PSUB_VALIDATOR "'";
    for (const std::string& file : files) command += " '" + file + "'";
    command += " 2>&1";
    FILE* pipe = ::popen(command.c_str(), "r");
    if (!pipe) return -1;
    char chunk[4096];
    for (std::size_t got; (got = std::fread(chunk, 1, sizeof chunk, pipe)) > 0;) report.append(chunk, got);
    const int status = ::pclose(pipe);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// `path` in single quotes for the shell.
std::string quotedPath(const fs::path& path) { return psub::test::quoted(path); }

std::array<double, 2> uvOfCorner(const Mesh& mesh, std::size_t corner) {
    const Index value = mesh.uv.corners[corner];
    return {mesh.uv.values[2 * value], mesh.uv.values[2 * value + 1]};
}

}  // namespace

// ---------------------------------------------------------------------------------------
// Reader: TEXCOORD_0

TEST_F(GltfIo, TexcoordsKeepTheSeamWhilePositionsWeld) {
    SeamSquare square = makeSeamSquare(kSeamUvs);
    for (const char* name : {"seam.gltf", "seam.glb"}) {
        const GltfAsset asset = readGltf(write(square.builder.model, name));
        EXPECT_EQ(asset.mesh.faces.vertexCount, 4u) << name;  // welded by position
        ASSERT_EQ(asset.mesh.faces.faceCount(), 2u);
        ASSERT_EQ(asset.mesh.uv.corners.size(), 6u);
        EXPECT_EQ(asset.mesh.uv.width, 2u);
        EXPECT_EQ(asset.mesh.uv.valueCount(), 6u);  // one per glTF vertex
        for (std::size_t c = 0; c < 6; ++c) {
            const auto uv = uvOfCorner(asset.mesh, c);
            EXPECT_FLOAT_EQ(float(uv[0]), kSeamUvs[2 * c]) << c;
            EXPECT_FLOAT_EQ(float(uv[1]), kSeamUvs[2 * c + 1]) << c;
        }
        // Corner 0 and corner 3 are one cage vertex with two UVs: the seam survives.
        EXPECT_EQ(asset.mesh.faces.verts[0], asset.mesh.faces.verts[3]);
        EXPECT_NE(asset.mesh.uv.corners[0], asset.mesh.uv.corners[3]);
        EXPECT_FALSE(asset.material.has_value());
        checkMesh(asset.mesh);
    }
}

TEST_F(GltfIo, NormalizedIntegerTexcoordsAreMappedToZeroOne) {
    SeamSquare square = makeSeamSquare(kSeamUvs);
    ModelBuilder& b = square.builder;
    const std::vector<std::uint16_t> shorts = {0, 0, 65535, 0, 65535, 65535, 0, 0, 65535, 65535, 0, 65535};
    const int uv16 = b.add(shorts.data(), shorts.size() * 2, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT, TINYGLTF_TYPE_VEC2,
                           6, TINYGLTF_TARGET_ARRAY_BUFFER);
    b.model.accessors[std::size_t(uv16)].normalized = true;
    b.model.meshes[0].primitives[0].attributes["TEXCOORD_0"] = uv16;
    GltfAsset asset = readGltf(write(b.model, "short.gltf"));
    EXPECT_EQ(uvOfCorner(asset.mesh, 2), (std::array<double, 2>{1, 1}));
    EXPECT_EQ(uvOfCorner(asset.mesh, 5), (std::array<double, 2>{0, 1}));

    std::vector<std::uint8_t> bytes = {0, 0, 255, 0, 255, 255, 0, 0, 255, 255, 0, 255};
    bytes.resize(16, 0);  // accessor data stays 4-byte aligned
    const int uv8 = b.add(bytes.data(), 12, TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_TYPE_VEC2, 6,
                          TINYGLTF_TARGET_ARRAY_BUFFER);
    b.model.accessors[std::size_t(uv8)].normalized = true;
    b.model.meshes[0].primitives[0].attributes["TEXCOORD_0"] = uv8;
    asset = readGltf(write(b.model, "byte.gltf"));
    EXPECT_EQ(uvOfCorner(asset.mesh, 1), (std::array<double, 2>{1, 0}));

    b.model.accessors[std::size_t(uv8)].normalized = false;  // integers must be normalized
    expectError(write(b.model, "raw.gltf"), {"accessor " + std::to_string(uv8), "TEXCOORD_0", "normalized"});
}

TEST_F(GltfIo, BadTexcoordAccessorsAreRefused) {
    SeamSquare square = makeSeamSquare({0, 0, 1, 0, 1, 1, 0, 0, 1, 1});  // 5 UVs for 6 vertices
    const int uv = square.uvAccessor;
    expectError(write(square.builder.model, "count.gltf"),
                {"accessor " + std::to_string(uv), "mesh 0 primitive 0 TEXCOORD_0", "has 5 elements, expected 6"});

    SeamSquare vec3 = makeSeamSquare(kSeamUvs);
    vec3.builder.model.meshes[0].primitives[0].attributes["TEXCOORD_0"] = vec3.builder.model.meshes[0].primitives[0].attributes["POSITION"];
    expectError(write(vec3.builder.model, "type.gltf"), {"TEXCOORD_0", "type is VEC3, expected VEC2"});
}

// ---------------------------------------------------------------------------------------
// Reader: touching shells

// One triangle-list primitive over `positions` and `indices`, its mesh on node 0 (no scene).
ModelBuilder triangleMesh(const std::vector<float>& positions, const std::vector<std::uint32_t>& indices) {
    ModelBuilder b;
    tinygltf::Primitive primitive;
    primitive.attributes["POSITION"] = b.positions(positions);
    primitive.indices = b.indices(indices);
    primitive.mode = TINYGLTF_MODE_TRIANGLES;
    tinygltf::Mesh mesh;
    mesh.primitives.push_back(primitive);
    b.model.meshes.push_back(mesh);
    tinygltf::Node node;
    node.mesh = 0;
    b.model.nodes.push_back(node);
    return b;
}

// True when one of the asset's warnings contains `part`.
bool warnedOf(const GltfAsset& asset, const std::string& part) {
    return std::any_of(asset.warnings.begin(), asset.warnings.end(),
                       [&](const std::string& warning) { return contains(warning, part); });
}

TEST_F(GltfIo, BoxesTouchingAlongAnEdgeLoadAsTwoShells) {
    std::vector<float> positions;
    std::vector<std::uint32_t> indices;
    addBox({0, 0, 0}, positions, indices);
    addBox({1, 1, 0}, positions, indices);  // shares the edge x = 1, y = 1, z in [0, 1]
    ModelBuilder b = triangleMesh(positions, indices);

    const GltfAsset asset = readGltf(write(b.model, "boxes.glb"));
    EXPECT_EQ(asset.mesh.faces.faceCount(), 24u);
    EXPECT_EQ(asset.mesh.faces.vertexCount, 16u);  // 14 after welding, the shared two un-welded
    EXPECT_EQ(asset.mesh.positions.size(), 48u);
    EXPECT_TRUE(warnedOf(asset, "touching shells"));
    const CheckedMesh checked = checkMesh(asset.mesh);  // manifold along every edge now
    EXPECT_EQ(checked.connectivity.boundaryEdgeCount, 0u);
    // Every cage vertex of box 2's faces lies in box 2.
    for (Index f = 12; f < 24; ++f)
        for (Index v : asset.mesh.faces.face(f)) EXPECT_GE(asset.mesh.positions[3 * v], 1.0);
    // The cage vertex of each glTF vertex has that vertex's position.
    for (std::size_t g = 0; g < asset.cageVertexOf.size(); ++g)
        for (std::size_t axis = 0; axis < 3; ++axis)
            EXPECT_EQ(asset.mesh.positions[3 * asset.cageVertexOf[g] + axis], double(positions[3 * g + axis]));

    // The same file loads through psub subdivide.
    const PsubRun run = runPsub(dir_, "subdivide " + quotedPath(path("boxes.glb")) + " -o " + quotedPath(path("boxes.obj")));
    EXPECT_EQ(run.status, 0) << run.err;
}

// A strip of 3 quads whose ends weld with a half twist (a Moebius band): one shell, and the
// glued edge twice in the same direction. The second triangle on it gets its own copies.
TEST_F(GltfIo, AShellMeetingItselfIsCutOpen) {
    // Bottom b0..b3 = glTF vertices 0..3, top t0..t3 = 4..7; b3 sits on t0 and t3 on b0.
    const std::vector<float> positions = {0, 0, 0, 1, 0, 0, 2, 0, 0, 0, 1, 0, /**/ 0, 1, 0, 1, 1, 1, 2, 1, 1, 0, 0, 0};
    std::vector<std::uint32_t> indices;
    for (std::uint32_t q = 0; q < 3; ++q) indices.insert(indices.end(), {q, q + 1, q + 5, q, q + 5, q + 4});
    ModelBuilder b = triangleMesh(positions, indices);
    const GltfAsset asset = readGltf(write(b.model, "moebius.glb"));
    EXPECT_EQ(asset.mesh.faces.faceCount(), 6u);
    EXPECT_EQ(asset.mesh.faces.vertexCount, 8u);  // 6 after welding, then the glued edge's 2 again
    EXPECT_TRUE(warnedOf(asset, "touching shells apart (1 edges"));
    checkMesh(asset.mesh);
    for (Index f = 0; f < 6; ++f)  // each corner keeps its own glTF vertex's position
        for (Index k = 0; k < 3; ++k)
            for (std::size_t axis = 0; axis < 3; ++axis)
                EXPECT_EQ(asset.mesh.positions[3 * asset.mesh.faces.verts[3 * f + k] + axis],
                          double(positions[3 * indices[3 * f + k] + axis]));
}

// ---------------------------------------------------------------------------------------
// Reader: materials

TEST_F(GltfIo, MaterialBaseColourAndTextureAreRead) {
    SeamSquare square = makeSeamSquare(kSeamUvs);
    addTexturedMaterial(square.builder, kPng);
    for (const char* name : {"textured.glb", "textured.gltf"}) {
        const GltfAsset asset = readGltf(write(square.builder.model, name));
        ASSERT_TRUE(asset.material.has_value()) << name;
        EXPECT_EQ(asset.material->name, "skin");
        EXPECT_EQ(asset.material->baseColorFactor, (std::array<double, 4>{0.5, 0.25, 1, 1}));
        ASSERT_TRUE(asset.material->baseColorTexture.has_value());
        EXPECT_EQ(asset.material->baseColorTexture->bytes, kPng);
        EXPECT_EQ(asset.material->baseColorTexture->mimeType, "image/png");
        EXPECT_EQ(asset.material->sampler.wrapS, TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE);
        EXPECT_EQ(asset.material->sampler.wrapT, TINYGLTF_TEXTURE_WRAP_MIRRORED_REPEAT);
        EXPECT_EQ(asset.material->sampler.magFilter, TINYGLTF_TEXTURE_FILTER_NEAREST);
    }
    // An external file, and a data URI.
    const std::string external = write(square.builder.model, "external.gltf");
    writeFile(path("tex.png"), std::string(kPng.begin(), kPng.end()));
    setImage(external, {{"uri", "tex.png"}});
    GltfAsset asset = readGltf(external);
    EXPECT_EQ(asset.material->baseColorTexture->bytes, kPng);
    EXPECT_EQ(asset.material->baseColorTexture->name, "tex.png");
    const std::string jpeg = "\xff\xd8\xff\xe0 not really a JPEG";
    writeFile(path("tex.jpg"), jpeg);
    setImage(external, {{"uri", "tex.jpg"}});
    asset = readGltf(external);
    EXPECT_EQ(asset.material->baseColorTexture->mimeType, "image/jpeg");  // by its magic bytes
    setImage(external, {{"uri", "data:image/png;base64,iVBORw0KGgo="}});  // the 8 PNG magic bytes
    asset = readGltf(external);
    EXPECT_EQ(asset.material->baseColorTexture->bytes, std::vector<unsigned char>(kPng.begin(), kPng.begin() + 8));
}

TEST_F(GltfIo, SeveralMaterialsKeepTheFirstWithAWarning) {
    SeamSquare square = makeSeamSquare(kSeamUvs);
    ModelBuilder& b = square.builder;
    b.model.meshes[0].primitives.push_back(b.model.meshes[0].primitives[0]);
    tinygltf::Material red, blue;
    red.pbrMetallicRoughness.baseColorFactor = {1, 0, 0, 1};
    blue.pbrMetallicRoughness.baseColorFactor = {0, 0, 1, 1};
    b.model.materials = {red, blue};
    b.model.meshes[0].primitives[0].material = 1;
    b.model.meshes[0].primitives[1].material = 0;
    const GltfAsset asset = readGltf(write(b.model, "two.gltf"));
    ASSERT_TRUE(asset.material.has_value());
    EXPECT_EQ(asset.material->baseColorFactor, (std::array<double, 4>{0, 0, 1, 1}));
    EXPECT_FALSE(asset.material->baseColorTexture.has_value());
    EXPECT_TRUE(warnedOf(asset, "only material 1 is kept"));
}

TEST_F(GltfIo, BadMaterialsAndImagesAreRefused) {
    SeamSquare square = makeSeamSquare(kSeamUvs);
    addTexturedMaterial(square.builder, kPng);
    tinygltf::Model model = square.builder.model;
    model.meshes[0].primitives[0].material = 3;
    expectError(write(model, "material.gltf"), {"mesh 0 primitive 0", "material 3 does not exist"});
    model = square.builder.model;
    model.materials[0].pbrMetallicRoughness.baseColorTexture.index = 5;
    expectError(write(model, "texture.gltf"), {"material 0", "base colour texture 5 does not exist"});
    model = square.builder.model;
    model.textures[0].source = 2;
    expectError(write(model, "image.gltf"), {"texture 0", "image 2 does not exist"});
    model = square.builder.model;
    model.textures[0].sampler = 4;
    expectError(write(model, "sampler.gltf"), {"texture 0", "sampler 4 does not exist"});

    const std::string missing = write(square.builder.model, "missing.gltf");
    setImage(missing, {{"uri", "nowhere.png"}});
    expectError(missing, {"image 0", "uri 'nowhere.png'", "missing"});
    const std::string empty = write(square.builder.model, "empty.gltf");
    writeFile(path("empty.png"), "");
    setImage(empty, {{"uri", "empty.png"}});
    EXPECT_TRUE(contains(inputErrorOf([&] { readGltf(empty); }), empty + ": "));
    const std::string text = write(square.builder.model, "text.gltf");
    writeFile(path("text.png"), "this is not an image");
    setImage(text, {{"uri", "text.png"}});
    expectError(text, {"image 0", "neither a PNG nor a JPEG"});

    // Through psub: exit 1, one line naming the file, and no output file.
    const PsubRun run = runPsub(dir_, "subdivide " + quotedPath(missing) + " -o " + quotedPath(path("out.glb")));
    EXPECT_EQ(run.status, 1);
    EXPECT_TRUE(contains(oneLine(run), missing + ": image 0")) << run.err;
    EXPECT_FALSE(fs::exists(path("out.glb")));
}

// ---------------------------------------------------------------------------------------
// Writer

namespace {

// A 3 x 2 grid of quads (one a pentagon with a midpoint on its top edge) over z = xy / 4.
struct Sheet {
    std::vector<double> positions, normals, uvValues;
    std::vector<std::uint32_t> faceOffsets{0}, faceVerts, faceValues;
};

Sheet makeSheet(bool seam) {
    Sheet s;
    for (int y = 0; y <= 2; ++y)
        for (int x = 0; x <= 3; ++x) {
            s.positions.insert(s.positions.end(), {double(x), double(y), x * y / 4.0});
            s.normals.insert(s.normals.end(), {-y / 4.0, -x / 4.0, 1.0});  // not unit: the writer normalises
            s.uvValues.insert(s.uvValues.end(), {x / 3.0, y / 2.0});
        }
    s.positions.insert(s.positions.end(), {0.5, 2, 0.25});  // vertex 12, on the top edge of face 3
    s.normals.insert(s.normals.end(), {0, 0, 0});          // a zero normal
    s.uvValues.insert(s.uvValues.end(), {0.5 / 3, 1});
    for (std::uint32_t y = 0; y < 2; ++y)
        for (std::uint32_t x = 0; x < 3; ++x) {
            const std::uint32_t v = y * 4 + x;
            std::vector<std::uint32_t> face = {v, v + 1, v + 5, v + 4};
            if (y == 1 && x == 0) face = {v, v + 1, v + 5, 12, v + 4};
            for (std::uint32_t corner : face) {
                s.faceVerts.push_back(corner);
                // Seam between columns 0 and 1: faces of column 1+ name copies of x = 1 values.
                const bool copy = seam && x >= 1 && corner % 4 == 1 && corner != 12;
                s.faceValues.push_back(copy ? 13 + corner / 4 : corner);
            }
            s.faceOffsets.push_back(std::uint32_t(s.faceVerts.size()));
        }
    for (std::uint32_t y = 0; y <= 2; ++y) s.uvValues.insert(s.uvValues.end(), {0.5, y / 2.0});  // values 13..15
    return s;
}

GltfSurface surfaceOf(const Sheet& s, bool withUv) {
    GltfSurface surface{s.positions, s.normals, s.faceOffsets, s.faceVerts, {}, {}};
    if (withUv) {
        surface.faceValues = s.faceValues;
        surface.uvValues = s.uvValues;
    }
    return surface;
}

GltfMaterial texturedMaterial() {
    GltfMaterial material;
    material.name = "sheet";
    material.baseColorFactor = {0.8, 0.7, 0.6, 1};
    material.baseColorTexture = GltfImage{"image/png", kPng, "sheet.png"};
    material.sampler.wrapS = 33071;
    return material;
}

}  // namespace

TEST_F(GltfIo, WrittenFilesPassTheKhronosValidator) {
    const Sheet sheet = makeSheet(true);
    const GltfMaterial textured = texturedMaterial();
    GltfMaterial plain;
    plain.baseColorFactor = {0.2, 0.4, 0.6, 1};
    std::vector<std::string> files;
    int n = 0;
    for (bool binary : {true, false})
        for (bool withUv : {false, true})
            for (const GltfMaterial* material : std::vector<const GltfMaterial*>{nullptr, &plain, &textured}) {
                const std::string file = path("sheet" + std::to_string(n++) + (binary ? ".glb" : ".gltf")).string();
                writeFile(file, formatGltf(surfaceOf(sheet, withUv), material, binary, "psub test"));
                files.push_back(file);
            }
    std::string report;
    EXPECT_EQ(validate(files, report), 0) << report;
    EXPECT_EQ(countOf(report, "0 errors, 0 warnings"), long(files.size())) << report;
}

TEST_F(GltfIo, WriterThenReaderKeepsPositionsUvsFacesAndMaterial) {
    const Sheet sheet = makeSheet(true);
    const GltfMaterial material = texturedMaterial();
    for (bool binary : {true, false}) {
        const std::string file = path(binary ? "round.glb" : "round.gltf").string();
        writeFile(file, formatGltf(surfaceOf(sheet, true), &material, binary, "psub test"));
        const GltfAsset asset = readGltf(file);
        // Positions weld back to the 13 vertices; faces are the fan triangles of the input's.
        ASSERT_EQ(asset.mesh.faces.vertexCount, 13u);
        ASSERT_EQ(asset.mesh.faces.faceCount(), 13u);  // 5 quads x 2 + a pentagon's 3
        std::size_t triangle = 0;
        for (std::size_t f = 0; f + 1 < sheet.faceOffsets.size(); ++f)
            for (std::uint32_t k = sheet.faceOffsets[f] + 1; k + 1 < sheet.faceOffsets[f + 1]; ++k, ++triangle) {
                const std::uint32_t corners[3] = {sheet.faceOffsets[f], k, k + 1};
                for (std::size_t i = 0; i < 3; ++i) {
                    const Index cage = asset.mesh.faces.verts[3 * triangle + i];
                    const std::uint32_t vertex = sheet.faceVerts[corners[i]], value = sheet.faceValues[corners[i]];
                    for (std::size_t axis = 0; axis < 3; ++axis)
                        EXPECT_EQ(asset.mesh.positions[3 * cage + axis], double(float(sheet.positions[3 * vertex + axis])));
                    const auto uv = uvOfCorner(asset.mesh, 3 * triangle + i);
                    EXPECT_EQ(uv[0], double(float(sheet.uvValues[2 * value])));
                    EXPECT_EQ(uv[1], double(float(sheet.uvValues[2 * value + 1])));
                }
            }
        ASSERT_TRUE(asset.material.has_value());
        EXPECT_EQ(asset.material->baseColorFactor, material.baseColorFactor);
        ASSERT_TRUE(asset.material->baseColorTexture.has_value());
        EXPECT_EQ(asset.material->baseColorTexture->bytes, kPng);
        EXPECT_EQ(asset.material->sampler.wrapS, 33071);
    }
}

// ---------------------------------------------------------------------------------------
// psub subdivide: glTF out, glTF in, --at

TEST_F(GltfIo, SubdivideWritesValidGltfFromObjAndGltf) {
    const std::string grid = dataPath("grid4x4.obj");
    const fs::path glb = path("grid.glb"), gltf = path("grid.gltf");
    ASSERT_EQ(runPsub(dir_, "subdivide " + quotedPath(grid) + " -o " + quotedPath(glb) + " --levels 2").status, 0);
    ASSERT_EQ(runPsub(dir_, "subdivide " + quotedPath(grid) + " -o " + quotedPath(gltf) + " --levels 1 --scheme cc").status, 0);
    // --levels 0 of a quad mesh: the input's positions, two triangles per quad.
    const fs::path level0 = path("level0.glb");
    ASSERT_EQ(runPsub(dir_, "subdivide " + quotedPath(grid) + " -o " + quotedPath(level0) + " --levels 0").status, 0);
    const Mesh obj = readObj(grid);
    const GltfAsset back = readGltf(level0.string());
    ASSERT_EQ(back.mesh.faces.faceCount(), 2 * obj.faces.faceCount());
    for (Index f = 0; f < obj.faces.faceCount(); ++f) {  // quad [a b c d]: triangles [a b c], [a c d]
        const auto quad = obj.faces.face(f);
        const Index corners[6] = {quad[0], quad[1], quad[2], quad[0], quad[2], quad[3]};
        for (std::size_t k = 0; k < 6; ++k) {
            const Index cage = back.mesh.faces.verts[6 * f + k];
            for (std::size_t axis = 0; axis < 3; ++axis)
                EXPECT_EQ(back.mesh.positions[3 * cage + axis], double(float(obj.positions[3 * corners[k] + axis])));
        }
    }

    // glTF in (textured, with UVs) -> glTF out keeps the material, and the texture's bytes with
    // the refined UVs whenever the library refines the cage's UVs (Refinement::uv).
    Cylinder cylinder = makeCylinder();
    for (auto& primitive : cylinder.builder.model.meshes[0].primitives) {
        std::vector<float> uvs;
        for (int ring = 0; ring < 3; ++ring)
            for (int column = 0; column < kRowSize; ++column) uvs.insert(uvs.end(), {float(column) / 8, float(ring) / 4});
        primitive.attributes["TEXCOORD_0"] = cylinder.builder.attribute(uvs, TINYGLTF_TYPE_VEC2, 2);
    }
    addTexturedMaterial(cylinder.builder, kPng);
    const std::string textured = write(cylinder.builder.model, "cylinder.glb");
    const GltfAsset input = readGltf(textured);
    ASSERT_FALSE(input.mesh.uv.empty());
    const bool refinesUv = !refine(input.mesh, checkMesh(input.mesh).connectivity, RefineOptions{}).uv.empty();
    const fs::path out = path("cylinder_out.gltf");
    const PsubRun run = runPsub(dir_, "subdivide " + quotedPath(textured) + " -o " + quotedPath(out) + " --levels 1");
    ASSERT_EQ(run.status, 0) << run.err;
    const GltfAsset refined = readGltf(out.string());
    ASSERT_TRUE(refined.material.has_value());
    EXPECT_EQ(refined.material->baseColorFactor, (std::array<double, 4>{0.5, 0.25, 1, 1}));
    EXPECT_EQ(refined.mesh.uv.empty(), !refinesUv);
    EXPECT_EQ(refined.material->baseColorTexture.has_value(), refinesUv);
    EXPECT_EQ(contains(run.err, "texture is left out"), !refinesUv) << run.err;
    if (refinesUv) {
        EXPECT_EQ(refined.material->baseColorTexture->bytes, kPng);
    }
    std::string report;
    EXPECT_EQ(validate({glb.string(), gltf.string(), level0.string(), out.string()}, report), 0) << report;
}

TEST_F(GltfIo, SubdivideAtPosesTheClipBeforeRefining) {
    const std::string cylinder = write(makeCylinder().builder.model, "cylinder.glb");
    const auto run = [&](const std::string& options, const std::string& name) {
        const fs::path out = path(name);
        const PsubRun result = runPsub(dir_, "subdivide " + quotedPath(cylinder) + " -o " + quotedPath(out) + " " + options);
        EXPECT_EQ(result.status, 0) << options << ": " << result.err;
        return readFile(out);
    };
    const std::string rest = run("--levels 1", "rest.obj");
    const std::string start = run("--levels 1 --at 0", "start.obj");
    const std::string bent = run("--levels 1 --at 1", "bent.obj");
    const std::string clamped = run("--levels 1 --at 100", "clamped.obj");
    const std::string stepped = run("--levels 1 --at 0.75 --anim step", "step.obj");
    EXPECT_EQ(rest, start);     // the bend clip starts at the rest pose
    EXPECT_NE(rest, bent);      // and ends a quarter turn away
    EXPECT_EQ(bent, clamped);   // past its end, it holds its last pose
    EXPECT_NE(stepped, bent);
    EXPECT_NE(stepped, rest);
}

TEST_F(GltfIo, SubdivideAtUsageErrors) {
    const std::string cylinder = write(makeCylinder().builder.model, "cylinder.glb");
    const std::string obj = dataPath("cube.obj");
    const auto status = [&](const std::string& args) {
        return runPsub(dir_, "subdivide " + args + " -o " + quotedPath(path("out.obj"))).status;
    };
    EXPECT_EQ(status(quotedPath(obj) + " --at 1"), 2);  // OBJ input has no clip
    EXPECT_EQ(status(quotedPath(cylinder) + " --at -1"), 2);
    EXPECT_EQ(status(quotedPath(cylinder) + " --at nan"), 2);
    EXPECT_EQ(status(quotedPath(cylinder) + " --at inf"), 2);
    EXPECT_EQ(status(quotedPath(cylinder) + " --anim bend"), 2);  // --anim without --at
    EXPECT_EQ(status(quotedPath(cylinder) + " --at 1 --anim nosuchclip"), 1);
    EXPECT_FALSE(fs::exists(path("out.obj")));
    const PsubRun help = runPsub(dir_, "subdivide --help");
    EXPECT_TRUE(contains(help.out, "--at")) << help.out;
    EXPECT_TRUE(contains(help.out, ".glb")) << help.out;
}
