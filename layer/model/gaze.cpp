#include "model/gaze.h"

#include "log.h"

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <memory>
#include <mutex>
#include <vector>

#include <fcntl.h>
#include <unistd.h>

namespace splitvk::gaze {

std::optional<split::Gaze> parse_line(std::string_view line, std::string *error) {
    std::vector<double> numbers;
    size_t i = 0;
    while (i < line.size()) {
        if (line[i] == ' ' || line[i] == '\t' || line[i] == '\r') {
            ++i;
            continue;
        }
        size_t end = i;
        while (end < line.size() && line[end] != ' ' && line[end] != '\t' && line[end] != '\r')
            ++end;
        const std::string_view word = line.substr(i, end - i);
        double value = 0;
        const auto [last, ec] = std::from_chars(word.data(), word.data() + word.size(), value);
        if (ec != std::errc() || last != word.data() + word.size() || !std::isfinite(value)) {
            // Appended piece by piece: GCC 12's -Wrestrict misfires on "literal" + std::string.
            error->assign(1, '\'').append(word).append("' is not a finite number");
            return std::nullopt;
        }
        if (numbers.size() == 4) {
            *error = "more than 4 numbers";
            return std::nullopt;
        }
        numbers.push_back(value);
        i = end;
    }
    error->clear();
    if (numbers.empty()) return std::nullopt;
    if (numbers.size() != 2 && numbers.size() != 4) {
        error->assign(std::to_string(numbers.size())).append(" numbers, expected x y or lx ly rx ry");
        return std::nullopt;
    }
    const auto units = [](double v) {
        return static_cast<uint32_t>(std::lround(std::clamp(v, 0.0, 1.0) * split::kGazeOne));
    };
    split::Gaze gaze;
    gaze.fixed = false;
    gaze.eyes[0] = {units(numbers[0]), units(numbers[1])};
    gaze.eyes[1] =
        numbers.size() == 4 ? split::GazePoint{units(numbers[2]), units(numbers[3])} : gaze.eyes[0];
    return gaze;
}

FifoReader::~FifoReader() {
    if (fd_ >= 0) ::close(fd_);
}

void FifoReader::bad_line(std::string_view line, const std::string &why) {
    ++bad_lines_;
    if (bad_lines_ > kMaxBadLineWarnings) return;
    const std::string shown(line.substr(0, 64));
    SPLITVK_WARN("SPLITVK_GAZE=fifo:%s: ignoring the line '%s%s': %s%s", path_.c_str(), shown.c_str(),
                 line.size() > shown.size() ? "..." : "", why.c_str(),
                 bad_lines_ == kMaxBadLineWarnings ? " (further bad lines go unreported)" : "");
}

void FifoReader::take_line(std::string_view line) {
    std::string error;
    if (const auto gaze = parse_line(line, &error))
        current_ = *gaze;
    else if (!error.empty())
        bad_line(line, error);
}

void FifoReader::try_open() {
    const auto now = std::chrono::steady_clock::now();
    if (now < next_open_) return;
    next_open_ = now + retry_;
    // Non-blocking: opening a pipe for reading does not wait for a writer, and reads return what
    // is there (or nothing) at once.
    fd_ = ::open(path_.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd_ >= 0) {
        SPLITVK_INFO("gaze: reading gaze points from %s", path_.c_str());
    } else if (!said_unopened_) {
        said_unopened_ = true;
        SPLITVK_WARN("SPLITVK_GAZE=fifo:%s: cannot open it (%s); the foveae stay fixed until it can be",
                     path_.c_str(), std::strerror(errno));
    }
}

split::Gaze FifoReader::poll() {
    if (fd_ < 0 && !read_failed_) try_open();
    if (fd_ < 0) return current_;
    char buffer[4096];
    for (;;) {
        const ssize_t n = ::read(fd_, buffer, sizeof(buffer));
        if (n < 0 && errno == EINTR) continue;
        // 0: no writer has the pipe open (now); a later writer's lines are read then.
        if (n == 0 || (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK))) break;
        if (n < 0) {
            SPLITVK_WARN("SPLITVK_GAZE=fifo:%s: reading failed (%s); no more gaze points", path_.c_str(),
                         std::strerror(errno));
            ::close(fd_);
            fd_ = -1;
            read_failed_ = true;
            break;
        }
        for (const char c : std::string_view(buffer, static_cast<size_t>(n))) {
            if (c == '\n') {
                if (overlong_)
                    bad_line(pending_, "longer than " + std::to_string(kMaxLine) + " characters");
                else
                    take_line(pending_);
                pending_.clear();
                overlong_ = false;
            } else if (pending_.size() < kMaxLine) {
                pending_.push_back(c);
            } else {
                overlong_ = true;
            }
        }
    }
    return current_;
}

split::Gaze hold_fixation(const split::Gaze &shown, const split::Gaze &measured) {
    if (shown.fixed || measured.fixed) return measured;
    const auto near = [](uint32_t a, uint32_t b) { return (a > b ? a - b : b - a) <= kFixationRadius; };
    split::Gaze held = measured;
    for (int eye = 0; eye < 2; ++eye)
        if (near(shown.eyes[eye].x, measured.eyes[eye].x) && near(shown.eyes[eye].y, measured.eyes[eye].y))
            held.eyes[eye] = shown.eyes[eye];
    return held;
}

split::Gaze frame_gaze(const Settings &settings) {
    if (settings.gaze != GazeMode::Fifo) return {};
    static std::mutex mutex;
    static std::unique_ptr<FifoReader> reader;
    static split::Gaze shown;
    std::lock_guard lock(mutex);
    if (!reader) reader = std::make_unique<FifoReader>(settings.gaze_fifo);
    shown = hold_fixation(shown, reader->poll());
    return shown;
}

} // namespace splitvk::gaze
