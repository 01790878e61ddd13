#pragma once

// SPLITVK_SPLIT=auto, the default, where the split does not pay: the layer passes frames through, as
// if there were no agent, and tries the split again now and then. A small frame is slower split
// whatever the fovea's size, so the verdict runs whatever SPLITVK_FOVEA is.
//
// Whether the split pays cannot be told from one side's numbers: a small frame is slower split
// (the agent's path is longer than the whole native frame) and a large one faster, and the native
// frame time is not measured while splitting. So each mode is measured in turn, by its median frame
// time over kWindow presents, and the faster one kept, the split only while it is faster than
// passing through by more than kMargin (noise never makes the application slower than native).
//
// A stint in a mode skips the kSkip presents after it began (the application recreating its
// swapchain and targets, the tile codec's keyframes), holds for a number of presents, then measures
// a window. Its measurement ends the stint:
//   - the other mode was never measured: switch to it (a probe);
//   - the stint was a probe: keep the faster mode. A probe that won starts a hold in its mode and
//     resets the hold to kFirstHold; one that lost goes back, and the hold doubles (up to
//     kLongestHold), so the loser is probed ever more rarely. A probe whose first kQuickWindow
//     frames already differ from the other mode by more than kClearly either way is decided then:
//     a probe of a split several times slower than passing through (a small frame) costs the
//     application kSkip + kQuickWindow slow frames, not a whole window of them;
//   - the stint was a hold: probe the other mode.
// The first stint is the split's, held for the first hold (kFirstHold with SPLITVK_FOVEA=auto, so
// that the fovea's own sizing settles before it is measured; none for a fixed fovea, so that a small
// application is slowed for no more than its first measurement); a window in which the fovea's size
// changed is not measured either.
//
// A switch takes effect only once the application follows it (it recreates its swapchain, session.h);
// presents of the other mode until then are not counted. Not thread-safe: the application's present
// calls it.

#include <cstdint>
#include <optional>
#include <vector>

namespace splitvk {

class SplitPayoff {
public:
    enum class Mode { Split, PassThrough };
    struct Switch {
        Mode to = Mode::Split;
        double split_ms = 0;  // the latest medians that decided it (0: not measured yet)
        double native_ms = 0; // passing through
        bool probe = false;   // to measure the other mode, not a verdict
    };

    // `first_hold`: presents of the split's first stint before its first measurement (kSkip aside).
    explicit SplitPayoff(uint32_t first_hold = kFirstHold) : hold_(first_hold) {}

    // One present's time since the previous one, presented in `mode`. `steady`: the fovea's size is
    // the previous present's (SPLITVK_FOVEA=auto's own sizing moves it while it settles, and a
    // split's frame time with it): a window is measured at one size, and one the size changed in
    // starts again. Returns what it decides, when it decides: a probe of the other mode, or after a
    // probe the faster mode (`mode` itself when the probe won).
    std::optional<Switch> observe(Mode mode, double frame_ms, bool steady = true);
    // The mode the presents should be in.
    Mode wanted() const { return wanted_; }
    // The application cannot follow a switch: stay in `mode` for good.
    void settle(Mode mode);
    bool settled() const { return settled_; }

    static constexpr uint32_t kSkip = 6;
    static constexpr uint32_t kWindow = 30;
    static constexpr uint32_t kQuickWindow = 8;
    // Far outside kMargin, and beyond what the median of kQuickWindow frames moves by with this
    // machine's noise: the same mode's medians of separate windows differ by up to 1.3x here.
    static constexpr double kClearly = 1.5;
    static constexpr uint32_t kFirstHold = 120;
    static constexpr uint32_t kLongestHold = 3840;
    static constexpr double kMargin = 0.05;

private:
    void begin_stint(Mode mode, bool probe, uint32_t hold);
    // The probe's window so far is kClearly faster or slower than the other mode's measurement.
    bool clearly_decided() const;

    Mode mode_ = Mode::Split; // the mode presents are measured in
    Mode wanted_ = Mode::Split;
    bool probe_ = false;
    uint32_t hold_ = kFirstHold; // of this stint
    uint32_t next_hold_ = kFirstHold;
    uint32_t presents_ = 0; // of this stint
    std::vector<double> window_;
    std::optional<double> measured_[2]; // by Mode
    bool settled_ = false;
};

} // namespace splitvk
