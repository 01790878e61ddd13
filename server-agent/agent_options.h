#pragma once

// splitvk-agent's command line. Parsing is separate from main() so it is unit-tested.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace splitvk::agent {

struct AgentOptions {
    std::string listen_host = "127.0.0.1";
    uint16_t listen_port = 7447;
    uint32_t device_index = 0;
    std::string token_file;
    bool validate = false;      // VK_LAYER_KHRONOS_validation in every session, messages logged
    uint32_t max_sessions = 16; // sessions served at once; more are rejected as ServerFull
    bool list_devices = false;
    bool help = false;
};

struct ParsedOptions {
    AgentOptions options;
    std::string error; // one line; empty when the command line is valid
};

ParsedOptions parse_agent_options(const std::vector<std::string> &arguments);

// Loopback addresses need no token; anything else exposes a GPU command interpreter to a network.
bool is_loopback_host(const std::string &host);

const char *agent_usage();

} // namespace splitvk::agent
