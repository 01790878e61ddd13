#include "target_rule.h"

#include "split_geometry.h"

#include <algorithm>
#include <cmath>

namespace splitvk::split {
namespace {

constexpr VkImageUsageFlags kWrittenByPasses = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT |
                                               VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT |
                                               VK_IMAGE_USAGE_STORAGE_BIT;

// Whether `e` is `base` halved k times (each axis rounded down or up); sets *divisor = 2^k.
bool halved(VkExtent2D e, VkExtent2D base, uint32_t *divisor) {
    if (base.width == 0 || base.height == 0) return false;
    for (uint32_t k = 0; k < 31; ++k) {
        const uint32_t d = 1u << k;
        const uint32_t w_lo = base.width / d, w_hi = (base.width + d - 1) / d;
        const uint32_t h_lo = base.height / d, h_hi = (base.height + d - 1) / d;
        if (w_hi < kMinTargetSide || h_hi < kMinTargetSide) return false;
        if ((e.width == w_lo || e.width == w_hi) && (e.height == h_lo || e.height == h_hi)) {
            *divisor = d;
            return true;
        }
    }
    return false;
}

bool chained(const void *next, VkStructureType type) {
    for (auto *p = static_cast<const VkBaseInStructure *>(next); p; p = p->pNext)
        if (p->sType == type) return true;
    return false;
}

TargetClass no(const char *reason) {
    TargetClass c;
    c.reason = reason;
    return c;
}

} // namespace

TargetClass classify_target(const VkImageCreateInfo &info, VkExtent2D screen, EyeMode eyes) {
    if (info.imageType != VK_IMAGE_TYPE_2D || info.extent.depth != 1) return no("not a 2D image");
    if (info.tiling != VK_IMAGE_TILING_OPTIMAL)
        return no("not optimal tiling (the host may address its texels)");
    if (!(info.usage & kWrittenByPasses))
        return no("no attachment or storage usage (a texture, not a target)");
    if (info.flags & (VK_IMAGE_CREATE_SPARSE_BINDING_BIT | VK_IMAGE_CREATE_ALIAS_BIT))
        return no("sparse or aliased");
    if (chained(info.pNext, VK_STRUCTURE_TYPE_EXTERNAL_MEMORY_IMAGE_CREATE_INFO))
        return no("external memory (shared beyond this process)");
    const VkExtent2D e{info.extent.width, info.extent.height};
    if (e.width < kMinTargetSide || e.height < kMinTargetSide)
        return no("smaller than a screen-space target");
    TargetClass c;
    const char *of = "the swapchain's extent";
    bool found = halved(e, screen, &c.divisor);
    if (!found && eyes != EyeMode::One) {
        // split::left_eye and right_eye: the left one W/2 wide, the right one W - W/2.
        const VkExtent2D left{screen.width / 2, screen.height},
            right{screen.width - screen.width / 2, screen.height};
        found = halved(e, left, &c.divisor) || halved(e, right, &c.divisor);
        c.eye = found;
        of = "one eye's extent";
    }
    if (!found) return no("not the swapchain's or an eye's extent, nor either halved on both axes");
    c.screen_space = true;
    c.layers = info.arrayLayers;
    c.reason = of;
    if (c.divisor > 1) c.reason += " / " + std::to_string(c.divisor);
    if (info.arrayLayers > 1) c.reason += ", per layer";
    return c;
}

PassDraw swapchain_pass_draw(SplitSide side, ClientRenders renders, bool runtime, bool whole_frames) {
    const bool renders_periphery = (side == SplitSide::Client) == (renders == ClientRenders::Periphery);
    // The swapped split under OpenXR: the client cuts an eye image to its views' foveae; the agent
    // replays it whole and downsamples it at its release, as eye images are not drawn scaled there.
    if (renders == ClientRenders::Fovea && runtime) return side == SplitSide::Client ? PassDraw::Cut : PassDraw::Whole;
    if (!renders_periphery) return PassDraw::Cut;
    if (side == SplitSide::Agent && whole_frames) return PassDraw::Whole;
    return PassDraw::Scaled;
}

bool scales_screen_space_targets(SplitSide side, ClientRenders renders) {
    return side == SplitSide::Client && renders == ClientRenders::Periphery;
}

bool guard_maps_target(const TargetClass &kind, EyeMode eyes) {
    if (!kind.screen_space) return false;
    return eyes != EyeMode::One || (kind.layers <= 1 && !kind.eye);
}

VkExtent3D scaled_target_extent(VkExtent3D full, double scale) {
    const VkExtent2D s = scaled_extent({full.width, full.height}, scale);
    return {s.width, s.height, full.depth};
}

VkExtent2D mip_extent(VkExtent2D base, uint32_t mip) {
    if (mip >= 32) return {1, 1};
    return {std::max(1u, base.width >> mip), std::max(1u, base.height >> mip)};
}

VkRect2D scale_target_rect(const VkRect2D &rect, VkExtent2D full, uint32_t mip, double scale) {
    const VkExtent2D scaled = mip_extent(scaled_extent(full, scale), mip);
    return scale_rect(rect, axis_scale(mip_extent(full, mip), scaled), scaled);
}

GroupRange scaled_group_range(uint32_t base, uint32_t count, double scale) {
    // The same tolerance as split_geometry's rounding: a product off by float noise does not step.
    const auto first = static_cast<uint64_t>(std::floor(static_cast<double>(base) * scale + 1e-6));
    if (count == 0) return {static_cast<uint32_t>(first), 0};
    const auto end = static_cast<uint64_t>(
        std::ceil((static_cast<double>(base) + static_cast<double>(count)) * scale - 1e-6));
    return {static_cast<uint32_t>(first),
            static_cast<uint32_t>(std::max<uint64_t>(1, end - std::min(end, first)))};
}

uint32_t scaled_group_count(uint32_t groups, double scale) {
    return scaled_group_range(0, groups, scale).count;
}

} // namespace splitvk::split
