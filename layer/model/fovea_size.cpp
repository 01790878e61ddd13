#include "model/fovea_size.h"

#include <algorithm>
#include <cmath>

namespace splitvk {

namespace {

double median(std::vector<double> values) {
    if (values.empty()) return 0;
    const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
    std::nth_element(values.begin(), middle, values.end());
    return *middle;
}

// A fraction of the eye in split::kGazeOne units, at least one. `down`: rounded down, for the
// largest size, since the agent refuses a size above it by any amount (0.6 is 39321.6 units).
uint32_t to_gaze_units(double fraction, bool down = false) {
    const double units = std::min(fraction, 1.0) * split::kGazeOne;
    const auto rounded = static_cast<long>(down ? std::floor(units) : std::round(units));
    return static_cast<uint32_t>(std::clamp<long>(rounded, 1, split::kGazeOne));
}

} // namespace

AutoFovea::AutoFovea(const FoveaSize &largest, double max_mbps) : largest_(largest), max_mbps_(max_mbps) {
    largest_units_ = {to_gaze_units(largest_.width, true), to_gaze_units(largest_.height, true)};
    while (max_level_ < 64 && !(size_at(max_level_) == largest_units_))
        ++max_level_;
    ceiling_ = max_level_ + 1;
    size_ = size_at(level_);
}

split::FrameFoveaSize AutoFovea::size_at(int level) const {
    const FoveaSize start;
    const double factor = std::pow(kStep, level);
    return {std::min(to_gaze_units(start.width * factor), largest_units_.width),
            std::min(to_gaze_units(start.height * factor), largest_units_.height)};
}

split::FrameFoveaSize AutoFovea::size() const {
    std::lock_guard lock(mutex_);
    return size_;
}

int AutoFovea::level() const {
    std::lock_guard lock(mutex_);
    return level_;
}

void AutoFovea::move_to(int level) {
    level_ = std::clamp(level, kMinLevel, max_level_);
    size_ = size_at(level_);
    settling_ = kSettle;
    window_.clear();
    shrinking_ = false;
}

void AutoFovea::shrink() {
    // A probe that failed makes the next one wait twice as long; the hold is what keeps a size
    // that is just too large from being tried every few windows.
    if (probing_) hold_windows_ = std::min(hold_windows_ * 2, kLongestHoldWindows);
    probing_ = false;
    held_windows_ = 0;
    ceiling_ = level_;
    move_to(level_ - 1);
    shrinking_ = true;
}

void AutoFovea::observe(const FoveaFrameCost &cost) {
    std::lock_guard lock(mutex_);
    if (!(cost.size == size_)) return;
    // A late frame shrinks the fovea at once, but one stall makes several frames late in a row:
    // those that come while a size entered by shrinking still settles are the same stall.
    if (cost.late) {
        if (!(shrinking_ && settling_ > 0)) shrink();
        return;
    }
    if (cost.frame_ms <= 0) return; // the first frame, with no interval to weigh it against
    if (settling_ > 0) {
        --settling_;
        return;
    }
    window_.push_back(cost);
    if (window_.size() < kWindow) return;

    std::vector<double> frame_ms, fovea_ms;
    double seconds = 0, bits = 0;
    for (const FoveaFrameCost &c : window_) {
        frame_ms.push_back(c.frame_ms);
        fovea_ms.push_back(std::min(c.exposed_wait_ms, c.fovea_path_ms));
        seconds += c.frame_ms / 1000;
        bits += 8.0 * static_cast<double>(c.tile_bytes);
    }
    window_.clear();
    const double frame = median(frame_ms), exposed = median(fovea_ms);
    const double mbps = seconds > 0 ? bits / 1e6 / seconds : 0;
    if (exposed > kShrinkShare * frame || (max_mbps_ > 0 && mbps > max_mbps_)) return shrink();

    // This size held a whole window: a probe that got here succeeded, and the sizes above it are
    // worth trying again.
    if (probing_) {
        probing_ = false;
        hold_windows_ = kFirstHoldWindows;
        ceiling_ = max_level_ + 1;
    }
    const int next = level_ + 1;
    if (next > max_level_ || exposed > kGrowShare * frame) return;
    const split::FrameFoveaSize now = size_at(level_), then = size_at(next);
    const double growth =
        (static_cast<double>(then.width) * then.height) / (static_cast<double>(now.width) * now.height);
    if (max_mbps_ > 0 && mbps * growth > max_mbps_) return;
    if (next < ceiling_) return move_to(next);
    // Just below the level that failed: try it again once the hold is over.
    if (++held_windows_ < hold_windows_) return;
    held_windows_ = 0;
    probing_ = true;
    ceiling_ = next + 1;
    move_to(next);
}

} // namespace splitvk
