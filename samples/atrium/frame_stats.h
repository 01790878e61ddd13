// Frame-time summary printed on exit, and the numbers of the start line (scripts parse both).
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace atrium {

struct FrameTimes {
    double median_ms = 0.0;
    double iqr_ms = 0.0; // 75th minus 25th percentile
    size_t frames = 0;
};

// Percentiles interpolate linearly between the closest ranks.
FrameTimes summarize(std::vector<double> frame_ms);

// "frame-time: median 12.34 ms, IQR 1.23 ms, 300 frames"
std::string format_frame_times(const FrameTimes &t);

// 300424 -> "300,424"
std::string with_thousands(size_t n);

} // namespace atrium
