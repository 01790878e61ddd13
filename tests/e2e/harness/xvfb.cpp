#include "xvfb.h"

#include <cerrno>
#include <cstring>

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <unistd.h>

namespace splitvk::e2e {

Xvfb::~Xvfb() {
    stop();
}

bool Xvfb::start(const std::filesystem::path &log_dir, const Env &env) {
    stop();
    int fds[2];
    if (::pipe2(fds, O_CLOEXEC) != 0) {
        error_ = std::string("pipe: ") + std::strerror(errno);
        return false;
    }
    ProcessSpec spec;
    spec.argv = {
        "Xvfb",      "-displayfd", std::to_string(fds[1]),
        "-screen",   "0",          std::to_string(kScreenWidth) + "x" + std::to_string(kScreenHeight) + "x24",
        "-nolisten", "tcp",        "-noreset"};
    spec.env = env;
    spec.out_dir = log_dir;
    spec.name = "Xvfb-" + std::to_string(::getpid());
    spec.keep_fds = {fds[1]};
    spec.parent_death_signal = SIGTERM; // lets Xvfb remove its lock file
    proc_ = std::make_unique<Process>(spec);
    if (!proc_->start()) {
        error_ = "cannot start Xvfb: " + proc_->error();
        ::close(fds[0]);
        ::close(fds[1]);
        proc_.reset();
        return false;
    }
    ::close(fds[1]);

    // Xvfb writes "<display>\n" once it is ready for clients.
    std::string text;
    const auto deadline = Clock::now() + std::chrono::seconds(20);
    while (text.find('\n') == std::string::npos) {
        auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
        if (left <= 0) break;
        pollfd pfd{fds[0], POLLIN, 0};
        int r = ::poll(&pfd, 1, static_cast<int>(left));
        if (r < 0 && errno == EINTR) continue;
        if (r <= 0) break;
        char buf[64];
        ssize_t n = ::read(fds[0], buf, sizeof buf);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) break; // EOF: Xvfb died
        text.append(buf, static_cast<size_t>(n));
    }
    ::close(fds[0]);
    if (text.find('\n') == std::string::npos) {
        auto r = proc_->terminate(std::chrono::seconds(2));
        error_ = "Xvfb did not report a display: " + r.describe() + "\n" + r.err();
        proc_.reset();
        return false;
    }
    display_ = std::stoi(text);
    return true;
}

std::string Xvfb::display() const {
    // (Not ":" + std::to_string(n): GCC 12 warns falsely about that under -O2, -Wrestrict.)
    std::string d(1, ':');
    d.append(std::to_string(display_));
    return d;
}

void Xvfb::stop() {
    if (!proc_) return;
    proc_->terminate(std::chrono::seconds(5));
    proc_.reset();
    display_ = -1;
}

} // namespace splitvk::e2e
