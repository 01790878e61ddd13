#pragma once

// The client's record of the agents it trusts, as ssh's known_hosts (docs/security.md):
// $XDG_CONFIG_HOME/splitvk/known_agents (~/.config/splitvk/known_agents), one agent a line:
//
//   # comment
//   192.168.1.20:7447 sha256:3f1c...e9   (the address as SPLITVK_SERVER names it, then the
//                                         SHA-256 of the agent's certificate)
//
// The first use of an address records the certificate the agent presented; from then on a
// different certificate at that address is refused, with one line that says what changed and
// how to accept it. A line that cannot be read is reported and skipped, never fatal.

#include <string>
#include <string_view>
#include <vector>

namespace splitvk::protocol {

struct KnownAgent {
    std::string address;     // "host:port" or "[v6]:port"
    std::string fingerprint; // canonical "sha256:<hex>"
    int line = 0;
};

struct KnownAgents {
    std::vector<KnownAgent> entries;
    std::vector<std::string> problems; // one line each: "PATH:LINE: why"
};

KnownAgents parse_known_agents(std::string_view text, const std::string &path);

// The first entry for `address`, or nullptr.
const KnownAgent *find_known_agent(const KnownAgents &known, std::string_view address);

// $XDG_CONFIG_HOME/splitvk/known_agents, or $HOME/.config/splitvk/known_agents; empty when
// neither variable is set (nothing is recorded then). Arguments: the variables' values (or null).
std::string known_agents_path(const char *xdg_config_home, const char *home);

// Appends one entry (creating the directory, mode 0700, and the file, mode 0600). Empty on
// success, else one line.
std::string append_known_agent(const std::string &path, const std::string &address,
                               const std::string &fingerprint);

} // namespace splitvk::protocol
