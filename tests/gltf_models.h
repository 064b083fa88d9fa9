// glTF test models written with tinygltf's writer, shared by the animation and playback tests:
// a small builder over tinygltf::Model and the two-bone cylinder.
#pragma once

#include <tiny_gltf.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <numbers>
#include <string>
#include <vector>

namespace psub::test {

struct ModelBuilder {
    tinygltf::Model model;

    ModelBuilder() {
        model.buffers.emplace_back();
        model.asset.version = "2.0";
    }

    // target: TINYGLTF_TARGET_ARRAY_BUFFER for vertex attributes, _ELEMENT_ARRAY_BUFFER for
    // indices, 0 for other data (the validator asks for it on vertex and index data).
    int view(const void* data, std::size_t bytes, int target = 0) {
        std::vector<unsigned char>& buffer = model.buffers[0].data;
        while (buffer.size() % 4 != 0) buffer.push_back(0);
        tinygltf::BufferView bufferView;
        bufferView.buffer = 0;
        bufferView.byteOffset = buffer.size();
        bufferView.byteLength = bytes;
        bufferView.target = target;
        const auto* begin = static_cast<const unsigned char*>(data);
        buffer.insert(buffer.end(), begin, begin + bytes);
        model.bufferViews.push_back(bufferView);
        return int(model.bufferViews.size() - 1);
    }
    int add(const void* data, std::size_t bytes, int componentType, int type, std::size_t count, int target = 0) {
        tinygltf::Accessor accessor;
        accessor.bufferView = view(data, bytes, target);
        accessor.componentType = componentType;
        accessor.type = type;
        accessor.count = count;
        model.accessors.push_back(accessor);
        return int(model.accessors.size() - 1);
    }
    int floats(const std::vector<float>& values, int type, std::size_t width, int target = 0) {
        return add(values.data(), values.size() * sizeof(float), TINYGLTF_COMPONENT_TYPE_FLOAT, type,
                   values.size() / width, target);
    }
    int attribute(const std::vector<float>& values, int type, std::size_t width) {
        return floats(values, type, width, TINYGLTF_TARGET_ARRAY_BUFFER);
    }
    // Sets min and max of a float accessor from its values (required on POSITION and on
    // animation sampler inputs).
    void bound(int index, const std::vector<float>& values, std::size_t width) {
        auto& accessor = model.accessors[std::size_t(index)];
        accessor.minValues.assign(width, 1e30);
        accessor.maxValues.assign(width, -1e30);
        for (std::size_t i = 0; i < values.size(); ++i) {
            accessor.minValues[i % width] = std::min(accessor.minValues[i % width], double(values[i]));
            accessor.maxValues[i % width] = std::max(accessor.maxValues[i % width], double(values[i]));
        }
    }
    int positions(const std::vector<float>& values) {
        const int index = attribute(values, TINYGLTF_TYPE_VEC3, 3);
        bound(index, values, 3);
        return index;
    }
    int joints(const std::vector<std::uint16_t>& values) {
        return add(values.data(), values.size() * 2, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT, TINYGLTF_TYPE_VEC4,
                   values.size() / 4, TINYGLTF_TARGET_ARRAY_BUFFER);
    }
    int indices(const std::vector<std::uint32_t>& values) {
        return add(values.data(), values.size() * 4, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, TINYGLTF_TYPE_SCALAR,
                   values.size(), TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
    }

    // A clip of one channel.
    void clip(const std::string& name, int node, const std::string& path, const std::string& interpolation,
              const std::vector<float>& times, const std::vector<float>& values, int type, std::size_t width) {
        tinygltf::Animation animation;
        animation.name = name;
        tinygltf::AnimationSampler sampler;
        sampler.input = floats(times, TINYGLTF_TYPE_SCALAR, 1);
        bound(sampler.input, times, 1);
        sampler.output = floats(values, type, width);
        sampler.interpolation = interpolation;
        animation.samplers.push_back(sampler);
        tinygltf::AnimationChannel channel;
        channel.sampler = 0;
        channel.target_node = node;
        channel.target_path = path;
        animation.channels.push_back(channel);
        model.animations.push_back(animation);
    }

    // Overwrites component `component` of element `element` of accessor `accessor` in the buffer.
    template <class T>
    void patch(int accessor, std::size_t element, std::size_t component, T value) {
        const tinygltf::Accessor& a = model.accessors[std::size_t(accessor)];
        const tinygltf::BufferView& view = model.bufferViews[std::size_t(a.bufferView)];
        const std::size_t width = std::size_t(tinygltf::GetNumComponentsInType(std::uint32_t(a.type)));
        const std::size_t offset = view.byteOffset + a.byteOffset + (element * width + component) * sizeof(T);
        std::memcpy(&model.buffers[0].data[offset], &value, sizeof(T));
    }
};

// The cylinder: radius 0.5, rings at y = 0, 0.5, 1, 1.5, 2, 8 columns, the seam column
// repeated (as glTF exporters split UV seams); two primitives, rings 0-2 and rings 2-4, so
// ring 2 appears twice. Joint 0 (node 0, root at the base) and joint 1 (node 1, at y = 1,
// child of node 0); weights of joint 1 by ring: 0, 0.25, 0.5, 0.75, 1. Node 2 holds the mesh
// and the skin; node 3 is a prop outside the skin (a camera).
constexpr int kRings = 5, kColumns = 8, kRowSize = kColumns + 1;
constexpr double kRadius = 0.5;
inline const float kJoint1Weight[kRings] = {0, 0.25f, 0.5f, 0.75f, 1};

inline std::array<float, 3> cylinderPoint(int ring, int column) {
    const double angle = 2 * std::numbers::pi * (column % kColumns) / kColumns;
    return {float(kRadius * std::cos(angle)), float(0.5 * ring), float(kRadius * std::sin(angle))};
}

struct CylinderAccessors {
    std::vector<int> positions, joints, weights, indices;
};

// One primitive over rings [firstRing, firstRing + 2].
inline tinygltf::Primitive cylinderPrimitive(ModelBuilder& b, int firstRing, float joint1WeightOfSharedRing,
                                      CylinderAccessors& accessors) {
    std::vector<float> positions, weights;
    std::vector<std::uint16_t> joints;
    for (int ring = firstRing; ring <= firstRing + 2; ++ring)
        for (int column = 0; column < kRowSize; ++column) {
            const auto point = cylinderPoint(ring, column);
            positions.insert(positions.end(), point.begin(), point.end());
            const float w1 = ring == 2 ? joint1WeightOfSharedRing : kJoint1Weight[ring];
            // a joint of zero weight is named 0, as the validator asks
            joints.insert(joints.end(), {0, std::uint16_t(w1 == 0 ? 0 : 1), 0, 0});
            weights.insert(weights.end(), {1 - w1, w1, 0, 0});
        }
    std::vector<std::uint32_t> indices;
    for (std::uint32_t ring = 0; ring < 2; ++ring)
        for (std::uint32_t column = 0; column < kColumns; ++column) {
            const std::uint32_t here = ring * kRowSize + column, right = here + 1;  // ring r: columns c, c + 1
            const std::uint32_t upRight = right + kRowSize, up = here + kRowSize;   // ring r + 1
            indices.insert(indices.end(), {here, up, upRight, here, upRight, right});  // facing outwards
        }
    tinygltf::Primitive primitive;
    primitive.mode = TINYGLTF_MODE_TRIANGLES;
    primitive.attributes["POSITION"] = b.positions(positions);
    primitive.attributes["JOINTS_0"] = b.joints(joints);
    primitive.attributes["WEIGHTS_0"] = b.attribute(weights, TINYGLTF_TYPE_VEC4, 4);
    primitive.indices = b.indices(indices);
    accessors.positions.push_back(primitive.attributes["POSITION"]);
    accessors.joints.push_back(primitive.attributes["JOINTS_0"]);
    accessors.weights.push_back(primitive.attributes["WEIGHTS_0"]);
    accessors.indices.push_back(primitive.indices);
    return primitive;
}

struct Cylinder {
    ModelBuilder builder;
    CylinderAccessors accessors;
};

inline const float kQuarterTurnZ[4] = {0, 0, float(std::sin(std::numbers::pi / 4)), float(std::cos(std::numbers::pi / 4))};

// upperSharedWeight: joint 1's weight on ring 2 in the upper primitive (0.5 welds the rings).
inline Cylinder makeCylinder(float upperSharedWeight = 0.5f) {
    Cylinder cylinder;
    ModelBuilder& b = cylinder.builder;
    tinygltf::Mesh mesh;
    mesh.primitives.push_back(cylinderPrimitive(b, 0, 0.5f, cylinder.accessors));
    mesh.primitives.push_back(cylinderPrimitive(b, 2, upperSharedWeight, cylinder.accessors));
    b.model.meshes.push_back(mesh);

    tinygltf::Node root, mid, holder, prop;
    root.name = "root";
    root.children = {1};
    mid.name = "mid";
    mid.translation = {0, 1, 0};
    holder.name = "cylinder";
    holder.mesh = 0;
    holder.skin = 0;
    prop.name = "prop";
    prop.camera = 0;  // a camera, so that the validator does not call the node empty
    tinygltf::Camera camera;
    camera.type = "perspective";
    camera.perspective.yfov = 0.8;
    camera.perspective.znear = 0.1;
    camera.perspective.zfar = 100;
    b.model.cameras.push_back(camera);
    b.model.nodes = {root, mid, holder, prop};

    tinygltf::Skin skin;
    skin.joints = {0, 1};
    const std::vector<float> inverseBind = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1,
                                            1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, -1, 0, 1};
    skin.inverseBindMatrices = b.floats(inverseBind, TINYGLTF_TYPE_MAT4, 16);
    b.model.skins.push_back(skin);

    tinygltf::Scene scene;
    scene.nodes = {0, 2, 3};
    b.model.scenes.push_back(scene);
    b.model.defaultScene = 0;

    const std::vector<float> bend = {0, 0, 0, 1, kQuarterTurnZ[0], kQuarterTurnZ[1], kQuarterTurnZ[2], kQuarterTurnZ[3]};
    b.clip("bend", 1, "rotation", "LINEAR", {0, 1}, bend, TINYGLTF_TYPE_VEC4, 4);
    b.clip("step", 1, "translation", "STEP", {0, 0.5f, 1}, {0, 1, 0, 0.5f, 1, 0, 1, 1, 0}, TINYGLTF_TYPE_VEC3, 3);
    // in-tangent, value, out-tangent per key: out-tangent (1, 0, 0) at key 0.
    b.clip("cubic", 1, "translation", "CUBICSPLINE", {0, 1},
           {0, 0, 0, 0, 1, 0, 1, 0, 0, /**/ 0, 0, 0, 1, 1, 0, 0, 0, 0}, TINYGLTF_TYPE_VEC3, 3);
    b.clip("prop", 3, "translation", "LINEAR", {0, 2}, {0, 0, 0, 5, 5, 5}, TINYGLTF_TYPE_VEC3, 3);
    return cylinder;
}


// Writes `model` as a .gltf (JSON with the buffer embedded) or .glb file; false on failure.
inline bool writeGltf(tinygltf::Model model, const std::string& path, bool binary = false) {
    tinygltf::TinyGLTF writer;
    return writer.WriteGltfSceneToFile(&model, path, true, true, true, binary);
}

}  // namespace psub::test
