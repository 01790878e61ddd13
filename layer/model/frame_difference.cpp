#include "model/frame_difference.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <vector>

namespace splitvk {

FrameDifference compare_frames(const uint8_t *mine, const uint8_t *theirs, uint32_t width, uint32_t height,
                               uint32_t layers, std::span<const VkRect2D> exact, uint32_t texel_bytes) {
    // The byte of channel c that the error is measured on: little-endian 16-bit channels' high byte.
    const size_t channel_stride = texel_bytes / 4, channel_byte = channel_stride - 1;
    FrameDifference d;
    d.pixels = uint64_t{width} * height * layers;
    // Which pixels of the current row must be equal: all of them, or those of `exact` in layer 0.
    std::vector<uint8_t> must_match(width, exact.empty() ? 1 : 0);
    for (uint32_t layer = 0; layer < layers; ++layer) {
        for (uint32_t y = 0; y < height; ++y) {
            if (!exact.empty()) {
                std::fill(must_match.begin(), must_match.end(), uint8_t{0});
                for (const VkRect2D &r : exact) {
                    const int64_t top = r.offset.y, left = r.offset.x;
                    if (layer != 0 || y < top || y >= top + r.extent.height) continue;
                    const auto from = static_cast<uint32_t>(std::clamp<int64_t>(left, 0, width));
                    const auto to =
                        static_cast<uint32_t>(std::clamp<int64_t>(left + r.extent.width, 0, width));
                    std::fill(must_match.begin() + from, must_match.begin() + to, uint8_t{1});
                }
            }
            const size_t row = (size_t{layer} * height + y) * width * texel_bytes;
            const uint8_t *a = mine + row;
            const uint8_t *b = theirs + row;
            for (uint32_t x = 0; x < width; ++x, a += texel_bytes, b += texel_bytes) {
                if (std::memcmp(a, b, texel_bytes) == 0) continue;
                uint32_t squared = 0;
                for (size_t c = 0; c < 3; ++c) {
                    const size_t at = c * channel_stride + channel_byte;
                    const auto diff = static_cast<uint32_t>(std::abs(int{a[at]} - int{b[at]}));
                    squared += diff * diff;
                    if (must_match[x]) {
                        d.largest = std::max(d.largest, diff);
                        d.channel_sum += diff;
                    }
                }
                d.squared_error += squared;
                if (must_match[x]) ++d.mismatches;
            }
        }
    }
    d.samples = d.pixels * 3;
    return d;
}

double psnr_db(double mse) {
    if (mse <= 0) return std::numeric_limits<double>::infinity();
    return 10 * std::log10(255.0 * 255.0 / mse);
}

double PeripheryScore::add(const FrameDifference &difference, bool late) {
    const double frame_db = psnr_db(difference.mse());
    std::lock_guard lock(mutex_);
    lowest_db_ = frames_ == 0 ? frame_db : std::min(lowest_db_, frame_db);
    ++frames_;
    if (late) ++late_;
    squared_error_ += difference.squared_error;
    samples_ += difference.samples;
    return frame_db;
}

PeripheryScore::Totals PeripheryScore::totals() const {
    std::lock_guard lock(mutex_);
    Totals t;
    t.frames = frames_;
    t.late = late_;
    t.psnr_db = psnr_db(samples_ ? squared_error_ / static_cast<double>(samples_) : 0);
    t.lowest_db = lowest_db_;
    return t;
}

} // namespace splitvk
