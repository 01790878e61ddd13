#pragma once

// The swapped split's periphery (SPLITVK_CLIENT_RENDERS=fovea), what the agent and the
// layer must agree on: the agent renders the whole frame, downsamples the presented image with a
// linear blit to split::scaled_extent(image, PeripheryConfig::scale) and streams that scaled image
// as Tiles flagged kTilePeriphery, one tile per part below, each in the scaled image's
// coordinates. The client checks a frame's parts against these before compositing them.

#include "settings.h"

#include <vulkan/vulkan.h>

#include <cstdint>
#include <vector>

namespace splitvk::split {

// The scale range a PeripheryConfig may carry: below 0.1 the periphery is no picture any more.
inline constexpr double kMinPeripheryScale = 0.1;
inline constexpr double kMaxPeripheryScale = 1.0;

// The parts the scaled periphery travels in: the left half [0, w/2) and the right half [w/2, w),
// each the full height, so that two threads encode them at once (and two decoders decode them);
// one part, the whole image, when it is narrower than 2 pixels.
std::vector<VkRect2D> periphery_parts(VkExtent2D periphery);

// Whether the agent encodes a periphery of this format lossily: 8-bit RGBA/BGRA, UNORM or SRGB
// (the blit keeps sRGB bytes sRGB, and x264 codes the bytes as they are). Any other 4-byte format
// travels losslessly, whatever the quality asked.
bool periphery_lossy_format(VkFormat format);

// Whether byte 0 of a texel of a lossy periphery format is blue (B8G8R8A8): the 4:2:0 codecs convert
// colour and must know which byte is red.
bool periphery_blue_first(VkFormat format);

// The tile codec a lossy periphery travels in for each SPLITVK_PERIPHERY_CODEC.
TileCodec periphery_tile_codec(PeripheryCodec codec);

} // namespace splitvk::split
