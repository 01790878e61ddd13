#pragma once

// One session, served in its own process (docs/architecture.md §8: one worker process per context is the real
// defence): adopt the accepted socket, handshake, then replay the client's messages in order until
// the client leaves or something fails. Any decode or replay error ends the session with one log
// line naming what failed.

#include "device_envelope.h"
#include "handshake.h"
#include "transport.h"

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace splitvk::agent {

struct SessionConfig {
    uint64_t session_id = 0;
    uint32_t device_index = 0;
    bool validate = false;
    bool full = false; // over --max-sessions: reject the Hello as ServerFull
    std::vector<uint8_t> token;
    std::string gpu_name;
    // Caps (agent_options.h): over one, the session ends with one log line naming the flag.
    uint32_t max_message_bytes = protocol::kDefaultMaxPayload;
    uint64_t max_host_memory = UINT64_MAX;
    uint64_t max_gpu_memory = UINT64_MAX;
    std::string record_corpus; // --record-corpus DIR; empty: off
    // What the handshake offers (agent_capabilities: --no-periphery drops kSwappedSplit).
    uint64_t capabilities = protocol::kSupportedCapabilities;
    // The GPU as clients are told it is (--emulate-limits included): sent in Welcome, checked
    // against each client's device envelope, and what replayed commands are checked against.
    protocol::DeviceDescription device;
    // The agent's TLS identity; null: TLS clients are turned away (a loopback agent without one).
    std::shared_ptr<protocol::TlsContext> tls;
};

// Exit statuses of a session process (the listener logs them).
enum SessionExit : int {
    kSessionClosed = 0,      // the client closed or said goodbye
    kSessionError = 1,       // malformed input, a decode or replay error
    kSessionHandshake = 2,   // no valid Hello (bad token, version, a command first, timeout)
    kSessionSetup = 3,       // the agent's own Vulkan setup failed
    kSessionValidation = 4,  // closed normally, but --validate reported errors (warnings do not count)
    kSessionConfinement = 5, // the session process could not be confined (confinement.h)
};
const char *session_exit_name(int status);
// The status of a session the client closed: kSessionValidation when --validate reported errors,
// kSessionClosed otherwise (validation warnings, performance ones included, leave it clean).
int closed_session_status(uint64_t validation_errors);

// Serves one connection; returns the process exit status.
int run_session(protocol::UniqueFd socket, const SessionConfig &config);

} // namespace splitvk::agent
