// The default fovea rects of an image (512x360 of a 1200x1080 eye, as fractions, centred in each
// eye), computed from the definition rather than from splitvk's code, so that tests are an
// independent oracle of where the split puts them.
#pragma once

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

} // namespace splitvk::e2e
