// readGltf: a glTF 2.0 file (through tinygltf) into a GltfAsset: the welded triangle cage, its
// skin, morph targets, node hierarchy and clips. Every index and byte range is checked here,
// so a bad file gives InputError naming the file and the element, never a crash.
#include "psub/animation.h"

#include <nlohmann/json.hpp>
#include <tiny_gltf.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <climits>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <unordered_map>

namespace psub {
namespace {

constexpr std::uint32_t kInfluences = 4;

using ImageBytes = std::vector<std::vector<unsigned char>>;  // per image of the file: its bytes

std::string percentDecoded(const std::string& uri);
constexpr std::size_t kMaxUnbackedCount = std::size_t(1) << 24;  // accessors without a buffer view

// The file being read, for error messages.
struct Context {
    const std::string& path;
    const tinygltf::Model& model;

    [[noreturn]] void fail(const std::string& element, const std::string& what) const {
        throw InputError(path + ": " + element + ": " + what);
    }
};

std::string named(const char* kind, std::size_t index) {
    std::string out(kind);  // appended, not kind + (...): GCC 12 warns falsely (-Wrestrict) on that
    out += ' ';
    out += std::to_string(index);
    return out;
}

std::string primitiveName(std::size_t mesh, std::size_t primitive) {
    return named("mesh", mesh) + " primitive " + std::to_string(primitive);
}

// A number as a person writes it: 7, 0.25, nan.
std::string number(double value) {
    char text[32];
    std::snprintf(text, sizeof text, "%.9g", value);
    return text;
}

std::string oneLine(std::string text) {
    while (!text.empty() && (text.back() == '\n' || text.back() == '\r' || text.back() == ' '))
        text.pop_back();
    for (std::size_t at = text.find('\n'); at != std::string::npos; at = text.find('\n', at))
        text.replace(at, 1, "; ");
    std::erase(text, '\r');
    return text;
}

// ---------------------------------------------------------------------------------------
// Accessors

// An accessor's elements converted to double (normalized integers mapped as glTF says).
struct Values {
    std::size_t count = 0;
    std::size_t width = 0;
    std::vector<double> data;  // count * width

    double at(std::size_t element, std::size_t component) const {
        return data[element * width + component];
    }
};

const char* typeName(int type) {
    switch (type) {
        case TINYGLTF_TYPE_SCALAR: return "SCALAR";
        case TINYGLTF_TYPE_VEC2: return "VEC2";
        case TINYGLTF_TYPE_VEC3: return "VEC3";
        case TINYGLTF_TYPE_VEC4: return "VEC4";
        case TINYGLTF_TYPE_MAT2: return "MAT2";
        case TINYGLTF_TYPE_MAT3: return "MAT3";
        case TINYGLTF_TYPE_MAT4: return "MAT4";
        default: return "unknown";
    }
}

template <class T>
T load(const unsigned char* bytes) {
    T value;
    std::memcpy(&value, bytes, sizeof value);
    return value;
}

double readComponent(const unsigned char* bytes, int componentType, bool normalized) {
    switch (componentType) {
        case TINYGLTF_COMPONENT_TYPE_BYTE: {
            const double v = load<std::int8_t>(bytes);
            return normalized ? std::max(v / 127.0, -1.0) : v;
        }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: {
            const double v = load<std::uint8_t>(bytes);
            return normalized ? v / 255.0 : v;
        }
        case TINYGLTF_COMPONENT_TYPE_SHORT: {
            const double v = load<std::int16_t>(bytes);
            return normalized ? std::max(v / 32767.0, -1.0) : v;
        }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
            const double v = load<std::uint16_t>(bytes);
            return normalized ? v / 65535.0 : v;
        }
        case TINYGLTF_COMPONENT_TYPE_INT: return load<std::int32_t>(bytes);
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
            const double v = load<std::uint32_t>(bytes);
            return normalized ? v / 4294967295.0 : v;
        }
        case TINYGLTF_COMPONENT_TYPE_FLOAT: return load<float>(bytes);
        default: return load<double>(bytes);  // TINYGLTF_COMPONENT_TYPE_DOUBLE
    }
}

std::size_t componentSize(int componentType) {
    const std::int32_t size = tinygltf::GetComponentSizeInBytes(std::uint32_t(componentType));
    return size > 0 ? std::size_t(size) : 0;
}

// `count` elements of `elementSize` bytes, `stride` bytes apart, from `offset` bytes into
// buffer view `view`: the first element's address, after checking every byte lies in the buffer.
const unsigned char* viewBytes(const Context& cx, int view, std::size_t offset, std::size_t count,
                               std::size_t elementSize, std::size_t stride,
                               const std::string& element) {
    if (view < 0 || std::size_t(view) >= cx.model.bufferViews.size())
        cx.fail(element, "buffer view " + std::to_string(view) + " does not exist");
    const tinygltf::BufferView& bufferView = cx.model.bufferViews[std::size_t(view)];
    if (bufferView.buffer < 0 || std::size_t(bufferView.buffer) >= cx.model.buffers.size())
        cx.fail(named("buffer view", std::size_t(view)),
                "buffer " + std::to_string(bufferView.buffer) + " does not exist");
    const std::vector<unsigned char>& buffer = cx.model.buffers[std::size_t(bufferView.buffer)].data;
    if (bufferView.byteOffset > buffer.size() || bufferView.byteLength > buffer.size() - bufferView.byteOffset)
        cx.fail(named("buffer view", std::size_t(view)),
                "bytes " + std::to_string(bufferView.byteOffset) + " + " +
                    std::to_string(bufferView.byteLength) + " overrun buffer " +
                    std::to_string(bufferView.buffer) + " of " + std::to_string(buffer.size()) + " bytes");
    const std::size_t available = bufferView.byteLength;
    const bool fits = count == 0 || (offset <= available && elementSize <= available - offset &&
                                     (count - 1) <= (available - offset - elementSize) / stride);
    if (!fits)
        cx.fail(element, std::to_string(count) + " elements of " + std::to_string(elementSize) +
                             " bytes from byte " + std::to_string(offset) + " overrun buffer view " +
                             std::to_string(view) + " of " + std::to_string(available) + " bytes");
    return buffer.data() + bufferView.byteOffset + offset;
}

void readElements(const unsigned char* bytes, std::size_t stride, std::size_t count, std::size_t width,
                  int componentType, bool normalized, double* out) {
    const std::size_t size = componentSize(componentType);
    for (std::size_t e = 0; e < count; ++e)
        for (std::size_t c = 0; c < width; ++c)
            out[e * width + c] = readComponent(bytes + e * stride + c * size, componentType, normalized);
}

void applySparse(const Context& cx, const tinygltf::Accessor& accessor, const std::string& element,
                 Values& values) {
    const auto& sparse = accessor.sparse;
    const std::size_t indexSize = componentSize(sparse.indices.componentType);
    if (sparse.count < 0 || std::size_t(sparse.count) > values.count)
        cx.fail(element, "sparse count " + std::to_string(sparse.count) + " is out of range");
    if (indexSize == 0 || sparse.indices.componentType == TINYGLTF_COMPONENT_TYPE_FLOAT ||
        sparse.indices.byteOffset < 0 || sparse.values.byteOffset < 0)
        cx.fail(element, "invalid sparse indices");
    const std::size_t count = std::size_t(sparse.count);
    const std::size_t valueSize = componentSize(accessor.componentType) * values.width;
    const unsigned char* indices = viewBytes(cx, sparse.indices.bufferView, std::size_t(sparse.indices.byteOffset),
                                             count, indexSize, indexSize, element + " sparse indices");
    const unsigned char* data = viewBytes(cx, sparse.values.bufferView, std::size_t(sparse.values.byteOffset),
                                          count, valueSize, valueSize, element + " sparse values");
    for (std::size_t i = 0; i < count; ++i) {
        const double target = readComponent(indices + i * indexSize, sparse.indices.componentType, false);
        if (!(target >= 0 && target < double(values.count)))
            cx.fail(element, "sparse index " + number(target) + " is out of range");
        readElements(data + i * valueSize, valueSize, 1, values.width, accessor.componentType,
                     accessor.normalized, &values.data[std::size_t(target) * values.width]);
    }
}

// Accessor `index`, which must have type `type`; `use` says what it is for (in messages).
Values readAccessor(const Context& cx, int index, int type, const std::string& use) {
    const std::string element = "accessor " + std::to_string(index) + " (" + use + ")";
    if (index < 0 || std::size_t(index) >= cx.model.accessors.size()) cx.fail(element, "does not exist");
    const tinygltf::Accessor& accessor = cx.model.accessors[std::size_t(index)];
    if (accessor.type != type)
        cx.fail(element, std::string("type is ") + typeName(accessor.type) + ", expected " + typeName(type));
    const std::size_t size = componentSize(accessor.componentType);
    if (size == 0) cx.fail(element, "unknown component type " + std::to_string(accessor.componentType));
    Values values;
    values.count = accessor.count;
    values.width = std::size_t(tinygltf::GetNumComponentsInType(std::uint32_t(type)));
    const std::size_t elementSize = size * values.width;
    if (accessor.bufferView < 0) {
        if (values.count > kMaxUnbackedCount) cx.fail(element, "too many elements without a buffer view");
        values.data.assign(values.count * values.width, 0.0);
    } else {
        const std::size_t viewStride =
            std::size_t(accessor.bufferView) < cx.model.bufferViews.size()
                ? cx.model.bufferViews[std::size_t(accessor.bufferView)].byteStride : 0;
        const std::size_t stride = viewStride != 0 ? viewStride : elementSize;
        const unsigned char* bytes =
            viewBytes(cx, accessor.bufferView, accessor.byteOffset, values.count, elementSize, stride, element);
        values.data.resize(values.count * values.width);
        readElements(bytes, stride, values.count, values.width, accessor.componentType, accessor.normalized,
                     values.data.data());
    }
    if (accessor.sparse.isSparse) applySparse(cx, accessor, element, values);
    return values;
}

void requireFinite(const Context& cx, const Values& values, int index, const std::string& use) {
    for (std::size_t i = 0; i < values.data.size(); ++i)
        if (!std::isfinite(values.data[i]))
            cx.fail("accessor " + std::to_string(index) + " (" + use + ")",
                    "element " + std::to_string(i / values.width) + " is not finite");
}

void requireCount(const Context& cx, const Values& values, std::size_t count, int index, const std::string& use) {
    if (values.count != count)
        cx.fail("accessor " + std::to_string(index) + " (" + use + ")",
                "has " + std::to_string(values.count) + " elements, expected " + std::to_string(count));
}

// ---------------------------------------------------------------------------------------
// Nodes

std::array<double, 16> identityMatrix() { return {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1}; }

template <std::size_t N>
void copyVector(const Context& cx, const std::vector<double>& from, std::array<double, N>& to,
                const std::string& element, const char* what) {
    if (from.empty()) return;
    if (from.size() != N)
        cx.fail(element, std::string(what) + " has " + std::to_string(from.size()) + " numbers, expected " +
                             std::to_string(N));
    for (std::size_t i = 0; i < N; ++i) {
        if (!std::isfinite(from[i])) cx.fail(element, std::string(what) + " is not finite");
        to[i] = from[i];
    }
}

GltfNode readNode(const Context& cx, std::size_t index) {
    const tinygltf::Node& node = cx.model.nodes[index];
    const std::string element = named("node", index);
    GltfNode result;
    result.name = node.name;
    copyVector(cx, node.translation, result.rest.translation, element, "translation");
    copyVector(cx, node.rotation, result.rest.rotation, element, "rotation");
    copyVector(cx, node.scale, result.rest.scale, element, "scale");
    auto& q = result.rest.rotation;
    const double length = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (!(length > 0)) cx.fail(element, "rotation is the zero quaternion");
    for (double& component : q) component /= length;
    if (!node.matrix.empty()) {
        std::array<double, 16> matrix{};
        copyVector(cx, node.matrix, matrix, element, "matrix");
        result.matrix = matrix;
    }
    return result;
}

// Parents from the children lists, then an order with every node after its parent.
void linkNodes(const Context& cx, GltfAsset& asset) {
    const std::size_t count = cx.model.nodes.size();
    for (std::size_t n = 0; n < count; ++n)
        for (int child : cx.model.nodes[n].children) {
            if (child < 0 || std::size_t(child) >= count)
                cx.fail(named("node", n), "child " + std::to_string(child) + " does not exist");
            if (asset.nodes[std::size_t(child)].parent >= 0 || std::size_t(child) == n)
                cx.fail(named("node", std::size_t(child)), "has more than one parent or is its own child");
            asset.nodes[std::size_t(child)].parent = std::int32_t(n);
        }
    for (std::size_t n = 0; n < count; ++n)
        if (asset.nodes[n].parent < 0) asset.nodeOrder.push_back(std::uint32_t(n));
    for (std::size_t next = 0; next < asset.nodeOrder.size(); ++next)  // breadth first
        for (int child : cx.model.nodes[asset.nodeOrder[next]].children)
            asset.nodeOrder.push_back(std::uint32_t(child));
    if (asset.nodeOrder.size() != count) cx.fail("nodes", "the hierarchy has a cycle");
}

// The node whose mesh is the cage: the first with a mesh and a skin, else the first with a mesh.
std::size_t findMeshNode(const Context& cx) {
    const auto& nodes = cx.model.nodes;
    auto found = std::find_if(nodes.begin(), nodes.end(), [](const auto& n) { return n.mesh >= 0 && n.skin >= 0; });
    if (found == nodes.end())
        found = std::find_if(nodes.begin(), nodes.end(), [](const auto& n) { return n.mesh >= 0; });
    if (found == nodes.end())
        cx.fail("meshes", cx.model.meshes.empty() ? "the file has no mesh"
                                                  : "no node instantiates any of the file's meshes");
    const std::size_t index = std::size_t(found - nodes.begin());
    if (std::size_t(found->mesh) >= cx.model.meshes.size())
        cx.fail(named("node", index), "mesh " + std::to_string(found->mesh) + " does not exist");
    if (found->skin >= 0 && std::size_t(found->skin) >= cx.model.skins.size())
        cx.fail(named("node", index), "skin " + std::to_string(found->skin) + " does not exist");
    return index;
}

// ---------------------------------------------------------------------------------------
// Skin

GltfSkin readSkin(const Context& cx, std::size_t index) {
    const tinygltf::Skin& skin = cx.model.skins[index];
    const std::string element = named("skin", index);
    if (skin.joints.empty()) cx.fail(element, "has no joints");
    if (skin.joints.size() > std::numeric_limits<std::uint16_t>::max())
        cx.fail(element, "has more than 65535 joints");
    GltfSkin result;
    for (int node : skin.joints) {
        if (node < 0 || std::size_t(node) >= cx.model.nodes.size())
            cx.fail(element, "joint node " + std::to_string(node) + " does not exist");
        result.jointNodes.push_back(std::uint32_t(node));
    }
    result.inverseBindMatrices.assign(skin.joints.size(), identityMatrix());
    if (skin.inverseBindMatrices >= 0) {
        const std::string use = element + " inverseBindMatrices";
        const Values matrices = readAccessor(cx, skin.inverseBindMatrices, TINYGLTF_TYPE_MAT4, use);
        requireFinite(cx, matrices, skin.inverseBindMatrices, use);
        if (matrices.count < skin.joints.size())
            cx.fail(element, "has " + std::to_string(skin.joints.size()) + " joints but " +
                                 std::to_string(matrices.count) + " inverse bind matrices");
        for (std::size_t j = 0; j < skin.joints.size(); ++j)
            std::copy_n(&matrices.data[16 * j], 16, result.inverseBindMatrices[j].begin());
    }
    return result;
}

// ---------------------------------------------------------------------------------------
// Primitives and welding

// One glTF vertex's data, as compared for welding.
struct VertexData {
    std::array<double, 3> position{};
    std::array<std::uint16_t, kInfluences> joints{};
    std::array<float, kInfluences> weights{};
    std::vector<float> deltas;  // 3 per morph target
};

// Merges glTF vertices into cage vertices: equal data, one cage vertex.
class Welder {
public:
    explicit Welder(std::uint32_t targetCount) : targetCount_(targetCount) {}

    Index add(const VertexData& vertex) {
        key_.clear();
        append(vertex.position.data(), sizeof vertex.position);
        append(vertex.joints.data(), sizeof vertex.joints);
        append(vertex.weights.data(), sizeof vertex.weights);
        append(vertex.deltas.data(), vertex.deltas.size() * sizeof(float));
        const auto [slot, inserted] = cageOf_.try_emplace(key_, Index(positions_.size() / 3));
        if (inserted) {
            positions_.insert(positions_.end(), vertex.position.begin(), vertex.position.end());
            joints_.insert(joints_.end(), vertex.joints.begin(), vertex.joints.end());
            weights_.insert(weights_.end(), vertex.weights.begin(), vertex.weights.end());
            deltas_.insert(deltas_.end(), vertex.deltas.begin(), vertex.deltas.end());
        }
        return slot->second;
    }

    Index count() const { return Index(positions_.size() / 3); }

    // A new cage vertex with the data of cage vertex `v` (to keep touching shells apart).
    Index duplicate(Index v) {
        const auto copy = [v](auto& data, std::size_t width) {
            data.insert(data.end(), data.begin() + std::ptrdiff_t(v * width),
                        data.begin() + std::ptrdiff_t((v + 1) * width));
        };
        copy(positions_, 3);
        copy(joints_, kInfluences);
        copy(weights_, kInfluences);
        copy(deltas_, 3 * std::size_t(targetCount_));
        return count() - 1;
    }

    void finish(GltfAsset& asset) {
        const std::size_t vertices = count();
        asset.mesh.faces.vertexCount = Index(vertices);
        asset.mesh.positions = std::move(positions_);
        if (asset.skin) {
            asset.skin->joints = std::move(joints_);
            asset.skin->weights = std::move(weights_);
        }
        // Vertex-major to target-major.
        asset.morphs.deltas.resize(deltas_.size());
        for (std::size_t v = 0; v < vertices; ++v)
            for (std::size_t t = 0; t < targetCount_; ++t)
                for (std::size_t axis = 0; axis < 3; ++axis)
                    asset.morphs.deltas[(t * vertices + v) * 3 + axis] = deltas_[(v * targetCount_ + t) * 3 + axis];
    }

private:
    void append(const void* bytes, std::size_t size) { key_.append(static_cast<const char*>(bytes), size); }

    std::uint32_t targetCount_;
    std::string key_;
    std::unordered_map<std::string, Index> cageOf_;
    std::vector<double> positions_;
    std::vector<std::uint16_t> joints_;
    std::vector<float> weights_;
    std::vector<float> deltas_;
};

int attribute(const tinygltf::Primitive& primitive, const char* name) {
    const auto found = primitive.attributes.find(name);
    return found == primitive.attributes.end() ? -1 : found->second;
}

// Corner lists (3 per triangle, local vertex numbers) of a primitive of `vertexCount` vertices.
std::vector<std::uint32_t> readTriangles(const Context& cx, const tinygltf::Primitive& primitive,
                                         std::size_t vertexCount, const std::string& element) {
    std::vector<std::uint32_t> indices;
    if (primitive.indices >= 0) {
        const std::string use = element + " indices";
        const Values values = readAccessor(cx, primitive.indices, TINYGLTF_TYPE_SCALAR, use);
        for (std::size_t i = 0; i < values.count; ++i) {
            const double index = values.data[i];
            if (!(index >= 0 && index < double(vertexCount) && index == std::floor(index)))
                cx.fail("accessor " + std::to_string(primitive.indices) + " (" + use + ")",
                        "index " + std::to_string(i) + " is " + number(index) + ", out of range (" +
                            std::to_string(vertexCount) + " vertices)");
            indices.push_back(std::uint32_t(index));
        }
    } else {
        for (std::size_t v = 0; v < vertexCount; ++v) indices.push_back(std::uint32_t(v));
    }
    const int mode = primitive.mode < 0 ? TINYGLTF_MODE_TRIANGLES : primitive.mode;
    if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP && mode != TINYGLTF_MODE_TRIANGLE_FAN)
        cx.fail(element, "mode " + std::to_string(mode) + " is points or lines; the cage needs triangles");
    if (mode == TINYGLTF_MODE_TRIANGLES) {
        if (indices.size() % 3 != 0)
            cx.fail(element, std::to_string(indices.size()) + " indices are not a whole number of triangles");
        return indices;
    }
    std::vector<std::uint32_t> corners;
    for (std::size_t i = 0; i + 2 < indices.size(); ++i) {
        if (mode == TINYGLTF_MODE_TRIANGLE_STRIP)  // glTF: {i, i + (1 + i % 2), i + (2 - i % 2)}
            corners.insert(corners.end(), {indices[i], indices[i + 1 + i % 2], indices[i + 2 - i % 2]});
        else  // TRIANGLE_FAN, glTF: {i + 1, i + 2, 0}
            corners.insert(corners.end(), {indices[i + 1], indices[i + 2], indices[0]});
    }
    return corners;
}

// JOINTS_0 / WEIGHTS_0 of one vertex into `vertex`: checked, zero-weight slots on joint 0, normalised.
void skinVertex(const Context& cx, const Values& joints, const Values& weights, std::size_t v,
                std::size_t jointCount, const std::string& jointsUse, const std::string& weightsUse,
                VertexData& vertex) {
    double sum = 0;
    for (std::size_t k = 0; k < kInfluences; ++k) {
        const double weight = weights.at(v, k), joint = joints.at(v, k);
        if (!std::isfinite(weight) || weight < 0)
            cx.fail(weightsUse, "vertex " + std::to_string(v) + ": weight " + number(weight) +
                                    " is negative or not finite");
        if (weight > 0 && !(joint >= 0 && joint < double(jointCount) && joint == std::floor(joint)))
            cx.fail(jointsUse, "vertex " + std::to_string(v) + ": joint " + number(joint) +
                                   " is out of range (the skin has " + std::to_string(jointCount) + " joints)");
        vertex.joints[k] = weight > 0 ? std::uint16_t(joint) : 0;
        sum += weight;
    }
    if (!(sum > 0)) cx.fail(weightsUse, "vertex " + std::to_string(v) + ": the weights sum to 0");
    for (std::size_t k = 0; k < kInfluences; ++k) vertex.weights[k] = float(weights.at(v, k) / sum);
}

struct PrimitiveAttributes {
    Values positions, joints, weights;
    Values uvs;  // TEXCOORD_0; count 0: none
    std::vector<Values> targets;  // POSITION deltas per morph target (empty Values: none)
};

std::string accessorUse(int index, const std::string& use) {
    return "accessor " + std::to_string(index) + " (" + use + ")";
}

PrimitiveAttributes readAttributes(const Context& cx, const tinygltf::Primitive& primitive,
                                   const std::string& element, const GltfAsset& asset) {
    PrimitiveAttributes attributes;
    const int position = attribute(primitive, "POSITION");
    if (position < 0) cx.fail(element, "has no POSITION attribute");
    attributes.positions = readAccessor(cx, position, TINYGLTF_TYPE_VEC3, element + " POSITION");
    requireFinite(cx, attributes.positions, position, element + " POSITION");
    const std::size_t count = attributes.positions.count;
    if (asset.skin) {
        const int joints = attribute(primitive, "JOINTS_0"), weights = attribute(primitive, "WEIGHTS_0");
        if (joints < 0 || weights < 0) cx.fail(element, "the mesh is skinned but this primitive has no JOINTS_0/WEIGHTS_0");
        attributes.joints = readAccessor(cx, joints, TINYGLTF_TYPE_VEC4, element + " JOINTS_0");
        attributes.weights = readAccessor(cx, weights, TINYGLTF_TYPE_VEC4, element + " WEIGHTS_0");
        requireCount(cx, attributes.joints, count, joints, element + " JOINTS_0");
        requireCount(cx, attributes.weights, count, weights, element + " WEIGHTS_0");
    }
    if (const int uv = attribute(primitive, "TEXCOORD_0"); uv >= 0) {
        const std::string use = element + " TEXCOORD_0";
        attributes.uvs = readAccessor(cx, uv, TINYGLTF_TYPE_VEC2, use);
        const tinygltf::Accessor& accessor = cx.model.accessors[std::size_t(uv)];
        const int type = accessor.componentType;
        if (type != TINYGLTF_COMPONENT_TYPE_FLOAT &&
            !(accessor.normalized && (type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE ||
                                      type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT)))
            cx.fail(accessorUse(uv, use), "component type " + std::to_string(type) +
                                              ", expected FLOAT or normalized UNSIGNED_BYTE / UNSIGNED_SHORT");
        requireFinite(cx, attributes.uvs, uv, use);
        requireCount(cx, attributes.uvs, count, uv, use);
    }
    if (primitive.targets.size() != asset.morphs.targetCount)
        cx.fail(element, "has " + std::to_string(primitive.targets.size()) + " morph targets, primitive 0 has " +
                             std::to_string(asset.morphs.targetCount));
    for (std::size_t t = 0; t < primitive.targets.size(); ++t) {
        const auto found = primitive.targets[t].find("POSITION");
        attributes.targets.emplace_back();
        if (found == primitive.targets[t].end()) continue;
        const std::string use = element + " target " + std::to_string(t) + " POSITION";
        attributes.targets.back() = readAccessor(cx, found->second, TINYGLTF_TYPE_VEC3, use);
        requireFinite(cx, attributes.targets.back(), found->second, use);
        requireCount(cx, attributes.targets.back(), count, found->second, use);
    }
    return attributes;
}

// What the primitives add up to beyond the welded cage: per glTF vertex its UV, per cage
// corner its glTF vertex.
struct CageExtras {
    std::vector<double> uvs;          // 2 per glTF vertex (0, 0 where a primitive has none)
    std::size_t primitivesWithUv = 0, primitivesWithoutUv = 0;
    std::vector<Index> gltfCorners;   // per entry of mesh.faces.verts
    std::size_t degenerate = 0;
};

// Welds one primitive's vertices into the cage and adds its triangles.
void addPrimitive(const Context& cx, std::size_t meshIndex, std::size_t index, Welder& welder,
                  GltfAsset& asset, CageExtras& extras) {
    const tinygltf::Primitive& primitive = cx.model.meshes[meshIndex].primitives[index];
    const std::string element = primitiveName(meshIndex, index);
    const PrimitiveAttributes attributes = readAttributes(cx, primitive, element, asset);
    const std::size_t count = attributes.positions.count;
    const std::vector<std::uint32_t> corners = readTriangles(cx, primitive, count, element);
    const std::string jointsUse = accessorUse(attribute(primitive, "JOINTS_0"), element + " JOINTS_0");
    const std::string weightsUse = accessorUse(attribute(primitive, "WEIGHTS_0"), element + " WEIGHTS_0");

    asset.primitiveFirstVertex.push_back(Index(asset.cageVertexOf.size()));
    const std::size_t first = asset.cageVertexOf.size();
    VertexData vertex;
    vertex.deltas.resize(3 * std::size_t(asset.morphs.targetCount));
    for (std::size_t v = 0; v < count; ++v) {
        for (std::size_t axis = 0; axis < 3; ++axis) vertex.position[axis] = attributes.positions.at(v, axis);
        if (asset.skin)
            skinVertex(cx, attributes.joints, attributes.weights, v, asset.skin->jointNodes.size(), jointsUse,
                       weightsUse, vertex);
        for (std::size_t t = 0; t < attributes.targets.size(); ++t)
            for (std::size_t axis = 0; axis < 3; ++axis)
                vertex.deltas[3 * t + axis] =
                    attributes.targets[t].data.empty() ? 0.0f : float(attributes.targets[t].at(v, axis));
        asset.cageVertexOf.push_back(welder.add(vertex));
        for (std::size_t axis = 0; axis < 2; ++axis)
            extras.uvs.push_back(attributes.uvs.count == 0 ? 0.0 : attributes.uvs.at(v, axis));
    }
    ++(attributes.uvs.count == 0 ? extras.primitivesWithoutUv : extras.primitivesWithUv);
    for (std::size_t c = 0; c < corners.size(); c += 3) {
        const std::array<Index, 3> face = {asset.cageVertexOf[first + corners[c]],
                                           asset.cageVertexOf[first + corners[c + 1]],
                                           asset.cageVertexOf[first + corners[c + 2]]};
        if (face[0] == face[1] || face[1] == face[2] || face[2] == face[0]) {
            ++extras.degenerate;
            continue;
        }
        asset.mesh.faces.addFace(face);
        for (std::size_t k = 0; k < 3; ++k) extras.gltfCorners.push_back(Index(first + corners[c + k]));
    }
}

// ---------------------------------------------------------------------------------------
// Touching shells

// The face corners (half-edges) of each undirected edge, grouped: edges[i] = {key, corner}.
std::vector<std::pair<std::uint64_t, Index>> edgeCorners(const Faces& faces) {
    std::vector<std::pair<std::uint64_t, Index>> edges;
    edges.reserve(faces.verts.size());
    for (Index f = 0; f < faces.faceCount(); ++f)
        for (Index k = 0; k < faces.faceSize(f); ++k) {
            const Index h = faces.offsets[f] + k;
            const Index next = faces.offsets[f] + (k + 1) % faces.faceSize(f);
            const Index a = std::min(faces.verts[h], faces.verts[next]), b = std::max(faces.verts[h], faces.verts[next]);
            edges.emplace_back((std::uint64_t(a) << 32) | b, h);
        }
    std::sort(edges.begin(), edges.end());
    return edges;
}

// The face holding each corner.
std::vector<Index> cornerFaces(const Faces& faces) {
    std::vector<Index> faceOf(faces.verts.size());
    for (Index f = 0; f < faces.faceCount(); ++f)
        std::fill(faceOf.begin() + faces.offsets[f], faceOf.begin() + faces.offsets[f + 1], f);
    return faceOf;
}

// Calls bad(first, last) for each edge group [first, last) of `edges` that makes the mesh
// non-manifold: three or more faces, or two in the same direction; good(first) for the others
// shared by two faces.
template <class Bad, class Good>
void forEachSharedEdge(const Faces& faces, const std::vector<std::pair<std::uint64_t, Index>>& edges, Bad bad,
                       Good good) {
    for (std::size_t first = 0, last = 0; first < edges.size(); first = last) {
        while (last < edges.size() && edges[last].first == edges[first].first) ++last;
        const bool sameDirection =
            last - first == 2 && faces.verts[edges[first].second] == faces.verts[edges[first + 1].second];
        if (last - first > 2 || sameDirection) bad(first, last);
        else if (last - first == 2) good(first);
    }
}

Index findRoot(std::vector<Index>& parent, Index x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
}

// Un-welds the vertices of edges that make the cage non-manifold, one copy per shell (faces
// connected through manifold edges); where one shell meets itself, per face beyond the first
// two. Returns how many such edges there were.
std::size_t separateTouchingShells(Faces& faces, Welder& welder) {
    std::vector<std::pair<std::uint64_t, Index>> edges = edgeCorners(faces);
    const std::vector<Index> faceOf = cornerFaces(faces);
    std::vector<Index> shell(faces.faceCount());
    for (Index f = 0; f < faces.faceCount(); ++f) shell[f] = f;
    std::vector<char> split(welder.count(), 0);
    std::size_t badEdges = 0;
    forEachSharedEdge(
        faces, edges,
        [&](std::size_t first, std::size_t) {
            ++badEdges;
            split[edges[first].first >> 32] = split[edges[first].first & 0xffffffffu] = 1;
        },
        [&](std::size_t first) {
            shell[findRoot(shell, faceOf[edges[first].second])] = findRoot(shell, faceOf[edges[first + 1].second]);
        });
    if (badEdges == 0) return 0;
    // One copy of each split vertex per shell; the first shell met keeps the vertex.
    std::unordered_map<std::uint64_t, Index> copyOf;
    std::vector<Index> keeper(split.size(), kNoIndex);
    for (std::size_t h = 0; h < faces.verts.size(); ++h) {
        const Index v = faces.verts[h];
        if (!split[v]) continue;
        const Index root = findRoot(shell, faceOf[h]);
        if (keeper[v] == kNoIndex) keeper[v] = root;
        if (keeper[v] == root) continue;
        const auto [slot, inserted] = copyOf.try_emplace((std::uint64_t(v) << 32) | root, kNoIndex);
        if (inserted) slot->second = welder.duplicate(v);
        faces.verts[h] = slot->second;
    }
    // A shell that meets itself: faces beyond the first (and a second of the other direction)
    // get their own copies of the edge's two vertices.
    edges = edgeCorners(faces);
    forEachSharedEdge(
        faces, edges,
        [&](std::size_t first, std::size_t last) {
            const bool keepSecond = faces.verts[edges[first].second] != faces.verts[edges[first + 1].second];
            for (std::size_t e = first + (keepSecond ? 2 : 1); e < last; ++e) {
                const Index f = faceOf[edges[e].second];
                const Index a = faces.verts[edges[e].second];
                const Index b = Index(edges[e].first >> 32) == a ? Index(edges[e].first & 0xffffffffu)
                                                                  : Index(edges[e].first >> 32);
                for (Index h = faces.offsets[f]; h < faces.offsets[f + 1]; ++h)
                    if (faces.verts[h] == a || faces.verts[h] == b) faces.verts[h] = welder.duplicate(faces.verts[h]);
            }
        },
        [](std::size_t) {});
    return badEdges;
}

// Default morph weights: the node's, else the mesh's, else zeros.
void readMorphDefaults(const Context& cx, const tinygltf::Node& node, std::size_t nodeIndex,
                       const tinygltf::Mesh& mesh, std::size_t meshIndex, GltfMorphs& morphs) {
    morphs.targetCount = mesh.primitives.empty() ? 0 : std::uint32_t(mesh.primitives[0].targets.size());
    const bool fromNode = !node.weights.empty();
    const std::vector<double>& weights = fromNode ? node.weights : mesh.weights;
    const std::string element = fromNode ? named("node", nodeIndex) : named("mesh", meshIndex);
    morphs.defaultWeights.assign(morphs.targetCount, 0.0f);
    if (weights.empty()) return;
    if (weights.size() != morphs.targetCount)
        cx.fail(element, "has " + std::to_string(weights.size()) + " morph weights for " +
                             std::to_string(morphs.targetCount) + " targets");
    for (std::size_t t = 0; t < weights.size(); ++t) {
        if (!std::isfinite(weights[t])) cx.fail(element, "morph weight " + std::to_string(t) + " is not finite");
        morphs.defaultWeights[t] = float(weights[t]);
    }
}

void readCage(const Context& cx, GltfAsset& asset) {
    const tinygltf::Node& node = cx.model.nodes[asset.meshNode];
    const std::size_t meshIndex = std::size_t(node.mesh);
    const tinygltf::Mesh& mesh = cx.model.meshes[meshIndex];
    if (mesh.primitives.empty()) cx.fail(named("mesh", meshIndex), "has no primitives");
    if (node.skin >= 0) asset.skin = readSkin(cx, std::size_t(node.skin));
    readMorphDefaults(cx, node, asset.meshNode, mesh, meshIndex, asset.morphs);
    Welder welder(asset.morphs.targetCount);
    CageExtras extras;
    bool moreInfluences = false;
    for (std::size_t p = 0; p < mesh.primitives.size(); ++p) {
        addPrimitive(cx, meshIndex, p, welder, asset, extras);
        moreInfluences = moreInfluences || attribute(mesh.primitives[p], "JOINTS_1") >= 0;
    }
    const std::string meshName = cx.path + ": " + named("mesh", meshIndex);
    if (const std::size_t touching = separateTouchingShells(asset.mesh.faces, welder); touching > 0) {
        for (std::size_t c = 0; c < extras.gltfCorners.size(); ++c)
            asset.cageVertexOf[extras.gltfCorners[c]] = asset.mesh.faces.verts[c];
        asset.warnings.push_back(meshName + ": kept touching shells apart (" + std::to_string(touching) +
                                 " edges shared by more than two triangles, or twice in one direction, after "
                                 "welding by position)");
    }
    welder.finish(asset);
    asset.mesh.source.path = cx.path;
    if (asset.mesh.faces.faceCount() == 0) cx.fail(named("mesh", meshIndex), "has no triangles");
    if (extras.primitivesWithUv > 0) {
        asset.mesh.uv.width = 2;
        asset.mesh.uv.values = std::move(extras.uvs);
        asset.mesh.uv.corners = std::move(extras.gltfCorners);
        separateSharedValues(asset.mesh);  // a glTF vertex whose copies were kept apart
        if (extras.primitivesWithoutUv > 0)
            asset.warnings.push_back(meshName + ": " + std::to_string(extras.primitivesWithoutUv) +
                                     " primitives without TEXCOORD_0 get UV (0, 0)");
    }
    if (extras.degenerate > 0)
        asset.warnings.push_back(meshName + ": dropped " + std::to_string(extras.degenerate) +
                                 " degenerate triangles (a corner repeated after welding)");
    if (moreInfluences && asset.skin)
        asset.warnings.push_back(cx.path + ": " + named("mesh", meshIndex) +
                                 ": JOINTS_1/WEIGHTS_1 ignored (at most 4 influences; weights renormalised)");
}

// ---------------------------------------------------------------------------------------
// Material

// The MIME type of PNG or JPEG bytes, from their magic bytes; empty for anything else.
std::string imageType(const std::vector<unsigned char>& bytes) {
    static constexpr unsigned char png[] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    static constexpr unsigned char jpeg[] = {0xff, 0xd8, 0xff};
    if (bytes.size() >= sizeof png && std::equal(std::begin(png), std::end(png), bytes.begin())) return "image/png";
    if (bytes.size() >= sizeof jpeg && std::equal(std::begin(jpeg), std::end(jpeg), bytes.begin())) return "image/jpeg";
    return {};
}

GltfImage readImage(const Context& cx, const ImageBytes& images, int index, const std::string& user) {
    if (index < 0 || std::size_t(index) >= cx.model.images.size())
        cx.fail(user, "image " + std::to_string(index) + " does not exist");
    const tinygltf::Image& image = cx.model.images[std::size_t(index)];
    const std::string element = named("image", std::size_t(index));
    const std::string where = image.bufferView >= 0 ? "buffer view " + std::to_string(image.bufferView)
                              : image.uri.starts_with("data:") ? std::string("its data URI")
                                                               : "uri '" + image.uri + "'";
    GltfImage result;
    result.index = std::size_t(index);
    if (std::size_t(index) < images.size()) result.bytes = images[std::size_t(index)];
    if (result.bytes.empty()) cx.fail(element, where + ": missing, unreadable or empty");
    result.mimeType = imageType(result.bytes);
    if (result.mimeType.empty()) cx.fail(element, where + ": neither a PNG nor a JPEG image");
    result.name = !image.name.empty() ? image.name
                  : image.uri.empty() || image.uri.starts_with("data:")
                      ? std::string()
                      : std::filesystem::path(percentDecoded(image.uri)).filename().string();
    return result;
}

GltfSampler readSampler(const Context& cx, int index, const std::string& user) {
    GltfSampler result;
    if (index < 0) return result;
    if (std::size_t(index) >= cx.model.samplers.size())
        cx.fail(user, "sampler " + std::to_string(index) + " does not exist");
    const tinygltf::Sampler& sampler = cx.model.samplers[std::size_t(index)];
    result.magFilter = sampler.magFilter;
    result.minFilter = sampler.minFilter;
    result.wrapS = sampler.wrapS;
    result.wrapT = sampler.wrapT;
    return result;
}

// The base colour of the first material the cage's primitives name (a warning if they name more).
void readMaterial(const Context& cx, const ImageBytes& images, GltfAsset& asset) {
    const std::size_t meshIndex = std::size_t(cx.model.nodes[asset.meshNode].mesh);
    const auto& primitives = cx.model.meshes[meshIndex].primitives;
    int chosen = -1;
    bool several = false;
    for (std::size_t p = 0; p < primitives.size(); ++p) {
        const int material = primitives[p].material;
        if (material < 0) continue;
        if (std::size_t(material) >= cx.model.materials.size())
            cx.fail(primitiveName(meshIndex, p), "material " + std::to_string(material) + " does not exist");
        if (chosen < 0) chosen = material;
        several = several || material != chosen;
    }
    if (chosen < 0) return;
    const std::string element = named("material", std::size_t(chosen));
    if (several)
        asset.warnings.push_back(cx.path + ": " + named("mesh", meshIndex) +
                                 ": primitives name several materials; only " + element + " is kept");
    const tinygltf::Material& material = cx.model.materials[std::size_t(chosen)];
    GltfMaterial result;
    result.name = material.name;
    copyVector(cx, material.pbrMetallicRoughness.baseColorFactor, result.baseColorFactor, element, "baseColorFactor");
    const tinygltf::TextureInfo& info = material.pbrMetallicRoughness.baseColorTexture;
    if (info.index >= 0) {
        if (std::size_t(info.index) >= cx.model.textures.size())
            cx.fail(element, "base colour texture " + std::to_string(info.index) + " does not exist");
        const std::string textureName = named("texture", std::size_t(info.index));
        const tinygltf::Texture& texture = cx.model.textures[std::size_t(info.index)];
        if (info.texCoord != 0)
            asset.warnings.push_back(cx.path + ": " + element + ": the base colour texture reads TEXCOORD_" +
                                     std::to_string(info.texCoord) + "; psub reads TEXCOORD_0 only");
        if (texture.source < 0)
            asset.warnings.push_back(cx.path + ": " + textureName + ": no PNG or JPEG source; texture ignored");
        else
            result.baseColorTexture = readImage(cx, images, texture.source, textureName);
        result.sampler = readSampler(cx, texture.sampler, textureName);
    }
    asset.material = std::move(result);
}

// ---------------------------------------------------------------------------------------
// Clips

struct PathInfo {
    GltfPath path;
    int type;
};

std::optional<PathInfo> pathOf(const std::string& name) {
    if (name == "translation") return PathInfo{GltfPath::Translation, TINYGLTF_TYPE_VEC3};
    if (name == "rotation") return PathInfo{GltfPath::Rotation, TINYGLTF_TYPE_VEC4};
    if (name == "scale") return PathInfo{GltfPath::Scale, TINYGLTF_TYPE_VEC3};
    if (name == "weights") return PathInfo{GltfPath::Weights, TINYGLTF_TYPE_SCALAR};
    return std::nullopt;
}

std::optional<GltfInterpolation> interpolationOf(const std::string& name) {
    if (name == "LINEAR" || name.empty()) return GltfInterpolation::Linear;
    if (name == "STEP") return GltfInterpolation::Step;
    if (name == "CUBICSPLINE") return GltfInterpolation::CubicSpline;
    return std::nullopt;
}

std::vector<float> toFloats(const Values& values) {
    std::vector<float> result(values.data.size());
    std::transform(values.data.begin(), values.data.end(), result.begin(), [](double v) { return float(v); });
    return result;
}

std::vector<float> readTimes(const Context& cx, int index, const std::string& use) {
    const Values times = readAccessor(cx, index, TINYGLTF_TYPE_SCALAR, use);
    requireFinite(cx, times, index, use);
    if (times.count == 0) cx.fail(accessorUse(index, use), "has no keyframes");
    std::vector<float> result = toFloats(times);
    for (std::size_t k = 1; k < result.size(); ++k)
        if (result[k] < result[k - 1])
            cx.fail(accessorUse(index, use), "keyframe " + std::to_string(k) + " comes before keyframe " +
                                                 std::to_string(k - 1));
    return result;
}

// The morph target count that a weights channel on `node` animates.
std::uint32_t weightsWidth(const Context& cx, std::size_t node, const std::string& element) {
    const int mesh = cx.model.nodes[node].mesh;
    if (mesh < 0 || std::size_t(mesh) >= cx.model.meshes.size())
        cx.fail(element, "animates the morph weights of node " + std::to_string(node) + ", which has no mesh");
    const auto& primitives = cx.model.meshes[std::size_t(mesh)].primitives;
    return primitives.empty() ? 0 : std::uint32_t(primitives[0].targets.size());
}

// Channel `c` of animation `a`, or nullopt for a channel glTF says to ignore.
std::optional<GltfChannel> readChannel(const Context& cx, const GltfAsset& asset, std::size_t a, std::size_t c,
                                       std::vector<std::string>& warnings) {
    const tinygltf::Animation& animation = cx.model.animations[a];
    const tinygltf::AnimationChannel& channel = animation.channels[c];
    const std::string element = named("animation", a) + " '" + animation.name + "' channel " + std::to_string(c);
    const std::optional<PathInfo> path = pathOf(channel.target_path);
    if (channel.target_node < 0 || !path) {
        warnings.push_back(cx.path + ": " + element + ": ignored (no target node, or path '" +
                           channel.target_path + "')");
        return std::nullopt;
    }
    if (std::size_t(channel.target_node) >= cx.model.nodes.size())
        cx.fail(element, "node " + std::to_string(channel.target_node) + " does not exist");
    if (channel.sampler < 0 || std::size_t(channel.sampler) >= animation.samplers.size())
        cx.fail(element, "sampler " + std::to_string(channel.sampler) + " does not exist");
    GltfChannel result;
    result.node = std::uint32_t(channel.target_node);
    result.path = path->path;
    if (result.path != GltfPath::Weights && asset.nodes[result.node].matrix)
        cx.fail(element, "animates node " + std::to_string(result.node) +
                             ", which has a matrix (glTF allows only translation/rotation/scale there)");
    const tinygltf::AnimationSampler& sampler = animation.samplers[std::size_t(channel.sampler)];
    const std::string samplerName = named("animation", a) + " '" + animation.name + "' sampler " +
                                    std::to_string(channel.sampler);
    const std::optional<GltfInterpolation> interpolation = interpolationOf(sampler.interpolation);
    if (!interpolation) cx.fail(samplerName, "unknown interpolation '" + sampler.interpolation + "'");
    result.interpolation = *interpolation;
    result.width = result.path == GltfPath::Weights ? weightsWidth(cx, result.node, element)
                   : result.path == GltfPath::Rotation ? 4u : 3u;
    if (result.width == 0) {
        warnings.push_back(cx.path + ": " + element + ": ignored (the mesh has no morph targets)");
        return std::nullopt;
    }
    result.times = readTimes(cx, sampler.input, samplerName + " input");
    const Values values = readAccessor(cx, sampler.output, path->type, samplerName + " output");
    requireFinite(cx, values, sampler.output, samplerName + " output");
    const std::size_t perKey = (result.interpolation == GltfInterpolation::CubicSpline ? 3 : 1) *
                               (result.path == GltfPath::Weights ? result.width : 1);
    requireCount(cx, values, result.times.size() * perKey, sampler.output, samplerName + " output");
    result.values = toFloats(values);
    return result;
}

GltfClip readClip(const Context& cx, const GltfAsset& asset, std::size_t a, std::vector<std::string>& warnings) {
    const tinygltf::Animation& animation = cx.model.animations[a];
    GltfClip clip;
    clip.name = animation.name;
    for (std::size_t c = 0; c < animation.channels.size(); ++c) {
        std::optional<GltfChannel> channel = readChannel(cx, asset, a, c, warnings);
        if (!channel) continue;
        clip.duration = std::max(clip.duration, double(channel->times.back()));
        clip.channels.push_back(std::move(*channel));
    }
    return clip;
}

// ---------------------------------------------------------------------------------------
// The file

std::vector<unsigned char> readBytes(const std::string& path) {
    const std::string text = readInputFile(path);
    try {
        return std::vector<unsigned char>(text.begin(), text.end());
    } catch (const std::bad_alloc&) {
        throw InputError(path + ": the file does not fit in memory");
    }
}

// tinygltf decodes images by default; psub keeps their bytes (per image index) undecoded.

bool keepImageBytes(tinygltf::Image*, const int index, std::string*, std::string*, int, int,
                    const unsigned char* bytes, int size, void* user) {
    auto& images = *static_cast<ImageBytes*>(user);
    if (index < 0 || size < 0) return true;
    if (images.size() <= std::size_t(index)) images.resize(std::size_t(index) + 1);
    images[std::size_t(index)].assign(bytes, bytes + size);
    return true;
}

// ---------------------------------------------------------------------------------------
// Checks before tinygltf parses: what it would crash on, hang on or silently accept.

constexpr std::size_t kMaxJsonDepth = 128;  // glTF itself nests about 6 deep; extras may add some

const char* fileKind(mode_t mode) {
    if (S_ISDIR(mode)) return "a directory";
    if (S_ISFIFO(mode)) return "a named pipe (FIFO)";
    if (S_ISCHR(mode)) return "a character device";
    if (S_ISBLK(mode)) return "a block device";
    if (S_ISSOCK(mode)) return "a socket";
    return "not a regular file";
}

// The deepest nesting of arrays and objects in `json` (strings skipped), stopping past `limit`.
std::size_t jsonDepth(std::string_view json, std::size_t limit) {
    std::size_t depth = 0, deepest = 0;
    bool inString = false;
    for (std::size_t i = 0; i < json.size() && deepest <= limit; ++i) {
        const char c = json[i];
        if (inString) {
            if (c == '\\') ++i;
            else if (c == '"') inString = false;
        } else if (c == '"') {
            inString = true;
        } else if (c == '[' || c == '{') {
            deepest = std::max(deepest, ++depth);
        } else if ((c == ']' || c == '}') && depth > 0) {
            --depth;
        }
    }
    return deepest;
}

// The JSON text of a .gltf file, or of a .glb's first chunk; refuses glb versions other than 2.
std::string_view jsonText(const std::string& path, const std::vector<unsigned char>& bytes, bool binary) {
    const char* text = reinterpret_cast<const char*>(bytes.data());
    if (!binary) return {text, bytes.size()};
    if (bytes.size() < 20) throw InputError(path + ": glb header: the file has " + std::to_string(bytes.size()) +
                                            " bytes, fewer than a header and a chunk header");
    const std::uint32_t version = load<std::uint32_t>(bytes.data() + 4);
    if (version != 2)
        throw InputError(path + ": glb header: version " + std::to_string(version) + ", expected 2 (glTF 2.0)");
    const std::size_t length = std::min<std::size_t>(load<std::uint32_t>(bytes.data() + 12), bytes.size() - 20);
    return {text + 20, length};
}

std::string percentDecoded(const std::string& uri) {
    std::string out;
    for (std::size_t i = 0; i < uri.size(); ++i) {
        const auto hex = [&](char c) { return std::isxdigit(static_cast<unsigned char>(c)) != 0; };
        if (uri[i] == '%' && i + 2 < uri.size() && hex(uri[i + 1]) && hex(uri[i + 2])) {
            out += char(std::stoi(uri.substr(i + 1, 2), nullptr, 16));
            i += 2;
        } else {
            out += uri[i];
        }
    }
    return out;
}

// An external file (buffer or image `uri`) must be a regular file: a FIFO would block the read
// forever, a directory or device has no sensible contents. Buffers must also have byteLength bytes.
void checkExternalFile(const std::string& path, const std::string& baseDir, const std::string& element,
                       const nlohmann::json& object) {
    const auto uri = object.find("uri");
    if (uri == object.end() || !uri->is_string()) return;
    const std::string text = uri->get<std::string>();
    if (text.starts_with("data:")) return;
    const std::string name = percentDecoded(text);
    for (const std::string& candidate : {baseDir.empty() ? name : baseDir + "/" + name, name}) {
        struct stat info {};
        if (::stat(candidate.c_str(), &info) != 0) continue;
        if (!S_ISREG(info.st_mode))
            throw InputError(path + ": " + element + ": uri '" + text + "' (" + candidate + ") is " +
                             fileKind(info.st_mode) + ", not a regular file");
        const auto length = object.find("byteLength");
        if (element.starts_with("buffer") && length != object.end() && length->is_number_unsigned() &&
            std::uintmax_t(info.st_size) != length->get<std::uintmax_t>())
            throw InputError(path + ": " + element + ": uri '" + text + "' (" + candidate + ") has " +
                             std::to_string(info.st_size) + " bytes, byteLength says " +
                             std::to_string(length->get<std::uintmax_t>()));
        return;
    }
}

void checkByteOffset(const std::string& path, const std::string& element, const nlohmann::json& object) {
    if (!object.is_object()) return;
    const auto offset = object.find("byteOffset");
    if (offset == object.end()) return;
    if (!offset->is_number_integer() || offset->get<std::int64_t>() < 0)
        throw InputError(path + ": " + element + ": byteOffset " + offset->dump() +
                         " is not a non-negative integer");
}

// Each element of the top-level array `key`, with its name ("accessor 3") for messages.
template <class Check>
void forEach(const nlohmann::json& root, const char* key, const char* kind, Check check) {
    const auto array = root.find(key);
    if (array == root.end() || !array->is_array()) return;
    for (std::size_t i = 0; i < array->size(); ++i)
        if ((*array)[i].is_object()) check(named(kind, i), (*array)[i]);
}

void precheck(const std::string& path, std::string_view json, const std::string& baseDir) {
    if (jsonDepth(json, kMaxJsonDepth) > kMaxJsonDepth)
        throw InputError(path + ": the JSON nests deeper than " + std::to_string(kMaxJsonDepth) +
                         " arrays and objects");
    const nlohmann::json root = nlohmann::json::parse(json, nullptr, false);
    if (!root.is_object()) return;  // tinygltf reports what is wrong with it
    forEach(root, "accessors", "accessor", [&](const std::string& element, const nlohmann::json& accessor) {
        checkByteOffset(path, element, accessor);
        const auto sparse = accessor.find("sparse");
        if (sparse == accessor.end() || !sparse->is_object()) return;
        for (const char* part : {"indices", "values"})
            if (const auto found = sparse->find(part); found != sparse->end())
                checkByteOffset(path, element + " sparse " + part, *found);
    });
    forEach(root, "bufferViews", "buffer view", [&](const std::string& element, const nlohmann::json& view) {
        checkByteOffset(path, element, view);
    });
    forEach(root, "buffers", "buffer", [&](const std::string& element, const nlohmann::json& buffer) {
        checkExternalFile(path, baseDir, element, buffer);
    });
    forEach(root, "images", "image", [&](const std::string& element, const nlohmann::json& image) {
        checkExternalFile(path, baseDir, element, image);
    });
    if (const auto scene = root.find("scene"); scene != root.end()) {
        const auto scenes = root.find("scenes");
        const std::size_t count = scenes != root.end() && scenes->is_array() ? scenes->size() : 0;
        if (!scene->is_number_integer() || scene->get<std::int64_t>() < 0 ||
            std::size_t(scene->get<std::int64_t>()) >= count)
            throw InputError(path + ": scene " + scene->dump() + " does not exist (the file has " +
                             std::to_string(count) + " scenes)");
    }
}

// Early glTF 2.0 exporters (COLLADA2GLTF) wrote skins the glTF 1.0 way: "jointNames" matched
// to the nodes' "jointName" instead of "joints" (required), which tinygltf refuses without a
// message. Such skins get their "joints" from those names (a warning says so); the patched JSON
// text, or nullopt when nothing needed it. InputError naming the skin when a name matches no
// node, or a skin has neither.
std::optional<std::string> legacyJointsResolved(const std::string& path, std::string_view json,
                                                std::vector<std::string>& warnings) {
    nlohmann::json root = nlohmann::json::parse(json, nullptr, false);
    if (!root.is_object() || !root.contains("skins") || !root["skins"].is_array()) return std::nullopt;
    bool patched = false;
    nlohmann::json& skins = root["skins"];
    for (std::size_t s = 0; s < skins.size(); ++s) {
        nlohmann::json& skin = skins[s];
        if (!skin.is_object() || skin.contains("joints")) continue;
        const std::string element = path + ": " + named("skin", s);
        const auto names = skin.find("jointNames");
        if (names == skin.end() || !names->is_array())
            throw InputError(element + ": has no \"joints\" (required by glTF 2.0)");
        nlohmann::json joints = nlohmann::json::array();
        for (const nlohmann::json& name : *names) {
            const nlohmann::json* nodes = root.contains("nodes") ? &root["nodes"] : nullptr;
            std::int64_t found = -1;
            for (std::size_t n = 0; nodes && nodes->is_array() && n < nodes->size(); ++n) {
                const nlohmann::json& node = (*nodes)[n];
                if (node.is_object() && node.contains("jointName") && node["jointName"] == name) {
                    if (found >= 0)
                        throw InputError(element + ": legacy joint name " + name.dump() + " names nodes " +
                                         std::to_string(found) + " and " + std::to_string(n));
                    found = std::int64_t(n);
                }
            }
            if (found < 0)
                throw InputError(element + ": has no \"joints\" (required by glTF 2.0), and its legacy "
                                 "\"jointNames\" entry " + name.dump() + " matches no node's \"jointName\"");
            joints.push_back(found);
        }
        skin["joints"] = std::move(joints);
        patched = true;
        std::string warning = element + ": no \"joints\"; took them from the legacy \"jointNames\" (glTF 1.0 style)";
        if (const auto bind = skin.find("bindShapeMatrix"); bind != skin.end()) {
            const nlohmann::json identity = {1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0};
            if (*bind != identity) warning += "; its legacy \"bindShapeMatrix\" is not the identity and is ignored";
        }
        warnings.push_back(warning);
    }
    if (!patched) return std::nullopt;
    return root.dump();
}

// `bytes` of a .glb with its JSON chunk replaced by `json` (padded with spaces).
std::vector<unsigned char> withJsonChunk(const std::vector<unsigned char>& bytes, std::string json) {
    while (json.size() % 4) json += ' ';
    const std::size_t oldEnd = std::min<std::size_t>(20 + std::size_t(load<std::uint32_t>(bytes.data() + 12)), bytes.size());
    std::vector<unsigned char> out(bytes.begin(), bytes.begin() + 12);
    const auto word = [&](std::uint32_t v) {
        for (int k = 0; k < 4; ++k) out.push_back(static_cast<unsigned char>(v >> (8 * k)));
    };
    word(std::uint32_t(json.size()));
    out.insert(out.end(), bytes.begin() + 16, bytes.begin() + 20);  // the chunk type
    out.insert(out.end(), json.begin(), json.end());
    out.insert(out.end(), bytes.begin() + std::ptrdiff_t(oldEnd), bytes.end());
    const std::uint32_t total = std::uint32_t(out.size());
    for (int k = 0; k < 4; ++k) out[std::size_t(8 + k)] = static_cast<unsigned char>(total >> (8 * k));
    return out;
}

// tinygltf's file access, made safe: no shell expansion of names, and only regular files are
// read (opened without blocking, so a FIFO that appears after the checks cannot hang us).
bool fileExists(const std::string& name, void*) {
    struct stat info {};
    return ::stat(name.c_str(), &info) == 0;
}

std::string expandNothing(const std::string& name, void*) { return name; }

bool readRegularFile(std::vector<unsigned char>* out, std::string* error, const std::string& name, void*) {
    const int fd = ::open(name.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) {
        *error += std::strerror(errno);
        return false;
    }
    struct stat info {};
    bool ok = ::fstat(fd, &info) == 0 && S_ISREG(info.st_mode);
    if (!ok) *error += std::string("is ") + fileKind(info.st_mode) + ", not a regular file";
    try {
        if (ok) out->resize(std::size_t(info.st_size));
    } catch (const std::bad_alloc&) {
        *error += "does not fit in memory (" + std::to_string(info.st_size) + " bytes)";
        ok = false;
    }
    for (std::size_t done = 0; ok && done < out->size();) {
        const ssize_t got = ::read(fd, out->data() + done, out->size() - done);
        if (got < 0 && errno == EINTR) continue;
        if (got <= 0) {
            *error += got < 0 ? std::strerror(errno) : "the file shrank while being read";
            ok = false;
        }
        done += got > 0 ? std::size_t(got) : 0;
    }
    ::close(fd);
    return ok;
}

bool writeNothing(std::string* error, const std::string&, const std::vector<unsigned char>&, void*) {
    *error += "psub never writes glTF files";
    return false;
}

tinygltf::Model parseFile(const std::string& path, std::vector<std::string>& warnings, ImageBytes& images) {
    std::vector<unsigned char> bytes = readBytes(path);
    if (bytes.empty()) throw InputError(path + ": the file is empty");
    if (bytes.size() > UINT_MAX) throw InputError(path + ": the file is larger than 4 GiB");
    tinygltf::TinyGLTF loader;
    loader.SetImageLoader(&keepImageBytes, &images);
    loader.SetFsCallbacks({&fileExists, &expandNothing, &readRegularFile, &writeNothing, nullptr});
    tinygltf::Model model;
    std::string error, warning;
    const std::string baseDir = std::filesystem::path(path).parent_path().string();
    const bool binary = bytes.size() >= 4 && std::memcmp(bytes.data(), "glTF", 4) == 0;
    precheck(path, jsonText(path, bytes, binary), baseDir);
    if (std::optional<std::string> json = legacyJointsResolved(path, jsonText(path, bytes, binary), warnings))
        bytes = binary ? withJsonChunk(bytes, std::move(*json)) : std::vector<unsigned char>(json->begin(), json->end());
    const unsigned length = unsigned(bytes.size());
    const bool ok = binary ? loader.LoadBinaryFromMemory(&model, &error, &warning, bytes.data(), length, baseDir)
                           : loader.LoadASCIIFromString(&model, &error, &warning,
                                                        reinterpret_cast<const char*>(bytes.data()), length, baseDir);
    if (!ok)
        throw InputError(path + ": not a valid glTF " + (binary ? "binary" : "file") + ": " +
                         (error.empty() ? std::string("unknown error") : oneLine(error)));
    if (!warning.empty()) warnings.push_back(path + ": " + oneLine(warning));
    return model;
}

}  // namespace

GltfAsset readGltf(const std::string& path) {
    GltfAsset asset;
    ImageBytes images;
    const tinygltf::Model model = parseFile(path, asset.warnings, images);
    const Context cx{path, model};
    for (std::size_t n = 0; n < model.nodes.size(); ++n) asset.nodes.push_back(readNode(cx, n));
    linkNodes(cx, asset);
    asset.meshNode = std::uint32_t(findMeshNode(cx));
    readCage(cx, asset);
    readMaterial(cx, images, asset);
    for (std::size_t a = 0; a < model.animations.size(); ++a)
        asset.clips.push_back(readClip(cx, asset, a, asset.warnings));
    return asset;
}

std::optional<std::size_t> findClip(const GltfAsset& asset, std::string_view name) {
    for (std::size_t c = 0; c < asset.clips.size(); ++c)
        if (asset.clips[c].name == name) return c;
    return std::nullopt;
}

}  // namespace psub
