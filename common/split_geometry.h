#pragma once

// The image-space split's geometry (docs/architecture.md §4), shared by the layer and the agent so that both
// sides scale, assign eyes and place foveae identically: the client renders the periphery of a
// split pass into the top-left ceil(s·W) x ceil(s·H) of the swapchain image, the agent shades the
// fovea of each eye at full resolution, and the compositor joins them by these same rectangles.

#include "settings.h"
#include "target_rule.h"

#include <vulkan/vulkan.h>

#include <optional>
#include <vector>

namespace splitvk::split {

// ceil(s·W) x ceil(s·H), at least 1x1.
VkExtent2D scaled_extent(VkExtent2D full, double scale);

// How a full-resolution extent maps onto its scaled one, per axis: scaled / full. The scaled extent
// is rounded up, so wherever s·W is not whole the factor is a little above s. Drawing with it makes
// a scaled pass fill its scaled extent to its last row and column, and that is what everything that
// reads the scaled image assumes: the compositor upsamples scaled / full per axis, and a later pass
// samples a scaled target by normalised coordinates. With s itself, a 1007-row eye scaled by 0.6
// would draw 604.2 rows into 605, and the unshaded last row would be upsampled into the picture.
struct AxisScale {
    double x = 1.0;
    double y = 1.0;
};
AxisScale axis_scale(VkExtent2D full, VkExtent2D scaled);
// The same for `full` scaled by `scale` (scaled_extent).
AxisScale axis_scale(VkExtent2D full, double scale);

// A viewport of the full image mapped into the scaled one: x and width times scale.x, y and height
// times scale.y; the depth range is unchanged.
VkViewport scale_viewport(const VkViewport &viewport, AxisScale scale);

// An integer rectangle (scissor, render area, clear rect) of the full image mapped into the
// scaled one: x0 = floor(x·scale.x), x1 = ceil((x+w)·scale.x), and alike in y, clamped to
// `scaled`. Rounding outwards keeps every pixel the full-resolution rectangle touches covered by
// the periphery.
VkRect2D scale_rect(const VkRect2D &rect, AxisScale scale, VkExtent2D scaled);

// A scaled split pass (docs/architecture.md §4), whichever side draws it: its render area, scissors
// and clear rects, `rect` of a pass whose full extent is `full`, go into the top-left
// scaled_extent(full, scale) by scale_rect with that extent's axis_scale; its viewports by
// scale_viewport with the same factors. The client draws its periphery so, and so does the agent in
// the swapped split (server-agent/periphery_scaling.h): the same rectangles on both sides.
VkRect2D scaled_pass_rect(const VkRect2D &rect, VkExtent2D full, double scale);
VkViewport scaled_pass_viewport(const VkViewport &viewport, VkExtent2D full, double scale);

// The intersection of two rectangles; when empty, a zero-extent rectangle at a's clamped offset.
VkRect2D intersect(const VkRect2D &a, const VkRect2D &b);

// Which halves of a side-by-side image a viewport (or a transfer's region, as a viewport of that
// rectangle) draws, as the foveae see it. A frame's coverage is the union over every viewport its
// split passes drew with; its foveae follow from that and SPLITVK_EYES only once the frame is
// complete (frame_foveae), so that a viewport drawn early cannot decide alone whether the frame is
// a stereo pair.
struct EyeCoverage {
    bool left = false;  // draws into the left half (W/2 wide), more than a pixel of it
    bool right = false; // draws into the right half (W - W/2 wide), more than a pixel of it
    // Is that half (a pixel of rounding allowed on every side, the whole height): one eye of a
    // stereo pair.
    bool left_eye = false;
    bool right_eye = false;

    bool any() const { return left || right; }
    bool stereo_pair() const { return left_eye && right_eye; }
    EyeCoverage &operator|=(const EyeCoverage &other);
};

// A viewport's coverage. One that draws into neither half by more than a pixel (a sliver, or one
// outside the image) counts for the half holding its centre.
EyeCoverage viewport_coverage(const VkViewport &viewport, VkExtent2D image);

// The left and right eyes of a side-by-side image: the left W/2 wide, the right W - W/2.
VkRect2D left_eye(VkExtent2D image);
VkRect2D right_eye(VkExtent2D image);

// The fovea of an eye: FoveaSize::pixels_for_eye, centred in the eye (rounded down).
VkRect2D fovea_of_eye(const VkRect2D &eye, const FoveaSize &fovea);

// Where the eyes look in a frame (SPLITVK_GAZE, docs/architecture.md §9): per eye a point of that eye's image
// in units of 1/kGazeOne of its width and height, so that both sides place the fovea with the same integer
// arithmetic (kGazeOne/2, kGazeOne/2 is the centre). A fixed gaze places every fovea where fovea_of_eye does,
// pixel for pixel what the split did before gaze existed.
inline constexpr uint32_t kGazeOne = 65536;
struct GazePoint {
    uint32_t x = kGazeOne / 2; // 0 (left edge) .. kGazeOne (right edge)
    uint32_t y = kGazeOne / 2; // 0 (top edge) .. kGazeOne (bottom edge)
};
struct Gaze {
    bool fixed = true;
    // The left eye (the only eye of a mono frame, whose one eye is the whole image), the right eye.
    GazePoint eyes[2];
};

// The size of one frame's foveae where the client picks it per frame (SPLITVK_FOVEA=auto),
// in 1/kGazeOne of each eye's width and height so that both sides compute the same pixels from it.
// Unset (width 0): the size SplitConfig gives. A set size is never larger than SplitConfig's in
// either dimension: the agent recorded its scissors for that one, and a smaller fovea, centred or
// at any gaze, lies within them (fovea_scissor).
struct FrameFoveaSize {
    uint32_t width = 0; // 1..kGazeOne when set
    uint32_t height = 0;
    bool set() const { return width != 0 && height != 0; }
    bool operator==(const FrameFoveaSize &) const = default;
};

// Each dimension the larger of the two; the one that is set when the other is not.
FrameFoveaSize larger(const FrameFoveaSize &a, const FrameFoveaSize &b);

// The size a frame's foveae take: `frame`'s as fractions of the eye when set, else `configured`.
FoveaSize frame_fovea_size(const FoveaSize &configured, const FrameFoveaSize &frame);

// Whether a frame may ask for `frame` in a session configured with `configured`: unset, or set,
// within 1..kGazeOne, and no larger than `configured` (fractional) in either dimension.
bool frame_fovea_size_allowed(const FoveaSize &configured, const FrameFoveaSize &frame);

// The fovea of an eye (FoveaSize::pixels_for_eye) centred on `point`: its offset is the point's
// pixel (floor(x·W / kGazeOne)) less half the fovea's size (rounded down), clamped so that the
// fovea stays inside the eye. Coordinates beyond kGazeOne are clamped too.
VkRect2D fovea_at_gaze(const VkRect2D &eye, const GazePoint &point, const FoveaSize &fovea);

// The foveae of a frame whose split passes drew `drawn` into `image` (sorted by x, as add_fovea
// keeps them; none when nothing was drawn). docs/architecture.md §4, §9:
// - EyeMode::One: the fovea of the whole image, centred.
// - Two: the fovea of each half drawn into. A stereo frame has two foveae wherever its last pass
//   draws: a full-screen pass (tone mapping, a multiview compose) gives both.
// - Auto: as Two when the frame's viewports include a stereo pair (one that is the left half and
//   one that is the right half), otherwise as One: a mono frame's fovea belongs at the centre of
//   the screen, however many panels it draws side by side.
// A gaze that is not fixed moves each eye's fovea to its point (fovea_at_gaze; a mono frame's one
// eye takes the left eye's point).
std::vector<VkRect2D> frame_foveae(const EyeCoverage &drawn, VkExtent2D image, EyeMode mode,
                                   const FoveaSize &fovea, const Gaze &gaze = {});

// The rectangle the agent cuts a viewport's scissors to in a pass into the swapchain image: the
// bounding box of every fovea the viewport's draws can end up in, whatever else the frame draws.
// One: the centred fovea. Two: the foveae of the halves it draws into (both, for a full-screen
// viewport). Auto: those and the centred fovea, since the frame may or may not turn out to be a
// stereo pair (set SPLITVK_EYES to shade less). Both sides composite only frame_foveae, which
// always lies within the scissors of the viewports that drew it.
// `moving_gaze` (SPLITVK_GAZE other than fixed): the scissor is recorded before the frame's gaze is
// known and may be replayed for many frames, so it covers every place the fovea can move to: the
// whole image (One, Auto) or the halves the viewport draws into (Two).
// `seam_pixels` (the client's, in the swapped split: SPLITVK_SEAM's feather) grows every fovea by
// seam_rect before the bounding box; the agent's scissors pass none.
VkRect2D fovea_scissor(const VkViewport &viewport, VkExtent2D image, EyeMode mode, const FoveaSize &fovea,
                       bool moving_gaze = false, uint32_t seam_pixels = 0);

// The swapped split's feathered seam (SPLITVK_SEAM=feather:N): `fovea` (of frame_foveae) grown by
// `pixels` on every side, clamped to the image and, for a fovea that lies wholly within one half of
// the image (an eye of a stereo frame), to that half, so that a band never reaches across the eye
// boundary into the other eye's picture. A fovea that straddles the centre (a mono frame's) is
// clamped to the image only. The client cuts its passes into a window's swapchain image to it
// (fovea_scissor), and the compositor blends across it, by this one rule: what the compositor
// blends is always what the client rendered. `pixels` 0: the fovea, clamped alike.
VkRect2D seam_rect(const VkRect2D &fovea, VkExtent2D image, uint32_t pixels);

// A scissor of a pass into a window's swapchain image cut to the foveae (the agent's rule in its split
// passes, and the client's in SPLITVK_CLIENT_RENDERS=fovea, whose foveae grow by its seam): `scissor`
// intersected with fovea_scissor of the viewport it pairs with. Without that viewport the eye is unknown, and
// the scissor stays as it is until the viewport is set.
VkRect2D narrow_to_foveae(const VkRect2D &scissor, const VkViewport *viewport, VkExtent2D image, EyeMode mode,
                          const FoveaSize &fovea, bool moving_gaze, uint32_t seam_pixels = 0);

// Every place a fovea of a window's swapchain of `screen` extent can be, in the coordinates a
// screen-space target of class `kind` holds before its divisor: the screen's, or for an eye-sized
// target (a layer of an eye texture, which holds either eye) what of them lies in each eye, in that
// eye's coordinates (a centred fovea straddles both eyes). SPLITVK_EYES=1: the centre; 2: both eyes;
// auto: all three; `moving_gaze` puts an eye's fovea anywhere in that eye. False, with nothing added,
// where guard_maps_target refuses the target.
bool window_guard_foveae(const TargetClass &kind, VkExtent2D screen, EyeMode mode, const FoveaSize &fovea,
                         bool moving_gaze, std::vector<VkRect2D> *out);

// The bounding box of `foveae` (a target's coordinates before its divisor) in mip `mip` of a
// target of class `kind` whose mip extent is `target_mip_extent`: divided by divisor << mip, rounded
// outwards, grown by `guard_pixels` on every side, bounded by the mip. False where nothing remains.
bool guard_in_target(const std::vector<VkRect2D> &foveae, const TargetClass &kind,
                     VkExtent2D target_mip_extent, uint32_t mip, uint32_t guard_pixels, VkRect2D *out);

// The guard of one attachment view of a screen-space target classified against a window's swapchain
// of `screen` extent (the agent's SPLITVK_AGENT_SCISSOR=guard:N, the client's SPLITVK_CLIENT_GUARD):
// window_guard_foveae mapped by guard_in_target. False: a pass into that view runs whole.
bool window_guard_rect(const TargetClass &kind, VkExtent2D screen, VkExtent2D target_mip_extent, uint32_t mip,
                       EyeMode mode, const FoveaSize &fovea, bool moving_gaze, uint32_t guard_pixels,
                       VkRect2D *out);

// An eye's field of view as OpenXR gives it (XrFovf): the angles of the image's edges from the
// view direction, in radians, within (-pi/2, pi/2); left and down are negative.
struct FieldOfView {
    double angle_left = 0;
    double angle_right = 0;
    double angle_up = 0;
    double angle_down = 0;
};

// The fovea of an eye (FoveaSize::pixels_for_eye of `eye`) centred on the projection of the view
// direction (docs/architecture.md §9: an asymmetric field of view moves it off the image's centre). On the
// image plane the edges lie at tan(angle); the view direction, at tan(0) = 0, lands at
//   x = (0 - tan(angleLeft)) / (tan(angleRight) - tan(angleLeft)) of the eye's width, and
//   y = (tan(angleUp) - 0) / (tan(angleUp) - tan(angleDown)) of its height (image y grows downward).
// The fovea's offset is that centre less half its size, rounded down (a symmetric field of view
// gives fovea_of_eye's rectangle), then clamped so that the fovea stays inside the eye. A field of
// view that spans nothing (right <= left, up <= down, or not finite) gives fovea_of_eye's.
VkRect2D fovea_at_view_direction(const VkRect2D &eye, const FieldOfView &fov, const FoveaSize &fovea);

// The inverse of that projection: where `direction`, given in the eye's own frame (OpenXR's view
// space: +x right, +y up, -z forward), crosses the eye's image, in units of 1/kGazeOne of its width
// and height, clamped to the image. Nothing for a direction that does not point ahead (z >= 0, or
// not finite) or a field of view that spans nothing.
std::optional<GazePoint> gaze_point_in_eye(const FieldOfView &fov, double x, double y, double z);

// One eye of an OpenXR runtime's swapchain (docs/architecture.md §9): a projection view of xrEndFrame that
// names the swapchain, with the array layer (imageArrayIndex) and sub-image rectangle (imageRect) that hold
// that eye, and its field of view. A layered swapchain drawn with multiview has an eye per layer; a
// side-by-side one has two rectangles in one layer.
struct RuntimeEye {
    uint32_t layer = 0;
    VkRect2D rect{};
    FieldOfView fov;
};

// A fovea in one array layer of an image (layer 0 for every window's swapchain image).
struct LayerFovea {
    uint32_t layer = 0;
    VkRect2D rect{};
};

// Records `eye` among a runtime swapchain's eyes: it replaces every eye of its layer whose rectangle
// overlaps its own (the same eye, drawn elsewhere or at another size, or with another field of
// view) and is added otherwise. Returns whether anything changed. Both sides apply the views in
// stream order, so they hold the same eyes for every frame.
bool note_runtime_eye(std::vector<RuntimeEye> &eyes, const RuntimeEye &eye);

// The foveae of an OpenXR runtime's eye image of `layers` array layers: before the application's
// projection views said where its eyes are, one centred in each layer (an eye per layer, the whole
// image); then one per eye, fovea_at_view_direction of its rectangle (clipped to the image; an eye
// in a layer the image does not have, or outside it, has none). Sorted by layer, then as add_fovea
// sorts: the order both sides report them in. Both sides composite them and the agent shades them.
// A gaze that is not fixed places the first two of `eyes` (in their order, which both sides share)
// at its points instead (fovea_at_gaze of the eye's rectangle): the client names, per image, where
// each of that image's eyes looks, whichever of the application's views it is.
std::vector<LayerFovea> runtime_eye_foveae(VkExtent2D image, uint32_t layers,
                                           const std::vector<RuntimeEye> &eyes, const FoveaSize &fovea,
                                           const Gaze &gaze = {});

// Every place a fovea of such an image can be in a session, which the agent's scissors of its split
// passes must cover: runtime_eye_foveae's, or with `moving_gaze` (the gaze is only known per frame,
// after the passes were recorded) each eye whole, and each layer whole before the views.
std::vector<LayerFovea> runtime_fovea_areas(VkExtent2D image, uint32_t layers,
                                            const std::vector<RuntimeEye> &eyes, const FoveaSize &fovea,
                                            bool moving_gaze);

// SPLITVK_AGENT_SCISSOR=guard:N under OpenXR: every place an eye's fovea can be in a screen-space
// target classified against an OpenXR runtime's swapchain of `image` extent, `layers` layers and
// `eyes` (as runtime_eye_foveae takes them), in the coordinates the target holds before its divisor:
// the image's (a target of the image's size, any layer), or with `eye_sized` (a target half the
// image's width) one eye's rectangle, with each fovea of that eye relative to it. An offscreen pass
// does not say which eye image or layer it renders for, so every eye's fovea counts. False, with
// nothing in *out, only where an eye-sized target cannot be mapped: an eye's rectangle is not a half of
// the image (before the views, the halves are taken as the eyes, the centred fovea cut by them).
// `moving_gaze`: as runtime_fovea_areas.
bool runtime_guard_foveae(VkExtent2D image, uint32_t layers, const std::vector<RuntimeEye> &eyes,
                          bool eye_sized, const FoveaSize &fovea, bool moving_gaze,
                          std::vector<VkRect2D> *out);

// The bounding box of the places `areas` (runtime_fovea_areas) of an OpenXR eye image that a
// viewport can draw into: every layer's (a multiview pass draws all its views with the same
// scissors), and of a side-by-side image the eyes whose foveae the viewport reaches (all of them
// where it is not known, or reaches none). A zero rectangle when `areas` is empty.
VkRect2D runtime_scissor(const std::vector<LayerFovea> &areas, const VkViewport *viewport);

// The foveae of a window's swapchain image, all in layer 0.
std::vector<LayerFovea> in_layer_zero(const std::vector<VkRect2D> &foveae);

// Adds `rect` to a set of foveae kept sorted by x, then y, without duplicates: the order both
// sides report them in.
void add_fovea(std::vector<VkRect2D> &foveae, const VkRect2D &rect);

} // namespace splitvk::split
