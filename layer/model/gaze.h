#pragma once

// Gaze sources of the layer (SPLITVK_GAZE): where each eye looks in the frame being
// presented, which places that frame's foveae on both sides (split::frame_foveae, carried to the
// agent in FramePresent).
//
// fifo:PATH: another process (an eye tracker's bridge) writes gaze points into a named pipe, one
// line each: "x y" (both eyes) or "lx ly rx ry", normalised to the eye's image (0 0 its top-left
// corner, 0.5 0.5 its centre, 1 1 its bottom-right). The layer creates nothing: it opens the path
// read-only and non-blocking at the first present, and at every present reads what the pipe holds
// without waiting, so the application never blocks on the writer. The newest good line applies from
// the present that reads it until the next one; a writer may close and reopen the pipe.
//
// No low-pass filter: it would only add latency to a saccade, after which the fovea must land at
// once. Fixations are another matter: the eye drifts and trembles by fractions of a degree, and
// trackers add noise of their own, and a fovea that follows every such point moves its tiles (each
// move costs the encoder its prediction from the previous tile) and its seam for nothing. So a point
// within kFixationRadius of where the fovea sits leaves it there (hold_fixation); the fovea itself
// is the margin for the gaze's latency (see docs/user-guide.md, "Where the fovea sits").

#include "split_geometry.h"

#include <chrono>
#include <optional>
#include <string>
#include <string_view>

namespace splitvk::gaze {

// One line of a gaze pipe, without its newline: "x y" or "lx ly rx ry", separated by spaces or tabs.
// Each number is finite and clamped to [0, 1] (a point off the eye holds the fovea at its edge), then
// taken in split::kGazeOne units. Nothing, with *error saying why in a few words, for anything
// else. An empty line (or one of blanks) is nothing with no error.
std::optional<split::Gaze> parse_line(std::string_view line, std::string *error);

// Reads one pipe (or any file) of gaze lines without ever blocking.
class FifoReader {
public:
    // A path that cannot be opened yet (the tracker's bridge has not made its pipe) is tried again
    // at most once per `retry`.
    explicit FifoReader(std::string path, std::chrono::steady_clock::duration retry = std::chrono::seconds(1))
        : path_(std::move(path)), retry_(retry) {}
    ~FifoReader();
    FifoReader(const FifoReader &) = delete;
    FifoReader &operator=(const FifoReader &) = delete;

    // Everything the pipe holds now, line by line: the gaze of the newest good line, or the one
    // before when none came; fixed until the first. A bad line gets one warning (the first
    // kMaxBadLineWarnings, then one saying that the rest go unreported); a path that cannot be
    // opened, one line, and the gaze stays fixed until it can be.
    split::Gaze poll();

    static constexpr size_t kMaxLine = 256;
    static constexpr uint32_t kMaxBadLineWarnings = 20;

private:
    void try_open();
    void take_line(std::string_view line);
    void bad_line(std::string_view line, const std::string &why);

    std::string path_;
    std::chrono::steady_clock::duration retry_;
    int fd_ = -1;
    std::chrono::steady_clock::time_point next_open_{}; // while fd_ < 0: when to try the path again
    bool said_unopened_ = false;                        // a path that cannot be opened is said once
    bool read_failed_ = false;                          // a read error ends the gaze for good
    std::string pending_;                               // a line not finished yet
    bool overlong_ = false;                             // discarding the rest of a line past kMaxLine
    uint32_t bad_lines_ = 0;
    split::Gaze current_;
};

// A fixation's points, in each axis, within 1/64 of the eye (19 pixels of a 1200-pixel eye, about
// 1.6 degrees of a 100-degree field of view: more than a microsaccade or a tracker's noise, less
// than any saccade worth following).
inline constexpr uint32_t kFixationRadius = split::kGazeOne / 64;

// The gaze to show: `measured`, but each eye whose point lies within kFixationRadius of `shown`'s
// in both axes keeps `shown`'s. A fixed gaze on either side is taken as it is.
split::Gaze hold_fixation(const split::Gaze &shown, const split::Gaze &measured);

// The gaze for the frame being presented now: fixed for SPLITVK_GAZE=fixed, otherwise the
// process's one reader of the pipe polled and held through fixations (thread-safe; every device of
// the process shares it).
split::Gaze frame_gaze(const Settings &settings);

} // namespace splitvk::gaze
