#pragma once

// The colour conversion of the 4:2:0 periphery codecs (tile_codec.h): 8-bit RGB bytes to Y'CbCr 4:2:0
// and back, BT.709 matrix, full range (0..255 in every plane, as the streams' VUI says). The bytes are
// converted as they are: an sRGB image's bytes stay sRGB-encoded, with no linearisation either way,
// as the blit that made the periphery kept them.
//
// Chroma is sited at the centre of each 2x2 block of luma (chroma_sample_loc_type 1): the encoder
// averages the block, the decoder interpolates bilinearly between the four nearest chroma samples
// (weights 9:3:3:1), the inverse of that siting. Integer arithmetic, so both sides round alike on
// every CPU.

#include <cstddef>
#include <cstdint>

namespace splitvk::tiles {

// Where red and blue sit in a 4-byte texel: byte 0 and 2 (R,G,B,A) or byte 2 and 0 (B,G,R,A). Green is
// byte 1 and alpha byte 3 in both; alpha does not travel through the planes.
struct ChannelOrder {
    bool blue_first = false;
    size_t red() const { return blue_first ? 2 : 0; }
    size_t blue() const { return blue_first ? 0 : 2; }
};

// A planar 4:2:0 picture: luma width x height, chroma (width+1)/2 x (height+1)/2. Chroma samples
// are `chroma_step` bytes apart in their rows: 1 for planar I420, 2 for NV12 (u = v - 1).
struct Yuv420Planes {
    uint8_t *y = nullptr;
    uint8_t *u = nullptr;
    uint8_t *v = nullptr;
    ptrdiff_t y_stride = 0;
    ptrdiff_t chroma_stride = 0; // of u and v alike
    ptrdiff_t chroma_step = 1;
};

// Converts width x height texels (rows `rgb_stride` bytes apart) into `planes`, which are at least
// `coded_width` x `coded_height` (each even, at least the picture's size): the picture's last column
// and row are repeated into the padding, so that the encoder codes no edge there.
void rgb_to_yuv420(const uint8_t *rgb, size_t rgb_stride, uint32_t width, uint32_t height, ChannelOrder order,
                   const Yuv420Planes &planes, uint32_t coded_width, uint32_t coded_height);

// Converts luma row `row` of a `width` x `height` picture (of a decoded frame at least that large) into
// `out`, width texels of 4 bytes in `order`, alpha 255. `scratch` holds 2 * ((width+1)/2) ints.
void yuv420_row_to_rgb(const Yuv420Planes &planes, uint32_t width, uint32_t height, uint32_t row,
                       ChannelOrder order, int32_t *scratch, uint8_t *out);

} // namespace splitvk::tiles
