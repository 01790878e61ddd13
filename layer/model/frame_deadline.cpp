#include "model/frame_deadline.h"

#include <algorithm>

namespace splitvk::deadline {

using namespace std::chrono_literals;

Clock::time_point from_monotonic(const timespec &at, const timespec &monotonic_now, Clock::time_point now) {
    const auto ns = [](const timespec &t) {
        return std::chrono::seconds(t.tv_sec) + std::chrono::nanoseconds(t.tv_nsec);
    };
    return now + std::chrono::duration_cast<Clock::duration>(ns(at) - ns(monotonic_now));
}

Clock::duration submit_margin(Clock::duration period) {
    return std::max<Clock::duration>(2ms, period / 4);
}

Clock::duration tile_wait(const TileWaitInput &in) {
    if (in.first_split_frame) return std::max<Clock::duration>(in.tile_wait, kFirstSplitFrameWait);
    if (!in.display.time) return in.tile_wait;
    const Clock::duration left =
        *in.display.time - in.now - in.composite_cost - submit_margin(in.display.period);
    Clock::duration bound = in.tile_wait;
    if (in.display.period > Clock::duration::zero())
        bound = std::min(bound, in.display.first_release.value_or(in.now) + in.display.period - in.now);
    return std::max(Clock::duration::zero(), std::min(left, bound));
}

void CompositeCost::add(Clock::duration sample) {
    samples_[next_] = std::max(sample, Clock::duration::zero());
    next_ = (next_ + 1) % kSamples;
    count_ = std::min(count_ + 1, kSamples);
}

Clock::duration CompositeCost::estimate() const {
    return count_ == 0 ? Clock::duration::zero() : *std::max_element(samples_, samples_ + count_);
}

} // namespace splitvk::deadline
