#include "split_geometry.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iterator>

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

AxisScale axis_scale(VkExtent2D full, VkExtent2D scaled) {
    return {full.width ? static_cast<double>(scaled.width) / full.width : 1.0,
            full.height ? static_cast<double>(scaled.height) / full.height : 1.0};
}

AxisScale axis_scale(VkExtent2D full, double scale) {
    return axis_scale(full, scaled_extent(full, scale));
}

VkViewport scale_viewport(const VkViewport &viewport, AxisScale scale) {
    VkViewport out = viewport;
    out.x = static_cast<float>(viewport.x * scale.x);
    out.y = static_cast<float>(viewport.y * scale.y);
    out.width = static_cast<float>(viewport.width * scale.x);
    out.height = static_cast<float>(viewport.height * scale.y);
    return out;
}

VkRect2D scale_rect(const VkRect2D &rect, AxisScale scale, VkExtent2D scaled) {
    const int64_t x0 = std::clamp<int64_t>(floor_scaled(rect.offset.x, scale.x), 0, scaled.width);
    const int64_t y0 = std::clamp<int64_t>(floor_scaled(rect.offset.y, scale.y), 0, scaled.height);
    const int64_t x1 = std::clamp<int64_t>(ceil_scaled(int64_t{rect.offset.x} + rect.extent.width, scale.x),
                                           x0, scaled.width);
    const int64_t y1 = std::clamp<int64_t>(ceil_scaled(int64_t{rect.offset.y} + rect.extent.height, scale.y),
                                           y0, scaled.height);
    return {{static_cast<int32_t>(x0), static_cast<int32_t>(y0)},
            {static_cast<uint32_t>(x1 - x0), static_cast<uint32_t>(y1 - y0)}};
}

VkRect2D scaled_pass_rect(const VkRect2D &rect, VkExtent2D full, double scale) {
    const VkExtent2D scaled = scaled_extent(full, scale);
    return scale_rect(rect, axis_scale(full, scaled), scaled);
}

VkViewport scaled_pass_viewport(const VkViewport &viewport, VkExtent2D full, double scale) {
    return scale_viewport(viewport, axis_scale(full, scale));
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

namespace {

// Apps compute per-eye viewports in float; allow them a pixel of rounding either way.
constexpr double kSlack = 1.0;

bool near(double a, double b) {
    return std::abs(a - b) <= kSlack;
}

// The bounding box of `a` and `b`; an empty `a` gives `b`.
VkRect2D bounding_box(const VkRect2D &a, const VkRect2D &b) {
    if (a.extent.width == 0 || a.extent.height == 0) return b;
    const int64_t x0 = std::min(a.offset.x, b.offset.x), y0 = std::min(a.offset.y, b.offset.y);
    const int64_t x1 = std::max(int64_t{a.offset.x} + a.extent.width, int64_t{b.offset.x} + b.extent.width);
    const int64_t y1 = std::max(int64_t{a.offset.y} + a.extent.height, int64_t{b.offset.y} + b.extent.height);
    return {{static_cast<int32_t>(x0), static_cast<int32_t>(y0)},
            {static_cast<uint32_t>(x1 - x0), static_cast<uint32_t>(y1 - y0)}};
}

} // namespace

EyeCoverage &EyeCoverage::operator|=(const EyeCoverage &other) {
    left |= other.left;
    right |= other.right;
    left_eye |= other.left_eye;
    right_eye |= other.right_eye;
    return *this;
}

VkRect2D left_eye(VkExtent2D image) {
    return {{0, 0}, {image.width / 2, image.height}};
}

VkRect2D right_eye(VkExtent2D image) {
    const uint32_t half = image.width / 2;
    return {{static_cast<int32_t>(half), 0}, {image.width - half, image.height}};
}

EyeCoverage viewport_coverage(const VkViewport &viewport, VkExtent2D image) {
    const double half = image.width / 2, width = image.width;
    const double x0 = viewport.x, x1 = static_cast<double>(viewport.x) + viewport.width;
    // A viewport's height may be negative (a flipped y axis): its rows are those between y and y+h.
    const double ya = viewport.y, yb = static_cast<double>(viewport.y) + viewport.height;
    const double y0 = std::min(ya, yb), y1 = std::max(ya, yb);
    EyeCoverage c;
    c.left = std::min(x1, half) - std::max(x0, 0.0) > kSlack;
    c.right = std::min(x1, width) - std::max(x0, half) > kSlack;
    if (!c.left && !c.right) {
        if ((x0 + x1) / 2.0 < half)
            c.left = true;
        else
            c.right = true;
    }
    const bool full_height = near(y0, 0.0) && near(y1, image.height);
    c.left_eye = half > 0 && full_height && near(x0, 0.0) && near(x1, half);
    c.right_eye = half > 0 && full_height && near(x0, half) && near(x1, width);
    return c;
}

VkRect2D fovea_of_eye(const VkRect2D &eye, const FoveaSize &fovea) {
    const auto [w, h] = fovea.pixels_for_eye(eye.extent.width, eye.extent.height);
    const uint32_t fw = std::min(w, eye.extent.width), fh = std::min(h, eye.extent.height);
    return {{eye.offset.x + static_cast<int32_t>((eye.extent.width - fw) / 2),
             eye.offset.y + static_cast<int32_t>((eye.extent.height - fh) / 2)},
            {fw, fh}};
}

FrameFoveaSize larger(const FrameFoveaSize &a, const FrameFoveaSize &b) {
    if (!a.set()) return b;
    if (!b.set()) return a;
    return {std::max(a.width, b.width), std::max(a.height, b.height)};
}

FoveaSize frame_fovea_size(const FoveaSize &configured, const FrameFoveaSize &frame) {
    if (!frame.set()) return configured;
    FoveaSize size;
    size.fractional = true;
    size.width = static_cast<double>(frame.width) / kGazeOne;
    size.height = static_cast<double>(frame.height) / kGazeOne;
    return size;
}

bool frame_fovea_size_allowed(const FoveaSize &configured, const FrameFoveaSize &frame) {
    if (!frame.set()) return frame.width == 0 && frame.height == 0;
    if (frame.width > kGazeOne || frame.height > kGazeOne || !configured.fractional) return false;
    const FoveaSize size = frame_fovea_size(configured, frame);
    return size.width <= configured.width && size.height <= configured.height;
}

VkRect2D fovea_at_gaze(const VkRect2D &eye, const GazePoint &point, const FoveaSize &fovea) {
    const VkRect2D centred = fovea_of_eye(eye, fovea);
    const uint32_t fw = centred.extent.width, fh = centred.extent.height;
    const uint64_t gx = std::min(point.x, kGazeOne), gy = std::min(point.y, kGazeOne);
    const int64_t cx = static_cast<int64_t>(gx * eye.extent.width / kGazeOne);
    const int64_t cy = static_cast<int64_t>(gy * eye.extent.height / kGazeOne);
    const int64_t x = std::clamp<int64_t>(cx - fw / 2, 0, int64_t{eye.extent.width} - fw);
    const int64_t y = std::clamp<int64_t>(cy - fh / 2, 0, int64_t{eye.extent.height} - fh);
    return {{eye.offset.x + static_cast<int32_t>(x), eye.offset.y + static_cast<int32_t>(y)}, {fw, fh}};
}

std::vector<VkRect2D> frame_foveae(const EyeCoverage &drawn, VkExtent2D image, EyeMode mode,
                                   const FoveaSize &fovea, const Gaze &gaze) {
    const auto place = [&](const VkRect2D &eye, int index) {
        return gaze.fixed ? fovea_of_eye(eye, fovea) : fovea_at_gaze(eye, gaze.eyes[index], fovea);
    };
    std::vector<VkRect2D> foveae;
    if (!drawn.any()) return foveae;
    // An image one pixel wide has no left half: its one eye is the whole image.
    const bool two =
        image.width >= 2 && (mode == EyeMode::Two || (mode == EyeMode::Auto && drawn.stereo_pair()));
    if (!two) {
        foveae.push_back(place({{0, 0}, image}, 0));
        return foveae;
    }
    if (drawn.left) add_fovea(foveae, place(left_eye(image), 0));
    if (drawn.right) add_fovea(foveae, place(right_eye(image), 1));
    return foveae;
}

VkRect2D seam_rect(const VkRect2D &fovea, VkExtent2D image, uint32_t pixels) {
    VkRect2D bound{{0, 0}, image};
    const int64_t half = image.width / 2;
    const int64_t x0 = fovea.offset.x, x1 = x0 + fovea.extent.width;
    if (image.width >= 2 && x1 <= half) bound = left_eye(image);
    if (image.width >= 2 && x0 >= half) bound = right_eye(image);
    const auto clamp32 = [](int64_t v) {
        return static_cast<int32_t>(std::clamp<int64_t>(v, INT32_MIN, INT32_MAX));
    };
    const int64_t p = pixels;
    const VkRect2D grown{{clamp32(fovea.offset.x - p), clamp32(fovea.offset.y - p)},
                         {static_cast<uint32_t>(std::min<int64_t>(fovea.extent.width + 2 * p, UINT32_MAX)),
                          static_cast<uint32_t>(std::min<int64_t>(fovea.extent.height + 2 * p, UINT32_MAX))}};
    return intersect(grown, bound);
}

VkRect2D fovea_scissor(const VkViewport &viewport, VkExtent2D image, EyeMode mode, const FoveaSize &fovea,
                       bool moving_gaze, uint32_t seam_pixels) {
    const EyeCoverage c = viewport_coverage(viewport, image);
    if (moving_gaze) {
        // A mono fovea may sit anywhere in the image, so One and Auto cannot cut anything.
        if (mode != EyeMode::Two || image.width < 2) return {{0, 0}, image};
        VkRect2D box{};
        if (c.left) box = left_eye(image);
        if (c.right) box = c.left ? VkRect2D{{0, 0}, image} : right_eye(image);
        return box;
    }
    VkRect2D box{};
    if (mode != EyeMode::Two || image.width < 2)
        box = seam_rect(fovea_of_eye({{0, 0}, image}, fovea), image, seam_pixels);
    if (mode == EyeMode::One) return box;
    for (const VkRect2D &f : frame_foveae(c, image, EyeMode::Two, fovea))
        box = bounding_box(box, seam_rect(f, image, seam_pixels));
    return box;
}

VkRect2D fovea_at_view_direction(const VkRect2D &eye, const FieldOfView &fov, const FoveaSize &fovea) {
    const VkRect2D centred = fovea_of_eye(eye, fovea);
    const double l = std::tan(fov.angle_left), r = std::tan(fov.angle_right);
    const double u = std::tan(fov.angle_up), d = std::tan(fov.angle_down);
    if (!std::isfinite(l) || !std::isfinite(r) || !std::isfinite(u) || !std::isfinite(d) || !(r > l) ||
        !(u > d))
        return centred;
    const double cx = (0.0 - l) / (r - l) * eye.extent.width;
    const double cy = (u - 0.0) / (u - d) * eye.extent.height;
    const uint32_t fw = centred.extent.width, fh = centred.extent.height;
    // Rounded down as fovea_of_eye rounds, with its tolerance for noise far below a pixel.
    const double x = std::floor(cx - fw / 2.0 + kEpsilon), y = std::floor(cy - fh / 2.0 + kEpsilon);
    const double max_x = eye.extent.width - fw, max_y = eye.extent.height - fh;
    return {{eye.offset.x + static_cast<int32_t>(std::clamp(x, 0.0, max_x)),
             eye.offset.y + static_cast<int32_t>(std::clamp(y, 0.0, max_y))},
            {fw, fh}};
}

std::optional<GazePoint> gaze_point_in_eye(const FieldOfView &fov, double x, double y, double z) {
    const double l = std::tan(fov.angle_left), r = std::tan(fov.angle_right);
    const double u = std::tan(fov.angle_up), d = std::tan(fov.angle_down);
    if (!std::isfinite(l) || !std::isfinite(r) || !std::isfinite(u) || !std::isfinite(d) || !(r > l) ||
        !(u > d) || !std::isfinite(x) || !std::isfinite(y) || !(z < 0))
        return std::nullopt;
    // The direction's crossing of the image plane at distance 1, then its place between the edges.
    const double px = (x / -z - l) / (r - l), py = (u - y / -z) / (u - d);
    const auto units = [](double fraction) {
        if (!std::isfinite(fraction)) return fraction > 0 ? kGazeOne : 0u; // beyond a clamp either way
        return static_cast<uint32_t>(std::lround(std::clamp(fraction, 0.0, 1.0) * kGazeOne));
    };
    return GazePoint{units(px), units(py)};
}

bool note_runtime_eye(std::vector<RuntimeEye> &eyes, const RuntimeEye &eye) {
    const auto same = [](const RuntimeEye &a, const RuntimeEye &b) {
        return a.layer == b.layer && a.rect.offset.x == b.rect.offset.x &&
               a.rect.offset.y == b.rect.offset.y && a.rect.extent.width == b.rect.extent.width &&
               a.rect.extent.height == b.rect.extent.height && a.fov.angle_left == b.fov.angle_left &&
               a.fov.angle_right == b.fov.angle_right && a.fov.angle_up == b.fov.angle_up &&
               a.fov.angle_down == b.fov.angle_down;
    };
    if (std::any_of(eyes.begin(), eyes.end(), [&](const RuntimeEye &e) { return same(e, eye); }))
        return false;
    std::erase_if(eyes, [&](const RuntimeEye &e) {
        return e.layer == eye.layer && intersect(e.rect, eye.rect).extent.width > 0 &&
               intersect(e.rect, eye.rect).extent.height > 0;
    });
    eyes.push_back(eye);
    return true;
}

std::vector<LayerFovea> runtime_eye_foveae(VkExtent2D image, uint32_t layers,
                                           const std::vector<RuntimeEye> &eyes, const FoveaSize &fovea,
                                           const Gaze &gaze) {
    std::vector<std::vector<VkRect2D>> by_layer(layers);
    const VkRect2D whole{{0, 0}, image};
    if (eyes.empty())
        for (auto &foveae : by_layer)
            foveae.push_back(fovea_of_eye(whole, fovea));
    for (size_t i = 0; i < eyes.size(); ++i) {
        const RuntimeEye &eye = eyes[i];
        const VkRect2D rect = intersect(eye.rect, whole);
        if (eye.layer >= layers || rect.extent.width == 0 || rect.extent.height == 0) continue;
        const bool at_gaze = !gaze.fixed && i < std::size(gaze.eyes);
        add_fovea(by_layer[eye.layer], at_gaze ? fovea_at_gaze(rect, gaze.eyes[i], fovea)
                                               : fovea_at_view_direction(rect, eye.fov, fovea));
    }
    std::vector<LayerFovea> out;
    for (uint32_t layer = 0; layer < layers; ++layer)
        for (const VkRect2D &rect : by_layer[layer])
            out.push_back({layer, rect});
    return out;
}

std::vector<LayerFovea> runtime_fovea_areas(VkExtent2D image, uint32_t layers,
                                            const std::vector<RuntimeEye> &eyes, const FoveaSize &fovea,
                                            bool moving_gaze) {
    if (!moving_gaze) return runtime_eye_foveae(image, layers, eyes, fovea);
    std::vector<LayerFovea> out;
    const VkRect2D whole{{0, 0}, image};
    for (uint32_t layer = 0; eyes.empty() && layer < layers; ++layer)
        out.push_back({layer, whole});
    for (const RuntimeEye &eye : eyes)
        if (const VkRect2D rect = intersect(eye.rect, whole);
            eye.layer < layers && rect.extent.width && rect.extent.height)
            out.push_back({eye.layer, rect});
    return out;
}

bool runtime_guard_foveae(VkExtent2D image, uint32_t layers, const std::vector<RuntimeEye> &eyes,
                          bool eye_sized, const FoveaSize &fovea, bool moving_gaze,
                          std::vector<VkRect2D> *out) {
    out->clear();
    const std::vector<LayerFovea> foveae = runtime_fovea_areas(image, layers, eyes, fovea, moving_gaze);
    if (!eye_sized) {
        for (const LayerFovea &f : foveae)
            add_fovea(*out, f.rect);
        return true;
    }
    const VkRect2D halves[2] = {left_eye(image), right_eye(image)};
    const auto is_half = [&](const VkRect2D &r) {
        return std::any_of(std::begin(halves), std::end(halves), [&](const VkRect2D &h) {
            return r.offset.x == h.offset.x && r.offset.y == h.offset.y && r.extent.width == h.extent.width &&
                   r.extent.height == h.extent.height;
        });
    };
    if (!std::all_of(eyes.begin(), eyes.end(), [&](const RuntimeEye &e) { return is_half(e.rect); }))
        return false;
    // Each eye's fovea lies in its half (fovea_at_view_direction keeps it inside); before the views,
    // the centred fovea of each layer straddles both halves, and the part in each is that eye's.
    for (const LayerFovea &f : foveae)
        for (const VkRect2D &half : halves) {
            VkRect2D in_half = intersect(f.rect, half);
            if (in_half.extent.width == 0 || in_half.extent.height == 0) continue;
            in_half.offset.x -= half.offset.x;
            add_fovea(*out, in_half);
        }
    return true;
}

std::vector<LayerFovea> in_layer_zero(const std::vector<VkRect2D> &foveae) {
    std::vector<LayerFovea> out;
    for (const VkRect2D &rect : foveae)
        out.push_back({0, rect});
    return out;
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

VkRect2D narrow_to_foveae(const VkRect2D &scissor, const VkViewport *viewport, VkExtent2D image, EyeMode mode,
                          const FoveaSize &fovea, bool moving_gaze, uint32_t seam_pixels) {
    if (!viewport) return scissor;
    return intersect(scissor, fovea_scissor(*viewport, image, mode, fovea, moving_gaze, seam_pixels));
}

bool window_guard_foveae(const TargetClass &kind, VkExtent2D screen, EyeMode mode, const FoveaSize &fovea,
                         bool moving_gaze, std::vector<VkRect2D> *out) {
    if (!guard_maps_target(kind, mode)) return false;
    const VkExtent2D s = screen;
    const uint32_t left = s.width / 2;
    const auto anywhere = [&](const VkRect2D &eye) { return moving_gaze ? eye : fovea_of_eye(eye, fovea); };
    std::vector<VkRect2D> places;
    if (mode != EyeMode::Two) places.push_back(anywhere({{0, 0}, s}));
    if (mode != EyeMode::One) {
        places.push_back(anywhere({{0, 0}, {left, s.height}}));
        places.push_back(anywhere({{static_cast<int32_t>(left), 0}, {s.width - left, s.height}}));
    }
    for (const VkRect2D &f : places) {
        if (!kind.eye) {
            out->push_back(f);
            continue;
        }
        const VkRect2D in_left = intersect(f, {{0, 0}, {left, s.height}});
        VkRect2D in_right = intersect(f, {{static_cast<int32_t>(left), 0}, {s.width - left, s.height}});
        in_right.offset.x -= static_cast<int32_t>(left);
        for (const VkRect2D &r : {in_left, in_right})
            if (r.extent.width && r.extent.height) out->push_back(r);
    }
    return true;
}

bool guard_in_target(const std::vector<VkRect2D> &foveae, const TargetClass &kind,
                     VkExtent2D target_mip_extent, uint32_t mip, uint32_t guard_pixels, VkRect2D *out) {
    if (foveae.empty()) return false;
    int64_t fx0 = INT64_MAX, fy0 = INT64_MAX, fx1 = 0, fy1 = 0;
    for (const VkRect2D &f : foveae) {
        fx0 = std::min<int64_t>(fx0, f.offset.x);
        fy0 = std::min<int64_t>(fy0, f.offset.y);
        fx1 = std::max<int64_t>(fx1, int64_t{f.offset.x} + f.extent.width);
        fy1 = std::max<int64_t>(fy1, int64_t{f.offset.y} + f.extent.height);
    }
    const int64_t divisor = int64_t{kind.divisor} << std::min(mip, 31u);
    const int64_t n = guard_pixels;
    const VkExtent2D e = target_mip_extent;
    const int64_t x0 = std::max<int64_t>(0, fx0 / divisor - n);
    const int64_t y0 = std::max<int64_t>(0, fy0 / divisor - n);
    const int64_t x1 = std::min<int64_t>(e.width, (fx1 + divisor - 1) / divisor + n);
    const int64_t y1 = std::min<int64_t>(e.height, (fy1 + divisor - 1) / divisor + n);
    if (x1 <= x0 || y1 <= y0) return false;
    *out = {{static_cast<int32_t>(x0), static_cast<int32_t>(y0)},
            {static_cast<uint32_t>(x1 - x0), static_cast<uint32_t>(y1 - y0)}};
    return true;
}

bool window_guard_rect(const TargetClass &kind, VkExtent2D screen, VkExtent2D target_mip_extent, uint32_t mip,
                       EyeMode mode, const FoveaSize &fovea, bool moving_gaze, uint32_t guard_pixels,
                       VkRect2D *out) {
    std::vector<VkRect2D> foveae;
    return window_guard_foveae(kind, screen, mode, fovea, moving_gaze, &foveae) &&
           guard_in_target(foveae, kind, target_mip_extent, mip, guard_pixels, out);
}

VkRect2D runtime_scissor(const std::vector<LayerFovea> &areas, const VkViewport *v) {
    const auto reaches = [&](const VkRect2D &f) {
        if (!v) return true;
        const double x0 = v->x, x1 = double(v->x) + v->width;
        const double y0 = std::min(double(v->y), double(v->y) + v->height);
        const double y1 = std::max(double(v->y), double(v->y) + v->height);
        return x0 < f.offset.x + double(f.extent.width) && f.offset.x < x1 &&
               y0 < f.offset.y + double(f.extent.height) && f.offset.y < y1;
    };
    const bool any =
        std::any_of(areas.begin(), areas.end(), [&](const LayerFovea &f) { return reaches(f.rect); });
    int64_t x0 = INT64_MAX, y0 = INT64_MAX, x1 = INT64_MIN, y1 = INT64_MIN;
    for (const LayerFovea &f : areas) {
        if (any && !reaches(f.rect)) continue;
        x0 = std::min<int64_t>(x0, f.rect.offset.x);
        y0 = std::min<int64_t>(y0, f.rect.offset.y);
        x1 = std::max<int64_t>(x1, int64_t{f.rect.offset.x} + f.rect.extent.width);
        y1 = std::max<int64_t>(y1, int64_t{f.rect.offset.y} + f.rect.extent.height);
    }
    if (x1 <= x0 || y1 <= y0) return {};
    return {{int32_t(x0), int32_t(y0)}, {uint32_t(x1 - x0), uint32_t(y1 - y0)}};
}

} // namespace splitvk::split
