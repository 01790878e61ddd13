#pragma once

// SPLITVK_FOVEA=auto: the fovea sized per frame from measured times.
//
// A larger fovea is a sharper picture, and costs the agent's size-dependent path: the read-back, the
// encode, the link and the client's decode all grow with its pixels, while the agent's draw does not
// (under auto it shades the largest size, the whole eye or auto:WxH, in every frame, since its
// scissors are recorded before any frame's size is known). The fovea may grow while that path keeps up with
// the client's own frame: while the part of each frame's wait for tiles that the fovea caused stays a small
// share of the frame. That part is the wait the client saw with its own work done
// (FrameRecord::exposed_wait_ms; all of the wait for an OpenXR runtime's image, which has no semaphores to
// tell), but no more than the size-dependent path took: a wait that the agent's draw alone makes longer than
// the client's frame is no reason to shrink the fovea, which cannot shorten it.
//
// The size moves along a ladder of sizes of the default's shape (kStep apart in each dimension, from
// kMinLevel below the default up to the largest, SPLITVK_FOVEA=auto:WxH or the whole eye, each
// dimension clamped to it), one level per decision. A decision needs a
// window of kWindow frames at the current size, after the kSettle frames that follow a change (they
// carry the new size's keyframes). It shrinks a level when the fovea's share of the window's median
// frame is above kShrinkShare, when the window's tile traffic is above SPLITVK_MAX_MBPS, or at once on
// a late frame (but not again for the late frames of the same stall, which come while the size it
// shrank to still settles); it grows a level when the share is at most kGrowShare and the traffic the next
// level would carry (its pixels' worth more) stays within SPLITVK_MAX_MBPS. Hysteresis: the level that failed
// is a ceiling the fovea does not grow back to until it has held below it for a while (the hold), and a
// ceiling that fails again doubles the hold. So the size settles within (kSettle + kWindow) frames per level
// it moves, and probes upward ever more rarely while the times hold.
//
// Thread-safe: the application's present reads the size of the frame it sends, and the present
// thread reports the frames it composites.

#include "split_geometry.h"

#include <cstdint>
#include <mutex>
#include <vector>

namespace splitvk {

// What one composited frame measured (from its FrameRecord).
struct FoveaFrameCost {
    split::FrameFoveaSize size; // the size the frame asked for
    bool late = false;          // composited without its tiles
    double frame_ms = 0;        // its present to the previous one
    double exposed_wait_ms = 0; // its wait for tiles with the client's own work done
    // The size-dependent part of the agent's path: read-back, encode, link and decode.
    double fovea_path_ms = 0;
    uint64_t tile_bytes = 0;
};

class AutoFovea {
public:
    // Starts at SPLITVK_FOVEA's default size, grows to at most `largest` (fractions of the eye) and
    // to at most `max_mbps` of tiles (0: no bound).
    AutoFovea(const FoveaSize &largest, double max_mbps);

    // The size the next frame asks for.
    split::FrameFoveaSize size() const;
    int level() const;
    // A composited frame's times. Frames of another size than the current one (still in flight
    // when it changed) are not counted.
    void observe(const FoveaFrameCost &cost);

    static constexpr double kStep = 1.189207115002721; // 2^(1/4): the area changes by sqrt(2)
    static constexpr int kMinLevel = -8;               // a quarter of the default's width and height
    static constexpr uint32_t kSettle = 2;
    static constexpr uint32_t kWindow = 8;
    static constexpr double kGrowShare = 0.05;
    static constexpr double kShrinkShare = 0.10;
    static constexpr uint32_t kFirstHoldWindows = 4;
    static constexpr uint32_t kLongestHoldWindows = 64;

private:
    split::FrameFoveaSize size_at(int level) const;
    void move_to(int level);
    void shrink();

    mutable std::mutex mutex_;
    FoveaSize largest_;
    split::FrameFoveaSize largest_units_; // largest_, rounded down to what the agent accepts
    double max_mbps_ = 0;
    int max_level_ = 0; // the first level that is the largest size
    int level_ = 0;
    split::FrameFoveaSize size_;
    uint32_t settling_ = kSettle; // frames still to skip at this size
    std::vector<FoveaFrameCost> window_;
    int ceiling_; // the lowest level that failed, not to grow to until the hold is over
    uint32_t hold_windows_ = kFirstHoldWindows;
    uint32_t held_windows_ = 0; // decided windows spent just below the ceiling
    bool probing_ = false;      // at the ceiling's level again, after a hold
    bool shrinking_ = false;    // this size was entered by shrinking
};

} // namespace splitvk
