// A real splitvk-agent for the length of a test, on a loopback port nobody else uses.
#pragma once

#include "process.h"
#include "vk_env.h"

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace splitvk::e2e {

std::filesystem::path agent_path(); // <build>/bin/splitvk-agent

// A port nobody listens on right now (bound on 127.0.0.1, read back, released).
uint16_t free_loopback_port();

// Waits (at most 20 s) until the agent log at `log_path` reports its session closed, and checks
// that the session, run with --validate, ended with no validation message.
::testing::AssertionResult agent_session_validation_clean(const std::filesystem::path &log_path);

// The client side: the validation log configure_validation() set up exists (the layer was
// loaded) and is empty.
::testing::AssertionResult client_validation_clean(const std::filesystem::path &validation_log);

class Agent {
public:
    // Starts `splitvk-agent --listen 127.0.0.1:<free port> <extra_args>` with SPLITVK_LOG_LEVEL=info
    // and its TLS identity in out_dir/<name>-state (unless extra_args name --state-dir or --tls-cert),
    // its output in out_dir/splitvk-agent.{stdout,stderr}, and waits until it listens. On failure
    // returns false and error() says why (with the agent's last words).
    // `port` 0 picks a free one; `name` is the stem of its output files.
    bool start(const Env &env, const std::filesystem::path &out_dir,
               const std::vector<std::string> &extra_args = {}, uint16_t port = 0,
               const std::string &name = "splitvk-agent");
    // SIGKILL to the listener and its sessions (one process group), as a crash or a power cut
    // would end them: no Goodbye, no FIN from a clean exit. Waits until they are gone.
    void kill();

    // Before start(): listen on `host` (default 127.0.0.1) and run the agent under `wrapper`
    // (e.g. {"ip", "netns", "exec", NS}, which execs it: the pid and its group stay the agent's).
    void set_host(std::string host, std::vector<std::string> wrapper = {}) {
        host_ = std::move(host);
        wrapper_ = std::move(wrapper);
    }

    uint16_t port() const { return port_; }
    // The listener's pid, which is also its process group (sessions are its forked children).
    int pid() const;
    std::string address() const { return host_ + ":" + std::to_string(port_); }
    std::string log() const; // what it wrote on stderr so far
    const std::string &error() const { return error_; }

private:
    std::unique_ptr<Process> process_;
    std::filesystem::path log_path_;
    uint16_t port_ = 0;
    std::string host_ = "127.0.0.1";
    std::vector<std::string> wrapper_;
    std::string error_;
};

} // namespace splitvk::e2e
