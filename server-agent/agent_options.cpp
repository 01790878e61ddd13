#include "agent_options.h"

#include "handshake.h"
#include "settings.h"

#include <cctype>
#include <charconv>

#include <arpa/inet.h>

namespace splitvk::agent {
namespace {

std::optional<uint32_t> parse_index(const std::string &text) {
    uint32_t value = 0;
    auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    if (ec != std::errc() || end != text.data() + text.size() || text.empty()) return std::nullopt;
    return value;
}

} // namespace

std::optional<uint64_t> parse_byte_size(const std::string &text) {
    uint64_t value = 0;
    const char *begin = text.data(), *end = text.data() + text.size();
    auto [p, ec] = std::from_chars(begin, end, value);
    if (ec != std::errc() || p == begin) return std::nullopt;
    unsigned shift = 0;
    if (p != end) {
        switch (*p) {
        case 'K':
        case 'k':
            shift = 10;
            break;
        case 'M':
        case 'm':
            shift = 20;
            break;
        case 'G':
        case 'g':
            shift = 30;
            break;
        case 'T':
        case 't':
            shift = 40;
            break;
        default:
            return std::nullopt;
        }
        ++p;
        if (p != end && (*p == 'i' || *p == 'B')) ++p; // 4GiB, 4GB: the same binary unit
        if (p != end && *p == 'B') ++p;
        if (p != end) return std::nullopt;
    }
    if (value > (uint64_t{1} << 63 >> shift)) return std::nullopt;
    return value << shift;
}

const char *agent_usage() {
    return "usage: splitvk-agent [--listen ADDR:PORT] [--device N] [--token-file FILE] [--validate]\n"
           "                     [--max-sessions N] [--max-message-bytes SIZE] [--max-host-memory SIZE]\n"
           "                     [--max-gpu-memory SIZE] [--record-corpus DIR] [--emulate-limits FILE]\n"
           "                     [--user NAME] [--no-confine] [--tls-cert FILE --tls-key FILE]\n"
           "                     [--state-dir DIR] [--no-periphery] [--advertise [NAME]]\n"
           "       splitvk-agent --list-devices\n"
           "       splitvk-agent --print-fingerprint [--state-dir DIR | --tls-cert FILE --tls-key FILE]\n"
           "\n"
           "The splitvk server agent: replays the command stream of applications running the\n"
           "VK_LAYER_SPLITVK_split_render layer on this machine's GPU and streams the fovea back.\n"
           "\n"
           "  --listen ADDR:PORT  address to listen on (default 127.0.0.1:7447, loopback only);\n"
           "                      a non-loopback address requires --token-file\n"
           "  --device N|UUID     the GPU to render on: its index or its UUID, as --list-devices prints\n"
           "                      them (default 0)\n"
           "  --token-file FILE   file holding the shared token clients must present\n"
           "  --validate          enable VK_LAYER_KHRONOS_validation (synchronization validation too) in\n"
           "                      every session and log its messages; only its errors, not its\n"
           "                      warnings, fail the session (exit status 4)\n"
           "  --max-sessions N    sessions served at once (default 16); more are rejected as server full\n"
           "  --max-message-bytes SIZE\n"
           "                      cap on one received message, raw or decompressed (default 64M: the\n"
           "                      most the layer ever sends); 64K-2G\n"
           "  --max-host-memory SIZE\n"
           "                      cap on the client data one session keeps in host memory (default 4G)\n"
           "  --max-gpu-memory SIZE\n"
           "                      cap on the VkDeviceMemory one session's client allocates (default 8G:\n"
           "                      more than a VR title at 2400x1080 needs, so a few sessions fit one GPU)\n"
           "                      Going over a cap ends that session only, with one log line. SIZE is\n"
           "                      bytes, or with a binary suffix: 512K, 512M, 4G.\n"
           "  --record-corpus DIR debugging: write the messages each session receives to DIR as seed\n"
           "                      inputs for the fuzzers (tests/fuzz, scripts/fuzz); the first 256\n"
           "                      per session, tokens left out\n"
           "  --emulate-limits FILE\n"
           "                      behave as a GPU with the limits and features of a Khronos Vulkan\n"
           "                      profile JSON (capabilities -> properties -> VkPhysicalDeviceProperties\n"
           "                      -> limits, and features): clients are checked against them and replayed\n"
           "                      commands that break them are flagged, as on such a GPU\n"
           "  --user NAME         the user each session process drops to when the agent runs as root\n"
           "                      (default nobody); it also gets the groups of the GPU device files\n"
           "  --no-confine        debugging only: sessions keep the agent's user and rights, without\n"
           "                      no_new_privs or Landlock (docs/security.md)\n"
           "  --tls-cert FILE, --tls-key FILE\n"
           "                      the agent's TLS certificate (PEM, itself first, then any chain) and\n"
           "                      its key (PEM, no passphrase); default: a P-256 key and a self-signed\n"
           "                      certificate made on first start in the state directory\n"
           "  --state-dir DIR     where the generated identity is kept (default $STATE_DIRECTORY, else\n"
           "                      $XDG_STATE_HOME/splitvk-agent or ~/.local/state/splitvk-agent)\n"
           "  --no-periphery      never render the periphery for a client (the swapped split,\n"
           "                      SPLITVK_CLIENT_RENDERS=fovea): such clients render it themselves, as\n"
           "                      in the default split, and say so once\n"
           "  --print-fingerprint print the SHA-256 of the agent's certificate (creating the identity\n"
           "                      if there is none yet) and exit; clients pin it with\n"
           "                      SPLITVK_AGENT_FINGERPRINT or record it on first use\n"
           "  --advertise [NAME]  advertise this agent over DNS-SD (_splitvk._tcp) through avahi-daemon,\n"
           "                      as instance NAME (default: the host name and the GPU), with its free\n"
           "                      session slots; without avahi-daemon it says so and serves anyway\n"
           "  --list-devices      print the GPUs this agent can use and exit\n"
           "  --help              print this help and exit\n";
}

uint64_t agent_capabilities(const AgentOptions &options) {
    uint64_t capabilities = protocol::kSupportedCapabilities;
    if (!options.periphery) capabilities &= ~protocol::capability::kSwappedSplit;
    return capabilities;
}

bool is_loopback_host(const std::string &host) {
    return splitvk::is_loopback_host(host);
}

std::optional<std::string> normalize_gpu_uuid(const std::string &text) {
    std::string hex;
    for (const char c : text) {
        if (c == '-') continue;
        if (!std::isxdigit(static_cast<unsigned char>(c))) return std::nullopt;
        hex += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    }
    if (hex.size() != 32) return std::nullopt;
    return hex;
}

ParsedOptions parse_agent_options(const std::vector<std::string> &arguments) {
    ParsedOptions parsed;
    AgentOptions &o = parsed.options;
    for (size_t i = 0; i < arguments.size(); ++i) {
        const std::string &arg = arguments[i];
        const auto value = [&](const char *what) -> std::optional<std::string> {
            if (i + 1 >= arguments.size()) {
                parsed.error = arg + " needs " + what;
                return std::nullopt;
            }
            return arguments[++i];
        };
        if (arg == "--help" || arg == "-h") {
            o.help = true;
        } else if (arg == "--list-devices") {
            o.list_devices = true;
        } else if (arg == "--listen") {
            const auto v = value("ADDR:PORT");
            if (!v) return parsed;
            // The same grammar as the layer's SPLITVK_SERVER, so one address works on both ends.
            Environment env = {{"SPLITVK_SERVER", *v}};
            const LoadedSettings settings = load_settings(env, "/nonexistent");
            if (!settings.valid()) {
                parsed.error = "--listen '" + *v + "' is invalid: expected HOST:PORT or [IPV6]:PORT";
                return parsed;
            }
            if (settings.settings.servers.size() > 1 || settings.settings.dnssd) {
                parsed.error = "--listen '" + *v + "' is invalid: expected one HOST:PORT or [IPV6]:PORT";
                return parsed;
            }
            o.listen_host = settings.settings.server.host;
            o.listen_port = settings.settings.server.port;
        } else if (arg == "--device") {
            const auto v = value("a GPU index or UUID");
            if (!v) return parsed;
            if (const auto index = parse_index(*v)) {
                o.device_index = *index;
                o.device_uuid.clear();
            } else if (auto uuid = normalize_gpu_uuid(*v)) {
                o.device_uuid = std::move(*uuid);
            } else {
                parsed.error =
                    "--device '" + *v + "' is invalid: expected a GPU index or UUID from --list-devices";
                return parsed;
            }
        } else if (arg == "--token-file") {
            const auto v = value("a file");
            if (!v) return parsed;
            o.token_file = *v;
        } else if (arg == "--validate") {
            o.validate = true;
        } else if (arg == "--max-sessions") {
            const auto v = value("a number of sessions");
            if (!v) return parsed;
            const auto count = parse_index(*v);
            if (!count || *count == 0 || *count > 1024) {
                parsed.error = "--max-sessions '" + *v + "' is invalid: expected 1-1024";
                return parsed;
            }
            o.max_sessions = *count;
        } else if (arg == "--max-message-bytes" || arg == "--max-host-memory" || arg == "--max-gpu-memory") {
            const auto v = value("a size such as 512M or 4G");
            if (!v) return parsed;
            const auto size = parse_byte_size(*v);
            if (arg == "--max-message-bytes") {
                // Below 64 KiB not even the setup of a small application fits; 2 GiB keeps the
                // u32 length (and the reader's arithmetic) far from overflow.
                if (!size || *size < (uint64_t{64} << 10) || *size > (uint64_t{2} << 30)) {
                    parsed.error = arg + " '" + *v + "' is invalid: expected a size from 64K to 2G";
                    return parsed;
                }
                o.max_message_bytes = static_cast<uint32_t>(*size);
            } else {
                if (!size || *size == 0) {
                    parsed.error = arg + " '" + *v + "' is invalid: expected a size such as 512M or 4G";
                    return parsed;
                }
                (arg == "--max-host-memory" ? o.max_host_memory : o.max_gpu_memory) = *size;
            }
        } else if (arg == "--emulate-limits") {
            const auto v = value("a Vulkan profile JSON file");
            if (!v) return parsed;
            o.emulate_limits = *v;
        } else if (arg == "--record-corpus") {
            const auto v = value("a directory");
            if (!v) return parsed;
            o.record_corpus = *v;
        } else if (arg == "--user") {
            const auto v = value("a user name");
            if (!v) return parsed;
            if (v->empty() || *v == "root" || *v == "0") {
                parsed.error = "--user '" + *v + "' is invalid: sessions must run as an unprivileged user";
                return parsed;
            }
            o.user = *v;
            o.user_given = true;
        } else if (arg == "--no-confine") {
            o.confine = false;
        } else if (arg == "--tls-cert" || arg == "--tls-key" || arg == "--state-dir") {
            const auto v = value(arg == "--state-dir" ? "a directory" : "a PEM file");
            if (!v) return parsed;
            if (v->empty()) {
                parsed.error = arg + " '' is invalid: expected a path";
                return parsed;
            }
            (arg == "--tls-cert" ? o.tls_cert : arg == "--tls-key" ? o.tls_key : o.state_dir) = *v;
        } else if (arg == "--print-fingerprint") {
            o.print_fingerprint = true;
        } else if (arg == "--no-periphery") {
            o.periphery = false;
        } else if (arg == "--advertise") {
            o.advertise = true;
            // NAME is optional: the next argument is it unless it is an option.
            if (i + 1 < arguments.size() && !arguments[i + 1].starts_with("--")) {
                o.advertise_name = arguments[++i];
                // A DNS-SD instance name is one DNS label: at most 63 bytes.
                if (o.advertise_name.empty() || o.advertise_name.size() > 63) {
                    parsed.error =
                        "--advertise '" + o.advertise_name + "' is invalid: expected a name of 1-63 bytes";
                    return parsed;
                }
            }
        } else {
            parsed.error = "unknown option '" + arg + "' (see --help)";
            return parsed;
        }
    }
    if (o.tls_cert.empty() != o.tls_key.empty()) {
        parsed.error = o.tls_cert.empty() ? "--tls-key needs --tls-cert (the certificate of that key)"
                                          : "--tls-cert needs --tls-key (the certificate's private key)";
        return parsed;
    }
    if (!o.help && !o.list_devices && !o.print_fingerprint && !is_loopback_host(o.listen_host) &&
        o.token_file.empty()) {
        parsed.error = "refusing to listen on non-loopback address " + o.listen_host +
                       " without --token-file: anyone on the network could drive this GPU";
    }
    return parsed;
}

} // namespace splitvk::agent
