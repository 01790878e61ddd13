#pragma once

// The agent's TLS identity (docs/security.md "The link"): the operator's certificate and
// key (--tls-cert/--tls-key), or a P-256 key and a self-signed certificate the agent makes on its
// first start and keeps in its state directory (agent.key, mode 0600, and agent.crt). Loaded once
// by the listener, before any session is forked: a confined session could not read the files.

#include "agent_options.h"
#include "result.h"
#include "tls.h"

#include <string>

namespace splitvk::agent {

struct AgentIdentity {
    protocol::TlsIdentity identity;
    protocol::CertificateInfo certificate;
    std::string source;     // where it came from, for the log: a file, or the state directory
    bool generated = false; // made just now
};

// --state-dir, else $STATE_DIRECTORY (systemd's StateDirectory=; the first of a ':' list), else
// $XDG_STATE_HOME/splitvk-agent, else $HOME/.local/state/splitvk-agent; empty if none is set.
std::string agent_state_dir(const AgentOptions &options);

// Loads the identity, making it first when the state directory holds none. One line on failure.
protocol::Result<AgentIdentity> load_agent_identity(const AgentOptions &options);

} // namespace splitvk::agent
