// The default fovea rects of an image (512x360 of a 1200x1080 eye, as fractions, centred in each
// eye), computed from the definition rather than from splitvk's code, so that tests are an
// independent oracle of where the split puts them.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

namespace splitvk::e2e {

struct Rect {
    uint32_t x = 0, y = 0, w = 0, h = 0;
};

inline std::vector<Rect> default_foveae(uint32_t width, uint32_t height, int eyes) {
    std::vector<Rect> rects;
    const uint32_t eye_w = width / static_cast<uint32_t>(eyes);
    const auto fw = static_cast<uint32_t>(std::lround(eye_w * 512.0 / 1200.0));
    const auto fh = static_cast<uint32_t>(std::lround(height * 360.0 / 1080.0));
    for (int e = 0; e < eyes; ++e)
        rects.push_back({static_cast<uint32_t>(e) * eye_w + (eye_w - fw) / 2, (height - fh) / 2, fw, fh});
    return rects;
}

// The fovea of an eye (at x = eye_x, eye_w wide) whose gaze is at (gx, gy), normalised to the eye
// (SPLITVK_GAZE=fifo): centred on floor(g·size), clamped into the eye. Points that are
// multiples of 1/8 keep the floor exact whatever the eye's size.
inline Rect fovea_at_gaze(double gx, double gy, uint32_t eye_x, uint32_t eye_w, uint32_t height) {
    const Rect centred = default_foveae(eye_w, height, 1)[0];
    const int64_t cx = static_cast<int64_t>(std::floor(gx * eye_w));
    const int64_t cy = static_cast<int64_t>(std::floor(gy * height));
    const int64_t x = std::clamp<int64_t>(cx - centred.w / 2, 0, eye_w - centred.w);
    const int64_t y = std::clamp<int64_t>(cy - centred.h / 2, 0, height - centred.h);
    return {eye_x + static_cast<uint32_t>(x), static_cast<uint32_t>(y), centred.w, centred.h};
}

} // namespace splitvk::e2e
