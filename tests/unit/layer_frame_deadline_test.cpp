// The OpenXR deadline of a frame's tile wait (layer/model/frame_deadline.h): what it allows for given
// display times, composite costs and clocks.
#include "model/frame_deadline.h"

#include <gtest/gtest.h>

namespace splitvk::deadline {
namespace {

using namespace std::chrono_literals;

// A 60 Hz frame released at `now`, its display time `ahead` later, SPLITVK_TILE_WAIT at its default.
TileWaitInput frame(Clock::duration ahead, Clock::duration cost = 1ms) {
    TileWaitInput in;
    in.now = Clock::time_point{} + 100s;
    in.display.time = in.now + ahead;
    in.display.period = 16666667ns;
    in.composite_cost = cost;
    in.tile_wait = 250ms;
    return in;
}

TEST(FrameDeadline, MarginIsAQuarterPeriodAndAtLeastTwoMilliseconds) {
    EXPECT_EQ(submit_margin(16ms), 4ms);
    EXPECT_EQ(submit_margin(11ms), 2750us);
    EXPECT_EQ(submit_margin(4ms), 2ms);
    EXPECT_EQ(submit_margin(0ms), 2ms);
}

TEST(FrameDeadline, BetweenWaitsForTheDisplayTimeLessCompositeAndMargin) {
    // 12 ms ahead, 1 ms composite, 16.67 / 4 ms margin: 12 - 1 - 4.17 ms.
    const TileWaitInput in = frame(12ms);
    EXPECT_EQ(tile_wait(in), 12ms - 1ms - 16666667ns / 4);
    // A dearer composite leaves less of it.
    EXPECT_EQ(tile_wait(frame(12ms, 5ms)), 12ms - 5ms - 16666667ns / 4);
}

TEST(FrameDeadline, PassedOrUnreachableDisplayTimeWaitsNothing) {
    EXPECT_EQ(tile_wait(frame(-3ms)), 0ms);
    EXPECT_EQ(tile_wait(frame(0ms)), 0ms);
    // Ahead, but not by its composite and the runtime's margin.
    EXPECT_EQ(tile_wait(frame(4ms, 1ms)), 0ms);
    EXPECT_EQ(tile_wait(frame(10ms, 9ms)), 0ms);
}

TEST(FrameDeadline, FarDisplayTimeIsCappedAtAPeriodAndTileWait) {
    // A second ahead: one period at most, so that the runtime's pacing does not learn the wait.
    EXPECT_EQ(tile_wait(frame(1s)), 16666667ns);
    // A SPLITVK_TILE_WAIT shorter than the period bounds it.
    TileWaitInput in = frame(1s);
    in.tile_wait = 5ms;
    EXPECT_EQ(tile_wait(in), 5ms);
    // The frame's eye images share the period from its first release: 10 ms after it, 6.67 ms are left.
    in = frame(1s);
    in.display.first_release = in.now - 10ms;
    EXPECT_EQ(tile_wait(in), 6666667ns);
    in.display.first_release = in.now - 20ms;
    EXPECT_EQ(tile_wait(in), 0ms);
    // Without a period from the runtime, only SPLITVK_TILE_WAIT does.
    in = frame(1s);
    in.display.period = 0ns;
    EXPECT_EQ(tile_wait(in), 250ms);
}

TEST(FrameDeadline, UnknownDisplayTimeWaitsTileWait) {
    TileWaitInput in = frame(1ms);
    in.display.time.reset();
    EXPECT_EQ(tile_wait(in), 250ms);
    in.tile_wait = 60s;
    EXPECT_EQ(tile_wait(in), 60s);
}

TEST(FrameDeadline, FirstSplitFrameWaitsLongWhateverItsDisplayTime) {
    TileWaitInput in = frame(-5ms);
    in.first_split_frame = true;
    EXPECT_EQ(tile_wait(in), kFirstSplitFrameWait);
    in.display.time.reset();
    EXPECT_EQ(tile_wait(in), kFirstSplitFrameWait);
    // A longer SPLITVK_TILE_WAIT is longer still.
    in.tile_wait = 20s;
    EXPECT_EQ(tile_wait(in), 20s);
}

TEST(FrameDeadline, MonotonicInstantsMapOntoTheLayersClock) {
    const Clock::time_point now = Clock::time_point{} + 42s;
    const timespec monotonic_now{1000, 900'000'000};
    EXPECT_EQ(from_monotonic({1001, 100'000'000}, monotonic_now, now), now + 200ms);
    EXPECT_EQ(from_monotonic({1000, 400'000'000}, monotonic_now, now), now - 500ms);
    EXPECT_EQ(from_monotonic(monotonic_now, monotonic_now, now), now);
}

TEST(FrameDeadline, CompositeCostIsTheLargestOfTheRecentSamples) {
    CompositeCost cost;
    EXPECT_EQ(cost.estimate(), 0ms);
    cost.add(2ms);
    cost.add(7ms);
    cost.add(3ms);
    EXPECT_EQ(cost.estimate(), 7ms);
    // The spike ages out after kSamples more frames.
    for (size_t i = 0; i < CompositeCost::kSamples - 1; ++i)
        cost.add(1ms);
    EXPECT_EQ(cost.estimate(), 3ms);
    cost.add(1ms);
    EXPECT_EQ(cost.estimate(), 1ms);
    cost.add(-4ms);
    EXPECT_EQ(cost.estimate(), 1ms);
}

} // namespace
} // namespace splitvk::deadline
