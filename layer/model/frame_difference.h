#pragma once

// SPLITVK_VERIFY=full's pixel comparison (verification.cpp): the client's presented image against
// the agent's frame of the same number. Plain functions, unit-tested on their own.
//
// In the paper's split verification turns the split off, and every pixel must match. In the
// swapped split (SPLITVK_CLIENT_RENDERS=fovea) the split stays on: the client presents its own
// foveae over the agent's lossy periphery, upsampled, and the agent renders the whole frame at full
// size, its native picture. Then only the foveae must match, and the whole image is measured by
// PSNR, which tells how far the periphery is from native.

#include <vulkan/vulkan.h>

#include <cstdint>
#include <mutex>
#include <span>

namespace splitvk {

// Two images of 4-byte texels (8-bit RGBA or BGRA, the same on both sides), rows packed, every
// array layer after the other.
struct FrameDifference {
    uint64_t pixels = 0;     // compared, every layer
    uint64_t mismatches = 0; // pixels where they must be equal and are not
    // Of those mismatching pixels' colour channels: the largest difference, and their sum.
    uint32_t largest = 0;
    uint64_t channel_sum = 0;
    // Over the colour channels (alpha left out) of every pixel, wherever it must match or not.
    double squared_error = 0;
    uint64_t samples = 0;

    double mse() const { return samples ? squared_error / static_cast<double>(samples) : 0; }
};

// Compares `mine` with `theirs`, `width` x `height` x `layers` texels of `texel_bytes` (4: 8-bit
// RGBA/BGRA; 8: four 16-bit channels) each. `exact`: the rects of layer 0 in which pixels must be
// equal (they may overlap); empty, every pixel of every layer must. A texel is equal when every byte
// is; the error is measured on the first three channels, of 16-bit texels on their high bytes (an
// 8-bit view, so that PSNR means the same for either size).
FrameDifference compare_frames(const uint8_t *mine, const uint8_t *theirs, uint32_t width, uint32_t height,
                               uint32_t layers, std::span<const VkRect2D> exact = {},
                               uint32_t texel_bytes = 4);

// PSNR in dB of 8-bit channels at mean squared error `mse`: 10 log10(255^2 / mse), +infinity for
// equal images (mse 0).
double psnr_db(double mse);

// The swapped split's periphery over a run of verified frames: each frame's PSNR, the lowest, and
// the PSNR of all of them together (of their summed squared error). Thread-safe: OpenXR eye images
// are compared on the application's threads.
class PeripheryScore {
public:
    // One frame whose periphery the agent sent; `late`: it showed an earlier frame's periphery.
    // Returns the frame's PSNR.
    double add(const FrameDifference &difference, bool late);

    struct Totals {
        uint64_t frames = 0;
        uint64_t late = 0;
        double psnr_db = 0;   // of every frame together; +infinity when all were equal
        double lowest_db = 0; // of a single frame
    };
    Totals totals() const;

private:
    mutable std::mutex mutex_;
    uint64_t frames_ = 0;
    uint64_t late_ = 0;
    double squared_error_ = 0;
    uint64_t samples_ = 0;
    double lowest_db_ = 0;
};

} // namespace splitvk
