// A real splitvk-agent for the length of a test, on a loopback port nobody else uses.
#pragma once

#include "agent_process.h"
#include "process.h"
#include "vk_env.h"

#include <chrono>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

namespace splitvk::e2e {

std::filesystem::path agent_path(); // <build>/bin/splitvk-agent

// Waits (at most 20 s) until the agent log at `log_path` reports a session closed and every session
// it started ended, and checks that every session closed, run with --validate, had no validation
// error: a client that reconnects or is brought in again by a resync has several, and the later ones
// replay the live-state snapshot.
::testing::AssertionResult agent_session_validation_clean(const std::filesystem::path &log_path);

// The client side: the validation log configure_validation() set up exists (the layer was
// loaded) and is empty.
::testing::AssertionResult client_validation_clean(const std::filesystem::path &validation_log);

// The build tree's splitvk-agent (AgentProcess has the rest).
// What `splitvk-agent --print-fingerprint --state-dir DIR` prints (`sha256:...`), the identity
// made there first if there is none; a test failure, and "", when the agent cannot say.
inline std::string agent_fingerprint(const Env &env, const std::filesystem::path &out_dir,
                                     const std::filesystem::path &state_dir) {
    ProcessSpec spec;
    spec.argv = {agent_path().string(), "--print-fingerprint", "--state-dir", state_dir.string()};
    spec.env = env;
    spec.out_dir = out_dir;
    spec.name = "fingerprint";
    const ProcessResult r = run_process(spec, std::chrono::seconds(30));
    EXPECT_TRUE(r.ok()) << r.describe() << r.err();
    if (!r.ok()) return "";
    std::string text = r.out();
    while (!text.empty() && (text.back() == '\n' || text.back() == ' '))
        text.pop_back();
    return text;
}

class Agent : public AgentProcess {
public:
    Agent() : AgentProcess(agent_path()) {}
};

} // namespace splitvk::e2e
