// The framing camera (GLM): one fixed viewing direction, a perspective that holds the box's
// bounding sphere, matrices mapping straight to Vulkan clip space (y down, depth 0..1).
#include "psub/render.h"

#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>

namespace psub {
namespace {

constexpr float kFovYDegrees = 30.0f;
constexpr float kMargin = 1.04f;  // the sphere's radius grows by this much: a thin border

std::array<float, 16> toArray(const glm::mat4& m) {
    std::array<float, 16> a;
    std::memcpy(a.data(), glm::value_ptr(m), sizeof(float) * 16);
    return a;
}

}  // namespace

void Box::extend(std::span<const float> xyz) {
    for (std::size_t i = 0; i + 2 < xyz.size(); i += 3)
        for (int axis = 0; axis < 3; ++axis) {
            min[axis] = std::min(min[axis], xyz[i + axis]);
            max[axis] = std::max(max[axis], xyz[i + axis]);
        }
}

Camera lookAt(std::array<float, 3> eyeAt, std::array<float, 3> targetAt, float radius, float aspect) {
    if (!(aspect > 0) || !std::isfinite(aspect)) throw std::invalid_argument("lookAt: aspect must be positive");
    const glm::vec3 eye(eyeAt[0], eyeAt[1], eyeAt[2]), centre(targetAt[0], targetAt[1], targetAt[2]);
    const float distance = glm::length(eye - centre);
    if (!(distance > 0) || !std::isfinite(distance)) throw std::invalid_argument("lookAt: the eye must not be the target");
    const float halfY = glm::radians(kFovYDegrees) / 2;
    const glm::mat4 view = glm::lookAtRH(eye, centre, glm::vec3(0, 1, 0));
    const float nearPlane = std::max(distance - 1.05f * radius, distance * 1e-3f);
    const float farPlane = distance + 1.05f * radius;
    glm::mat4 projection = glm::perspectiveRH_ZO(2 * halfY, aspect, nearPlane, farPlane);
    projection[1][1] *= -1;  // Vulkan's framebuffer y points down
    Camera camera;
    camera.view = toArray(view);
    camera.projection = toArray(projection);
    camera.viewProjection = toArray(projection * view);
    camera.eye = eyeAt;
    camera.target = targetAt;
    camera.verticalFovDegrees = kFovYDegrees;
    return camera;
}

Camera frameBox(std::array<float, 3> min, std::array<float, 3> max, float aspect, std::array<float, 3> towardsEye) {
    if (!(aspect > 0) || !std::isfinite(aspect)) throw std::invalid_argument("frameBox: aspect must be positive");
    const glm::vec3 direction(towardsEye[0], towardsEye[1], towardsEye[2]);
    const float sideways = std::hypot(direction.x, direction.z);
    if (!(sideways > 1e-6f * glm::length(direction)) || !std::isfinite(glm::length(direction)))
        throw std::invalid_argument("frameBox: the viewing direction must not be vertical or zero");
    const bool empty = min[0] > max[0] || min[1] > max[1] || min[2] > max[2];
    const glm::vec3 lo = empty ? glm::vec3(0) : glm::vec3(min[0], min[1], min[2]);
    const glm::vec3 hi = empty ? glm::vec3(0) : glm::vec3(max[0], max[1], max[2]);
    const glm::vec3 centre = 0.5f * (lo + hi);
    float radius = 0.5f * glm::length(hi - lo);
    if (!(radius > 0) || !std::isfinite(radius)) radius = 1.0f;
    radius *= kMargin;
    // The sphere fits when its angular radius is within the narrower half field of view.
    const float halfY = glm::radians(kFovYDegrees) / 2;
    const float halfNarrow = std::min(halfY, std::atan(aspect * std::tan(halfY)));
    const float distance = radius / std::sin(halfNarrow);
    const glm::vec3 eye = centre + distance * glm::normalize(direction);
    return lookAt({eye.x, eye.y, eye.z}, {centre.x, centre.y, centre.z}, radius, aspect);
}

}  // namespace psub
