#include "frame_stats.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace atrium {

namespace {

double percentile(const std::vector<double> &sorted, double p) {
    const double rank = p * double(sorted.size() - 1);
    const size_t lo = size_t(std::floor(rank));
    const size_t hi = std::min(lo + 1, sorted.size() - 1);
    return sorted[lo] + (sorted[hi] - sorted[lo]) * (rank - double(lo));
}

} // namespace

FrameTimes summarize(std::vector<double> frame_ms) {
    FrameTimes t;
    t.frames = frame_ms.size();
    if (frame_ms.empty()) return t;
    std::sort(frame_ms.begin(), frame_ms.end());
    t.median_ms = percentile(frame_ms, 0.5);
    t.iqr_ms = percentile(frame_ms, 0.75) - percentile(frame_ms, 0.25);
    return t;
}

std::string format_frame_times(const FrameTimes &t) {
    char line[128];
    std::snprintf(line, sizeof(line), "frame-time: median %.2f ms, IQR %.2f ms, %zu frames", t.median_ms,
                  t.iqr_ms, t.frames);
    return line;
}

std::string with_thousands(size_t n) {
    std::string digits = std::to_string(n), out;
    for (size_t i = 0; i < digits.size(); ++i) {
        if (i > 0 && (digits.size() - i) % 3 == 0) out += ',';
        out += digits[i];
    }
    return out;
}

} // namespace atrium
