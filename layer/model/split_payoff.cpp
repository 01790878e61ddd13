#include "model/split_payoff.h"

#include <algorithm>

namespace splitvk {
namespace {

double median(std::vector<double> values) {
    std::sort(values.begin(), values.end());
    const size_t n = values.size();
    return n % 2 ? values[n / 2] : (values[n / 2 - 1] + values[n / 2]) / 2;
}

size_t index(SplitPayoff::Mode mode) {
    return mode == SplitPayoff::Mode::Split ? 0 : 1;
}

SplitPayoff::Mode other(SplitPayoff::Mode mode) {
    return mode == SplitPayoff::Mode::Split ? SplitPayoff::Mode::PassThrough : SplitPayoff::Mode::Split;
}

} // namespace

void SplitPayoff::begin_stint(Mode mode, bool probe, uint32_t hold) {
    wanted_ = mode;
    probe_ = probe;
    hold_ = hold;
    presents_ = 0;
    window_.clear();
}

void SplitPayoff::settle(Mode mode) {
    settled_ = true;
    begin_stint(mode, false, 0);
    mode_ = mode;
}

bool SplitPayoff::clearly_decided() const {
    const std::optional<double> &other_ms = measured_[index(other(mode_))];
    if (!other_ms || *other_ms <= 0) return false;
    const double ms = median(window_);
    return ms > *other_ms * kClearly || ms * kClearly < *other_ms;
}

std::optional<SplitPayoff::Switch> SplitPayoff::observe(Mode mode, double frame_ms, bool steady) {
    if (settled_) return std::nullopt;
    // The switch asked for has not been followed yet; presents of the mode it left say nothing.
    if (mode != wanted_) return std::nullopt;
    if (mode != mode_) {
        mode_ = mode;
        presents_ = 0;
        window_.clear();
    }
    if (++presents_ <= kSkip + hold_ || frame_ms <= 0) return std::nullopt;
    if (!steady) {
        window_.clear();
        return std::nullopt;
    }
    window_.push_back(frame_ms);
    if (window_.size() < kWindow && !(probe_ && window_.size() >= kQuickWindow && clearly_decided()))
        return std::nullopt;
    measured_[index(mode)] = median(window_);
    window_.clear();

    const std::optional<double> &split_ms = measured_[index(Mode::Split)];
    const std::optional<double> &native_ms = measured_[index(Mode::PassThrough)];
    Switch decided;
    decided.split_ms = split_ms.value_or(0);
    decided.native_ms = native_ms.value_or(0);
    if (!measured_[index(other(mode))] || !probe_) {
        // Nothing to compare with yet, or a hold is over: measure the other mode.
        decided.to = other(mode);
        decided.probe = true;
        begin_stint(decided.to, true, 0);
        return decided;
    }
    const Mode faster = *split_ms < *native_ms * (1 - kMargin) ? Mode::Split : Mode::PassThrough;
    // A probe that won stays, and the other mode is probed again after the first hold; one that lost
    // goes back, and is probed again after twice the hold it had.
    next_hold_ = faster == mode ? kFirstHold : std::min(next_hold_ * 2, kLongestHold);
    decided.to = faster;
    begin_stint(faster, false, next_hold_);
    return decided;
}

} // namespace splitvk
