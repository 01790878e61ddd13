#pragma once

// The agent's listener: accepts connections and serves each in a forked child process, so a crash
// in one session never takes down the listener or another session. The parent stays
// single-threaded (the Acceptor is plain POSIX: nothing to inherit across fork), reaps its children,
// logs one line per session start and end, and stops cleanly on SIGTERM / SIGINT.

#include "advertiser.h"
#include "agent_options.h"
#include "device_envelope.h"
#include "tls.h"

#include <memory>
#include <optional>
#include <string>

namespace splitvk::agent {

// Serves until SIGTERM or SIGINT; returns the process exit status. `device` is the GPU as sessions
// present it to clients: the real one, narrowed by --emulate-limits. `tls` is the agent's TLS
// identity (null when it has none, which only a loopback agent may run without). `advertisement`
// (--advertise) is published over DNS-SD while it listens, its free slots kept up to date.
int run_listener(const AgentOptions &options, const std::string &gpu_name,
                 const protocol::DeviceDescription &device, std::shared_ptr<protocol::TlsContext> tls,
                 const std::optional<Advertisement> &advertisement);

} // namespace splitvk::agent
