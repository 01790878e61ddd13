// A private X server for the tests: `Xvfb -displayfd` picks a free display number itself, so tests
// never assume that :0 or :99 is free and several test binaries can run at once.
#pragma once

#include "process.h"

#include <filesystem>
#include <memory>
#include <string>

namespace splitvk::e2e {

class Xvfb {
public:
    // 2560x1440 holds the sample's default 2400x1080 window at (0,0).
    static constexpr int kScreenWidth = 2560;
    static constexpr int kScreenHeight = 1440;

    Xvfb() = default;
    ~Xvfb();
    Xvfb(const Xvfb &) = delete;
    Xvfb &operator=(const Xvfb &) = delete;

    // Starts Xvfb and waits until it is ready (it writes its display number when it accepts
    // clients). Logs go to log_dir. False with error() on failure.
    bool start(const std::filesystem::path &log_dir, const Env &env);
    void stop();
    bool running() const { return proc_ != nullptr; }
    bool alive() { return proc_ && proc_->running(); } // started and not ended since

    int display_number() const { return display_; }
    std::string display() const; // ":N", for DISPLAY
    const std::string &error() const { return error_; }

private:
    std::unique_ptr<Process> proc_;
    int display_ = -1;
    std::string error_;
};

// One Xvfb per test binary, started on first use (so listing tests needs no X server) and stopped
// by the test environment at exit. Fails the calling test (returns nullptr) when it cannot start.
Xvfb *shared_xvfb();
void stop_shared_xvfb();
std::string shared_xvfb_error();

} // namespace splitvk::e2e
