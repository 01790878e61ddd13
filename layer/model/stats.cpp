#include "model/stats.h"

#include "log.h"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>

#include <fcntl.h>
#include <unistd.h>

namespace splitvk {

namespace {

// The value at quantile q of sorted data, interpolating between neighbours.
double quantile(const std::vector<double> &sorted, double q) {
    if (sorted.empty()) return 0;
    const double position = q * static_cast<double>(sorted.size() - 1);
    const auto below = static_cast<size_t>(position);
    const size_t above = std::min(below + 1, sorted.size() - 1);
    const double fraction = position - static_cast<double>(below);
    return sorted[below] + (sorted[above] - sorted[below]) * fraction;
}

} // namespace

const char *FrameStats::csv_header() {
    return "frame,frame_ms,periphery_ms,tile_wait_ms,exposed_wait_ms,network_ms,decode_ms,merge_ms,"
           "merge_gpu_ms,tile_bytes,raw_bytes,agent_draw_ms,agent_readback_ms,agent_encode_ms,"
           "present_call_ms,late,xr_frame,xr_view,fovea_x,fovea_y,fovea_w,fovea_h,present_to_composite_ms,"
           "periphery_decode_ms,periphery_bytes,periphery_psnr_db,frame_latency_ms,agent";
}

FrameStats::FrameStats(const std::string &path) {
    if (path.empty()) return;
    fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd_ < 0) {
        SPLITVK_WARN("SPLITVK_STATS: cannot write %s (%s); no per-frame statistics", path.c_str(),
                     std::strerror(errno));
        return;
    }
    append(std::string(csv_header()) + "\n");
}

FrameStats::~FrameStats() {
    if (fd_ >= 0) ::close(fd_);
}

bool FrameStats::append(const std::string &text) {
    size_t done = 0;
    while (done < text.size()) {
        const ssize_t n = ::write(fd_, text.data() + done, text.size() - done);
        if (n > 0) {
            done += static_cast<size_t>(n);
        } else if (n < 0 && errno != EINTR) {
            SPLITVK_WARN("SPLITVK_STATS: writing failed (%s); no more per-frame statistics",
                         std::strerror(errno));
            ::close(fd_);
            fd_ = -1;
            return false;
        }
    }
    return true;
}

void FrameStats::record(const FrameRecord &r) {
    std::lock_guard lock(mutex_);
    const auto now = std::chrono::steady_clock::now();
    if (frames_ == 0) first_ = now;
    last_ = now;
    ++frames_;
    if (r.late) ++late_;
    if (r.passed_through) ++passed_through_;
    tile_bytes_ += r.tile_bytes + r.periphery_bytes;
    if (r.frame_ms > 0) frame_ms_.push_back(r.frame_ms);
    if (r.xr_frame >= 0) ++eye_images_;
    if (r.xr_frame >= 0 && r.xr_frame != last_xr_frame_) {
        if (xr_frames_ > 0)
            xr_frame_ms_.push_back(std::chrono::duration<double, std::milli>(now - xr_frame_start_).count());
        ++xr_frames_;
        last_xr_frame_ = r.xr_frame;
        xr_frame_start_ = now;
    }
    if (fd_ < 0) return;
    // "inf" for equal images, which strtod and Python's float() read back.
    char psnr[32] = "";
    if (r.periphery_psnr_db) std::snprintf(psnr, sizeof(psnr), "%.3f", *r.periphery_psnr_db);
    char latency[32] = "";
    if (r.frame_latency_ms) std::snprintf(latency, sizeof(latency), "%.3f", *r.frame_latency_ms);
    char row[1024];
    const int length = std::snprintf(
        row, sizeof(row),
        "%llu,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,%llu,%llu,%.3f,%.3f,%.3f,%.3f,%d,%lld,%d,%d,%d,%u,%u,%."
        "3f,%.3f,%llu,%s,%s,%s\n",
        static_cast<unsigned long long>(r.frame), r.frame_ms, r.periphery_ms, r.tile_wait_ms,
        r.exposed_wait_ms, r.network_ms, r.decode_ms, r.merge_ms, r.merge_gpu_ms,
        static_cast<unsigned long long>(r.tile_bytes), static_cast<unsigned long long>(r.raw_bytes),
        r.agent_draw_ms, r.agent_readback_ms, r.agent_encode_ms, r.present_call_ms, r.late ? 1 : 0,
        static_cast<long long>(r.xr_frame), r.xr_view, r.fovea.offset.x, r.fovea.offset.y,
        r.fovea.extent.width, r.fovea.extent.height, r.present_to_composite_ms, r.periphery_decode_ms,
        static_cast<unsigned long long>(r.periphery_bytes), psnr, latency, r.agent.c_str());
    if (length > 0 && static_cast<size_t>(length) < sizeof(row))
        append(std::string(row, static_cast<size_t>(length)));
}

void AcquireTimes::acquired(uint64_t swapchain, uint32_t image, Clock::time_point at) {
    std::lock_guard lock(mutex_);
    acquired_[{swapchain, image}] = at;
}

std::optional<AcquireTimes::Clock::time_point> AcquireTimes::take(uint64_t swapchain, uint32_t image) {
    std::lock_guard lock(mutex_);
    const auto it = acquired_.find({swapchain, image});
    if (it == acquired_.end()) return std::nullopt;
    const Clock::time_point at = it->second;
    acquired_.erase(it);
    return at;
}

void AcquireTimes::forget(uint64_t swapchain) {
    std::lock_guard lock(mutex_);
    std::erase_if(acquired_, [&](const auto &entry) { return entry.first.first == swapchain; });
}

size_t AcquireTimes::size() {
    std::lock_guard lock(mutex_);
    return acquired_.size();
}

std::optional<double> latency_ms(std::optional<std::chrono::steady_clock::time_point> start,
                                 std::chrono::steady_clock::time_point end) {
    if (!start) return std::nullopt;
    return std::chrono::duration<double, std::milli>(end - *start).count();
}

void FrameStats::set_client_renders_fovea(bool fovea) {
    std::lock_guard lock(mutex_);
    client_renders_fovea_ = fovea;
}

std::string FrameStats::summary() {
    std::lock_guard lock(mutex_);
    if (frames_ == 0) return {};
    const char *mode = client_renders_fovea_ ? "split (client renders fovea)" : "split";
    const double seconds = std::chrono::duration<double>(last_ - first_).count();
    const double mbits = seconds > 0 ? static_cast<double>(tile_bytes_) * 8 / seconds / 1e6 : 0;
    char line[256];
    if (xr_frames_ > 0) {
        // A release per eye image: the rows of one OpenXR frame are one frame to the viewer.
        auto sorted = xr_frame_ms_;
        std::sort(sorted.begin(), sorted.end());
        std::snprintf(line, sizeof(line),
                      "%s: %llu eye images in %llu OpenXR frames, OpenXR frame time median %.1f ms (IQR %.1f "
                      "ms), %.1f Mbit/s of tiles, %llu late",
                      mode, static_cast<unsigned long long>(eye_images_),
                      static_cast<unsigned long long>(xr_frames_), quantile(sorted, 0.5),
                      quantile(sorted, 0.75) - quantile(sorted, 0.25), mbits,
                      static_cast<unsigned long long>(late_));
        std::string summary = line;
        // A window the application presents beside its eyes (a mirror) is counted apart: its
        // presents are not eye images.
        if (frames_ > eye_images_)
            summary += ", and " + std::to_string(frames_ - eye_images_) + " window presents";
        return summary;
    }
    auto sorted = frame_ms_;
    std::sort(sorted.begin(), sorted.end());
    std::snprintf(line, sizeof(line),
                  "%s: %llu frames, frame time median %.1f ms (IQR %.1f ms), %.1f Mbit/s of tiles, %llu late",
                  mode, static_cast<unsigned long long>(frames_), quantile(sorted, 0.5),
                  quantile(sorted, 0.75) - quantile(sorted, 0.25), mbits,
                  static_cast<unsigned long long>(late_));
    std::string summary = line;
    if (passed_through_ > 0)
        summary += ", " + std::to_string(passed_through_) + " passed through (SPLITVK_SPLIT=auto)";
    return summary;
}

void FrameStats::hold_eye_row(const FrameRecord &record) {
    std::lock_guard lock(held_mutex_);
    held_eye_rows_.push_back(record);
}

std::vector<FrameRecord> FrameStats::take_eye_rows(uint64_t xr_frame) {
    std::lock_guard lock(held_mutex_);
    std::vector<FrameRecord> taken;
    std::erase_if(held_eye_rows_, [&](const FrameRecord &row) {
        if (static_cast<uint64_t>(row.xr_frame) > xr_frame) return false;
        taken.push_back(row);
        return true;
    });
    return taken;
}

} // namespace splitvk
