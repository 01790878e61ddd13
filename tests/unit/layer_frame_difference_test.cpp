// SPLITVK_VERIFY=full's comparison (layer/model/frame_difference.h): the mismatch count where pixels must
// be equal, the PSNR over the whole image, and the swapped split's periphery score over frames.

#include "model/frame_difference.h"

#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

namespace splitvk {
namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

// `width` x `height` x `layers` texels of one colour.
std::vector<uint8_t> image(uint32_t width, uint32_t height, uint32_t layers, uint8_t value) {
    std::vector<uint8_t> pixels(size_t{width} * height * layers * 4, value);
    for (size_t i = 3; i < pixels.size(); i += 4)
        pixels[i] = 255;
    return pixels;
}

uint8_t *texel(std::vector<uint8_t> &pixels, uint32_t width, uint32_t height, uint32_t x, uint32_t y,
               uint32_t layer = 0) {
    return pixels.data() + ((size_t{layer} * height + y) * width + x) * 4;
}

TEST(PsnrDb, KnownMeanSquaredErrors) {
    // 255^2 / mse = 10^(dB/10).
    EXPECT_DOUBLE_EQ(psnr_db(255.0 * 255.0), 0.0);
    EXPECT_NEAR(psnr_db(255.0 * 255.0 / 100.0), 20.0, 1e-9);
    EXPECT_NEAR(psnr_db(1.0), 48.1308036, 1e-6); // one step of 255 in every channel
    EXPECT_NEAR(psnr_db(6.5025), 40.0, 1e-9);
}

TEST(PsnrDb, EqualImagesAreInfinite) {
    EXPECT_EQ(psnr_db(0.0), kInfinity);
}

TEST(CompareFrames, EqualImagesMatchEverywhereWithInfinitePsnr) {
    const auto a = image(8, 4, 1, 100);
    const FrameDifference d = compare_frames(a.data(), a.data(), 8, 4, 1);
    EXPECT_EQ(d.pixels, 32u);
    EXPECT_EQ(d.mismatches, 0u);
    EXPECT_EQ(d.samples, 96u);
    EXPECT_EQ(d.squared_error, 0.0);
    EXPECT_EQ(psnr_db(d.mse()), kInfinity);
}

TEST(CompareFrames, MeanSquaredErrorIsOverTheColourChannelsOfEveryPixel) {
    // Every colour channel off by 4, alpha off too (alpha is not colour): mse 16, PSNR 36.12 dB.
    auto a = image(10, 10, 1, 100);
    auto b = image(10, 10, 1, 104);
    for (size_t i = 3; i < b.size(); i += 4)
        b[i] = 0;
    const FrameDifference d = compare_frames(a.data(), b.data(), 10, 10, 1);
    EXPECT_EQ(d.mismatches, 100u);
    EXPECT_EQ(d.largest, 4u);
    EXPECT_EQ(d.channel_sum, 100u * 3 * 4);
    EXPECT_DOUBLE_EQ(d.mse(), 16.0);
    EXPECT_NEAR(psnr_db(d.mse()), 10 * std::log10(255.0 * 255.0 / 16.0), 1e-9);
}

TEST(CompareFrames, OnlyTheExactRectsCountMismatchesWhileThePsnrCoversEverything) {
    constexpr uint32_t kWidth = 16, kHeight = 8;
    auto mine = image(kWidth, kHeight, 1, 50);
    auto theirs = mine;
    // Outside the fovea: one pixel off by 10 in red.
    texel(theirs, kWidth, kHeight, 0, 0)[0] = 60;
    // Inside the fovea (4,2 4x3): one pixel off by 2 in green.
    texel(theirs, kWidth, kHeight, 5, 3)[1] = 52;
    const VkRect2D fovea{{4, 2}, {4, 3}};
    const FrameDifference d = compare_frames(mine.data(), theirs.data(), kWidth, kHeight, 1, {&fovea, 1});
    EXPECT_EQ(d.mismatches, 1u);
    EXPECT_EQ(d.largest, 2u);
    EXPECT_EQ(d.channel_sum, 2u);
    EXPECT_DOUBLE_EQ(d.squared_error, 100.0 + 4.0);
    EXPECT_DOUBLE_EQ(d.mse(), 104.0 / (kWidth * kHeight * 3));

    // The fovea's right and bottom edges are outside it: a difference there counts only in the PSNR.
    auto edge = mine;
    texel(edge, kWidth, kHeight, 8, 2)[2] = 0;
    texel(edge, kWidth, kHeight, 4, 5)[2] = 0;
    EXPECT_EQ(compare_frames(mine.data(), edge.data(), kWidth, kHeight, 1, {&fovea, 1}).mismatches, 0u);
    texel(edge, kWidth, kHeight, 7, 4)[2] = 0; // its last pixel
    EXPECT_EQ(compare_frames(mine.data(), edge.data(), kWidth, kHeight, 1, {&fovea, 1}).mismatches, 1u);
}

TEST(CompareFrames, RectsOutsideTheImageAreClippedAndOnlyLayerZeroHasThem) {
    constexpr uint32_t kWidth = 4, kHeight = 4;
    auto mine = image(kWidth, kHeight, 2, 0);
    auto theirs = image(kWidth, kHeight, 2, 1);
    const VkRect2D beyond{{-2, -2}, {4, 4}}; // covers 0,0 to 1,1
    const FrameDifference d = compare_frames(mine.data(), theirs.data(), kWidth, kHeight, 2, {&beyond, 1});
    EXPECT_EQ(d.pixels, 32u);
    EXPECT_EQ(d.mismatches, 4u);
    EXPECT_DOUBLE_EQ(d.mse(), 1.0);
    // Without rects, every pixel of both layers must match.
    EXPECT_EQ(compare_frames(mine.data(), theirs.data(), kWidth, kHeight, 2).mismatches, 32u);
}

TEST(PeripheryScore, TotalsAreThePsnrOfEveryFrameTogetherAndTheLowestFrame) {
    PeripheryScore score;
    EXPECT_EQ(score.totals().frames, 0u);
    FrameDifference good;
    good.samples = 300;
    good.squared_error = 300 * 6.5025; // 40 dB
    FrameDifference late;
    late.samples = 300;
    late.squared_error = 300 * 65.025; // 30 dB
    EXPECT_NEAR(score.add(good, false), 40.0, 1e-9);
    EXPECT_NEAR(score.add(late, true), 30.0, 1e-9);
    const auto t = score.totals();
    EXPECT_EQ(t.frames, 2u);
    EXPECT_EQ(t.late, 1u);
    EXPECT_NEAR(t.lowest_db, 30.0, 1e-9);
    // The mean squared error of both: (6.5025 + 65.025) / 2.
    EXPECT_NEAR(t.psnr_db, psnr_db((6.5025 + 65.025) / 2), 1e-9);
}

TEST(PeripheryScore, EqualFramesScoreInfinity) {
    PeripheryScore score;
    FrameDifference equal;
    equal.samples = 30;
    EXPECT_EQ(score.add(equal, false), kInfinity);
    EXPECT_EQ(score.totals().psnr_db, kInfinity);
    EXPECT_EQ(score.totals().lowest_db, kInfinity);
}

} // namespace
} // namespace splitvk
