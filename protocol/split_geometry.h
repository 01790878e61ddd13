#pragma once

// The image-space split's geometry (DESIGN §4), shared by the layer and the agent so that both
// sides scale, assign eyes and place foveae identically: the client renders the periphery of a
// split pass into the top-left ceil(s·W) x ceil(s·H) of the swapchain image, the agent shades the
// fovea of each eye at full resolution, and the compositor joins them by these same rectangles.

#include "settings.h"

#include <vulkan/vulkan.h>

#include <vector>

namespace splitvk::split {

// ceil(s·W) x ceil(s·H), at least 1x1.
VkExtent2D scaled_extent(VkExtent2D full, double scale);

// A viewport of the full image mapped into the scaled one: x, y, width and height times s; the
// depth range is unchanged.
VkViewport scale_viewport(const VkViewport &viewport, double scale);

// An integer rectangle (scissor, render area, clear rect) of the full image mapped into the
// scaled one: x0 = floor(x·s), x1 = ceil((x+w)·s), clamped to `scaled`. Rounding outwards keeps
// every pixel the full-resolution rectangle touches covered by the periphery.
VkRect2D scale_rect(const VkRect2D &rect, double scale, VkExtent2D scaled);

// The intersection of two rectangles; when empty, a zero-extent rectangle at a's clamped offset.
VkRect2D intersect(const VkRect2D &a, const VkRect2D &b);

// The eye a viewport draws (a rectangle of the image): EyeMode::One: the whole image. Two: the
// half (W/2 wide, the right one W - W/2) holding the viewport's centre. Auto: the left or right
// half when the viewport lies within it (1 px of rounding allowed), otherwise the whole image.
VkRect2D eye_for_viewport(const VkViewport &viewport, VkExtent2D image, EyeMode mode);

// The fovea of an eye: FoveaSize::pixels_for_eye, centred in the eye (rounded down).
VkRect2D fovea_of_eye(const VkRect2D &eye, const FoveaSize &fovea);

// eye_for_viewport, then fovea_of_eye.
VkRect2D fovea_for_viewport(const VkViewport &viewport, VkExtent2D image, EyeMode mode,
                            const FoveaSize &fovea);

// Adds `rect` to a set of foveae kept sorted by x, then y, without duplicates: the order both
// sides report them in.
void add_fovea(std::vector<VkRect2D> &foveae, const VkRect2D &rect);

} // namespace splitvk::split
