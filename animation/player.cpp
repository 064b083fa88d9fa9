// GltfPlayer: poses a GltfAsset at a time. Samples the clip's channels into the nodes' local
// transforms, composes world matrices down the hierarchy, then morphs and skins every cage
// vertex, in buffers allocated once by the constructor.
#include "psub/animation.h"

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>

#include <algorithm>
#include <cassert>
#include <cmath>

namespace psub {
namespace {

glm::dmat4 toMat4(const std::array<double, 16>& columnMajor) { return glm::make_mat4(columnMajor.data()); }

void store(const glm::dmat4& matrix, std::array<double, 16>& columnMajor) {
    const double* values = glm::value_ptr(matrix);
    std::copy_n(values, 16, columnMajor.begin());
}

// T * R * S, or the node's own matrix.
glm::dmat4 localMatrix(const GltfNode& node, const NodeTransform& transform) {
    if (node.matrix) return toMat4(*node.matrix);
    const auto& q = transform.rotation;
    glm::dmat4 matrix = glm::mat4_cast(glm::dquat(q[3], q[0], q[1], q[2]));  // glm: w first
    for (int axis = 0; axis < 3; ++axis) matrix[axis] *= transform.scale[std::size_t(axis)];
    matrix[3] = glm::dvec4(transform.translation[0], transform.translation[1], transform.translation[2], 1);
    return matrix;
}

// The keyframes around `time`: key <= next, and how far time is from key to next.
struct Segment {
    std::size_t key = 0, next = 0;
    double fraction = 0;
};

Segment locate(const std::vector<float>& times, double time) {
    const std::size_t last = times.size() - 1;
    if (time <= times.front()) return {0, 0, 0};
    if (time >= times.back()) return {last, last, 0};
    const auto upper = std::upper_bound(times.begin(), times.end(), time,
                                        [](double t, float key) { return t < double(key); });
    const std::size_t next = std::size_t(upper - times.begin());
    const double span = double(times[next]) - double(times[next - 1]);
    return {next - 1, next, (time - double(times[next - 1])) / span};
}

// Spherical interpolation of unit quaternions along the shorter arc.
void slerp(const float* from, const float* to, double t, double* out) {
    double cosine = 0;
    for (int i = 0; i < 4; ++i) cosine += double(from[i]) * double(to[i]);
    const double sign = cosine < 0 ? -1.0 : 1.0;
    cosine = std::abs(cosine);
    double fromWeight = 1 - t, toWeight = t;
    if (cosine < 0.9995) {  // else nearly equal: linear, normalised by the caller
        const double angle = std::acos(cosine), sine = std::sin(angle);
        fromWeight = std::sin((1 - t) * angle) / sine;
        toWeight = std::sin(t * angle) / sine;
    }
    for (int i = 0; i < 4; ++i) out[i] = fromWeight * double(from[i]) + sign * toWeight * double(to[i]);
}

// Hermite spline between keys k and k + 1 (values stored in-tangent, value, out-tangent).
void cubic(const GltfChannel& channel, const Segment& segment, double* out) {
    const std::size_t width = channel.width;
    const float* key = &channel.values[3 * segment.key * width];
    const float* next = &channel.values[3 * segment.next * width];
    const double step = double(channel.times[segment.next]) - double(channel.times[segment.key]);
    const double t = segment.fraction, t2 = t * t, t3 = t2 * t;
    for (std::size_t c = 0; c < width; ++c)
        out[c] = (2 * t3 - 3 * t2 + 1) * key[width + c] + (t3 - 2 * t2 + t) * step * key[2 * width + c] +
                 (-2 * t3 + 3 * t2) * next[width + c] + (t3 - t2) * step * next[c];
}

// Channel value at `time` into out[0 .. width).
void sample(const GltfChannel& channel, double time, double* out) {
    const Segment segment = locate(channel.times, time);
    const std::size_t width = channel.width;
    const bool isCubic = channel.interpolation == GltfInterpolation::CubicSpline;
    if (isCubic && segment.key != segment.next) {
        cubic(channel, segment, out);
    } else if (channel.interpolation == GltfInterpolation::Step || segment.key == segment.next) {
        const float* value = &channel.values[(isCubic ? 3 * segment.key + 1 : segment.key) * width];
        std::copy_n(value, width, out);
    } else if (channel.path == GltfPath::Rotation) {
        slerp(&channel.values[segment.key * 4], &channel.values[segment.next * 4], segment.fraction, out);
    } else {
        const float* from = &channel.values[segment.key * width];
        const float* to = &channel.values[segment.next * width];
        for (std::size_t c = 0; c < width; ++c)
            out[c] = double(from[c]) + segment.fraction * (double(to[c]) - double(from[c]));
    }
}

void normalizeQuaternion(double* q) {
    const double length = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (!(length > 0)) {
        q[0] = q[1] = q[2] = 0;
        q[3] = 1;
        return;
    }
    for (int i = 0; i < 4; ++i) q[i] /= length;
}

// Rows 0..2 of an affine matrix, row-major, in float.
std::array<float, 12> affineRows(const glm::dmat4& matrix) {
    std::array<float, 12> rows{};
    for (int row = 0; row < 3; ++row)
        for (int column = 0; column < 4; ++column)
            rows[std::size_t(4 * row + column)] = float(matrix[column][row]);
    return rows;
}

void transformPoint(const std::array<float, 12>& m, const float* p, float weight, float* sum) {
    for (int row = 0; row < 3; ++row) {
        const float* r = &m[std::size_t(4 * row)];
        sum[row] += weight * (r[0] * p[0] + r[1] * p[1] + r[2] * p[2] + r[3]);
    }
}

}  // namespace

GltfPlayer::GltfPlayer(const GltfAsset& asset) : asset_(asset) {
    rest_.assign(asset.mesh.positions.size(), 0.0f);
    std::transform(asset.mesh.positions.begin(), asset.mesh.positions.end(), rest_.begin(),
                   [](double v) { return float(v); });
    local_.resize(asset.nodes.size());
    world_.resize(asset.nodes.size());
    skinning_.resize(asset.skin ? asset.skin->jointNodes.size() : 1);
    std::size_t widest = 4;
    for (const GltfClip& clip : asset.clips)
        for (const GltfChannel& channel : clip.channels) widest = std::max<std::size_t>(widest, channel.width);
    sample_.resize(widest);
    weights_.resize(asset.morphs.defaultWeights.size());
    resetToRest();
}

void GltfPlayer::restPose(std::span<float> out) const {
    assert(out.size() == rest_.size());
    std::copy(rest_.begin(), rest_.end(), out.begin());
}

void GltfPlayer::staticPose(std::span<float> out) {
    assert(out.size() == rest_.size());
    resetToRest();
    computeWorldMatrices();
    deform(out);
}

void GltfPlayer::pose(std::size_t clip, double seconds, std::span<float> out, bool loop) {
    assert(clip < clipCount() && std::isfinite(seconds) && out.size() == rest_.size());
    const GltfClip& played = asset_.clips[clip];
    const double duration = played.duration;
    double time = 0;
    if (duration > 0 && std::isfinite(seconds)) {
        time = loop ? std::fmod(seconds, duration) : seconds;
        if (loop && time < 0) time += duration;
        time = std::clamp(time, 0.0, duration);
    }
    resetToRest();
    applyClip(played, time);
    computeWorldMatrices();
    deform(out);
}

void GltfPlayer::resetToRest() {
    for (std::size_t n = 0; n < local_.size(); ++n) local_[n] = asset_.nodes[n].rest;
    std::copy(asset_.morphs.defaultWeights.begin(), asset_.morphs.defaultWeights.end(), weights_.begin());
}

void GltfPlayer::applyClip(const GltfClip& clip, double time) {
    for (const GltfChannel& channel : clip.channels) {
        sample(channel, time, sample_.data());
        NodeTransform& target = local_[channel.node];
        switch (channel.path) {
            case GltfPath::Translation: std::copy_n(sample_.begin(), 3, target.translation.begin()); break;
            case GltfPath::Scale: std::copy_n(sample_.begin(), 3, target.scale.begin()); break;
            case GltfPath::Rotation:
                normalizeQuaternion(sample_.data());
                std::copy_n(sample_.begin(), 4, target.rotation.begin());
                break;
            case GltfPath::Weights:
                if (channel.node != asset_.meshNode) break;  // another mesh's weights
                for (std::size_t t = 0; t < std::min<std::size_t>(channel.width, weights_.size()); ++t)
                    weights_[t] = float(sample_[t]);
                break;
        }
    }
}

void GltfPlayer::computeWorldMatrices() {
    for (std::uint32_t n : asset_.nodeOrder) {
        glm::dmat4 world = localMatrix(asset_.nodes[n], local_[n]);
        const std::int32_t parent = asset_.nodes[n].parent;
        if (parent >= 0) world = toMat4(world_[std::size_t(parent)]) * world;
        store(world, world_[n]);
    }
    if (!asset_.skin) {
        skinning_[0] = affineRows(toMat4(world_[asset_.meshNode]));
        return;
    }
    const GltfSkin& skin = *asset_.skin;
    for (std::size_t j = 0; j < skin.jointNodes.size(); ++j)
        skinning_[j] = affineRows(toMat4(world_[skin.jointNodes[j]]) * toMat4(skin.inverseBindMatrices[j]));
}

void GltfPlayer::deform(std::span<float> out) {
    const std::size_t values = rest_.size();
    std::copy(rest_.begin(), rest_.end(), out.begin());
    for (std::size_t t = 0; t < weights_.size(); ++t) {  // morph targets
        const float weight = weights_[t];
        if (weight == 0) continue;
        const float* delta = &asset_.morphs.deltas[t * values];
        for (std::size_t i = 0; i < values; ++i) out[i] += weight * delta[i];
    }
    for (std::size_t v = 0; v < values / 3; ++v) {  // skinning, or the mesh node's transform
        float* p = &out[3 * v];
        float sum[3] = {0, 0, 0};
        if (!asset_.skin) {
            transformPoint(skinning_[0], p, 1.0f, sum);
        } else {
            for (std::size_t k = 0; k < 4; ++k) {
                const float weight = asset_.skin->weights[4 * v + k];
                if (weight != 0) transformPoint(skinning_[asset_.skin->joints[4 * v + k]], p, weight, sum);
            }
        }
        std::copy_n(sum, 3, p);
    }
}

}  // namespace psub
