#pragma once

// How long a frame may wait for the agent's tiles before it is composited without them.
//
// A window's present has no deadline the layer knows: it waits up to SPLITVK_TILE_WAIT. An OpenXR
// frame has one: xrWaitFrame gave it a predicted display time, and the runtime's compositor takes
// the eye images some time before that. A fovea that comes after the image was handed back is of no
// use, and waiting for it makes the whole frame miss its display, which a VR user sees as judder;
// the frame shows the upsampled periphery in its centre instead.
//
// Pure: the caller measures the clock and the composite and passes them in.

#include <chrono>
#include <cstddef>
#include <optional>

#include <time.h>

namespace splitvk::deadline {

using Clock = std::chrono::steady_clock;

// The first split frame an agent replays after it (re)joined costs it many times a later one, and
// nothing can be done about that ahead of the frame: lavapipe compiles its shader variants at the
// first draw that uses them (the agent's pipelines are created when the application creates them,
// long before), and the tile encoder starts with a keyframe. Measured on lavapipe, 2 busy cores:
// the agent's draw 8-63 ms for vkcube's first frame against 0.8 ms after, 0.8-1.5 s for atrium's
// at 2400x1080 against 0.25 s; x264 12-71 ms against 0.5 ms. That frame waits this long, once, even
// past an OpenXR display time: had the client gone on, every frame it submitted meanwhile would queue
// behind that one at the agent and come late too, until the agent caught up. One missed display
// (the runtime shows its previous frame again) costs less than a second of late foveae.
constexpr std::chrono::milliseconds kFirstSplitFrameWait{5000};

// When a frame is to be displayed, on the layer's clock, and the display's refresh period; `time`
// unset where no display time is known (a window, or a runtime whose time the layer cannot
// convert). `first_release`: when the frame's first eye image was handed back, from which all of
// the frame's eye images together wait one period at most (unset: from each wait's start).
struct FrameDisplay {
    std::optional<Clock::time_point> time;
    Clock::duration period{};
    std::optional<Clock::time_point> first_release;
};

// An instant of CLOCK_MONOTONIC (what XR_KHR_convert_timespec_time converts an XrTime to) on the
// layer's clock, from readings of both clocks taken together: exact whichever clock steady_clock
// reads, with only the gap between the two readings as error.
Clock::time_point from_monotonic(const timespec &at, const timespec &monotonic_now, Clock::time_point now);

// What the runtime needs between the layer's return from xrReleaseSwapchainImage and the display
// time: its own release submit, the application's xrEndFrame, and its compositor's pass over the
// layers. Monado's pacing reserves 2 ms for its compositor beyond its measured work
// (U_PACING_APP_MIN_MARGIN_MS) and its compositor renders a frame in a couple more; other
// compositors work to a fraction of a period before vsync too. A quarter of the period: 4.2 ms at
// 60 Hz, 2.8 ms at 90 Hz; never under 2 ms, the runtime's own minimum.
Clock::duration submit_margin(Clock::duration period);

struct TileWaitInput {
    FrameDisplay display;
    Clock::time_point now;
    // The composite the frame still needs after its tiles came (CompositeCost::estimate()).
    Clock::duration composite_cost{};
    // SPLITVK_TILE_WAIT: the longest any frame waits, with a display time or not.
    Clock::duration tile_wait{};
    // The first split frame after the agent joined (kFirstSplitFrameWait).
    bool first_split_frame = false;
};

// How long the frame may still wait for its tiles from `now`: 0 once the display time can no longer
// be met with the composite and the runtime's margin; the time left to it, but never past one
// display period from the frame's first release (its eye images share it) nor SPLITVK_TILE_WAIT;
// SPLITVK_TILE_WAIT without a display time. A period at most, since runtimes pace adaptively: Monado
// predicts the next display time after the application's measured xrBeginFrame-to-xrEndFrame time,
// which includes these waits, so a frame that waited longer than a period would push its
// successors' display times out and the application's frame rate would follow the agent's link
// instead of the display.
Clock::duration tile_wait(const TileWaitInput &input);

// The composite's cost as measured on recent frames: the largest of the last kSamples, so that one
// slower composite does not make the next frame late, and a spike ages out within a few frames.
class CompositeCost {
public:
    static constexpr size_t kSamples = 8;

    void add(Clock::duration sample);
    // Zero before any sample: the first split frame, whose wait does not depend on it.
    Clock::duration estimate() const;

private:
    Clock::duration samples_[kSamples]{};
    size_t count_ = 0;
    size_t next_ = 0;
};

} // namespace splitvk::deadline
