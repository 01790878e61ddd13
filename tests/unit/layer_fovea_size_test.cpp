// SPLITVK_FOVEA=auto (layer/model/fovea_size.h) against a modelled agent: how the sizing moves, where it
// settles and how fast.

#include "model/fovea_size.h"

#include <algorithm>
#include <cmath>
#include <map>

#include <gtest/gtest.h>

namespace splitvk {
namespace {

// A split pair in lockstep: the client's own frame takes `client_ms`; the agent's path is its draw
// (independent of the fovea: under auto it shades whole eyes) and then a size-dependent part, per
// eye-sized fovea `path_ms_per_eye` and `bytes_per_eye`, scaled by the fovea's share of the eye.
struct ModelledPair {
    double client_ms = 20;
    double agent_draw_ms = 5;
    double path_ms_per_eye = 4;
    double bytes_per_eye = 0;

    FoveaFrameCost frame(const split::FrameFoveaSize &size) const {
        const double share = (double(size.width) / split::kGazeOne) * (double(size.height) / split::kGazeOne);
        FoveaFrameCost cost;
        cost.size = size;
        cost.fovea_path_ms = path_ms_per_eye * share;
        cost.exposed_wait_ms = std::max(0.0, agent_draw_ms + cost.fovea_path_ms - client_ms);
        cost.frame_ms = client_ms + cost.exposed_wait_ms;
        cost.tile_bytes = static_cast<uint64_t>(bytes_per_eye * share);
        return cost;
    }
};

// Runs `frames` frames, the size of each reported one frame later, as the present thread reports
// them; returns the level of every frame.
std::vector<int> run(AutoFovea &sizing, const ModelledPair &pair, int frames) {
    std::vector<int> levels;
    FoveaFrameCost in_flight;
    bool pending = false;
    for (int i = 0; i < frames; ++i) {
        levels.push_back(sizing.level());
        const FoveaFrameCost now = pair.frame(sizing.size());
        if (pending) sizing.observe(in_flight);
        in_flight = now;
        pending = true;
    }
    return levels;
}

// The first frame from which the level never changes again within `levels`, other than to probe one
// level up and come back.
size_t settled_from(const std::vector<int> &levels) {
    const int settled = levels.back();
    size_t from = levels.size();
    while (from > 0 && (levels[from - 1] == settled || levels[from - 1] == settled + 1))
        --from;
    return from;
}

const FoveaSize kWholeEye{true, 1.0, 1.0, true}; // SPLITVK_FOVEA=auto

// Each level moved costs a settle and a window; the bound the docs state.
constexpr int kFramesPerLevel = AutoFovea::kSettle + AutoFovea::kWindow + 1;

TEST(AutoFovea, StartsAtTheDefaultSize) {
    AutoFovea sizing(kWholeEye, 0);
    EXPECT_EQ(sizing.level(), 0);
    EXPECT_EQ(sizing.size().width, static_cast<uint32_t>(std::lround(512.0 / 1200.0 * split::kGazeOne)));
    EXPECT_EQ(sizing.size().height, static_cast<uint32_t>(std::lround(360.0 / 1080.0 * split::kGazeOne)));
}

TEST(AutoFovea, AFastAgentGrowsItToTheWholeEye) {
    AutoFovea sizing(kWholeEye, 0);
    ModelledPair fast; // the whole path within the client's frame at any size
    const auto levels = run(sizing, fast, 400);
    EXPECT_EQ(sizing.size().width, split::kGazeOne);
    EXPECT_EQ(sizing.size().height, split::kGazeOne);
    EXPECT_LE(settled_from(levels), static_cast<size_t>(levels.back() * kFramesPerLevel));
}

TEST(AutoFovea, ASlowLinkSettlesOnASmallerFovea) {
    AutoFovea fast_sizing(kWholeEye, 0), slow_sizing(kWholeEye, 0);
    ModelledPair fast;
    ModelledPair slow;
    slow.path_ms_per_eye = 200; // a lossless eye takes 200 ms over the link
    const auto fast_levels = run(fast_sizing, fast, 600);
    const auto slow_levels = run(slow_sizing, slow, 600);
    EXPECT_LT(slow_levels.back(), 0) << "smaller than the default";
    EXPECT_LT(slow_levels.back(), fast_levels.back());
    // Where it settles, the fovea costs the frame at most kShrinkShare of it.
    const FoveaFrameCost settled = slow.frame(slow_sizing.size());
    EXPECT_LE(std::min(settled.exposed_wait_ms, settled.fovea_path_ms),
              AutoFovea::kShrinkShare * settled.frame_ms);
    EXPECT_LE(settled_from(slow_levels), static_cast<size_t>(-slow_levels.back() * kFramesPerLevel + 1));
}

TEST(AutoFovea, SettledItProbesUpwardEverMoreRarely) {
    AutoFovea sizing(kWholeEye, 0);
    ModelledPair slow;
    slow.path_ms_per_eye = 200;
    const auto levels = run(sizing, slow, 3000);
    std::map<int, int> frames_at;
    for (size_t i = levels.size() / 2; i < levels.size(); ++i)
        ++frames_at[levels[i]];
    ASSERT_LE(frames_at.size(), 2u) << "the settled level and the one probed above it";
    EXPECT_GE(frames_at[levels.back()], static_cast<int>(levels.size() / 2 * 9 / 10))
        << "probes take at most a tenth of the frames once the hold has grown";
}

TEST(AutoFovea, AnAgentDrawSlowerThanTheClientIsNoReasonToShrink) {
    AutoFovea sizing(kWholeEye, 0);
    ModelledPair pair;
    pair.agent_draw_ms = 50; // every frame waits ~30 ms, whatever the fovea
    pair.path_ms_per_eye = 1;
    run(sizing, pair, 400);
    EXPECT_EQ(sizing.size().width, split::kGazeOne);
}

// A late frame shrinks the fovea at once, without waiting for a window. One stall makes several
// frames late in a row: the first shrinks it, the rest of that stall (while the smaller size
// settles) do not; a late frame after a growth does.
TEST(AutoFovea, ALateFrameShrinksItAtOnceAndOneStallOnlyOnce) {
    AutoFovea sizing(kWholeEye, 0);
    FoveaFrameCost late;
    late.late = true;
    late.frame_ms = 20;
    for (int i = 0; i < 3; ++i) {
        late.size = sizing.size();
        sizing.observe(late);
    }
    EXPECT_EQ(sizing.level(), -1);

    ModelledPair fast;
    run(sizing, fast, 200); // grows again, a level at a time
    ASSERT_GE(sizing.level(), 1);
    const int grown = sizing.level();
    late.size = sizing.size();
    sizing.observe(late);
    EXPECT_EQ(sizing.level(), grown - 1);
}

TEST(AutoFovea, FramesOfAnEarlierSizeAreNotCounted) {
    AutoFovea sizing(kWholeEye, 0);
    FoveaFrameCost late;
    late.size = {1, 1};
    late.late = true;
    sizing.observe(late);
    EXPECT_EQ(sizing.level(), 0);
}

TEST(AutoFovea, MaxMbpsBoundsIt) {
    // 1 MB per whole eye at 50 frames per second: 400 Mbit/s; a bound of 100 keeps a quarter.
    AutoFovea sizing(kWholeEye, 100);
    ModelledPair pair;
    pair.bytes_per_eye = 1e6;
    run(sizing, pair, 600);
    const FoveaFrameCost settled = pair.frame(sizing.size());
    const double mbps = settled.tile_bytes * 8 / 1e6 / (settled.frame_ms / 1000);
    EXPECT_LE(mbps, 100);
    EXPECT_GT(mbps * AutoFovea::kStep * AutoFovea::kStep, 100) << "one level more would cross the bound";
}

// SPLITVK_FOVEA=auto:WxH: the largest size, which the agent's scissors are recorded for.
TEST(AutoFovea, GrowsToTheLargestSizeAndNoFurther) {
    AutoFovea sizing(FoveaSize{true, 0.6, 0.5, true}, 0);
    ModelledPair fast;
    const auto levels = run(sizing, fast, 400);
    EXPECT_EQ(sizing.size(), (split::FrameFoveaSize{39321, split::kGazeOne / 2}));
    EXPECT_EQ(*std::max_element(levels.begin(), levels.end()), levels.back());

    // 0.6 of the eye is 39321.6 units: every size must pass the agent's check against 0.6 itself.
    const FoveaSize fractional_cap{true, 0.6, 0.6, true};
    AutoFovea awkward(fractional_cap, 0);
    for (int frame = 0; frame < 400; ++frame) {
        const split::FrameFoveaSize size = awkward.size();
        ASSERT_TRUE(split::frame_fovea_size_allowed(fractional_cap, size)) << "level " << awkward.level();
        awkward.observe(fast.frame(size)); // reported at once: the window logic does not mind
    }
    EXPECT_EQ(awkward.size(), (split::FrameFoveaSize{39321, 39321}));

    AutoFovea below(FoveaSize{true, 0.25, 0.25, true}, 0); // smaller than the default: starts there
    EXPECT_EQ(below.size(), (split::FrameFoveaSize{split::kGazeOne / 4, split::kGazeOne / 4}));
    run(below, fast, 100);
    EXPECT_EQ(below.size(), (split::FrameFoveaSize{split::kGazeOne / 4, split::kGazeOne / 4}));
}

// Above SPLITVK_MAX_MBPS from the start: it shrinks until the traffic is within the bound.
TEST(AutoFovea, MaxMbpsShrinksItBelowTheBound) {
    AutoFovea sizing(kWholeEye, 20);
    ModelledPair pair;
    pair.bytes_per_eye = 1e6; // the default size: about 57 Mbit/s at 50 frames per second
    ASSERT_GT(pair.frame(sizing.size()).tile_bytes * 8 / 1e6 / 0.02, 20);
    run(sizing, pair, 600);
    const FoveaFrameCost settled = pair.frame(sizing.size());
    EXPECT_LT(sizing.level(), 0);
    EXPECT_LE(settled.tile_bytes * 8 / 1e6 / (settled.frame_ms / 1000), 20);
}

// A size that keeps failing is tried again ever more rarely: the hold doubles with each failure.
TEST(AutoFovea, EachFailedProbeDoublesTheHold) {
    AutoFovea sizing(kWholeEye, 0);
    ModelledPair slow;
    slow.path_ms_per_eye = 200;
    const auto levels = run(sizing, slow, 4000);
    const int settled = levels.back();
    std::vector<size_t> probes; // the frames at which it went up to the level above, again
    for (size_t i = 1; i < levels.size(); ++i)
        if (levels[i] == settled + 1 && levels[i - 1] == settled) probes.push_back(i);
    ASSERT_GE(probes.size(), 4u);
    std::vector<size_t> gaps;
    for (size_t i = 1; i < probes.size(); ++i)
        gaps.push_back(probes[i] - probes[i - 1]);
    for (size_t i = 1; i < gaps.size(); ++i)
        EXPECT_GE(gaps[i], gaps[i - 1]) << "probe " << i;
    EXPECT_GE(gaps.back(), 4 * gaps.front());
}

TEST(AutoFovea, NeverLeavesItsLadder) {
    AutoFovea sizing(kWholeEye, 0);
    ModelledPair hopeless;
    hopeless.client_ms = 1;
    hopeless.path_ms_per_eye = 1e6;
    run(sizing, hopeless, 400);
    EXPECT_EQ(sizing.level(), AutoFovea::kMinLevel);
    EXPECT_GE(sizing.size().width, 1u);
}

} // namespace
} // namespace splitvk
