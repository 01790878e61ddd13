// A real splitvk-agent on a loopback port nobody else uses, running until it is killed or its
// owner goes: the e2e suites' Agent (agent.h) and `splitvk-harness agent` (the scripts') both.
#pragma once

#include "process.h"

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace splitvk::e2e {

// A port nobody listens on right now (bound on 127.0.0.1, read back, released).
uint16_t free_loopback_port();

class AgentProcess {
public:
    explicit AgentProcess(std::filesystem::path binary) : binary_(std::move(binary)) {}

    // Starts `<binary> --listen 127.0.0.1:<free port> <extra_args>` with SPLITVK_LOG_LEVEL=info
    // and its TLS identity in out_dir/<name>-state (unless extra_args name --state-dir or --tls-cert),
    // its output in out_dir/<name>.{stdout,stderr}, and waits until it listens. On failure
    // returns false and error() says why (with the agent's last words).
    // `port` 0 picks a free one; `name` is the stem of its output files.
    bool start(const Env &env, const std::filesystem::path &out_dir,
               const std::vector<std::string> &extra_args = {}, uint16_t port = 0,
               const std::string &name = "splitvk-agent");
    // SIGKILL to the listener and its sessions (one process group), as a crash or a power cut
    // would end them: no Goodbye, no FIN from a clean exit. Waits until they are gone.
    void kill();
    // SIGTERM to the listener and its sessions (one process group): a clean stop, which ends the
    // sessions; SIGKILL after `grace`. What it reports on the way out stays in log().
    ProcessResult stop(std::chrono::milliseconds grace);

    // Before start(): listen on `host` (default 127.0.0.1) and run the agent under `wrapper`
    // (e.g. {"ip", "netns", "exec", NS} or {"taskset", "-c", "1"}, which exec it: the pid and its
    // group stay the agent's).
    void set_host(std::string host, std::vector<std::string> wrapper = {}) {
        host_ = std::move(host);
        wrapper_ = std::move(wrapper);
    }

    uint16_t port() const { return port_; }
    bool running() const { return process_ && process_->running(); }
    // The listener's pid, which is also its process group (sessions are its forked children).
    int pid() const;
    std::string address() const { return host_ + ":" + std::to_string(port_); }
    std::string log() const; // what it wrote on stderr so far
    const std::filesystem::path &log_path() const { return log_path_; }
    const std::string &error() const { return error_; }

private:
    std::filesystem::path binary_;
    std::unique_ptr<Process> process_;
    std::filesystem::path log_path_;
    uint16_t port_ = 0;
    std::string host_ = "127.0.0.1";
    std::vector<std::string> wrapper_;
    std::string error_;
};

} // namespace splitvk::e2e
