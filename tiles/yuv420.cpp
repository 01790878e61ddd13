#include "yuv420.h"

#include <algorithm>

namespace splitvk::tiles {
namespace {

// BT.709: Kr 0.2126, Kb 0.0722; full range, so no offset or scale of luma, chroma centred on 128.
// Forward coefficients in 1/65536 (each row of the matrix sums to 65536 for luma and to 0 for
// chroma, so grey stays grey exactly).
constexpr int32_t kYr = 13933, kYg = 46871, kYb = 4732;
constexpr int32_t kCbR = -7509, kCbG = -25259, kCbB = 32768;
constexpr int32_t kCrR = 32768, kCrG = -29763, kCrB = -3005;
// Inverse: R = Y + 1.5748 Cr, G = Y - 0.187324 Cb - 0.468124 Cr, B = Y + 1.8556 Cb, in 1/65536.
constexpr int32_t kRCr = 103206, kGCb = -12276, kGCr = -30679, kBCb = 121609;

inline uint8_t clamp_byte(int32_t value) {
    return static_cast<uint8_t>(std::clamp(value, 0, 255));
}

} // namespace

void rgb_to_yuv420(const uint8_t *rgb, size_t rgb_stride, uint32_t width, uint32_t height, ChannelOrder order,
                   const Yuv420Planes &planes, uint32_t coded_width, uint32_t coded_height) {
    const size_t r = order.red(), b = order.blue();
    auto texel = [&](uint32_t x, uint32_t y) {
        return rgb + rgb_stride * std::min(y, height - 1) + size_t{std::min(x, width - 1)} * 4;
    };
    for (uint32_t y = 0; y < coded_height; ++y) {
        uint8_t *luma = planes.y + planes.y_stride * y;
        const uint8_t *row = texel(0, y);
        for (uint32_t x = 0; x < width; ++x) {
            const uint8_t *p = row + size_t{x} * 4;
            luma[x] = static_cast<uint8_t>((kYr * p[r] + kYg * p[1] + kYb * p[b] + 32768) >> 16);
        }
        std::fill(luma + width, luma + coded_width, luma[width - 1]);
    }
    for (uint32_t cy = 0; cy < coded_height / 2; ++cy) {
        uint8_t *u = planes.u + planes.chroma_stride * cy;
        uint8_t *v = planes.v + planes.chroma_stride * cy;
        for (uint32_t cx = 0; cx < coded_width / 2; ++cx) {
            // The 2x2 block's sums: the coefficients then carry a factor 4 (two more bits of shift).
            int32_t sr = 0, sg = 0, sb = 0;
            for (uint32_t dy = 0; dy < 2; ++dy)
                for (uint32_t dx = 0; dx < 2; ++dx) {
                    const uint8_t *p = texel(2 * cx + dx, 2 * cy + dy);
                    sr += p[r];
                    sg += p[1];
                    sb += p[b];
                }
            const ptrdiff_t at = planes.chroma_step * cx;
            u[at] = clamp_byte(((kCbR * sr + kCbG * sg + kCbB * sb + (1 << 17)) >> 18) + 128);
            v[at] = clamp_byte(((kCrR * sr + kCrG * sg + kCrB * sb + (1 << 17)) >> 18) + 128);
        }
    }
}

void yuv420_row_to_rgb(const Yuv420Planes &planes, uint32_t width, uint32_t height, uint32_t row,
                       ChannelOrder order, int32_t *scratch, uint8_t *out) {
    const uint32_t chroma_width = (width + 1) / 2, chroma_height = (height + 1) / 2;
    // Vertically: luma row 2k sits a quarter of a chroma row above chroma row k, 2k+1 a quarter
    // below; 3:1 with the nearer neighbour (the edge repeated). Values in 1/4.
    const uint32_t k = row / 2;
    const uint32_t neighbour = row % 2 ? std::min(k + 1, chroma_height - 1) : (k > 0 ? k - 1 : 0);
    const uint8_t *u0 = planes.u + planes.chroma_stride * k,
                  *u1 = planes.u + planes.chroma_stride * neighbour;
    const uint8_t *v0 = planes.v + planes.chroma_stride * k,
                  *v1 = planes.v + planes.chroma_stride * neighbour;
    int32_t *cb = scratch, *cr = scratch + chroma_width;
    for (uint32_t i = 0; i < chroma_width; ++i) {
        const ptrdiff_t at = planes.chroma_step * i;
        cb[i] = 3 * u0[at] + u1[at] - 4 * 128;
        cr[i] = 3 * v0[at] + v1[at] - 4 * 128;
    }
    const uint8_t *luma = planes.y + planes.y_stride * row;
    const size_t r = order.red(), b = order.blue();
    for (uint32_t x = 0; x < width; ++x) {
        // Horizontally the same 3:1: chroma in 1/16, so the products are scaled by 2^20.
        const uint32_t i = x / 2;
        const uint32_t j = x % 2 ? std::min(i + 1, chroma_width - 1) : (i > 0 ? i - 1 : 0);
        const int32_t u = 3 * cb[i] + cb[j], v = 3 * cr[i] + cr[j];
        const int32_t y = (int32_t{luma[x]} << 20) + (1 << 19);
        uint8_t *p = out + size_t{x} * 4;
        p[r] = clamp_byte((y + kRCr * v) >> 20);
        p[1] = clamp_byte((y + kGCb * u + kGCr * v) >> 20);
        p[b] = clamp_byte((y + kBCb * u) >> 20);
        p[3] = 255;
    }
}

} // namespace splitvk::tiles
