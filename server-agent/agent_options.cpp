#include "agent_options.h"

#include "settings.h"

#include <charconv>

namespace splitvk::agent {
namespace {

std::optional<uint32_t> parse_index(const std::string &text) {
    uint32_t value = 0;
    auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    if (ec != std::errc() || end != text.data() + text.size() || text.empty()) return std::nullopt;
    return value;
}

} // namespace

const char *agent_usage() {
    return "usage: splitvk-agent [--listen ADDR:PORT] [--device N] [--token-file FILE] [--validate]\n"
           "                     [--max-sessions N]\n"
           "       splitvk-agent --list-devices\n"
           "\n"
           "The splitvk server agent: replays the command stream of applications running the\n"
           "VK_LAYER_SPLITVK_split_render layer on this machine's GPU and streams the fovea back.\n"
           "\n"
           "  --listen ADDR:PORT  address to listen on (default 127.0.0.1:7447, loopback only);\n"
           "                      a non-loopback address requires --token-file\n"
           "  --device N          index of the GPU to render on, as --list-devices prints it (default 0)\n"
           "  --token-file FILE   file holding the shared token clients must present\n"
           "  --validate          enable VK_LAYER_KHRONOS_validation (synchronization validation too) in\n"
           "                      every session and log its messages as errors\n"
           "  --max-sessions N    sessions served at once (default 16); more are rejected as server full\n"
           "  --list-devices      print the GPUs this agent can use and exit\n"
           "  --help              print this help and exit\n";
}

bool is_loopback_host(const std::string &host) {
    return host == "localhost" || host == "::1" || host.starts_with("127.");
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
            o.listen_host = settings.settings.server.host;
            o.listen_port = settings.settings.server.port;
        } else if (arg == "--device") {
            const auto v = value("a GPU index");
            if (!v) return parsed;
            const auto index = parse_index(*v);
            if (!index) {
                parsed.error = "--device '" + *v + "' is invalid: expected a GPU index from --list-devices";
                return parsed;
            }
            o.device_index = *index;
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
        } else {
            parsed.error = "unknown option '" + arg + "' (see --help)";
            return parsed;
        }
    }
    if (!o.help && !o.list_devices && !is_loopback_host(o.listen_host) && o.token_file.empty()) {
        parsed.error = "refusing to listen on non-loopback address " + o.listen_host +
                       " without --token-file: anyone on the network could drive this GPU";
    }
    return parsed;
}

} // namespace splitvk::agent
