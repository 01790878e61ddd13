#pragma once

// The texel size of tiles, one rule for both sides: the agent reads a fovea back at this many bytes a
// pixel and encodes it so, and the layer sizes its decoder and upload buffer by it (then checks the
// tile against the image it composites into). Tiles carry texels as the image stores them, byte for
// byte, so a format can travel only when its texel is one whole block of a size the tile codecs
// take: a single-plane colour format with 1x1 blocks, not compressed, not Y'CbCr, of 4 or 8 bytes.
// Facts from vk.xml (vk_format_info.h, codegen/emit_formats.py).

#include "vk_format_info.h"

#include <vulkan/vulkan.h>

#include <cstdint>

namespace splitvk {

// 4 (8-bit RGBA/BGRA, the 10-bit packed formats, B10G11R11, E5B9G9R9, RG16, R32) or 8 (RGBA16,
// RG32, R64) for the formats whose images can be split; 0 for every other format (depth/stencil,
// compressed, multi-planar or Y'CbCr, 3-byte, 16-byte, and values vk.xml does not list).
constexpr uint32_t tile_texel_bytes(VkFormat format) {
    const FormatInfo info = format_info(format);
    if (info.block_width != 1 || info.block_height != 1 || info.depth || info.stencil || info.compressed ||
        info.ycbcr)
        return 0;
    return info.block_bytes == 4 || info.block_bytes == 8 ? info.block_bytes : 0;
}

} // namespace splitvk
