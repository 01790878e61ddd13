// The screen-space target rule (protocol/screen_space.h): which images the client renders at
// SPLITVK_SCALE, and how their regions round. The layer classifies every image with it.

#include "split_geometry.h"
#include "target_rule.h"

#include <gtest/gtest.h>

namespace splitvk::split {
namespace {

constexpr VkExtent2D kScreen{2400, 1080};

VkImageCreateInfo image(uint32_t w, uint32_t h,
                        VkImageUsageFlags usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT |
                                                  VK_IMAGE_USAGE_SAMPLED_BIT,
                        uint32_t layers = 1) {
    VkImageCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO;
    info.imageType = VK_IMAGE_TYPE_2D;
    info.format = VK_FORMAT_R16G16B16A16_SFLOAT;
    info.extent = {w, h, 1};
    info.mipLevels = 1;
    info.arrayLayers = layers;
    info.samples = VK_SAMPLE_COUNT_1_BIT;
    info.tiling = VK_IMAGE_TILING_OPTIMAL;
    info.usage = usage;
    return info;
}

bool qualifies(const VkImageCreateInfo &info, EyeMode eyes = EyeMode::Auto) {
    return classify_target(info, kScreen, eyes).screen_space;
}

TEST(ScreenSpace, SwapchainExtentAndItsHalvings) {
    const TargetClass full = classify_target(image(2400, 1080), kScreen, EyeMode::Auto);
    EXPECT_TRUE(full.screen_space);
    EXPECT_EQ(full.divisor, 1u);
    EXPECT_EQ(full.reason, "the swapchain's extent");
    // A bloom chain: half, quarter, eighth.
    for (uint32_t d : {2u, 4u, 8u}) {
        const TargetClass c = classify_target(image(2400 / d, 1080 / d), kScreen, EyeMode::Auto);
        EXPECT_TRUE(c.screen_space) << d;
        EXPECT_EQ(c.divisor, d);
        EXPECT_FALSE(c.eye);
    }
    // Halving an odd side rounds either way: 1080 / 16 = 67.5.
    EXPECT_TRUE(qualifies(image(150, 67)));
    EXPECT_TRUE(qualifies(image(150, 68)));
    EXPECT_FALSE(qualifies(image(150, 66)));
}

TEST(ScreenSpace, AspectRatioMustBeKept) {
    EXPECT_FALSE(qualifies(image(1200, 1080 / 4))); // half width, quarter height
    EXPECT_FALSE(qualifies(image(2400, 540)));
    EXPECT_FALSE(qualifies(image(2401, 1080)));
    EXPECT_FALSE(qualifies(image(1024, 1024))); // a shadow map
}

TEST(ScreenSpace, EyesAndLayers) {
    // One eye of 2400x1080 side by side: 1200x1080, and its halvings.
    const TargetClass eye = classify_target(image(1200, 1080), kScreen, EyeMode::Auto);
    EXPECT_TRUE(eye.screen_space);
    EXPECT_TRUE(eye.eye);
    EXPECT_EQ(eye.reason, "one eye's extent");
    EXPECT_TRUE(qualifies(image(300, 270), EyeMode::Two));
    // A multiview eye texture qualifies per layer.
    const TargetClass layered =
        classify_target(image(1200, 1080, VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT, 2), kScreen, EyeMode::Two);
    EXPECT_TRUE(layered.screen_space);
    EXPECT_EQ(layered.reason, "one eye's extent, per layer");
    // With one eye there is no eye-sized target: 1200x1080 is then just another size.
    EXPECT_FALSE(qualifies(image(1200, 1080), EyeMode::One));
    // An odd swapchain width: the right eye is the wider one.
    EXPECT_TRUE(classify_target(image(1201, 1080), {2401, 1080}, EyeMode::Two).screen_space);
}

// SPLITVK_AGENT_SCISSOR=guard:N: a multiview sample drew 1280x720 eye layers and
// squeezed each into a 640-wide half of a 1280x720 screen; with SPLITVK_EYES=1 the guard cut each
// layer to the centred screen fovea, which the squeeze puts at the layers' inner edges (41,829 fovea
// pixels wrong). Layered targets under one eye are replayed whole; everything else keeps its guard.
TEST(ScreenSpace, GuardRefusesLayersUnderOneEye) {
    constexpr VkExtent2D screen{1280, 720};
    const auto kind = [&](uint32_t w, uint32_t h, uint32_t layers, EyeMode eyes) {
        return classify_target(image(w, h, VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT, layers), screen, eyes);
    };
    // The reported case: screen-sized layers, one eye.
    const TargetClass squeezed = kind(1280, 720, 2, EyeMode::One);
    ASSERT_TRUE(squeezed.screen_space);
    EXPECT_EQ(squeezed.layers, 2u);
    EXPECT_FALSE(guard_maps_target(squeezed, EyeMode::One));
    EXPECT_FALSE(guard_maps_target(kind(640, 360, 2, EyeMode::One), EyeMode::One)); // its halving
    // Single-layer targets under one eye (hdr's bloom chain, deferred's G-buffer) keep their guard.
    EXPECT_TRUE(guard_maps_target(kind(1280, 720, 1, EyeMode::One), EyeMode::One));
    EXPECT_TRUE(guard_maps_target(kind(320, 180, 1, EyeMode::One), EyeMode::One));
    // With two eyes, or auto, the foveae are computed per eye: eye layers keep their guard (exact).
    for (EyeMode eyes : {EyeMode::Two, EyeMode::Auto}) {
        EXPECT_TRUE(guard_maps_target(kind(640, 720, 2, eyes), eyes));
        EXPECT_TRUE(guard_maps_target(kind(1280, 720, 2, eyes), eyes));
    }
    // Not screen-space: never guarded.
    EXPECT_FALSE(guard_maps_target(kind(1024, 1024, 1, EyeMode::Auto), EyeMode::Auto));
}

TEST(ScreenSpace, OnlyTargetsThatPassesWrite) {
    EXPECT_TRUE(qualifies(image(2400, 1080, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT)));
    EXPECT_TRUE(qualifies(image(2400, 1080, VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT)));
    // A screen-sized texture the app uploads (sampled, transfer dst) is content, not a target.
    EXPECT_FALSE(qualifies(image(2400, 1080, VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT)));
    VkImageCreateInfo linear = image(2400, 1080);
    linear.tiling = VK_IMAGE_TILING_LINEAR;
    EXPECT_FALSE(qualifies(linear));
    VkImageCreateInfo volume = image(2400, 1080);
    volume.imageType = VK_IMAGE_TYPE_3D;
    EXPECT_FALSE(qualifies(volume));
    VkImageCreateInfo aliased = image(2400, 1080);
    aliased.flags = VK_IMAGE_CREATE_ALIAS_BIT;
    EXPECT_FALSE(qualifies(aliased));
    VkExternalMemoryImageCreateInfo external{};
    external.sType = VK_STRUCTURE_TYPE_EXTERNAL_MEMORY_IMAGE_CREATE_INFO;
    VkImageCreateInfo shared = image(2400, 1080);
    shared.pNext = &external;
    EXPECT_FALSE(qualifies(shared));
    // Reductions end before they reach exposure-sized images.
    EXPECT_FALSE(qualifies(image(2400 / 256, 1080 / 256)));
    EXPECT_FALSE(qualifies(image(1, 1)));
}

TEST(ScreenSpace, ScaledExtentRoundsLikeTheSwapchainPass) {
    for (uint32_t d : {1u, 2u, 4u, 8u}) {
        const VkExtent3D e = scaled_target_extent({2400 / d, 1080 / d, 1}, 0.6);
        const VkExtent2D pass = scaled_extent({2400 / d, 1080 / d}, 0.6);
        EXPECT_EQ(e.width, pass.width);
        EXPECT_EQ(e.height, pass.height);
        EXPECT_EQ(e.depth, 1u);
    }
    const VkExtent3D full = scaled_target_extent({2400, 1080, 1}, 0.6);
    EXPECT_EQ(full.width, 1440u);
    EXPECT_EQ(full.height, 648u);
    const VkExtent3D eighth = scaled_target_extent({300, 135, 1}, 0.6);
    EXPECT_EQ(eighth.width, 180u);
    EXPECT_EQ(eighth.height, 81u);
    const VkExtent3D odd = scaled_target_extent({150, 67, 1}, 0.6); // 90 x 40.2
    EXPECT_EQ(odd.width, 90u);
    EXPECT_EQ(odd.height, 41u);
}

TEST(ScreenSpace, RegionsScaleIntoTheScaledMip) {
    const VkRect2D whole = scale_target_rect({{0, 0}, {2400, 1080}}, {2400, 1080}, 0, 0.6);
    EXPECT_EQ(whole.extent.width, 1440u);
    EXPECT_EQ(whole.extent.height, 648u);
    // Mip 1 of the scaled image is 720x324: the region of full mip 1 (1200x540) fills it.
    const VkRect2D mip1 = scale_target_rect({{0, 0}, {1200, 540}}, {2400, 1080}, 1, 0.6);
    EXPECT_EQ(mip1.extent.width, 720u);
    EXPECT_EQ(mip1.extent.height, 324u);
    // Rounded outwards, clamped to the scaled mip.
    const VkRect2D part = scale_target_rect({{1, 1}, {2, 2}}, {2400, 1080}, 0, 0.6);
    EXPECT_EQ(part.offset.x, 0);
    EXPECT_EQ(part.extent.width, 2u);
    EXPECT_EQ(scaled_group_count(300, 0.6), 180u); // ceil(2400 / 8) groups of 8 -> 1440 pixels
    EXPECT_EQ(scaled_group_count(135, 0.6), 81u);
    EXPECT_EQ(scaled_group_count(1, 0.6), 1u);
    EXPECT_EQ(scaled_group_count(0, 0.6), 0u);
    // ceil(ceil(W / 8) s) groups always cover ceil(W s) pixels.
    for (uint32_t w = 1; w < 3000; w += 7)
        EXPECT_GE(scaled_group_count((w + 7) / 8, 0.6) * 8, scaled_extent({w, 1}, 0.6).width) << w;
}

// vkCmdDispatchBase over a scaled storage image: base and count scale together, base 0 as
// vkCmdDispatch does, and a dispatch split in parts still covers every scaled group.
TEST(ScreenSpace, DispatchBaseGroupsScaleLikeTheirRange) {
    for (uint32_t n : {1u, 2u, 81u, 135u, 300u}) {
        const GroupRange whole = scaled_group_range(0, n, 0.6);
        EXPECT_EQ(whole.base, 0u);
        EXPECT_EQ(whole.count, scaled_group_count(n, 0.6)) << n;
    }
    const GroupRange right = scaled_group_range(150, 150, 0.6); // the right half of 300 groups
    EXPECT_EQ(right.base, 90u);
    EXPECT_EQ(right.count, 90u);
    EXPECT_EQ(scaled_group_range(5, 0, 0.6).count, 0u);
    EXPECT_EQ(scaled_group_range(7, 1, 0.6).count, 1u); // never empty: [4.2, 4.8) rounds to [4, 5)
    // Any cut of [0, n) into two parts leaves no scaled group uncovered.
    for (uint32_t n : {17u, 135u, 300u})
        for (uint32_t cut = 1; cut < n; ++cut) {
            const GroupRange a = scaled_group_range(0, cut, 0.6), b = scaled_group_range(cut, n - cut, 0.6);
            EXPECT_GE(a.base + a.count, b.base) << n << " cut at " << cut;
            EXPECT_EQ(b.base + b.count, scaled_group_count(n, 0.6)) << n << " cut at " << cut;
        }
}

// Which side draws what (split::swapchain_pass_draw): of a pass into a window's swapchain image,
// one side draws the periphery scaled and the other the foveae cut, in either split; the swapped
// split's agent draws whole frames only for a verifying client. Neither side scales screen-space
// targets in the swapped split: the client's paper split alone does.
TEST(SplitSides, OneSideScalesWhatTheOtherCuts) {
    for (ClientRenders renders : {ClientRenders::Periphery, ClientRenders::Fovea}) {
        const PassDraw client = swapchain_pass_draw(SplitSide::Client, renders, false);
        const PassDraw agent = swapchain_pass_draw(SplitSide::Agent, renders, false);
        EXPECT_NE(client, agent);
        EXPECT_NE(client, PassDraw::Whole);
        EXPECT_NE(agent, PassDraw::Whole);
        // Whoever renders the periphery scales.
        const bool client_periphery = renders == ClientRenders::Periphery;
        EXPECT_EQ(client == PassDraw::Scaled, client_periphery);
        EXPECT_EQ(agent == PassDraw::Scaled, !client_periphery);
    }
    // The paper's split cuts an OpenXR eye image on the agent and scales it on the client; the
    // swapped split cuts it on the client, and its agent replays it whole and downsamples it at its
    // release.
    EXPECT_EQ(swapchain_pass_draw(SplitSide::Client, ClientRenders::Periphery, true), PassDraw::Scaled);
    EXPECT_EQ(swapchain_pass_draw(SplitSide::Agent, ClientRenders::Periphery, true), PassDraw::Cut);
    EXPECT_EQ(swapchain_pass_draw(SplitSide::Client, ClientRenders::Fovea, true), PassDraw::Cut);
    EXPECT_EQ(swapchain_pass_draw(SplitSide::Agent, ClientRenders::Fovea, true), PassDraw::Whole);
    // A verifying client's agent replays the native frame; the client cuts all the same.
    EXPECT_EQ(swapchain_pass_draw(SplitSide::Agent, ClientRenders::Fovea, false, true), PassDraw::Whole);
    EXPECT_EQ(swapchain_pass_draw(SplitSide::Client, ClientRenders::Fovea, false, true), PassDraw::Cut);
    EXPECT_EQ(swapchain_pass_draw(SplitSide::Agent, ClientRenders::Periphery, false, true), PassDraw::Cut);

    EXPECT_TRUE(scales_screen_space_targets(SplitSide::Client, ClientRenders::Periphery));
    EXPECT_FALSE(scales_screen_space_targets(SplitSide::Agent, ClientRenders::Periphery));
    EXPECT_FALSE(scales_screen_space_targets(SplitSide::Client, ClientRenders::Fovea));
    EXPECT_FALSE(scales_screen_space_targets(SplitSide::Agent, ClientRenders::Fovea));
}

// A scaled pass's rectangles (scaled_pass_rect, scaled_pass_viewport), the ones the client's paper
// split and the swapped split's agent both draw with: the whole image's area fills the scaled extent
// exactly, on odd sizes too; a half (an eye) fills its scaled half; viewports scale by the same
// per-axis factors.
TEST(SplitSides, ScaledPassRectanglesFillTheScaledExtent) {
    for (VkExtent2D full : {kScreen, VkExtent2D{1007, 613}, VkExtent2D{2400, 1080}})
        for (double scale : {0.5, 0.6, 0.25, 1.0}) {
            const VkExtent2D scaled = scaled_extent(full, scale);
            const VkRect2D area = scaled_pass_rect({{0, 0}, full}, full, scale);
            EXPECT_EQ(area.offset.x, 0);
            EXPECT_EQ(area.offset.y, 0);
            EXPECT_EQ(area.extent.width, scaled.width) << full.width << " at " << scale;
            EXPECT_EQ(area.extent.height, scaled.height) << full.height << " at " << scale;
            const VkViewport v =
                scaled_pass_viewport({0, 0, float(full.width), float(full.height), 0, 1}, full, scale);
            EXPECT_FLOAT_EQ(v.width, float(scaled.width));
            EXPECT_FLOAT_EQ(v.height, float(scaled.height));
            EXPECT_EQ(v.maxDepth, 1.0f);
            // The right eye ends where the scaled image does, and starts at or left of its scaled offset.
            const VkRect2D right = right_eye(full);
            const VkRect2D r = scaled_pass_rect(right, full, scale);
            EXPECT_EQ(r.offset.x + r.extent.width, scaled.width);
            EXPECT_LE(r.offset.x, int32_t(right.offset.x * scale + 1));
        }
    // Outside the image: clamped to the scaled extent.
    const VkRect2D beyond = scaled_pass_rect({{2300, 1000}, {400, 400}}, kScreen, 0.5);
    EXPECT_EQ(beyond.offset.x + beyond.extent.width, 1200u);
    EXPECT_EQ(beyond.offset.y + beyond.extent.height, 540u);
}

} // namespace
} // namespace splitvk::split
