#pragma once

// Per-frame statistics of a split device (SPLITVK_STATS=path.csv): one CSV row per present, and
// a one-line summary at vkDestroyDevice. Times are milliseconds; the agent's stages come with
// its tiles (protocol::AgentTimings). Each row is formatted whole and handed to the kernel with one
// write(2) by the presenting thread, so an application killed at any point (SIGTERM, SIGKILL)
// leaves the header and whole rows only; a write into the page cache does not wait for the disk.

#include <vulkan/vulkan.h>

#include <chrono>
#include <cstdint>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace splitvk {

struct FrameRecord {
    uint64_t frame = 0;
    double frame_ms = 0;     // this present to the previous one (0 for the first)
    double periphery_ms = 0; // GPU time of the latest completed split pass (gpu_timing.h)
    double tile_wait_ms = 0; // the present waited for this frame's tiles
    // The part of tile_wait_ms after the GPU had finished everything submitted before this present
    // (Compositor::take_waits): the client was done with its frame and only waited for tiles.
    double exposed_wait_ms = 0;
    double network_ms = 0;   // FramePresent sent to Tiles received, less the agent's own time
    double decode_ms = 0;    // the slowest eye
    double merge_ms = 0;     // upload and composite, as recorded and submitted on this thread
    double merge_gpu_ms = 0; // GPU time of the latest completed composite (gpu_timing.h)
    uint64_t tile_bytes = 0; // Tiles payload received (the foveae's; the periphery's: periphery_bytes)
    uint64_t raw_bytes = 0;  // the same tiles uncompressed (at their texel size)
    double agent_draw_ms = 0;
    double agent_readback_ms = 0;
    double agent_encode_ms = 0;
    // How long the application's vkQueuePresentKHR of this frame took: with the present thread
    // (SPLITVK_PRESENT_DEPTH > 0) only the wait for room in it, not this frame's tiles.
    double present_call_ms = 0;
    bool late = false; // composited from the periphery alone
    // An OpenXR eye image (one row per xrReleaseSwapchainImage, so a swapchain per eye gives two
    // rows per frame): the OpenXR frame it belongs to, counted by xrEndFrame from 0, and the index
    // of the first projection view the image holds (0 the left eye, as applications order them).
    // -1 for a window's present, and xr_view -1 too before an xrEndFrame named the image's swapchain.
    int64_t xr_frame = -1;
    int32_t xr_view = -1;
    // The first fovea the frame asked for (the left eye's of a stereo frame; the first layer's of a
    // layered OpenXR eye image), which follows SPLITVK_GAZE; width 0 when the frame had none.
    VkRect2D fovea{};
    // The application's present (where this frame's gaze was read) to its composite submitted: the
    // layer's part of the latency from a gaze point to the screen, on the present thread too.
    double present_to_composite_ms = 0;
    // The swapped split (SPLITVK_CLIENT_RENDERS=fovea): decoding the agent's periphery (its slowest
    // part), and its Tiles payload as received; 0 in a frame without one.
    double periphery_decode_ms = 0;
    uint64_t periphery_bytes = 0;
    // The swapped split under SPLITVK_VERIFY=full: the presented frame (the client's foveae over
    // the agent's periphery, upsampled) against the agent's native frame, PSNR over the whole image;
    // infinite for equal images. Unset (an empty field) in every other frame.
    std::optional<double> periphery_psnr_db;
    // SPLITVK_SPLIT=auto passed the frame through (Session::passing_through()): shown as drawn, no
    // fovea (width 0), no tiles.
    bool passed_through = false;
    // When the frame reached the screen, measured alike for frames split, passed through or unsplit
    // (a session without an agent: native through the same layer): on a window, the application's
    // acquire of the presented image returning to the real vkQueuePresentKHR returning (on the
    // present thread with SPLITVK_PRESENT_DEPTH > 0); under OpenXR, xrWaitFrame returning to the
    // runtime's xrEndFrame of that frame returning, the same value in each eye image's row. Unset
    // (an empty field) when the start was not seen: an image presented without an acquire the layer
    // saw, or an OpenXR frame that was never ended.
    std::optional<double> frame_latency_ms;
    // The agent whose tiles the frame shows ("host:port", as SPLITVK_SERVER names it); empty when
    // none does: unsplit, passed through, late, or no agent there.
    std::string agent;
};

// When the application's acquires of swapchain images returned, until the present of each image
// (frame_latency_ms). Keyed by swapchain and image index: several images may be in flight, and an
// image is presented in any order after its acquire. An entry without a present (the application
// acquired and never presented, or its swapchain went out of date) is replaced by that image's
// next acquire or dropped with its swapchain.
class AcquireTimes {
public:
    using Clock = std::chrono::steady_clock;

    void acquired(uint64_t swapchain, uint32_t image, Clock::time_point at);
    // The acquire of this image that its present ends, taken out; std::nullopt when none was seen.
    std::optional<Clock::time_point> take(uint64_t swapchain, uint32_t image);
    void forget(uint64_t swapchain);
    size_t size();

private:
    std::mutex mutex_;
    std::map<std::pair<uint64_t, uint32_t>, Clock::time_point> acquired_;
};

// Milliseconds from a frame's start to `end`; unset without a start.
std::optional<double> latency_ms(std::optional<std::chrono::steady_clock::time_point> start,
                                 std::chrono::steady_clock::time_point end);

class FrameStats {
public:
    // `path` empty: only the summary is kept.
    explicit FrameStats(const std::string &path);
    ~FrameStats();
    FrameStats(const FrameStats &) = delete;
    FrameStats &operator=(const FrameStats &) = delete;

    void record(const FrameRecord &record);

    // The summary's mode: "split" (the client renders the periphery), or with `client_renders_fovea`
    // "split (client renders fovea)" (the swapped split).
    void set_client_renders_fovea(bool fovea);

    // "split: 300 frames, frame time median 41.2 ms (IQR 3.1 ms), 87.5 Mbit/s of tiles, 0 late";
    // empty when no frame was recorded. With OpenXR eye images, the frames are counted as OpenXR
    // frames and the frame time is theirs: "split: 16 eye images in 8 OpenXR frames, OpenXR frame
    // time median ...".
    std::string summary();

    // OpenXR: an eye image's row, held from its release until its frame's xrEndFrame, whose return
    // ends the frame's latency; take_eye_rows() hands back those of frames up to `xr_frame`
    // (every one for UINT64_MAX), in release order.
    void hold_eye_row(const FrameRecord &record);
    std::vector<FrameRecord> take_eye_rows(uint64_t xr_frame);

    // The CSV header: column names with their units.
    static const char *csv_header();

private:
    std::mutex mutex_;
    // held_eye_rows_, apart from mutex_: rows taken out are then record()ed.
    std::mutex held_mutex_;
    std::vector<FrameRecord> held_eye_rows_;
    // Appends `text` with one write (a regular file takes it whole); false after an error.
    bool append(const std::string &text);

    int fd_ = -1;
    std::vector<double> frame_ms_;
    // OpenXR: frames seen (a new xr_frame), and the time from one's first row to the next one's.
    uint64_t xr_frames_ = 0;
    int64_t last_xr_frame_ = -1;
    std::chrono::steady_clock::time_point xr_frame_start_{};
    std::vector<double> xr_frame_ms_;
    bool client_renders_fovea_ = false;
    uint64_t frames_ = 0;
    uint64_t eye_images_ = 0; // of frames_, the OpenXR eye images (rows with an xr_frame)
    uint64_t late_ = 0;
    uint64_t passed_through_ = 0;
    uint64_t tile_bytes_ = 0;
    std::chrono::steady_clock::time_point first_{};
    std::chrono::steady_clock::time_point last_{};
};

} // namespace splitvk
