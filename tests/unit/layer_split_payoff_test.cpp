// SPLITVK_SPLIT=auto's verdict on the split (layer/model/split_payoff.h): each mode measured in turn, the
// faster kept, the loser probed ever more rarely, and nothing counted until a switch is followed.
#include "model/split_payoff.h"

#include <optional>

#include <gtest/gtest.h>

namespace splitvk {
namespace {

using Mode = SplitPayoff::Mode;

// Feeds presents in the mode the payoff wants, each taking the given time in that mode, following
// every switch at once, until it decides; returns the decision and counts the presents in *presents.
struct Machine {
    double split_ms = 0;
    double native_ms = 0;
};

SplitPayoff::Switch run_until_decided(SplitPayoff &payoff, const Machine &m, uint32_t *presents) {
    for (uint32_t i = 0; i < 100000; ++i) {
        const Mode mode = payoff.wanted();
        ++*presents;
        if (auto d = payoff.observe(mode, mode == Mode::Split ? m.split_ms : m.native_ms)) return *d;
    }
    ADD_FAILURE() << "no decision";
    return {};
}

TEST(SplitPayoff, FirstMeasuresTheSplitAfterItsHoldThenProbesPassingThrough) {
    SplitPayoff payoff;
    uint32_t presents = 0;
    const auto d = run_until_decided(payoff, {20, 5}, &presents);
    EXPECT_EQ(presents, SplitPayoff::kSkip + SplitPayoff::kFirstHold + SplitPayoff::kWindow);
    EXPECT_TRUE(d.probe);
    EXPECT_EQ(d.to, Mode::PassThrough);
    EXPECT_DOUBLE_EQ(d.split_ms, 20);
    EXPECT_EQ(payoff.wanted(), Mode::PassThrough);
}

// A fixed fovea has nothing to settle: the split is measured at once, and a slow one passes through
// after a window and a probe. Later holds are the same as with a sizing fovea.
TEST(SplitPayoff, WithoutAFirstHoldASlowSplitPassesThroughAfterTwoWindows) {
    SplitPayoff payoff(0);
    uint32_t presents = 0;
    auto d = run_until_decided(payoff, {20, 5}, &presents);
    EXPECT_EQ(presents, SplitPayoff::kSkip + SplitPayoff::kWindow);
    EXPECT_TRUE(d.probe);
    EXPECT_EQ(d.to, Mode::PassThrough);
    d = run_until_decided(payoff, {20, 5}, &presents);
    EXPECT_EQ(presents, 2 * SplitPayoff::kSkip + SplitPayoff::kWindow + SplitPayoff::kQuickWindow)
        << "passing through is clearly faster: its probe is decided early";
    EXPECT_FALSE(d.probe);
    EXPECT_EQ(d.to, Mode::PassThrough);
    presents = 0;
    d = run_until_decided(payoff, {20, 5}, &presents);
    EXPECT_TRUE(d.probe);
    EXPECT_EQ(presents, SplitPayoff::kSkip + SplitPayoff::kFirstHold + SplitPayoff::kWindow);
}

TEST(SplitPayoff, ASlowSplitPassesThroughAndIsProbedAgainNowAndThen) {
    SplitPayoff payoff;
    uint32_t presents = 0;
    run_until_decided(payoff, {20, 5}, &presents); // probe passing through
    presents = 0;
    auto d = run_until_decided(payoff, {20, 5}, &presents);
    EXPECT_EQ(presents, SplitPayoff::kSkip + SplitPayoff::kQuickWindow) << "a probe holds nothing";
    EXPECT_FALSE(d.probe);
    EXPECT_EQ(d.to, Mode::PassThrough) << "the probe won";
    EXPECT_DOUBLE_EQ(d.native_ms, 5);
    // Then it holds, and probes the split again.
    presents = 0;
    d = run_until_decided(payoff, {20, 5}, &presents);
    EXPECT_EQ(presents, SplitPayoff::kSkip + SplitPayoff::kFirstHold + SplitPayoff::kWindow);
    EXPECT_TRUE(d.probe);
    EXPECT_EQ(d.to, Mode::Split);
    // The split loses again: back to passing through, and the next probe comes twice as late.
    d = run_until_decided(payoff, {20, 5}, &presents);
    EXPECT_FALSE(d.probe);
    EXPECT_EQ(d.to, Mode::PassThrough);
    presents = 0;
    d = run_until_decided(payoff, {20, 5}, &presents);
    EXPECT_TRUE(d.probe);
    EXPECT_EQ(presents, SplitPayoff::kSkip + 2 * SplitPayoff::kFirstHold + SplitPayoff::kWindow);
}

TEST(SplitPayoff, AFastSplitStaysSplitAndTheLosingProbeComesEverMoreRarely) {
    SplitPayoff payoff;
    uint32_t presents = 0;
    const Machine m{100, 200};
    run_until_decided(payoff, m, &presents); // probe passing through
    uint32_t previous_gap = 0;
    for (int round = 0; round < 8; ++round) {
        auto d = run_until_decided(payoff, m, &presents); // the verdict after the probe
        EXPECT_FALSE(d.probe);
        EXPECT_EQ(d.to, Mode::Split);
        presents = 0;
        d = run_until_decided(payoff, m, &presents); // the next probe
        EXPECT_TRUE(d.probe);
        EXPECT_EQ(d.to, Mode::PassThrough);
        EXPECT_GE(presents, previous_gap) << "round " << round;
        EXPECT_LE(presents, SplitPayoff::kSkip + SplitPayoff::kLongestHold + SplitPayoff::kWindow);
        previous_gap = presents;
    }
    EXPECT_EQ(previous_gap, SplitPayoff::kSkip + SplitPayoff::kLongestHold + SplitPayoff::kWindow)
        << "the hold doubles up to its longest";
}

// A small application's split probes cost it only the few slow frames it takes to see that the
// split still loses by far: each later probe of the split is kSkip + kQuickWindow presents.
TEST(SplitPayoff, AProbeOfASplitSeveralTimesSlowerEndsAfterTheQuickWindow) {
    SplitPayoff payoff(0);
    uint32_t presents = 0;
    run_until_decided(payoff, {20, 5}, &presents); // the split measured: probe passing through
    run_until_decided(payoff, {20, 5}, &presents); // passing through, for a hold
    for (int round = 0; round < 4; ++round) {
        auto d = run_until_decided(payoff, {20, 5}, &presents);
        ASSERT_TRUE(d.probe);
        ASSERT_EQ(d.to, Mode::Split);
        uint32_t split_presents = 0;
        d = run_until_decided(payoff, {20, 5}, &split_presents);
        EXPECT_EQ(split_presents, SplitPayoff::kSkip + SplitPayoff::kQuickWindow) << "round " << round;
        EXPECT_FALSE(d.probe);
        EXPECT_EQ(d.to, Mode::PassThrough);
        EXPECT_DOUBLE_EQ(d.split_ms, 20);
    }
}

// Within kClearly either way the quick window decides nothing: a close call gets the whole window.
TEST(SplitPayoff, ACloseCallIsMeasuredOverTheWholeWindow) {
    SplitPayoff payoff(0);
    uint32_t presents = 0;
    const Machine m{10, 13}; // the split 1.3x faster: a clear win, but not beyond kClearly
    run_until_decided(payoff, m, &presents);
    presents = 0;
    const auto d = run_until_decided(payoff, m, &presents);
    EXPECT_EQ(presents, SplitPayoff::kSkip + SplitPayoff::kWindow);
    EXPECT_EQ(d.to, Mode::Split);
    EXPECT_DOUBLE_EQ(d.native_ms, 13);
}

TEST(SplitPayoff, TheSplitMustWinByTheMarginOverPassingThrough) {
    // Within the margin (noise), passing through wins: the application is never slower than native.
    SplitPayoff payoff;
    uint32_t presents = 0;
    const Machine m{97, 100};
    run_until_decided(payoff, m, &presents);
    EXPECT_EQ(run_until_decided(payoff, m, &presents).to, Mode::PassThrough);
    SplitPayoff other;
    const Machine clear{90, 100};
    run_until_decided(other, clear, &presents);
    EXPECT_EQ(run_until_decided(other, clear, &presents).to, Mode::Split);
}

TEST(SplitPayoff, PresentsOfTheModeItLeftAreNotCounted) {
    SplitPayoff payoff;
    uint32_t presents = 0;
    run_until_decided(payoff, {20, 5}, &presents); // wants PassThrough from now
    // The application has not recreated its swapchain yet: its split presents, however slow, say
    // nothing about passing through.
    for (int i = 0; i < 1000; ++i)
        EXPECT_FALSE(payoff.observe(Mode::Split, 1000).has_value());
    presents = 0;
    const auto d = run_until_decided(payoff, {20, 5}, &presents);
    EXPECT_EQ(presents, SplitPayoff::kSkip + SplitPayoff::kQuickWindow);
    EXPECT_DOUBLE_EQ(d.native_ms, 5);
}

TEST(SplitPayoff, TheMedianIgnoresAStall) {
    SplitPayoff payoff;
    uint32_t presents = 0;
    run_until_decided(payoff, {20, 5}, &presents);
    // Passing through: one long stall in the window (a swapchain recreated late) moves nothing.
    for (uint32_t i = 0; i < SplitPayoff::kSkip; ++i)
        payoff.observe(Mode::PassThrough, 5);
    std::optional<SplitPayoff::Switch> d;
    for (uint32_t i = 0; i < SplitPayoff::kWindow && !d; ++i)
        d = payoff.observe(Mode::PassThrough, i == 3 ? 900 : 5);
    ASSERT_TRUE(d.has_value());
    EXPECT_DOUBLE_EQ(d->native_ms, 5);
    EXPECT_EQ(d->to, Mode::PassThrough);
}

TEST(SplitPayoff, AWindowInWhichTheFoveaMovedIsMeasuredAgain) {
    // auto's own sizing grows the fovea while the split's first stint runs, and the split's frame time
    // falls with it: only a window at one size counts.
    SplitPayoff payoff;
    uint32_t presents = 0;
    for (; presents < SplitPayoff::kSkip + SplitPayoff::kFirstHold + SplitPayoff::kWindow - 1; ++presents)
        ASSERT_FALSE(payoff.observe(Mode::Split, 9).has_value());
    EXPECT_FALSE(payoff.observe(Mode::Split, 9, /*steady=*/false).has_value()) << "the window starts again";
    std::optional<SplitPayoff::Switch> d;
    uint32_t after = 0;
    while (!d && after < 1000) {
        ++after;
        d = payoff.observe(Mode::Split, 3);
    }
    ASSERT_TRUE(d.has_value());
    EXPECT_EQ(after, SplitPayoff::kWindow);
    EXPECT_DOUBLE_EQ(d->split_ms, 3) << "measured at the settled size only";
}

TEST(SplitPayoff, SettledDecidesNothingMore) {
    SplitPayoff payoff;
    payoff.settle(Mode::Split);
    EXPECT_TRUE(payoff.settled());
    for (int i = 0; i < 10000; ++i)
        ASSERT_FALSE(payoff.observe(Mode::Split, 50).has_value());
    EXPECT_EQ(payoff.wanted(), Mode::Split);
}

} // namespace
} // namespace splitvk
