// The camera walk. Everything here is a pure function of the frame index (never of time), so
// frame N shows the same pixels on every run.
#pragma once

#include <cstdint>

#include <glm/glm.hpp>

namespace atrium {

struct Scene;

struct EyeView {
    glm::mat4 view_proj; // Vulkan clip space: y down, depth in [0, 1]
    glm::vec3 position;
};

// An eye as a head-mounted display reports it (OpenXR's XrView, relative to the head): where it
// is in the head's frame (x right, y up, looking down -z) and the tangents of its field of view's
// half-angles (left and down negative). Asymmetric fields of view are the rule.
struct HeadEye {
    glm::mat4 eye_to_head{1.0f};
    float tan_left = -1.0f, tan_right = 1.0f, tan_up = 1.0f, tan_down = -1.0f;
};

class CameraPath {
public:
    // A figure-eight through the atrium's courtyard at eye height, or one framed to a model's bounds.
    static CameraPath for_scene(const Scene &scene);

    // Eye `eye` of `eye_count` (1: mono; 2: stereo, 0 = left) at frame `frame`. The eyes of a pair
    // are ipd apart along the camera's right vector and look in the same direction.
    EyeView eye_view(uint64_t frame, uint32_t eye, uint32_t eye_count, float aspect) const;

    // The same walk as a head at frame `frame` (the mono eye's position and direction), carrying
    // an eye of a head-mounted display.
    EyeView head_eye_view(uint64_t frame, const HeadEye &eye) const;

    float ipd() const { return ipd_; }

private:
    struct Head {
        glm::vec3 position, forward;
    };
    Head head(uint64_t frame) const;

    glm::vec3 centre_{0.0f};
    glm::vec2 radius_{8.0f, 1.8f}; // figure-eight extent along x and z
    float height_ = 1.7f;          // eye height above centre_.y
    float bob_ = 0.08f;            // vertical sway
    float ipd_ = 0.064f;
    float near_ = 0.05f;
    float far_ = 200.0f;
};

} // namespace atrium
