#include "split_geometry.h"

#include <algorithm>
#include <cmath>

namespace splitvk::split {
namespace {

// s·x is computed in double, where 0.6 is not exact: 1080·0.6 may land a hair above 648. A
// tolerance far below a pixel keeps ceil/floor from stepping a whole pixel on that noise.
constexpr double kEpsilon = 1e-6;

int64_t floor_scaled(int64_t v, double scale) {
    return static_cast<int64_t>(std::floor(static_cast<double>(v) * scale + kEpsilon));
}

int64_t ceil_scaled(int64_t v, double scale) {
    return static_cast<int64_t>(std::ceil(static_cast<double>(v) * scale - kEpsilon));
}

} // namespace

VkExtent2D scaled_extent(VkExtent2D full, double scale) {
    const auto w = std::max<int64_t>(1, ceil_scaled(full.width, scale));
    const auto h = std::max<int64_t>(1, ceil_scaled(full.height, scale));
    return {static_cast<uint32_t>(w), static_cast<uint32_t>(h)};
}

VkViewport scale_viewport(const VkViewport &viewport, double scale) {
    VkViewport out = viewport;
    out.x = static_cast<float>(viewport.x * scale);
    out.y = static_cast<float>(viewport.y * scale);
    out.width = static_cast<float>(viewport.width * scale);
    out.height = static_cast<float>(viewport.height * scale);
    return out;
}

VkRect2D scale_rect(const VkRect2D &rect, double scale, VkExtent2D scaled) {
    const int64_t x0 = std::clamp<int64_t>(floor_scaled(rect.offset.x, scale), 0, scaled.width);
    const int64_t y0 = std::clamp<int64_t>(floor_scaled(rect.offset.y, scale), 0, scaled.height);
    const int64_t x1 =
        std::clamp<int64_t>(ceil_scaled(int64_t{rect.offset.x} + rect.extent.width, scale), x0, scaled.width);
    const int64_t y1 = std::clamp<int64_t>(ceil_scaled(int64_t{rect.offset.y} + rect.extent.height, scale),
                                           y0, scaled.height);
    return {{static_cast<int32_t>(x0), static_cast<int32_t>(y0)},
            {static_cast<uint32_t>(x1 - x0), static_cast<uint32_t>(y1 - y0)}};
}

VkRect2D intersect(const VkRect2D &a, const VkRect2D &b) {
    const int64_t ax1 = int64_t{a.offset.x} + a.extent.width, ay1 = int64_t{a.offset.y} + a.extent.height;
    const int64_t bx1 = int64_t{b.offset.x} + b.extent.width, by1 = int64_t{b.offset.y} + b.extent.height;
    const int64_t x0 = std::max<int64_t>(a.offset.x, b.offset.x),
                  y0 = std::max<int64_t>(a.offset.y, b.offset.y);
    const int64_t x1 = std::min(ax1, bx1), y1 = std::min(ay1, by1);
    if (x1 <= x0 || y1 <= y0) {
        // A scissor offset must be non-negative; a zero extent anywhere draws nothing.
        return {{std::max<int32_t>(0, static_cast<int32_t>(std::min<int64_t>(x0, INT32_MAX))),
                 std::max<int32_t>(0, static_cast<int32_t>(std::min<int64_t>(y0, INT32_MAX)))},
                {0, 0}};
    }
    return {{static_cast<int32_t>(x0), static_cast<int32_t>(y0)},
            {static_cast<uint32_t>(x1 - x0), static_cast<uint32_t>(y1 - y0)}};
}

VkRect2D eye_for_viewport(const VkViewport &viewport, VkExtent2D image, EyeMode mode) {
    const VkRect2D whole{{0, 0}, image};
    const uint32_t half = image.width / 2;
    const VkRect2D left{{0, 0}, {half, image.height}};
    const VkRect2D right{{static_cast<int32_t>(half), 0}, {image.width - half, image.height}};
    const double x0 = viewport.x, x1 = static_cast<double>(viewport.x) + viewport.width;
    switch (mode) {
    case EyeMode::One:
        return whole;
    case EyeMode::Two:
        return (x0 + x1) / 2.0 < half ? left : right;
    case EyeMode::Auto:
        break;
    }
    // Apps compute per-eye viewports in float; allow them a pixel of rounding either way.
    constexpr double kSlack = 1.0;
    if (half == 0) return whole;
    if (x0 >= -kSlack && x1 <= half + kSlack) return left;
    if (x0 >= half - kSlack && x1 <= image.width + kSlack) return right;
    return whole;
}

VkRect2D fovea_of_eye(const VkRect2D &eye, const FoveaSize &fovea) {
    const auto [w, h] = fovea.pixels_for_eye(eye.extent.width, eye.extent.height);
    const uint32_t fw = std::min(w, eye.extent.width), fh = std::min(h, eye.extent.height);
    return {{eye.offset.x + static_cast<int32_t>((eye.extent.width - fw) / 2),
             eye.offset.y + static_cast<int32_t>((eye.extent.height - fh) / 2)},
            {fw, fh}};
}

VkRect2D fovea_for_viewport(const VkViewport &viewport, VkExtent2D image, EyeMode mode,
                            const FoveaSize &fovea) {
    return fovea_of_eye(eye_for_viewport(viewport, image, mode), fovea);
}

void add_fovea(std::vector<VkRect2D> &foveae, const VkRect2D &rect) {
    const auto less = [](const VkRect2D &a, const VkRect2D &b) {
        if (a.offset.x != b.offset.x) return a.offset.x < b.offset.x;
        if (a.offset.y != b.offset.y) return a.offset.y < b.offset.y;
        if (a.extent.width != b.extent.width) return a.extent.width < b.extent.width;
        return a.extent.height < b.extent.height;
    };
    const auto it = std::lower_bound(foveae.begin(), foveae.end(), rect, less);
    if (it != foveae.end() && !less(rect, *it)) return;
    foveae.insert(it, rect);
}

} // namespace splitvk::split
