// A real splitvk-agent for the length of a test, on a loopback port nobody else uses.
#pragma once

#include "agent_process.h"
#include "process.h"
#include "vk_env.h"

#include <filesystem>
#include <string>

#include <gtest/gtest.h>

namespace splitvk::e2e {

std::filesystem::path agent_path(); // <build>/bin/splitvk-agent

// Waits (at most 20 s) until the agent log at `log_path` reports its session closed, and checks
// that the session, run with --validate, ended with no validation message.
::testing::AssertionResult agent_session_validation_clean(const std::filesystem::path &log_path);

// The client side: the validation log configure_validation() set up exists (the layer was
// loaded) and is empty.
::testing::AssertionResult client_validation_clean(const std::filesystem::path &validation_log);

// The build tree's splitvk-agent (AgentProcess has the rest).
class Agent : public AgentProcess {
public:
    Agent() : AgentProcess(agent_path()) {}
};

} // namespace splitvk::e2e
