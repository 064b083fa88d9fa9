// formatGltf: a refined surface (positions, normals, optional per-corner UVs, optional base
// colour material) as the bytes of one .glb or self-contained .gltf, through tinygltf's writer.
#include "psub/animation.h"

#include <tiny_gltf.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <sstream>
#include <unordered_map>

namespace psub {
namespace {

// Appends `bytes` to the model's only buffer as a new buffer view (4-byte aligned) and returns it.
int addView(tinygltf::Model& model, const void* bytes, std::size_t size, int target) {
    std::vector<unsigned char>& buffer = model.buffers[0].data;
    buffer.resize((buffer.size() + 3) / 4 * 4, 0);
    tinygltf::BufferView view;
    view.buffer = 0;
    view.byteOffset = buffer.size();
    view.byteLength = size;
    view.target = target;
    const auto* begin = static_cast<const unsigned char*>(bytes);
    buffer.insert(buffer.end(), begin, begin + size);
    model.bufferViews.push_back(view);
    return int(model.bufferViews.size() - 1);
}

template <class T>
int addAccessor(tinygltf::Model& model, const std::vector<T>& values, int componentType, int type,
                std::size_t width, int target) {
    tinygltf::Accessor accessor;
    accessor.bufferView = addView(model, values.data(), values.size() * sizeof(T), target);
    accessor.componentType = componentType;
    accessor.type = type;
    accessor.count = values.size() / width;
    model.accessors.push_back(accessor);
    return int(model.accessors.size() - 1);
}

// The glTF vertices: one per distinct (position vertex, UV value) pair of the corners.
struct Vertices {
    std::vector<std::uint32_t> position, uv;  // per glTF vertex
    std::vector<std::uint32_t> ofCorner;      // per corner: its glTF vertex
};

Vertices gltfVertices(const GltfSurface& surface) {
    Vertices out;
    const bool hasUv = !surface.faceValues.empty();
    std::unordered_map<std::uint64_t, std::uint32_t> index;
    out.ofCorner.reserve(surface.faceVerts.size());
    for (std::size_t c = 0; c < surface.faceVerts.size(); ++c) {
        const std::uint32_t p = surface.faceVerts[c], t = hasUv ? surface.faceValues[c] : 0;
        const auto [slot, inserted] = index.try_emplace((std::uint64_t(p) << 32) | t, std::uint32_t(out.position.size()));
        if (inserted) {
            out.position.push_back(p);
            out.uv.push_back(t);
        }
        out.ofCorner.push_back(slot->second);
    }
    return out;
}

std::vector<float> unitNormal(const GltfSurface& surface, std::uint32_t v) {
    const double x = surface.normals[3 * v], y = surface.normals[3 * v + 1], z = surface.normals[3 * v + 2];
    const double length = std::sqrt(x * x + y * y + z * z);
    if (!(length > 0) || !std::isfinite(length)) return {0, 0, 1};
    return {float(x / length), float(y / length), float(z / length)};
}

// Adds POSITION, NORMAL and TEXCOORD_0 of the glTF vertices to `primitive`.
void addAttributes(tinygltf::Model& model, const GltfSurface& surface, const Vertices& vertices,
                   tinygltf::Primitive& primitive) {
    std::vector<float> positions, normals, uvs;
    for (std::size_t v = 0; v < vertices.position.size(); ++v) {
        const std::uint32_t p = vertices.position[v];
        for (std::size_t axis = 0; axis < 3; ++axis) positions.push_back(float(surface.positions[3 * p + axis]));
        if (!surface.normals.empty()) {
            const std::vector<float> normal = unitNormal(surface, p);
            normals.insert(normals.end(), normal.begin(), normal.end());
        }
        if (!surface.faceValues.empty())
            for (std::size_t axis = 0; axis < 2; ++axis) uvs.push_back(float(surface.uvValues[2 * vertices.uv[v] + axis]));
    }
    const int position = addAccessor(model, positions, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, 3,
                                     TINYGLTF_TARGET_ARRAY_BUFFER);
    tinygltf::Accessor& bounded = model.accessors[std::size_t(position)];
    bounded.minValues.assign(3, std::numeric_limits<double>::infinity());
    bounded.maxValues.assign(3, -std::numeric_limits<double>::infinity());
    for (std::size_t i = 0; i < positions.size(); ++i) {
        bounded.minValues[i % 3] = std::min(bounded.minValues[i % 3], double(positions[i]));
        bounded.maxValues[i % 3] = std::max(bounded.maxValues[i % 3], double(positions[i]));
    }
    primitive.attributes["POSITION"] = position;
    if (!normals.empty())
        primitive.attributes["NORMAL"] = addAccessor(model, normals, TINYGLTF_COMPONENT_TYPE_FLOAT,
                                                     TINYGLTF_TYPE_VEC3, 3, TINYGLTF_TARGET_ARRAY_BUFFER);
    if (!uvs.empty())
        primitive.attributes["TEXCOORD_0"] = addAccessor(model, uvs, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC2,
                                                         2, TINYGLTF_TARGET_ARRAY_BUFFER);
}

// Fan triangles of every face, over glTF vertices.
std::vector<std::uint32_t> triangles(const GltfSurface& surface, const Vertices& vertices) {
    std::vector<std::uint32_t> indices;
    for (std::size_t f = 0; f + 1 < surface.faceOffsets.size(); ++f)
        for (std::uint32_t k = surface.faceOffsets[f] + 1; k + 1 < surface.faceOffsets[f + 1]; ++k)
            indices.insert(indices.end(), {vertices.ofCorner[surface.faceOffsets[f]], vertices.ofCorner[k],
                                           vertices.ofCorner[k + 1]});
    return indices;
}

void addMaterial(tinygltf::Model& model, const GltfMaterial& material, bool withTexture) {
    tinygltf::Material out;
    out.name = material.name;
    out.pbrMetallicRoughness.baseColorFactor.assign(material.baseColorFactor.begin(), material.baseColorFactor.end());
    out.pbrMetallicRoughness.metallicFactor = 0;  // psub draws no metal; glTF's default would be 1
    if (material.baseColorTexture && withTexture) {
        const GltfImage& source = *material.baseColorTexture;
        tinygltf::Image image;
        image.name = source.name;
        image.mimeType = source.mimeType;
        image.bufferView = addView(model, source.bytes.data(), source.bytes.size(), 0);
        model.images.push_back(image);
        tinygltf::Sampler sampler;
        sampler.magFilter = material.sampler.magFilter;
        sampler.minFilter = material.sampler.minFilter;
        sampler.wrapS = material.sampler.wrapS;
        sampler.wrapT = material.sampler.wrapT;
        model.samplers.push_back(sampler);
        tinygltf::Texture texture;
        texture.source = 0;
        texture.sampler = 0;
        model.textures.push_back(texture);
        out.pbrMetallicRoughness.baseColorTexture.index = 0;
    }
    model.materials.push_back(out);
}

}  // namespace

std::string formatGltf(const GltfSurface& surface, const GltfMaterial* material, bool binary,
                       const std::string& generator) {
    tinygltf::Model model;
    model.asset.version = "2.0";
    model.asset.generator = generator;
    model.buffers.emplace_back();
    const Vertices vertices = gltfVertices(surface);
    tinygltf::Primitive primitive;
    primitive.mode = TINYGLTF_MODE_TRIANGLES;
    addAttributes(model, surface, vertices, primitive);
    primitive.indices = addAccessor(model, triangles(surface, vertices), TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT,
                                    TINYGLTF_TYPE_SCALAR, 1, TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
    if (material) {
        addMaterial(model, *material, !surface.faceValues.empty());
        primitive.material = 0;
    }
    tinygltf::Mesh mesh;
    mesh.primitives.push_back(primitive);
    model.meshes.push_back(mesh);
    tinygltf::Node node;
    node.mesh = 0;
    model.nodes.push_back(node);
    tinygltf::Scene scene;
    scene.nodes.push_back(0);
    model.scenes.push_back(scene);
    model.defaultScene = 0;
    model.buffers[0].data.resize((model.buffers[0].data.size() + 3) / 4 * 4, 0);
    std::ostringstream stream;
    tinygltf::TinyGLTF writer;
    if (!writer.WriteGltfSceneToStream(&model, stream, false, binary))
        throw std::runtime_error("tinygltf could not serialise the glTF asset");
    return stream.str();
}

}  // namespace psub
