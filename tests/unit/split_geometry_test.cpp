// The split's shared geometry and tracker (protocol/split_*.h): the layer scales with them and the agent
// places foveae with it, so these numbers are what both sides agree on.

#include "split_geometry.h"
#include "split_tracker.h"

#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>

namespace splitvk::split {
namespace {

bool same(const VkRect2D &a, const VkRect2D &b) {
    return a.offset.x == b.offset.x && a.offset.y == b.offset.y && a.extent.width == b.extent.width &&
           a.extent.height == b.extent.height;
}

#define EXPECT_RECT(r, X, Y, W, H)                                                                           \
    EXPECT_TRUE(same((r), VkRect2D{{(X), (Y)}, {(W), (H)}}))                                                 \
        << (r).offset.x << "," << (r).offset.y << " " << (r).extent.width << "x" << (r).extent.height

TEST(SplitGeometry, ScaledExtentIsThePapersPeriphery) {
    const VkExtent2D e = scaled_extent({2400, 1080}, 0.6);
    EXPECT_EQ(e.width, 1440u);
    EXPECT_EQ(e.height, 648u);
    const VkExtent2D odd = scaled_extent({1201, 541}, 0.6); // 720.6 x 324.6 round up
    EXPECT_EQ(odd.width, 721u);
    EXPECT_EQ(odd.height, 325u);
    EXPECT_EQ(scaled_extent({1, 1}, 0.01).width, 1u);
}

TEST(SplitGeometry, ViewportScalesAllButDepth) {
    const VkViewport v =
        scale_viewport({1200.f, 0.f, 1200.f, 1080.f, 0.25f, 0.75f}, axis_scale({2400, 1080}, 0.6));
    EXPECT_FLOAT_EQ(v.x, 720.f);
    EXPECT_FLOAT_EQ(v.y, 0.f);
    EXPECT_FLOAT_EQ(v.width, 720.f);
    EXPECT_FLOAT_EQ(v.height, 648.f);
    EXPECT_FLOAT_EQ(v.minDepth, 0.25f);
    EXPECT_FLOAT_EQ(v.maxDepth, 0.75f);
    const VkViewport flipped =
        scale_viewport({0.f, 1080.f, 2400.f, -1080.f, 0.f, 1.f}, axis_scale({2400, 1080}, 0.5));
    EXPECT_FLOAT_EQ(flipped.y, 540.f);
    EXPECT_FLOAT_EQ(flipped.height, -540.f);
}

TEST(SplitGeometry, RectsRoundOutwardsAndClamp) {
    const VkExtent2D scaled = scaled_extent({2400, 1080}, 0.6);
    const AxisScale scale = axis_scale({2400, 1080}, scaled);
    EXPECT_RECT(scale_rect({{0, 0}, {2400, 1080}}, scale, scaled), 0, 0, 1440u, 648u);
    EXPECT_RECT(scale_rect({{1200, 0}, {1200, 1080}}, scale, scaled), 720, 0, 720u, 648u);
    // 1 -> 0.6 floors to 0; 1+2=3 -> 1.8 ceils to 2.
    EXPECT_RECT(scale_rect({{1, 1}, {2, 2}}, scale, scaled), 0, 0, 2u, 2u);
    // A scissor past the image is clamped to the scaled extent.
    EXPECT_RECT(scale_rect({{2000, 1000}, {1000, 1000}}, scale, scaled), 1200, 600, 240u, 48u);
    EXPECT_RECT(scale_rect({{5000, 0}, {10, 10}}, scale, scaled), 1440, 0, 0u, 6u);
    // The 'whole surface' scissor some apps use.
    EXPECT_RECT(scale_rect({{0, 0}, {0x7fffffffu, 0x7fffffffu}}, scale, scaled), 0, 0, 1440u, 648u);
}

// At every size, and not only where s·W is whole: the full image's viewport fills the scaled extent
// to its last row and column, so that no pixel of the scaled image is left unshaded (the compositor
// upsamples every one of them into the picture), and a rectangle's scaled pixels cover the scaled
// viewport's picture of every pixel the rectangle holds.
TEST(SplitGeometry, ScaledPassesFillTheirScaledExtentAtEverySize) {
    for (const double s : {0.6, 0.5, 0.75, 1.0 / 3.0, 0.37, 0.9}) {
        for (uint32_t w = 1; w <= 2100; w += (w < 64 ? 1 : 37)) {
            for (const uint32_t h : {1u, 7u, 143u, 240u, 601u, 1007u, 1080u, w}) {
                const VkExtent2D full{w, h};
                const VkExtent2D scaled = scaled_extent(full, s);
                const AxisScale scale = axis_scale(full, scaled);
                const VkViewport v = scale_viewport({0.f, 0.f, float(w), float(h), 0.f, 1.f}, scale);
                // The last pixel centre of the scaled extent is inside the viewport (and no more).
                ASSERT_GT(v.x + v.width, scaled.width - 0.5f) << w << "x" << h << " at " << s;
                ASSERT_GT(v.y + v.height, scaled.height - 0.5f) << w << "x" << h << " at " << s;
                ASSERT_LE(v.x + v.width, scaled.width + 1e-3f) << w << "x" << h << " at " << s;
                ASSERT_LE(v.y + v.height, scaled.height + 1e-3f) << w << "x" << h << " at " << s;
                EXPECT_RECT(scale_rect({{0, 0}, {w, h}}, scale, scaled), 0, 0, scaled.width, scaled.height);
                // The left and right halves (eyes side by side) keep every scaled pixel their viewport
                // covers: the scissor's scaled end is at or past the viewport's, its start at or before.
                const uint32_t half = w / 2;
                const VkRect2D right = scale_rect({{int32_t(half), 0}, {w - half, h}}, scale, scaled);
                const VkViewport rv =
                    scale_viewport({float(half), 0.f, float(w - half), float(h), 0.f, 1.f}, scale);
                ASSERT_LE(float(right.offset.x), rv.x + 1e-3f) << w << " at " << s;
                ASSERT_GE(float(right.offset.x + int32_t(right.extent.width)), rv.x + rv.width - 1e-3f);
                const VkRect2D left = scale_rect({{0, 0}, {half, h}}, scale, scaled);
                const VkViewport lv = scale_viewport({0.f, 0.f, float(half), float(h), 0.f, 1.f}, scale);
                ASSERT_GE(float(left.extent.width), lv.width - 1e-3f) << w << " at " << s;
            }
        }
    }
}

TEST(SplitGeometry, Intersection) {
    EXPECT_RECT(intersect({{0, 0}, {100, 100}}, {{50, 60}, {100, 100}}), 50, 60, 50u, 40u);
    const VkRect2D empty = intersect({{0, 0}, {10, 10}}, {{20, 20}, {5, 5}});
    EXPECT_EQ(empty.extent.width, 0u);
    EXPECT_EQ(empty.extent.height, 0u);
    EXPECT_GE(empty.offset.x, 0);
}

TEST(SplitGeometry, EyeCoverage) {
    const VkExtent2D image{2400, 1080};
    const VkViewport left{0.f, 0.f, 1200.f, 1080.f, 0.f, 1.f};
    const VkViewport right{1200.f, 0.f, 1200.f, 1080.f, 0.f, 1.f};
    const VkViewport whole{0.f, 0.f, 2400.f, 1080.f, 0.f, 1.f};
    const VkViewport sloppy{-0.5f, 0.f, 1200.8f, 1080.f, 0.f, 1.f}; // within a pixel of the left half
    const VkViewport flipped{1200.f, 1080.f, 1200.f, -1080.f, 0.f, 1.f};
    EyeCoverage c = viewport_coverage(left, image);
    EXPECT_TRUE(c.left && c.left_eye);
    EXPECT_FALSE(c.right || c.right_eye);
    c = viewport_coverage(right, image);
    EXPECT_TRUE(c.right && c.right_eye);
    EXPECT_FALSE(c.left || c.left_eye);
    c = viewport_coverage(whole, image);
    EXPECT_TRUE(c.left && c.right);          // draws into both halves...
    EXPECT_FALSE(c.left_eye || c.right_eye); // ...but is neither eye
    c = viewport_coverage(sloppy, image);
    EXPECT_TRUE(c.left && c.left_eye);
    EXPECT_FALSE(c.right) << "0.3 px past the centre is rounding, not drawing";
    c = viewport_coverage(flipped, image);
    EXPECT_TRUE(c.right && c.right_eye) << "a negative height spans the same rows";
    // Not the whole height: a quadrant is no eye.
    EXPECT_FALSE(viewport_coverage({0.f, 0.f, 1200.f, 540.f, 0.f, 1.f}, image).left_eye);
    // A sliver counts for the half holding its centre.
    c = viewport_coverage({1800.f, 0.f, 0.5f, 10.f, 0.f, 1.f}, image);
    EXPECT_TRUE(c.right);
    EXPECT_FALSE(c.left);
    // An odd width: the right eye takes the extra column.
    EXPECT_TRUE(viewport_coverage({600.f, 0.f, 601.f, 540.f, 0.f, 1.f}, {1201, 540}).right_eye);
    EXPECT_RECT(right_eye({1201, 540}), 600, 0, 601u, 540u);
    EXPECT_RECT(left_eye({1201, 540}), 0, 0, 600u, 540u);
}

TEST(SplitGeometry, DefaultFoveaIsThePapers) {
    const FoveaSize fovea; // 512x360 of a 1200x1080 eye
    const VkExtent2D image{2400, 1080};
    EXPECT_RECT(fovea_of_eye(left_eye(image), fovea), 344, 360, 512u, 360u);
    EXPECT_RECT(fovea_of_eye(right_eye(image), fovea), 1544, 360, 512u, 360u);
    // One eye of the whole image: the same fractions of 2400x1080.
    EXPECT_RECT(fovea_of_eye({{0, 0}, image}, fovea), 688, 360, 1024u, 360u);
    FoveaSize pixels;
    pixels.fractional = false;
    pixels.width = 5000;
    pixels.height = 100;
    EXPECT_RECT(fovea_of_eye({{1200, 0}, {1200, 1080}}, pixels), 1200, 490, 1200u, 100u);
}

// The frame's foveae from everything it drew.
std::vector<VkRect2D> foveae_of(std::initializer_list<VkViewport> viewports, EyeMode mode,
                                VkExtent2D image = {2400, 1080}) {
    EyeCoverage drawn;
    for (const VkViewport &v : viewports)
        drawn |= viewport_coverage(v, image);
    return frame_foveae(drawn, image, mode, FoveaSize{});
}

TEST(SplitGeometry, StereoFramesHaveBothFoveaeWhereverTheirLastPassDraws) {
    const VkViewport whole{0.f, 0.f, 2400.f, 1080.f, 0.f, 1.f};
    const VkViewport left{0.f, 0.f, 1200.f, 1080.f, 0.f, 1.f}, right{1200.f, 0.f, 1200.f, 1080.f, 0.f, 1.f};
    // SPLITVK_EYES=2, a full-screen last pass (tone mapping, a multiview compose): both eyes.
    auto f = foveae_of({whole}, EyeMode::Two);
    ASSERT_EQ(f.size(), 2u);
    EXPECT_RECT(f[0], 344, 360, 512u, 360u);
    EXPECT_RECT(f[1], 1544, 360, 512u, 360u);
    // ...and per-eye viewports give the same two.
    f = foveae_of({right, left}, EyeMode::Two);
    ASSERT_EQ(f.size(), 2u);
    EXPECT_RECT(f[0], 344, 360, 512u, 360u);
    EXPECT_RECT(f[1], 1544, 360, 512u, 360u);
    // A frame that drew only one half has only that eye's.
    f = foveae_of({left}, EyeMode::Two);
    ASSERT_EQ(f.size(), 1u);
    EXPECT_RECT(f[0], 344, 360, 512u, 360u);
    // Auto: a stereo pair, then a full-screen overlay: still the eyes' two.
    f = foveae_of({left, right, whole}, EyeMode::Auto);
    ASSERT_EQ(f.size(), 2u);
    EXPECT_RECT(f[1], 1544, 360, 512u, 360u);
    // One: the centre, whatever was drawn.
    f = foveae_of({left, right}, EyeMode::One);
    ASSERT_EQ(f.size(), 1u);
    EXPECT_RECT(f[0], 688, 360, 1024u, 360u);
    EXPECT_TRUE(foveae_of({}, EyeMode::Two).empty());
}

TEST(SplitGeometry, AutoIsStereoOnlyForTwoViewportsThatTileTheImageInHalves) {
    // Three side-by-side panels (a mono app): none is an eye, so one fovea at the screen's centre,
    // not one in each half around the middle panel.
    const VkViewport panels[] = {{0.f, 0.f, 800.f, 1080.f, 0.f, 1.f},
                                 {800.f, 0.f, 800.f, 1080.f, 0.f, 1.f},
                                 {1600.f, 0.f, 800.f, 1080.f, 0.f, 1.f}};
    auto f = foveae_of({panels[0], panels[1], panels[2]}, EyeMode::Auto);
    ASSERT_EQ(f.size(), 1u);
    EXPECT_RECT(f[0], 688, 360, 1024u, 360u);
    // Panels that each lie within a half but do not tile it are no stereo pair either.
    f = foveae_of({{0.f, 0.f, 1000.f, 1080.f, 0.f, 1.f}, {1300.f, 0.f, 1100.f, 1080.f, 0.f, 1.f}},
                  EyeMode::Auto);
    ASSERT_EQ(f.size(), 1u);
    EXPECT_RECT(f[0], 688, 360, 1024u, 360u);
    // One eye alone is no pair.
    f = foveae_of({{1200.f, 0.f, 1200.f, 1080.f, 0.f, 1.f}}, EyeMode::Auto);
    ASSERT_EQ(f.size(), 1u);
    EXPECT_RECT(f[0], 688, 360, 1024u, 360u);
    // Two half viewports (rounded as apps compute them) are: two foveae, one per eye.
    f = foveae_of({{-0.25f, 0.f, 1200.5f, 1080.f, 0.f, 1.f}, {1200.25f, 0.f, 1199.75f, 1080.f, 0.f, 1.f}},
                  EyeMode::Auto);
    ASSERT_EQ(f.size(), 2u);
    EXPECT_RECT(f[0], 344, 360, 512u, 360u);
    EXPECT_RECT(f[1], 1544, 360, 512u, 360u);
    // Four quadrants tile the image but not in halves: mono.
    EXPECT_EQ(foveae_of({{0.f, 0.f, 1200.f, 540.f, 0.f, 1.f},
                         {1200.f, 0.f, 1200.f, 540.f, 0.f, 1.f},
                         {0.f, 540.f, 1200.f, 540.f, 0.f, 1.f},
                         {1200.f, 540.f, 1200.f, 540.f, 0.f, 1.f}},
                        EyeMode::Auto)
                  .size(),
              1u);
}

// SPLITVK_FOVEA=auto: a frame's size replaces the configured one, and the agent takes none larger
// than the one its scissors were recorded for.
TEST(SplitGeometry, AFrameFoveaSizeIsAFractionOfTheEye) {
    const FoveaSize configured{true, 1.0, 1.0};
    EXPECT_EQ(frame_fovea_size(configured, {}).width, 1.0) << "unset: the configured size";
    const FoveaSize half = frame_fovea_size(configured, {kGazeOne / 2, kGazeOne / 4});
    EXPECT_TRUE(half.fractional);
    EXPECT_EQ(half.pixels_for_eye(1200, 1080), std::make_pair(600u, 270u));
    EXPECT_RECT(fovea_of_eye(left_eye({2400, 1080}), half), 300, 405, 600u, 270u);

    EXPECT_TRUE(frame_fovea_size_allowed(configured, {}));
    EXPECT_TRUE(frame_fovea_size_allowed(configured, {kGazeOne, kGazeOne}));
    EXPECT_FALSE(frame_fovea_size_allowed(configured, {kGazeOne + 1, 1}));
    EXPECT_FALSE(frame_fovea_size_allowed(configured, {0, 5})) << "half set";
    const FoveaSize paper{}; // 512/1200 x 360/1080
    EXPECT_TRUE(frame_fovea_size_allowed(paper, {kGazeOne / 4, kGazeOne / 4}));
    EXPECT_FALSE(frame_fovea_size_allowed(paper, {kGazeOne / 2, kGazeOne / 4})) << "wider than configured";
    EXPECT_FALSE(frame_fovea_size_allowed(FoveaSize{false, 512, 360}, {1, 1}))
        << "pixels: no fraction to compare";

    EXPECT_EQ(larger({10, 40}, {20, 30}), (FrameFoveaSize{20, 40}));
    EXPECT_EQ(larger({}, {20, 30}), (FrameFoveaSize{20, 30}));
    EXPECT_EQ(larger({10, 40}, {}), (FrameFoveaSize{10, 40}));
    EXPECT_FALSE(larger({}, {}).set());
}

// The agent's scissor for a viewport holds every fovea the frame can give that viewport's pixels.
TEST(SplitGeometry, FoveaScissorHoldsEveryFoveaAViewportCanDrawInto) {
    const FoveaSize fovea;
    const VkExtent2D image{2400, 1080};
    const VkViewport left{0.f, 0.f, 1200.f, 1080.f, 0.f, 1.f}, whole{0.f, 0.f, 2400.f, 1080.f, 0.f, 1.f};
    EXPECT_RECT(fovea_scissor(whole, image, EyeMode::One, fovea), 688, 360, 1024u, 360u);
    EXPECT_RECT(fovea_scissor(left, image, EyeMode::One, fovea), 688, 360, 1024u, 360u);
    EXPECT_RECT(fovea_scissor(left, image, EyeMode::Two, fovea), 344, 360, 512u, 360u);
    EXPECT_RECT(fovea_scissor(whole, image, EyeMode::Two, fovea), 344, 360, 1712u, 360u); // both eyes
    // Auto: the eye's fovea or the centre's, as the rest of the frame decides.
    EXPECT_RECT(fovea_scissor(left, image, EyeMode::Auto, fovea), 344, 360, 1368u, 360u);
    EXPECT_RECT(fovea_scissor(whole, image, EyeMode::Auto, fovea), 344, 360, 1712u, 360u);
    // Whatever the frame draws, its foveae lie within the scissors of the viewports that drew them.
    const VkViewport viewports[] = {left,
                                    whole,
                                    {1200.f, 0.f, 1200.f, 1080.f, 0.f, 1.f},
                                    {800.f, 0.f, 800.f, 1080.f, 0.f, 1.f},
                                    {0.f, 0.f, 1000.f, 540.f, 0.f, 1.f}};
    for (EyeMode mode : {EyeMode::One, EyeMode::Two, EyeMode::Auto})
        for (const VkViewport &v : viewports) {
            const EyeCoverage own = viewport_coverage(v, image);
            for (const EyeCoverage &rest : {EyeCoverage{}, EyeCoverage{true, true, true, true}}) {
                EyeCoverage drawn = rest;
                drawn |= own;
                const VkRect2D scissor = fovea_scissor(v, image, mode, fovea);
                for (const VkRect2D &f : frame_foveae(drawn, image, mode, fovea)) {
                    // A fovea the viewport draws into (it overlaps the viewport's columns) is inside.
                    const VkRect2D columns{{static_cast<int32_t>(v.x), 0},
                                           {static_cast<uint32_t>(v.width), image.height}};
                    const VkRect2D drawn_part = intersect(f, columns);
                    if (drawn_part.extent.width == 0) continue;
                    EXPECT_TRUE(same(intersect(drawn_part, scissor), drawn_part))
                        << "mode " << static_cast<int>(mode) << ", viewport at " << v.x << " w " << v.width;
                }
            }
        }
}

// SPLITVK_GAZE: a fovea centred on the eye's gaze point, clamped into the eye; the centre point
// gives the fixed fovea's pixels.
TEST(SplitGeometry, FoveaAtTheGaze) {
    const FoveaSize fovea;
    const VkRect2D left = left_eye({2400, 1080}), right = right_eye({2400, 1080});
    EXPECT_RECT(fovea_at_gaze(left, {kGazeOne / 2, kGazeOne / 2}, fovea), 344, 360, 512u, 360u);
    EXPECT_RECT(fovea_at_gaze(right, {kGazeOne / 2, kGazeOne / 2}, fovea), 1544, 360, 512u, 360u);
    // A quarter across and down the left eye: its pixel (300, 270) at the fovea's centre.
    EXPECT_RECT(fovea_at_gaze(left, {kGazeOne / 4, kGazeOne / 4}, fovea), 44, 90, 512u, 360u);
    // Corners and beyond hold the fovea at the eye's edges, inside the eye.
    EXPECT_RECT(fovea_at_gaze(left, {0, 0}, fovea), 0, 0, 512u, 360u);
    EXPECT_RECT(fovea_at_gaze(right, {kGazeOne, kGazeOne}, fovea), 1888, 720, 512u, 360u);
    EXPECT_RECT(fovea_at_gaze(right, {0xFFFFFFFFu, 0}, fovea), 1888, 0, 512u, 360u);
    // A fovea as large as the eye has nowhere to move.
    EXPECT_RECT(fovea_at_gaze(left, {0, kGazeOne}, FoveaSize{false, 5000, 5000}), 0, 0, 1200u, 1080u);

    // frame_foveae: each eye at its own point; a mono frame's one eye at the left eye's point.
    Gaze gaze;
    gaze.fixed = false;
    gaze.eyes[0] = {0, 0};
    gaze.eyes[1] = {kGazeOne, kGazeOne / 2};
    const EyeCoverage stereo{true, true, true, true};
    auto f = frame_foveae(stereo, {2400, 1080}, EyeMode::Auto, fovea, gaze);
    ASSERT_EQ(f.size(), 2u);
    EXPECT_RECT(f[0], 0, 0, 512u, 360u);
    EXPECT_RECT(f[1], 1888, 360, 512u, 360u);
    f = frame_foveae(EyeCoverage{true, true, false, false}, {2400, 1080}, EyeMode::Auto, fovea, gaze);
    ASSERT_EQ(f.size(), 1u);
    EXPECT_RECT(f[0], 0, 0, 1024u, 360u);
    // Fixed: the centred foveae, whatever points it holds.
    gaze.fixed = true;
    f = frame_foveae(stereo, {2400, 1080}, EyeMode::Two, fovea, gaze);
    ASSERT_EQ(f.size(), 2u);
    EXPECT_RECT(f[0], 344, 360, 512u, 360u);
}

// With a moving gaze, the agent's scissor (recorded before any frame's gaze is known) holds every
// fovea any gaze can give the viewport's eyes.
TEST(SplitGeometry, FoveaScissorForAMovingGazeHoldsTheWholeEye) {
    const FoveaSize fovea;
    const VkExtent2D image{2400, 1080};
    const VkViewport left{0.f, 0.f, 1200.f, 1080.f, 0.f, 1.f}, right{1200.f, 0.f, 1200.f, 1080.f, 0.f, 1.f},
        whole{0.f, 0.f, 2400.f, 1080.f, 0.f, 1.f};
    EXPECT_RECT(fovea_scissor(left, image, EyeMode::Two, fovea, true), 0, 0, 1200u, 1080u);
    EXPECT_RECT(fovea_scissor(right, image, EyeMode::Two, fovea, true), 1200, 0, 1200u, 1080u);
    EXPECT_RECT(fovea_scissor(whole, image, EyeMode::Two, fovea, true), 0, 0, 2400u, 1080u);
    EXPECT_RECT(fovea_scissor(left, image, EyeMode::Auto, fovea, true), 0, 0, 2400u, 1080u);
    EXPECT_RECT(fovea_scissor(left, image, EyeMode::One, fovea, true), 0, 0, 2400u, 1080u);
    for (EyeMode mode : {EyeMode::One, EyeMode::Two, EyeMode::Auto})
        for (const VkViewport &v : {left, right, whole})
            for (uint32_t x : {0u, kGazeOne / 3, kGazeOne})
                for (uint32_t y : {0u, kGazeOne / 2, kGazeOne}) {
                    Gaze gaze;
                    gaze.fixed = false;
                    gaze.eyes[0] = gaze.eyes[1] = {x, y};
                    const EyeCoverage drawn = viewport_coverage(v, image);
                    const VkRect2D scissor = fovea_scissor(v, image, mode, fovea, true);
                    for (const VkRect2D &f : frame_foveae(drawn, image, mode, fovea, gaze))
                        EXPECT_TRUE(same(intersect(f, scissor), f))
                            << "mode " << static_cast<int>(mode) << ", viewport at " << v.x << ", gaze " << x
                            << "," << y;
                }
}

// docs/architecture.md §9: an eye's fovea at the projection of its view direction (for the OpenXR layer).
TEST(SplitGeometry, FoveaAtTheViewDirection) {
    const FoveaSize fovea; // 512x360 of a 1200x1080 eye
    const VkRect2D eye{{1200, 0}, {1200, 1080}};
    const double a = 0.785398163397448; // 45 degrees
    // Symmetric: the centred fovea, exactly fovea_of_eye's.
    EXPECT_RECT(fovea_at_view_direction(eye, {-a, a, a, -a}, fovea), 1544, 360, 512u, 360u);
    EXPECT_TRUE(same(fovea_at_view_direction({{0, 0}, {1201, 541}}, {-0.6, 0.6, 0.5, -0.5}, fovea),
                     fovea_of_eye({{0, 0}, {1201, 541}}, fovea)));
    // Asymmetric, as a headset's inner edge is narrower: left -45, right +26.565 (tan 0.5), so the
    // view direction is 1 / 1.5 of the width across: x = 800, fovea 800 - 256 = 544 into the eye.
    // Up +26.565 (tan 0.5), down -45 (tan -1): y = 0.5 / 1.5 of the height from the top = 360,
    // fovea 360 - 180 = 180.
    const double t = std::atan(0.5);
    EXPECT_RECT(fovea_at_view_direction(eye, {-a, t, t, -a}, fovea), 1200 + 544, 180, 512u, 360u);
    // The mirror image (the other eye): 1200 - 800 - 256 = 144; down the other way: 720 - 180 = 540.
    EXPECT_RECT(fovea_at_view_direction(eye, {-t, a, a, -t}, fovea), 1200 + 144, 540, 512u, 360u);
    // Far off centre: clamped so that the fovea stays inside the eye.
    const double wide = 1.5, narrow = 0.05;
    EXPECT_RECT(fovea_at_view_direction(eye, {-wide, narrow, narrow, -wide}, fovea), 1200 + 688, 0, 512u,
                360u);
    EXPECT_RECT(fovea_at_view_direction(eye, {-narrow, wide, wide, -narrow}, fovea), 1200, 720, 512u, 360u);
    // A view direction outside the field of view: the same, at the edge.
    EXPECT_RECT(fovea_at_view_direction(eye, {0.2, 0.6, -0.1, -0.5}, fovea), 1200, 0, 512u, 360u);
    // Degenerate fields of view: fovea_of_eye's.
    EXPECT_RECT(fovea_at_view_direction(eye, {0.3, 0.3, a, -a}, fovea), 1544, 360, 512u, 360u);
    EXPECT_RECT(fovea_at_view_direction(eye, {-a, a, -a, a}, fovea), 1544, 360, 512u, 360u);
    EXPECT_RECT(fovea_at_view_direction(eye, {-a, std::nan(""), a, -a}, fovea), 1544, 360, 512u, 360u);
    EXPECT_RECT(fovea_at_view_direction(eye, {}, fovea), 1544, 360, 512u, 360u);
}

#define EXPECT_LAYER_RECT(f, l, x, y, w, h)                                                                  \
    do {                                                                                                     \
        EXPECT_EQ((f).layer, l##u);                                                                          \
        EXPECT_RECT((f).rect, x, y, w, h);                                                                   \
    } while (0)

// An OpenXR eye image: before the application's views, one eye per layer, the whole layer, centred;
// then each eye the views placed, at its view direction within its rectangle (both sides place them
// with this one function).
TEST(SplitGeometry, RuntimeEyeFoveae) {
    const FoveaSize fovea;
    const double a = 0.785398163397448, t = std::atan(0.5);
    const FieldOfView inner_narrow{-a, t, t, -a};
    // A swapchain per eye.
    auto f = runtime_eye_foveae({1200, 1080}, 1, {}, fovea);
    ASSERT_EQ(f.size(), 1u);
    EXPECT_LAYER_RECT(f[0], 0, 344, 360, 512u, 360u);
    f = runtime_eye_foveae({1200, 1080}, 1, {{0, {{0, 0}, {1200, 1080}}, inner_narrow}}, fovea);
    ASSERT_EQ(f.size(), 1u);
    EXPECT_LAYER_RECT(f[0], 0, 544, 180, 512u, 360u);
    // Layered (multiview): a fovea per layer, each from its own view, sorted by layer.
    f = runtime_eye_foveae({1200, 1080}, 2, {}, fovea);
    ASSERT_EQ(f.size(), 2u);
    EXPECT_LAYER_RECT(f[0], 0, 344, 360, 512u, 360u);
    EXPECT_LAYER_RECT(f[1], 1, 344, 360, 512u, 360u);
    const FieldOfView mirrored{-t, a, t, -a};
    f = runtime_eye_foveae({1200, 1080}, 2,
                           {{1, {{0, 0}, {1200, 1080}}, mirrored}, {0, {{0, 0}, {1200, 1080}}, inner_narrow}},
                           fovea);
    ASSERT_EQ(f.size(), 2u);
    EXPECT_LAYER_RECT(f[0], 0, 544, 180, 512u, 360u);
    EXPECT_LAYER_RECT(f[1], 1, 144, 180, 512u, 360u);
    // Side by side: two rectangles of one layer, each fovea within its own half, sorted by x.
    f = runtime_eye_foveae(
        {2400, 1080}, 1,
        {{0, {{1200, 0}, {1200, 1080}}, mirrored}, {0, {{0, 0}, {1200, 1080}}, inner_narrow}}, fovea);
    ASSERT_EQ(f.size(), 2u);
    EXPECT_LAYER_RECT(f[0], 0, 544, 180, 512u, 360u);
    EXPECT_LAYER_RECT(f[1], 0, 1344, 180, 512u, 360u);
    // Before the views, a side-by-side image is one eye: the fovea of the whole image, centred.
    f = runtime_eye_foveae({2400, 1080}, 1, {}, fovea);
    ASSERT_EQ(f.size(), 1u);
    EXPECT_LAYER_RECT(f[0], 0, 688, 360, 1024u, 360u); // the fovea's fractions of the whole width
    // An eye in a layer the image lacks, or outside it, has no fovea; one reaching past it is clipped.
    f = runtime_eye_foveae({1200, 1080}, 1,
                           {{1, {{0, 0}, {1200, 1080}}, {}},
                            {0, {{1300, 0}, {100, 100}}, {}},
                            {0, {{600, 0}, {1200, 1080}}, {}}},
                           fovea);
    ASSERT_EQ(f.size(), 1u);
    EXPECT_LAYER_RECT(f[0], 0, 772, 360, 256u, 360u);
}

// SPLITVK_AGENT_SCISSOR=guard:N under OpenXR: an offscreen target of an eye image's size is cut
// around the eyes' foveae where the split puts them (every eye and layer: the pass does not say
// which it renders for), an eye-sized one around each eye's fovea within its half; an eye-sized
// target of eyes that are not the halves cannot be mapped.
TEST(SplitGeometry, RuntimeGuardFoveae) {
    const FoveaSize fovea;
    const double a = 0.785398163397448, t = std::atan(0.5);
    const FieldOfView inner_narrow{-a, t, t, -a}, mirrored{-t, a, t, -a};
    std::vector<VkRect2D> f;
    // Before the views: the centred fovea of each layer (one rectangle for both layers).
    ASSERT_TRUE(runtime_guard_foveae({1200, 1080}, 2, {}, false, fovea, false, &f));
    ASSERT_EQ(f.size(), 1u);
    EXPECT_RECT(f[0], 344, 360, 512u, 360u);
    // Each layer's eye at its view direction.
    ASSERT_TRUE(runtime_guard_foveae(
        {1200, 1080}, 2, {{0, {{0, 0}, {1200, 1080}}, inner_narrow}, {1, {{0, 0}, {1200, 1080}}, mirrored}},
        false, fovea, false, &f));
    ASSERT_EQ(f.size(), 2u);
    EXPECT_RECT(f[0], 144, 180, 512u, 360u);
    EXPECT_RECT(f[1], 544, 180, 512u, 360u);
    // Side by side, a target of the whole image: the foveae where they are in it.
    const std::vector<RuntimeEye> halves{{0, {{0, 0}, {1200, 1080}}, inner_narrow},
                                         {0, {{1200, 0}, {1200, 1080}}, mirrored}};
    ASSERT_TRUE(runtime_guard_foveae({2400, 1080}, 1, halves, false, fovea, false, &f));
    ASSERT_EQ(f.size(), 2u);
    EXPECT_RECT(f[0], 544, 180, 512u, 360u);
    EXPECT_RECT(f[1], 1344, 180, 512u, 360u);
    // An eye-sized target: each eye's fovea within its half, in the half's coordinates.
    ASSERT_TRUE(runtime_guard_foveae({2400, 1080}, 1, halves, true, fovea, false, &f));
    ASSERT_EQ(f.size(), 2u);
    EXPECT_RECT(f[0], 144, 180, 512u, 360u);
    EXPECT_RECT(f[1], 544, 180, 512u, 360u);
    // Before the views the image is one eye: its centred fovea, cut by the halves.
    ASSERT_TRUE(runtime_guard_foveae({2400, 1080}, 1, {}, true, fovea, false, &f));
    ASSERT_EQ(f.size(), 2u);
    EXPECT_RECT(f[0], 0, 360, 512u, 360u);
    EXPECT_RECT(f[1], 688, 360, 512u, 360u);
    // Eyes in other rectangles than the halves: an eye-sized target holds no known eye.
    EXPECT_FALSE(runtime_guard_foveae({2400, 1080}, 1, {{0, {{0, 0}, {800, 1080}}, inner_narrow}}, true,
                                      fovea, false, &f));
    EXPECT_TRUE(f.empty());
    EXPECT_FALSE(runtime_guard_foveae({1200, 1080}, 1, {{0, {{0, 0}, {1200, 1080}}, inner_narrow}}, true,
                                      fovea, false, &f));
}

// SPLITVK_GAZE under OpenXR: a moving gaze places an image's first two eyes (in the order both sides
// hold them) at its points; the agent's scissors and guards then cover each eye whole.
TEST(SplitGeometry, RuntimeEyeFoveaeAtTheGaze) {
    const FoveaSize fovea;
    const double a = 0.785398163397448, t = std::atan(0.5);
    const FieldOfView inner_narrow{-a, t, t, -a}, mirrored{-t, a, t, -a};
    const std::vector<RuntimeEye> halves{{0, {{1200, 0}, {1200, 1080}}, mirrored},
                                         {0, {{0, 0}, {1200, 1080}}, inner_narrow}};
    Gaze gaze;
    gaze.fixed = false;
    gaze.eyes[0] = {kGazeOne / 4, kGazeOne / 2}; // the first eye noted: the right half
    gaze.eyes[1] = {kGazeOne, 0};                // the left half, clamped to its top-right corner
    auto f = runtime_eye_foveae({2400, 1080}, 1, halves, fovea, gaze);
    ASSERT_EQ(f.size(), 2u);
    EXPECT_LAYER_RECT(f[0], 0, 688, 0, 512u, 360u);         // sorted by x: the left half's
    EXPECT_LAYER_RECT(f[1], 0, 1200 + 44, 360, 512u, 360u); // 300 - 256 into the right half
    // A fixed gaze keeps the view directions; so does a third eye beyond the gaze's two.
    f = runtime_eye_foveae({2400, 1080}, 1, halves, fovea, {});
    ASSERT_EQ(f.size(), 2u);
    EXPECT_LAYER_RECT(f[0], 0, 544, 180, 512u, 360u);
    const std::vector<RuntimeEye> layered{{0, {{0, 0}, {1200, 1080}}, inner_narrow},
                                          {1, {{0, 0}, {1200, 1080}}, mirrored},
                                          {2, {{0, 0}, {1200, 1080}}, inner_narrow}};
    f = runtime_eye_foveae({1200, 1080}, 3, layered, fovea, gaze);
    ASSERT_EQ(f.size(), 3u);
    EXPECT_LAYER_RECT(f[0], 0, 44, 360, 512u, 360u);
    EXPECT_LAYER_RECT(f[1], 1, 688, 0, 512u, 360u);
    EXPECT_LAYER_RECT(f[2], 2, 544, 180, 512u, 360u);
    // Before the views the gaze has no eye to go to: the centred fovea.
    f = runtime_eye_foveae({1200, 1080}, 1, {}, fovea, gaze);
    ASSERT_EQ(f.size(), 1u);
    EXPECT_LAYER_RECT(f[0], 0, 344, 360, 512u, 360u);

    // Where the foveae can be: at the view directions for a fixed gaze, each eye whole for a
    // moving one, each layer whole before the views.
    auto areas = runtime_fovea_areas({2400, 1080}, 1, halves, fovea, false);
    ASSERT_EQ(areas.size(), 2u);
    EXPECT_LAYER_RECT(areas[0], 0, 544, 180, 512u, 360u);
    areas = runtime_fovea_areas({2400, 1080}, 1, halves, fovea, true);
    ASSERT_EQ(areas.size(), 2u);
    EXPECT_LAYER_RECT(areas[0], 0, 1200, 0, 1200u, 1080u);
    EXPECT_LAYER_RECT(areas[1], 0, 0, 0, 1200u, 1080u);
    areas = runtime_fovea_areas({1200, 1080}, 2, {}, fovea, true);
    ASSERT_EQ(areas.size(), 2u);
    EXPECT_LAYER_RECT(areas[1], 1, 0, 0, 1200u, 1080u);
    // Every fovea a moving gaze gives lies in its area.
    for (uint32_t x : {0u, kGazeOne / 3, kGazeOne})
        for (uint32_t y : {0u, kGazeOne / 2, kGazeOne}) {
            gaze.eyes[0] = gaze.eyes[1] = {x, y};
            const auto placed = runtime_eye_foveae({2400, 1080}, 1, halves, fovea, gaze);
            const auto where = runtime_fovea_areas({2400, 1080}, 1, halves, fovea, true);
            for (const LayerFovea &p : placed)
                EXPECT_TRUE(std::any_of(where.begin(), where.end(),
                                        [&](const LayerFovea &w) {
                                            return w.layer == p.layer &&
                                                   same(intersect(p.rect, w.rect), p.rect);
                                        }))
                    << x << "," << y;
        }
    // A guard with a moving gaze: an eye-sized target is cut to nothing, each half whole.
    std::vector<VkRect2D> g;
    ASSERT_TRUE(runtime_guard_foveae({2400, 1080}, 1, halves, true, fovea, true, &g));
    ASSERT_EQ(g.size(), 1u);
    EXPECT_RECT(g[0], 0, 0, 1200u, 1080u);
    ASSERT_TRUE(runtime_guard_foveae({2400, 1080}, 1, halves, false, fovea, true, &g));
    ASSERT_EQ(g.size(), 2u);
}

// The gaze direction in an eye's frame, projected into its image: the inverse of the view
// direction's projection, clamped to the image; nothing for a direction behind the eye.
TEST(SplitGeometry, GazePointInEye) {
    const double a = 0.785398163397448, t = std::atan(0.5);
    // Straight ahead, symmetric: the centre.
    auto p = gaze_point_in_eye({-a, a, a, -a}, 0, 0, -1);
    ASSERT_TRUE(p);
    EXPECT_EQ(p->x, kGazeOne / 2);
    EXPECT_EQ(p->y, kGazeOne / 2);
    // Straight ahead, inner edge narrower: where fovea_at_view_direction centres the fovea.
    p = gaze_point_in_eye({-a, t, t, -a}, 0, 0, -2);
    ASSERT_TRUE(p);
    EXPECT_EQ(p->x, static_cast<uint32_t>(std::lround(kGazeOne / 1.5)));
    EXPECT_EQ(p->y, static_cast<uint32_t>(std::lround(kGazeOne * 0.5 / 1.5)));
    // The fovea there is the view direction's, give or take the pixel that 1/kGazeOne rounds to.
    const VkRect2D eye{{0, 0}, {1200, 1080}};
    const VkRect2D at_gaze = fovea_at_gaze(eye, *p, FoveaSize{});
    const VkRect2D ahead = fovea_at_view_direction(eye, {-a, t, t, -a}, FoveaSize{});
    EXPECT_LE(std::abs(at_gaze.offset.x - ahead.offset.x), 1);
    EXPECT_LE(std::abs(at_gaze.offset.y - ahead.offset.y), 1);
    // Right and up by tan 0.5 of a ±45° eye: three quarters across, a quarter down.
    p = gaze_point_in_eye({-a, a, a, -a}, 0.5, 0.5, -1);
    ASSERT_TRUE(p);
    EXPECT_EQ(p->x, kGazeOne * 3 / 4);
    EXPECT_EQ(p->y, kGazeOne / 4);
    // Beyond the edges: clamped.
    p = gaze_point_in_eye({-a, a, a, -a}, -3, -3, -1);
    ASSERT_TRUE(p);
    EXPECT_EQ(p->x, 0u);
    EXPECT_EQ(p->y, kGazeOne);
    // Behind the eye, sideways, not finite, or a field of view spanning nothing: nothing.
    EXPECT_FALSE(gaze_point_in_eye({-a, a, a, -a}, 0, 0, 1));
    EXPECT_FALSE(gaze_point_in_eye({-a, a, a, -a}, 1, 0, 0));
    EXPECT_FALSE(gaze_point_in_eye({-a, a, a, -a}, std::nan(""), 0, -1));
    EXPECT_FALSE(gaze_point_in_eye({a, a, a, -a}, 0, 0, -1));
}

// An eye replaces the eyes of its layer it overlaps (the same eye moved, resized or with another
// field of view), and joins those it does not; the same eye again changes nothing.
TEST(SplitGeometry, NoteRuntimeEye) {
    const FieldOfView a{-0.5, 0.5, 0.5, -0.5}, b{-0.6, 0.4, 0.5, -0.5};
    std::vector<RuntimeEye> eyes;
    EXPECT_TRUE(note_runtime_eye(eyes, {0, {{0, 0}, {1200, 1080}}, a}));
    EXPECT_FALSE(note_runtime_eye(eyes, {0, {{0, 0}, {1200, 1080}}, a}));
    EXPECT_TRUE(note_runtime_eye(eyes, {0, {{1200, 0}, {1200, 1080}}, a})); // the other half
    EXPECT_TRUE(note_runtime_eye(eyes, {1, {{0, 0}, {1200, 1080}}, a}));    // another layer
    ASSERT_EQ(eyes.size(), 3u);
    EXPECT_TRUE(note_runtime_eye(eyes, {0, {{0, 0}, {1200, 1080}}, b})); // another field of view
    ASSERT_EQ(eyes.size(), 3u);
    EXPECT_TRUE(note_runtime_eye(eyes, {0, {{0, 0}, {2400, 1080}}, b})); // one eye over both halves
    ASSERT_EQ(eyes.size(), 2u);
    EXPECT_EQ(eyes.back().rect.extent.width, 2400u);
}

TEST(SplitGeometry, FoveaSetIsSortedAndUnique) {
    std::vector<VkRect2D> foveae;
    add_fovea(foveae, {{1544, 360}, {512, 360}});
    add_fovea(foveae, {{344, 360}, {512, 360}});
    add_fovea(foveae, {{1544, 360}, {512, 360}});
    add_fovea(foveae, {{344, 10}, {512, 360}});
    ASSERT_EQ(foveae.size(), 3u);
    EXPECT_RECT(foveae[0], 344, 10, 512u, 360u);
    EXPECT_RECT(foveae[1], 344, 360, 512u, 360u);
    EXPECT_RECT(foveae[2], 1544, 360, 512u, 360u);
}

} // namespace
} // namespace splitvk::split

// The per-command-buffer tracker (common/split_tracker.h): both sides feed it the app's calls,
// so which viewports were in effect inside split passes, and thus the foveae, must follow the
// Vulkan state rules exactly.
namespace splitvk::split {
namespace {

const VkViewport kLeft{0.f, 0.f, 1200.f, 1080.f, 0.f, 1.f};
const VkViewport kRight{1200.f, 0.f, 1200.f, 1080.f, 0.f, 1.f};
const VkExtent2D kImage{2400, 1080};

TEST(SplitTracker, ViewportsSetBeforeThePassCountOnlyInsideIt) {
    CommandTracker t;
    t.set_viewports(0, 1, &kLeft, false);
    t.note_foveae(); // outside a split pass: nothing
    EXPECT_TRUE(t.drawn().empty());
    // A pass that sets its own viewport before drawing never draws with the one it inherited
    // (atrium --path hdr: the last bloom pass's), so only its own fovea is noted.
    t.begin_split(7, kImage);
    t.set_viewports(0, 1, &kRight, false);
    t.note_foveae();
    t.end_split();
    ASSERT_EQ(t.drawn().size(), 1u);
    EXPECT_EQ(t.drawn()[0].image, 7u);
    const auto foveae = t.drawn()[0].foveae(EyeMode::Two, FoveaSize{});
    ASSERT_EQ(foveae.size(), 1u);
    EXPECT_RECT(foveae[0], 1544, 360, 512u, 360u);
}

TEST(SplitTracker, APassThatSetsNoViewportDrawsWithTheInheritedOne) {
    CommandTracker t;
    t.set_viewports(0, 1, &kLeft, false);
    t.begin_split(7, kImage);
    EXPECT_TRUE(t.drawn().empty()) << "nothing is noted at the pass's begin";
    t.end_split();
    ASSERT_EQ(t.drawn().size(), 1u);
    const auto foveae = t.drawn()[0].foveae(EyeMode::Two, FoveaSize{});
    ASSERT_EQ(foveae.size(), 1u);
    EXPECT_RECT(foveae[0], 344, 360, 512u, 360u);
}

TEST(SplitTracker, StaticPipelineStateWinsWhileBound) {
    auto state = std::make_shared<StaticViewportState>();
    state->has_viewports = true;
    state->viewports = {kRight};
    CommandTracker t;
    t.set_viewports(0, 1, &kLeft, false);
    t.bind_pipeline(state);
    ASSERT_NE(t.viewport(0), nullptr);
    EXPECT_FLOAT_EQ(t.viewport(0)->x, 1200.f);
    EXPECT_FALSE(t.static_scissors());
    // The static value was applied to the command buffer state: a dynamic pipeline sees it...
    t.bind_pipeline(nullptr);
    EXPECT_FLOAT_EQ(t.viewport(0)->x, 1200.f);
    // ...unless the app sets its own, even while the static pipeline is bound.
    t.bind_pipeline(state);
    t.set_viewports(0, 1, &kLeft, false);
    EXPECT_FLOAT_EQ(t.viewport(0)->x, 1200.f);
    t.bind_pipeline(nullptr);
    EXPECT_FLOAT_EQ(t.viewport(0)->x, 0.f);
}

TEST(SplitTracker, UnsetIndicesAreNotViewports) {
    CommandTracker t;
    t.set_viewports(1, 1, &kRight, false);
    EXPECT_EQ(t.viewport(0), nullptr);
    ASSERT_NE(t.viewport(1), nullptr);
    const VkViewport both[] = {kLeft, kRight};
    t.set_viewports(0, 2, both, true);
    EXPECT_TRUE(t.dynamic_viewports().with_count);
    t.set_viewports(0, 1, &kRight, true); // with count: the count is state too
    EXPECT_EQ(t.viewport(1), nullptr);
}

TEST(SplitTracker, MergeUnionsCoveragePerImage) {
    // Command buffers submitted apart, one per eye: their union is the stereo pair.
    std::vector<DrawnImage> all;
    merge_drawn(all, {{1, kImage, viewport_coverage(kRight, kImage), {}}});
    merge_drawn(all, {{1, kImage, viewport_coverage(kLeft, kImage), {}},
                      {2, kImage, viewport_coverage(kLeft, kImage), {}}});
    ASSERT_EQ(all.size(), 2u);
    const auto both = all[0].foveae(EyeMode::Auto, FoveaSize{});
    ASSERT_EQ(both.size(), 2u);
    EXPECT_EQ(both[0].offset.x, 344);
    EXPECT_EQ(both[1].offset.x, 1544);
    const auto one = all[1].foveae(EyeMode::Auto, FoveaSize{}); // one eye alone: mono, centred
    ASSERT_EQ(one.size(), 1u);
    EXPECT_EQ(one[0].offset.x, 688);
}

// SPLITVK_FOVEA=auto with the depth mask: a pass notes the fovea it left unshaded in its image's
// record, and the record of a frame keeps the largest, whichever command buffer masked it.
TEST(SplitTracker, TheLargestMaskOfAFrameIsKept) {
    CommandTracker tracker;
    tracker.note_mask({5, 5}); // outside a split pass: nothing
    EXPECT_TRUE(tracker.drawn().empty());
    tracker.begin_split(1, kImage);
    tracker.note_mask({100, 300});
    tracker.note_mask({200, 200});
    tracker.end_split();
    ASSERT_EQ(tracker.drawn().size(), 1u);
    EXPECT_EQ(tracker.drawn()[0].masked, (FrameFoveaSize{200, 300}));

    CommandTracker offscreen;
    offscreen.begin_split(2, kImage, /*swapchain=*/false);
    offscreen.note_mask({100, 100});
    offscreen.end_split();
    EXPECT_TRUE(offscreen.drawn().empty()) << "a pass into screen-space targets has no foveae to mask";

    std::vector<DrawnImage> frame;
    merge_drawn(frame, {{1, kImage, viewport_coverage(kLeft, kImage), {}}});
    merge_drawn(frame, tracker.drawn());
    merge_drawn(frame, {{1, kImage, viewport_coverage(kRight, kImage), {300, 100}}});
    ASSERT_EQ(frame.size(), 1u);
    EXPECT_EQ(frame[0].masked, (FrameFoveaSize{300, 300}));
}

TEST(SplitTracker, StaticStateFromCreateInfo) {
    const VkRect2D scissor{{0, 0}, {100, 100}};
    VkPipelineViewportStateCreateInfo vs{};
    vs.sType = VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO;
    vs.viewportCount = vs.scissorCount = 1;
    vs.pViewports = &kLeft;
    vs.pScissors = &scissor;
    const VkDynamicState scissor_only[] = {VK_DYNAMIC_STATE_SCISSOR};
    VkPipelineDynamicStateCreateInfo dynamic{};
    dynamic.sType = VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO;
    dynamic.dynamicStateCount = 1;
    dynamic.pDynamicStates = scissor_only;
    VkGraphicsPipelineCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO;
    info.pViewportState = &vs;
    info.pDynamicState = &dynamic;
    const auto state = static_viewport_state(info);
    ASSERT_NE(state, nullptr);
    EXPECT_TRUE(state->has_viewports);
    EXPECT_FALSE(state->has_scissors);

    DynamicStateStorage storage;
    VkGraphicsPipelineCreateInfo out{};
    add_dynamic_states(info, true, false, storage, out);
    ASSERT_EQ(out.pDynamicState->dynamicStateCount, 2u);
    EXPECT_EQ(out.pDynamicState->pDynamicStates[0], VK_DYNAMIC_STATE_SCISSOR);
    EXPECT_EQ(out.pDynamicState->pDynamicStates[1], VK_DYNAMIC_STATE_VIEWPORT);
    EXPECT_EQ(info.pDynamicState, &dynamic); // the app's create info is untouched

    // Statically discarded rasterization: pViewportState is ignored, so nothing is static.
    VkPipelineRasterizationStateCreateInfo raster{};
    raster.sType = VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO;
    raster.rasterizerDiscardEnable = VK_TRUE;
    info.pRasterizationState = &raster;
    EXPECT_EQ(static_viewport_state(info), nullptr);
}

// A pass into screen-space targets only is scaled but draws no fovea; a copy or blit into
// a swapchain image counts as drawing there; secondaries give the foveae of the executing pass.
TEST(SplitTracker, OffscreenPassesDrawNoFovea) {
    CommandTracker t;
    t.begin_split(0, {2400, 1080}, false);
    const VkViewport whole{0.f, 0.f, 2400.f, 1080.f, 0.f, 1.f};
    t.set_viewports(0, 1, &whole, false);
    t.note_foveae();
    EXPECT_TRUE(t.in_split());
    EXPECT_FALSE(t.swapchain_pass());
    t.end_split();
    EXPECT_TRUE(t.drawn().empty());
}

TEST(SplitTracker, TransfersIntoTheSwapchainImageAreDrawing) {
    CommandTracker t;
    const VkRect2D whole{{0, 0}, {2400, 1080}};
    t.note_transfer(7, {2400, 1080}, whole);
    ASSERT_EQ(t.drawn().size(), 1u);
    const auto one = t.drawn()[0].foveae(EyeMode::Auto, FoveaSize{});
    ASSERT_EQ(one.size(), 1u); // one viewport-like rectangle over both halves
    EXPECT_RECT(one[0], 688, 360, 1024u, 360u);
    const auto two = t.drawn()[0].foveae(EyeMode::Two, FoveaSize{});
    ASSERT_EQ(two.size(), 2u); // both eyes it covers
    EXPECT_RECT(two[0], 344, 360, 512u, 360u);
    EXPECT_RECT(two[1], 1544, 360, 512u, 360u);
    CommandTracker empty;
    empty.note_transfer(7, {2400, 1080}, {{0, 0}, {0, 10}});
    EXPECT_TRUE(empty.drawn().empty());
    // The swapped split: a copy of the client's full-size picture makes its frame a cut one (the
    // periphery comes from the agent), as atrium --path compute writes the image; a plain one does not.
    EXPECT_FALSE(t.drawn()[0].cut);
    t.note_transfer(7, {2400, 1080}, whole, /*cut=*/true);
    EXPECT_TRUE(t.drawn()[0].cut);
}

TEST(SplitTracker, SecondariesGiveTheExecutingPassItsFoveae) {
    CommandTracker secondary;
    secondary.begin_secondary();
    const VkViewport left{0.f, 0.f, 1200.f, 1080.f, 0.f, 1.f}, right{1200.f, 0.f, 1200.f, 1080.f, 0.f, 1.f};
    secondary.set_viewports(0, 1, &left, false);
    secondary.note_foveae();
    secondary.set_viewports(0, 1, &right, false);
    secondary.note_foveae();
    EXPECT_TRUE(secondary.drawn().empty()); // its image is unknown until executed
    CommandTracker primary;
    const VkViewport stale{0.f, 0.f, 2400.f, 1080.f, 0.f, 1.f};
    primary.set_viewports(0, 1, &stale, false);
    primary.begin_split(9, {2400, 1080});
    primary.contents_in_secondaries();
    primary.merge_executed(secondary);
    primary.end_split(); // the stale viewport adds nothing
    ASSERT_EQ(primary.drawn().size(), 1u);
    EXPECT_EQ(primary.drawn()[0].image, 9u);
    const auto foveae = primary.drawn()[0].foveae(EyeMode::Auto, FoveaSize{});
    ASSERT_EQ(foveae.size(), 2u);
    EXPECT_RECT(foveae[0], 344, 360, 512u, 360u);
    EXPECT_RECT(foveae[1], 1544, 360, 512u, 360u);
    // Executed outside a split pass, it notes nothing.
    CommandTracker outside;
    outside.merge_executed(secondary);
    EXPECT_TRUE(outside.drawn().empty());
}

// A render pass handle value reused by the driver after vkDestroyRenderPass must not
// hand the new pass the dead one's target (its secondaries would be recorded scaled for a pass
// that is not, or the other way round). The layer forgets the value at destroy and at create.
TEST(SplitTracker, ARenderPassForgottenPredictsNothing) {
    PassPredictions predictions;
    constexpr uint64_t pass = 0x5a00, other = 0x5b00;
    EXPECT_FALSE(predictions.predict(pass).has_value()); // never begun: no prediction
    predictions.note_begin(pass, {true, {2400, 1080}});
    predictions.note_begin(other, {false, {800, 600}});
    auto p = predictions.predict(pass);
    ASSERT_TRUE(p.has_value());
    EXPECT_TRUE(p->scaled);
    EXPECT_EQ(p->extent.width, 2400u);
    predictions.note_begin(pass, {true, {1200, 540}}); // the latest instance wins
    EXPECT_EQ(predictions.predict(pass)->extent.width, 1200u);
    predictions.forget(pass); // vkDestroyRenderPass; the driver may now reuse 0x5a00
    EXPECT_FALSE(predictions.predict(pass).has_value());
    ASSERT_TRUE(predictions.predict(other).has_value()); // other passes keep theirs
    EXPECT_FALSE(predictions.predict(other)->scaled);
    predictions.forget(pass); // forgetting twice (destroy, then the reused value's create) is harmless
    EXPECT_FALSE(predictions.predict(pass).has_value());
}

// Dynamic renderings with secondary contents are predicted by what the secondaries' inheritance
// can name: attachment formats (in order) and the view mask.
TEST(SplitTracker, RenderingKeyIsWhatTheInheritanceNames) {
    const VkFormat bgra = VK_FORMAT_B8G8R8A8_UNORM, rgba16 = VK_FORMAT_R16G16B16A16_SFLOAT;
    const VkFormat one[] = {bgra}, two[] = {bgra, rgba16}, swapped[] = {rgba16, bgra};
    const VkFormat depth = VK_FORMAT_D32_SFLOAT, none = VK_FORMAT_UNDEFINED;
    const uint64_t base = rendering_key(one, 1, depth, none, 0);
    EXPECT_EQ(base, rendering_key(one, 1, depth, none, 0));
    EXPECT_NE(base, rendering_key(one, 1, none, none, 0));  // no depth
    EXPECT_NE(base, rendering_key(one, 1, depth, none, 3)); // multiview
    EXPECT_NE(base, rendering_key(two, 2, depth, none, 0));
    EXPECT_NE(rendering_key(two, 2, depth, none, 0), rendering_key(swapped, 2, depth, none, 0));
    const VkFormat with_hole[] = {bgra, none};
    EXPECT_NE(base, rendering_key(with_hole, 2, depth, none, 0)); // an unused second location
    PassPredictions renderings;
    renderings.note_begin(base, {true, {2400, 1080}});
    EXPECT_TRUE(renderings.predict(base).has_value());
    EXPECT_FALSE(renderings.predict(rendering_key(one, 1, none, none, 0)).has_value());
}

// The compute sets a dispatch looks at are the command buffer's own, begun afresh with it
// (the layer resets the tracker at vkBeginCommandBuffer and vkResetCommandBuffer/Pool, and drops it
// with the command buffer): a set a previous recording bound, one that writes a screen-space target,
// must not scale a later recording's dispatch that binds no such set.
TEST(SplitTracker, ComputeSetsEndWithTheRecording) {
    const auto set = [](uint64_t v) { return reinterpret_cast<VkDescriptorSet>(v); };
    CommandTracker t;
    const VkDescriptorSet screen_space[] = {set(0x10), set(0x20)};
    t.bind_compute_sets(1, 2, screen_space);
    ASSERT_EQ(t.compute_sets().size(), 3u);
    EXPECT_EQ(t.compute_sets()[0], VK_NULL_HANDLE);
    EXPECT_EQ(t.compute_sets()[1], set(0x10));
    EXPECT_EQ(t.compute_sets()[2], set(0x20));
    const VkDescriptorSet rebound[] = {set(0x30)};
    t.bind_compute_sets(2, 1, rebound);
    EXPECT_EQ(t.compute_sets()[2], set(0x30));

    t.reset(); // the command buffer is begun again
    EXPECT_TRUE(t.compute_sets().empty());
    const VkDescriptorSet plain[] = {set(0x40)};
    t.bind_compute_sets(0, 1, plain);
    ASSERT_EQ(t.compute_sets().size(), 1u);
    EXPECT_EQ(t.compute_sets()[0], set(0x40));
}

// A command buffer that dispatched over a screen-space target, reset or begun
// again, then dispatches over an ordinary image: that dispatch's group counts must stay as recorded
// (the layer scales them only when the tracker says a bound set writes a screen-space target).
TEST(SplitTracker, ReusedCommandBufferDoesNotScaleAPlainDispatch) {
    const auto set = [](uint64_t v) { return reinterpret_cast<VkDescriptorSet>(v); };
    const VkDescriptorSet target_set = set(0x10), plain_set = set(0x40);
    const auto writes_screen_space = [&](VkDescriptorSet s) { return s == target_set; };
    CommandTracker t;
    EXPECT_FALSE(t.dispatch_writes_screen_space(writes_screen_space));
    t.bind_compute_sets(0, 1, &target_set);
    EXPECT_TRUE(t.dispatch_writes_screen_space(writes_screen_space));

    t.reset(); // vkResetCommandBuffer, vkResetCommandPool or vkBeginCommandBuffer again
    EXPECT_FALSE(t.dispatch_writes_screen_space(writes_screen_space));
    t.bind_compute_sets(0, 1, &plain_set);
    EXPECT_FALSE(t.dispatch_writes_screen_space(writes_screen_space));
    // A set bound at another set number alone does not make it scaled either.
    t.bind_compute_sets(2, 1, &plain_set);
    EXPECT_FALSE(t.dispatch_writes_screen_space(writes_screen_space));
    t.bind_compute_sets(1, 1, &target_set);
    EXPECT_TRUE(t.dispatch_writes_screen_space(writes_screen_space));
}

// Both the layer and the agent pass dynamic scissors down in runs of the indices the application
// set: an index it never set holds no value and must not be passed, and a vkCmdSet*WithCount
// call sets every index up to its count.
TEST(SplitTracker, ValidRunsSkipTheIndicesNeverSet) {
    struct Run {
        uint32_t first, count;
        int first_value;
        bool operator==(const Run &) const = default;
    };
    const auto runs = [](const StateArray<int> &state) {
        std::vector<int> out;
        for (const int v : state.values)
            out.push_back(v * 10); // what the split passes down is rewritten, not the state itself
        std::vector<Run> found;
        for_each_valid_run(state, out, [&](uint32_t first, uint32_t count, const int *v) {
            found.push_back({first, count, *v});
        });
        return found;
    };
    StateArray<int> state;
    EXPECT_TRUE(runs(state).empty());

    const int a[] = {1, 2};
    const int b[] = {5};
    const int c[] = {7, 8};
    state.assign(1, 2, a, false); // indices 1-2
    state.assign(5, 1, b, false); // index 5
    EXPECT_EQ(runs(state), (std::vector<Run>{{1, 2, 10}, {5, 1, 50}}));
    state.assign(3, 2, c, false); // 3-4 join the runs either side into one
    EXPECT_EQ(runs(state), (std::vector<Run>{{1, 5, 10}}));

    state.assign(0, 2, c, true); // with count: exactly indices 0-1
    EXPECT_EQ(runs(state), (std::vector<Run>{{0, 2, 70}}));
}

// The agent's scissor rule in split passes, shared with the client's fovea mode: the scissor cut by
// the viewport's fovea_scissor, left alone while the viewport is unknown.
TEST(SplitGeometry, NarrowToFoveaeCutsByTheViewportsFoveaScissor) {
    const FoveaSize fovea;
    const VkExtent2D image{2400, 1080};
    const VkViewport left{0.f, 0.f, 1200.f, 1080.f, 0.f, 1.f}, whole{0.f, 0.f, 2400.f, 1080.f, 0.f, 1.f};
    const VkRect2D all{{0, 0}, image};
    EXPECT_RECT(narrow_to_foveae(all, nullptr, image, EyeMode::Two, fovea, false), 0, 0, 2400u, 1080u);
    EXPECT_RECT(narrow_to_foveae(all, &left, image, EyeMode::Two, fovea, false), 344, 360, 512u, 360u);
    EXPECT_RECT(narrow_to_foveae(all, &whole, image, EyeMode::Two, fovea, false), 344, 360, 1712u, 360u);
    EXPECT_RECT(narrow_to_foveae(all, &whole, image, EyeMode::One, fovea, false), 688, 360, 1024u, 360u);
    // The app's own scissor still bounds it.
    EXPECT_RECT(narrow_to_foveae({{0, 0}, {500, 500}}, &left, image, EyeMode::Two, fovea, false), 344, 360,
                156u, 140u);
    // Disjoint: empty, as intersect gives it.
    EXPECT_EQ(narrow_to_foveae({{0, 0}, {100, 100}}, &left, image, EyeMode::Two, fovea, false).extent.width,
              0u);
    // A moving gaze: the whole eye the viewport draws into.
    EXPECT_RECT(narrow_to_foveae(all, &left, image, EyeMode::Two, fovea, true), 0, 0, 1200u, 1080u);
}

// The swapped split's seam (SPLITVK_SEAM=feather:N): each fovea grown by N, clamped to the image and
// to the eye it lies in, so that the two eyes' bands never reach across the eye boundary.
TEST(SplitGeometry, SeamRectGrowsTheFoveaWithinItsEye) {
    const VkExtent2D image{2400, 1080};
    const VkRect2D left_fovea{{344, 360}, {512, 360}}, right_fovea{{1544, 360}, {512, 360}};
    EXPECT_RECT(seam_rect(left_fovea, image, 16), 328, 344, 544u, 392u);
    EXPECT_RECT(seam_rect(right_fovea, image, 16), 1528, 344, 544u, 392u);
    EXPECT_RECT(seam_rect(left_fovea, image, 0), 344, 360, 512u, 360u);
    // A mono frame's centred fovea straddles the eye boundary: only the image bounds it.
    EXPECT_RECT(seam_rect({{688, 360}, {1024, 360}}, image, 16), 672, 344, 1056u, 392u);
    // At the image's edges (a fovea at a gaze in a corner).
    EXPECT_RECT(seam_rect({{0, 0}, {512, 360}}, image, 16), 0, 0, 528u, 376u);
    EXPECT_RECT(seam_rect({{1888, 720}, {512, 360}}, image, 16), 1872, 704, 528u, 376u);
    // At the eye boundary, from either side: clamped to the fovea's own eye.
    const VkRect2D left_inner{{688, 360}, {512, 360}}, right_inner{{1200, 360}, {512, 360}};
    EXPECT_RECT(seam_rect(left_inner, image, 16), 672, 344, 528u, 392u);
    EXPECT_RECT(seam_rect(right_inner, image, 16), 1200, 344, 528u, 392u);
    for (const uint32_t pixels : {1u, 16u, 256u, 100000u}) {
        const VkRect2D a = seam_rect(left_inner, image, pixels), b = seam_rect(right_inner, image, pixels);
        EXPECT_LE(a.offset.x + int32_t(a.extent.width), 1200) << pixels;
        EXPECT_GE(b.offset.x, 1200) << pixels;
        EXPECT_EQ(intersect(a, b).extent.width * intersect(a, b).extent.height, 0u) << pixels;
        // Never past the image.
        EXPECT_GE(a.offset.y, 0) << pixels;
        EXPECT_LE(b.offset.y + int64_t{b.extent.height}, 1080) << pixels;
    }
    // An odd width: the left eye is W/2 wide, the right the rest.
    EXPECT_RECT(seam_rect({{100, 10}, {400, 20}}, {1001, 100}, 200), 0, 0, 500u, 100u);
    EXPECT_RECT(seam_rect({{600, 10}, {300, 20}}, {1001, 100}, 200), 500, 0, 501u, 100u);
    // A fovea at the gaze, pushed against the eye boundary, stays in its eye.
    const VkRect2D at_gaze = fovea_at_gaze(left_eye(image), {kGazeOne, kGazeOne / 2}, FoveaSize{});
    EXPECT_RECT(seam_rect(at_gaze, image, 16), 672, 344, 528u, 392u);
}

// The client's cut with a seam: every fovea a viewport can draw into, each grown by seam_rect (the
// agent's scissors, with none, are as they were).
TEST(SplitGeometry, FoveaScissorWithASeamHoldsEveryGrownFovea) {
    const FoveaSize fovea;
    const VkExtent2D image{2400, 1080};
    const VkViewport left{0.f, 0.f, 1200.f, 1080.f, 0.f, 1.f}, right{1200.f, 0.f, 1200.f, 1080.f, 0.f, 1.f},
        whole{0.f, 0.f, 2400.f, 1080.f, 0.f, 1.f};
    EXPECT_RECT(fovea_scissor(left, image, EyeMode::Two, fovea, false, 16), 328, 344, 544u, 392u);
    EXPECT_RECT(fovea_scissor(right, image, EyeMode::Two, fovea, false, 16), 1528, 344, 544u, 392u);
    EXPECT_RECT(fovea_scissor(whole, image, EyeMode::Two, fovea, false, 16), 328, 344, 1744u, 392u);
    EXPECT_RECT(fovea_scissor(whole, image, EyeMode::One, fovea, false, 16), 672, 344, 1056u, 392u);
    // Auto: the centred fovea and the left eye's, both grown.
    EXPECT_RECT(fovea_scissor(left, image, EyeMode::Auto, fovea, false, 16), 328, 344, 1400u, 392u);
    // A moving gaze already holds the whole eye.
    EXPECT_RECT(fovea_scissor(left, image, EyeMode::Two, fovea, true, 16), 0, 0, 1200u, 1080u);
    // A feather wider than the eye: the left eye's cut stays in the left eye.
    EXPECT_RECT(fovea_scissor(left, image, EyeMode::Two, fovea, false, 4096), 0, 0, 1200u, 1080u);
    const VkRect2D all{{0, 0}, image};
    EXPECT_RECT(narrow_to_foveae(all, &right, image, EyeMode::Two, fovea, false, 16), 1528, 344, 544u, 392u);
    EXPECT_RECT(narrow_to_foveae(all, &right, image, EyeMode::Two, fovea, false), 1544, 360, 512u, 360u);
    // Every frame fovea's seam lies within the cut of the viewports that drew it.
    for (const EyeMode mode : {EyeMode::One, EyeMode::Two, EyeMode::Auto})
        for (const VkViewport &v : {left, right, whole}) {
            const VkRect2D cut = fovea_scissor(v, image, mode, fovea, false, 16);
            for (const VkRect2D &f : frame_foveae(viewport_coverage(v, image), image, mode, fovea)) {
                const VkRect2D seam = seam_rect(f, image, 16);
                EXPECT_TRUE(same(intersect(seam, cut), seam)) << int(mode) << " " << v.x << "," << v.width;
            }
        }
}

// The guard of a screen-space target (SPLITVK_AGENT_SCISSOR=guard:N, SPLITVK_CLIENT_GUARD): every place a
// fovea can be, into the target's pixels rounded outwards, grown by N.
TEST(SplitGeometry, WindowGuardRectMapsEveryFoveaPlaceIntoTheTarget) {
    const FoveaSize fovea;
    const VkExtent2D screen{2400, 1080};
    TargetClass full;
    full.screen_space = true;
    VkRect2D r{};
    // Two eyes: the foveae at 344,360 and 1544,360 (512x360), their box 344..2056 x 360..720.
    ASSERT_TRUE(window_guard_rect(full, screen, screen, 0, EyeMode::Two, fovea, false, 64, &r));
    EXPECT_RECT(r, 280, 296, 1840u, 488u);
    ASSERT_TRUE(window_guard_rect(full, screen, screen, 0, EyeMode::Two, fovea, false, 0, &r));
    EXPECT_RECT(r, 344, 360, 1712u, 360u);
    // Mip 1 of it: halved outwards, then N of the mip's pixels.
    ASSERT_TRUE(window_guard_rect(full, screen, {1200, 540}, 1, EyeMode::Two, fovea, false, 64, &r));
    EXPECT_RECT(r, 108, 116, 984u, 308u);
    // A quarter-size target.
    TargetClass quarter = full;
    quarter.divisor = 4;
    ASSERT_TRUE(window_guard_rect(quarter, screen, {600, 270}, 0, EyeMode::Two, fovea, false, 64, &r));
    EXPECT_RECT(r, 22, 26, 556u, 218u);
    // Bounded by the target.
    ASSERT_TRUE(window_guard_rect(quarter, screen, {600, 270}, 0, EyeMode::Two, fovea, false, 400, &r));
    EXPECT_RECT(r, 0, 0, 600u, 270u);
    // An eye-sized target holds either eye: each eye's fovea in its own coordinates.
    TargetClass eye = full;
    eye.eye = true;
    ASSERT_TRUE(window_guard_rect(eye, screen, {1200, 1080}, 0, EyeMode::Two, fovea, false, 64, &r));
    EXPECT_RECT(r, 280, 296, 640u, 488u);
    // One eye: the centred fovea, 688,360 1024x360.
    ASSERT_TRUE(window_guard_rect(full, screen, screen, 0, EyeMode::One, fovea, false, 0, &r));
    EXPECT_RECT(r, 688, 360, 1024u, 360u);
    // A moving gaze: the whole eyes.
    ASSERT_TRUE(window_guard_rect(full, screen, screen, 0, EyeMode::Two, fovea, true, 64, &r));
    EXPECT_RECT(r, 0, 0, 2400u, 1080u);
    // Refused (runs whole): not screen-space, or a layered target with one eye.
    EXPECT_FALSE(window_guard_rect(TargetClass{}, screen, screen, 0, EyeMode::Two, fovea, false, 64, &r));
    TargetClass layered = eye;
    layered.layers = 2;
    EXPECT_FALSE(window_guard_rect(layered, screen, {1200, 1080}, 0, EyeMode::One, fovea, false, 64, &r));
    EXPECT_TRUE(window_guard_rect(layered, screen, {1200, 1080}, 0, EyeMode::Two, fovea, false, 64, &r));
}

// The scissor of an OpenXR eye image's split pass: the areas a viewport reaches, all of them where it
// reaches none or is unknown.
TEST(SplitGeometry, RuntimeScissorTakesTheAreasAViewportReaches) {
    const std::vector<LayerFovea> areas = {{0, {{100, 100}, {200, 200}}}, {0, {{700, 100}, {200, 200}}}};
    const VkViewport left{0.f, 0.f, 500.f, 500.f, 0.f, 1.f}, none{1000.f, 0.f, 10.f, 10.f, 0.f, 1.f};
    EXPECT_RECT(runtime_scissor(areas, &left), 100, 100, 200u, 200u);
    EXPECT_RECT(runtime_scissor(areas, nullptr), 100, 100, 800u, 200u);
    EXPECT_RECT(runtime_scissor(areas, &none), 100, 100, 800u, 200u);
    EXPECT_RECT(runtime_scissor({}, &left), 0, 0, 0u, 0u);
}

// The swapped split's cut of an OpenXR eye image (CommandTracker::cut_runtime_pass): the pass draws
// only where its areas are, and its image's record carries the eyes' version it was cut by; two
// command buffers cut by different versions join as mixed, a pass not cut leaves the version alone.
TEST(SplitTracker, RuntimeCutRecordsTheEyesItWasCutBy) {
    const std::vector<LayerFovea> areas = {{0, {{10, 20}, {30, 40}}}};
    const VkViewport whole{0.f, 0.f, 192.f, 160.f, 0.f, 1.f};
    const auto cut_by = [&](uint64_t version) {
        CommandTracker t;
        t.set_viewports(0, 1, &whole, false);
        t.begin_split(7, {192, 160});
        t.cut_runtime_pass(areas, version);
        EXPECT_TRUE(t.cut());
        EXPECT_NE(t.runtime_areas(), nullptr);
        EXPECT_RECT(runtime_scissor(*t.runtime_areas(), t.viewport(0)), 10, 20, 30u, 40u);
        t.note_foveae();
        t.end_split();
        EXPECT_EQ(t.runtime_areas(), nullptr);
        return t.drawn();
    };
    const auto a = cut_by(3);
    ASSERT_EQ(a.size(), 1u);
    EXPECT_TRUE(a[0].cut);
    EXPECT_EQ(a[0].cut_eyes, 3);

    std::vector<DrawnImage> joined = a;
    merge_drawn(joined, cut_by(3));
    EXPECT_EQ(joined[0].cut_eyes, 3);
    merge_drawn(joined, cut_by(4));
    EXPECT_EQ(joined[0].cut_eyes, DrawnImage::kMixedRuntimeCut);

    // A window's cut pass carries no eyes.
    CommandTracker window;
    window.set_viewports(0, 1, &whole, false);
    window.begin_split(7, {192, 160});
    window.cut_pass();
    EXPECT_EQ(window.runtime_areas(), nullptr);
    window.note_foveae();
    window.end_split();
    ASSERT_EQ(window.drawn().size(), 1u);
    EXPECT_EQ(window.drawn()[0].cut_eyes, DrawnImage::kNoRuntimeCut);
    std::vector<DrawnImage> with_window = a;
    merge_drawn(with_window, window.drawn());
    EXPECT_EQ(with_window[0].cut_eyes, 3);
}

} // namespace
} // namespace splitvk::split
