#include "camera.h"

#include "scene.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <glm/gtc/matrix_transform.hpp>

namespace atrium {

namespace {
constexpr double frames_per_loop = 720.0;
} // namespace

CameraPath CameraPath::for_scene(const Scene &scene) {
    CameraPath path;
    if (scene.procedural) return path;
    // Models: assume y is up and scale the walk with the model, taking its longest side to be
    // about as long as the atrium's (26 m, as in Sponza) to guess its units for the IPD.
    const glm::vec3 extent = glm::max(scene.bounds_max - scene.bounds_min, glm::vec3(1e-3f));
    const float scale = std::max({extent.x, extent.y, extent.z}) / 26.0f;
    path.centre_ = glm::vec3(0.5f * (scene.bounds_min.x + scene.bounds_max.x), scene.bounds_min.y,
                             0.5f * (scene.bounds_min.z + scene.bounds_max.z));
    path.radius_ = glm::vec2(0.32f * extent.x, 0.2f * extent.z);
    path.height_ = std::min(1.7f * scale, 0.4f * extent.y);
    path.bob_ = 0.08f * scale;
    path.ipd_ = 0.064f * scale;
    path.near_ = 0.05f * scale;
    path.far_ = 4.0f * std::max({extent.x, extent.y, extent.z});
    return path;
}

CameraPath::Head CameraPath::head(uint64_t frame) const {
    // Parameters in double so that late frames do not lose precision.
    const double t = 2.0 * std::numbers::pi * double(frame) / frames_per_loop;
    const glm::vec3 position =
        centre_ + glm::vec3(float(radius_.x * std::sin(t)), float(height_ + bob_ * std::sin(3.0 * t)),
                            float(radius_.y * std::sin(2.0 * t)));
    // The velocity (radius.x cos t, ., 2 radius.y cos 2t) never vanishes: the camera moves every frame.
    const double heading =
        std::atan2(2.0 * radius_.y * std::cos(2.0 * t), radius_.x * std::cos(t)) + 0.35 * std::sin(1.7 * t);
    const double pitch = 0.12 + 0.1 * std::sin(2.3 * t);
    const glm::vec3 forward(float(std::cos(pitch) * std::cos(heading)), float(std::sin(pitch)),
                            float(std::cos(pitch) * std::sin(heading)));
    return {position, forward};
}

EyeView CameraPath::eye_view(uint64_t frame, uint32_t eye, uint32_t eye_count, float aspect) const {
    const auto [position, forward] = head(frame);
    const glm::vec3 up(0.0f, 1.0f, 0.0f);
    const glm::vec3 right = glm::normalize(glm::cross(forward, up));

    const float offset = eye_count == 2 ? (eye == 0 ? -0.5f : 0.5f) * ipd_ : 0.0f;
    const glm::vec3 eye_position = position + offset * right;

    // 75 degrees vertically, narrowed so that wide (mono) viewports stay under 100 horizontally.
    const float half_h = std::min(std::tan(glm::radians(37.5f)), std::tan(glm::radians(50.0f)) / aspect);
    glm::mat4 proj = glm::perspective(2.0f * std::atan(half_h), aspect, near_, far_);
    proj[1][1] *= -1.0f; // Vulkan's clip space has y pointing down
    const glm::mat4 view = glm::lookAt(eye_position, eye_position + forward, up);
    return {proj * view, eye_position};
}

EyeView CameraPath::head_eye_view(uint64_t frame, const HeadEye &eye) const {
    const auto [position, forward] = head(frame);
    const glm::mat4 head_view = glm::lookAt(position, position + forward, glm::vec3(0.0f, 1.0f, 0.0f));
    const glm::mat4 view = glm::inverse(eye.eye_to_head) * head_view;
    // The frustum through the four tangents, into Vulkan's clip space (y down, depth in [0, 1]).
    const float width = eye.tan_right - eye.tan_left, height = eye.tan_up - eye.tan_down;
    glm::mat4 proj(0.0f);
    proj[0][0] = 2.0f / width;
    proj[2][0] = (eye.tan_right + eye.tan_left) / width;
    proj[1][1] = -2.0f / height;
    proj[2][1] = -(eye.tan_up + eye.tan_down) / height;
    proj[2][2] = far_ / (near_ - far_);
    proj[3][2] = -(far_ * near_) / (far_ - near_);
    proj[2][3] = -1.0f;
    return {proj * view, glm::vec3(glm::inverse(view)[3])};
}

} // namespace atrium
