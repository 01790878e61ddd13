#pragma once

// Screen-space targets (docs/architecture.md §4): the rule that decides, when an image is created,
// whether the client renders it at SPLITVK_SCALE, and how the regions that commands name in such an
// image map into the scaled one. Pure functions, so that one table holds the rule and a unit test
// pins it (tests/unit/screen_space_test.cpp); layer/capture/screen_space.h applies it.
//
// A screen-space target is an image a frame renders into at a size tied to the screen: a 2D,
// optimal-tiling colour, depth/stencil or storage image whose extent (per layer: layered eye
// textures qualify layer by layer) is the swapchain's, one eye's, or either halved k times on both
// axes (rounded down or up, so 2400x1080 / 16 = 150x67 or 150x68), with both sides at least
// kMinTargetSide. Smaller images, textures that no pass writes (no attachment or storage usage),
// aliased, sparse and external images stay full size.

#include "settings.h"

#include <vulkan/vulkan.h>

#include <cstdint>
#include <string>

namespace splitvk::split {

// Reductions (1x1 exposure, 4x4 luminance) and tiny lookup images are not screen-space: their texels
// are not pixels of the screen, and scaling them would change what the frame computes.
constexpr uint32_t kMinTargetSide = 16;

struct TargetClass {
    bool screen_space = false;
    bool eye = false;     // sized after one eye (half the swapchain's width), not the whole screen
    uint32_t divisor = 1; // 1, 2, 4, ...: the screen (or eye) extent halved log2(divisor) times
    uint32_t layers = 1;  // array layers: a multiview eye texture has one per eye
    std::string reason;   // why, for the info line: "the swapchain's extent / 2", "no attachment usage"
};

// Which side draws what of a frame (docs/architecture.md §4): one table both sides read, so that a
// pass one side draws scaled (the periphery) the other draws cut to the foveae, never both or
// neither. SPLITVK_CLIENT_RENDERS=periphery: the client scales, the agent cuts (fovea shading);
// fovea, the swapped split: the other way round. An OpenXR runtime's image is not swapped in this
// slice: the client draws it whole and the agent sends no periphery for it.
enum class SplitSide { Client, Agent };
enum class PassDraw {
    Scaled, // into the top-left scaled_extent(full, SPLITVK_SCALE) (scaled_pass_rect): the periphery
    Cut,    // at full size, its scissors cut to the foveae (narrow_to_foveae): the foveae
    Whole,  // as recorded
};
// How `side` draws a pass into a swapchain image. `runtime`: an OpenXR runtime's image.
// `whole_frames`: the agent of a swapped split replays whole frames at full size, because the client
// verifies (SPLITVK_VERIFY compares with the agent's native frame, PeripheryConfig::whole_frames).
PassDraw swapchain_pass_draw(SplitSide side, ClientRenders renders, bool runtime, bool whole_frames = false);
// Whether `side` creates the screen-space targets classify_target finds at SPLITVK_SCALE: the client
// of the paper's split alone. In the swapped split the client keeps them full size (it cuts its
// passes into them to a guard) and so does the agent: its scaled passes into the swapchain image
// sample them by normalised coordinates.
bool scales_screen_space_targets(SplitSide side, ClientRenders renders);

// `screen`: the extent of the device's newest swapchain; `eyes`: SPLITVK_EYES (Two and Auto also
// accept one eye's extent, since Auto may find eyes side by side).
TargetClass classify_target(const VkImageCreateInfo &info, VkExtent2D screen, EyeMode eyes);

// SPLITVK_AGENT_SCISSOR=guard:N: whether the agent may cut a pass into this
// target to the foveae grown by N. The foveae are computed in the screen (or, with two eyes, in each
// eye) and map to a target by its divisor alone; a layered or eye-sized target under SPLITVK_EYES=1
// has no such mapping: its layers are eyes that a later pass composes where the agent cannot see (a
// 1280x720 layer squeezed into a 640-wide half of a 1280x720 screen puts the centred fovea at the
// layer's edge), so the agent replays its passes whole.
bool guard_maps_target(const TargetClass &kind, EyeMode eyes);

// The extent a screen-space target is created with: width and height as split::scaled_extent
// rounds them (ceil, at least 1), depth unchanged.
VkExtent3D scaled_target_extent(VkExtent3D full, double scale);

// The extent of mip `mip` of an image of extent `base`.
VkExtent2D mip_extent(VkExtent2D base, uint32_t mip);

// A region (copy, blit, resolve, clear) of mip `mip` of a screen-space target whose app-visible
// extent is `full`, mapped into the scaled image: offsets and ends times the mip's axis_scale,
// rounded outwards as scale_rect does and clamped to the scaled mip.
VkRect2D scale_target_rect(const VkRect2D &rect, VkExtent2D full, uint32_t mip, double scale);

// The group count of a dispatch over a scaled target: ceil(n·s), at least 1 (covers every scaled
// pixel whenever n groups covered every full one).
uint32_t scaled_group_count(uint32_t groups, double scale);

// The groups of a vkCmdDispatchBase over a scaled target: groups [base, base + count) on one axis
// become [floor(base·s), ceil((base + count)·s)), at least one group when count is not 0. With base 0
// this is scaled_group_count; dispatches that tile an image in parts (base 0, then base n, ...)
// leave no scaled group out, since each part's end rounds up exactly where the next part's start
// rounds down.
struct GroupRange {
    uint32_t base = 0;
    uint32_t count = 0;
};
GroupRange scaled_group_range(uint32_t base, uint32_t count, double scale);

} // namespace splitvk::split
