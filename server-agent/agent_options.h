#pragma once

// splitvk-agent's command line. Parsing is separate from main() so it is unit-tested.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace splitvk::agent {

// 64 MiB: what the layer itself can send (its connection refuses larger payloads), so a larger
// message never comes from a real client.
inline constexpr uint32_t kDefaultMaxMessageBytes = 64u << 20;
// 4 GiB of host memory and 8 GiB of GPU memory per session: several times what splitvk-atrium or
// a VR title at 2400x1080 uses, well below what a server with one GPU shared by a few sessions has.
inline constexpr uint64_t kDefaultMaxHostMemory = uint64_t{4} << 30;
inline constexpr uint64_t kDefaultMaxGpuMemory = uint64_t{8} << 30;

struct AgentOptions {
    std::string listen_host = "127.0.0.1";
    uint16_t listen_port = 7447;
    uint32_t device_index = 0;
    // --device UUID: the GPU whose deviceUUID this is (32 hex digits, dashes allowed), resolved to
    // device_index at start; empty: device_index as given.
    std::string device_uuid;
    std::string token_file;
    bool validate = false;      // VK_LAYER_KHRONOS_validation in every session, messages logged
    uint32_t max_sessions = 16; // sessions served at once; more are rejected as ServerFull
    // Per-session caps (docs/security.md). Going over one ends that session with one log line.
    uint32_t max_message_bytes = kDefaultMaxMessageBytes; // any received payload, raw or decompressed
    uint64_t max_host_memory = kDefaultMaxHostMemory;     // client data the session keeps in host memory
    uint64_t max_gpu_memory = kDefaultMaxGpuMemory;       // VkDeviceMemory the client asks for
    std::string record_corpus;                            // debug: write received messages here
    // A Khronos profile JSON: the agent behaves as a device with those limits and features
    //, to test what a stricter GPU would do without one.
    std::string emulate_limits;
    // The session process's confinement (confinement.h): the user a root agent's sessions drop
    // to, and --no-confine (debugging) to leave sessions with the agent's own rights.
    std::string user = "nobody";
    bool user_given = false;
    bool confine = true;
    // The agent's TLS identity (identity.h): --tls-cert/--tls-key, or a key and self-signed
    // certificate generated on first start in --state-dir (default $STATE_DIRECTORY, which
    // systemd sets, else $XDG_STATE_HOME/splitvk-agent or ~/.local/state/splitvk-agent).
    std::string tls_cert;
    std::string tls_key;
    std::string state_dir;
    bool print_fingerprint = false;
    // --no-periphery: never grant the swapped split (capability kSwappedSplit), so every client
    // renders the periphery itself and the agent the foveae (SPLITVK_CLIENT_RENDERS=fovea clients
    // say so once and stay on the paper's split).
    bool periphery = true;
    // --advertise [NAME]: advertise the agent over DNS-SD through avahi-daemon (advertiser.h) as
    // instance NAME (default: the host and the GPU).
    bool advertise = false;
    std::string advertise_name;
    bool list_devices = false;
    bool help = false;
};

struct ParsedOptions {
    AgentOptions options;
    std::string error; // one line; empty when the command line is valid
};

ParsedOptions parse_agent_options(const std::vector<std::string> &arguments);

// The capability bits this agent's sessions offer in their handshake (protocol/handshake.h): the
// protocol's, less what the options turn off.
uint64_t agent_capabilities(const AgentOptions &options);

// "4096", "512K", "512M", "4G", "1T" (binary units: K = 1024); nullopt if malformed or over 2^63.
std::optional<uint64_t> parse_byte_size(const std::string &text);

// Loopback addresses need no token; anything else exposes a GPU command interpreter to a network.
bool is_loopback_host(const std::string &host);

// "0123...cdef" (32 hex digits) from a UUID written with or without dashes, in either case;
// nullopt when it is not one.
std::optional<std::string> normalize_gpu_uuid(const std::string &text);

const char *agent_usage();

} // namespace splitvk::agent
