#include "agent_process.h"

#include <algorithm>
#include <chrono>
#include <csignal>
#include <thread>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

namespace splitvk::e2e {

using namespace std::chrono_literals;

uint16_t free_loopback_port() {
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    if (fd < 0) return 0;
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof(addr);
    uint16_t port = 0;
    if (::bind(fd, reinterpret_cast<sockaddr *>(&addr), sizeof(addr)) == 0 &&
        ::getsockname(fd, reinterpret_cast<sockaddr *>(&addr), &len) == 0)
        port = ntohs(addr.sin_port);
    ::close(fd);
    return port;
}

bool AgentProcess::start(const Env &env, const std::filesystem::path &out_dir,
                         const std::vector<std::string> &extra_args, uint16_t port, const std::string &name) {
    port_ = port ? port : free_loopback_port();
    if (port_ == 0) {
        error_ = "no free loopback port";
        return false;
    }
    ProcessSpec spec;
    spec.argv = wrapper_;
    spec.argv.insert(spec.argv.end(), {binary_.string(), "--listen", address()});
    spec.argv.insert(spec.argv.end(), extra_args.begin(), extra_args.end());
    const auto given = [&](const char *flag) {
        return std::find(extra_args.begin(), extra_args.end(), flag) != extra_args.end();
    };
    // Never the user's own state directory.
    if (!given("--state-dir") && !given("--tls-cert"))
        spec.argv.insert(spec.argv.end(), {"--state-dir", (out_dir / (name + "-state")).string()});
    spec.env = env;
    spec.env["SPLITVK_LOG_LEVEL"] = "info";
    spec.out_dir = out_dir;
    spec.name = name;
    log_path_ = out_dir / (name + ".stderr");
    process_ = std::make_unique<Process>(spec);
    if (!process_->start()) {
        error_ = process_->error();
        return false;
    }
    const auto deadline = std::chrono::steady_clock::now() + 30s;
    while (std::chrono::steady_clock::now() < deadline) {
        if (log().find("listening on") != std::string::npos) return true;
        if (!process_->running()) break;
        std::this_thread::sleep_for(50ms);
    }
    error_ = "splitvk-agent did not start listening:\n" + log();
    return false;
}

std::string AgentProcess::log() const {
    return read_file(log_path_);
}

void AgentProcess::kill() {
    if (!process_) return;
    ::kill(-process_->pid(), SIGKILL);
    process_->wait(std::chrono::seconds(10));
}

ProcessResult AgentProcess::stop(std::chrono::milliseconds grace) {
    if (!process_) return {};
    return process_->terminate(grace);
}

int AgentProcess::pid() const {
    return process_ ? process_->pid() : -1;
}

} // namespace splitvk::e2e
