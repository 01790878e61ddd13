#include "settings.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <fstream>
#include <optional>
#include <sstream>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/stat.h>
#include <unistd.h>

extern char **environ;

namespace splitvk {
namespace {

constexpr std::string_view kEnvPrefix = "SPLITVK_";
constexpr std::string_view kFilePrefix = "splitvk_split_render.";
constexpr const char *kSettingsFileName = "vk_layer_settings.txt";

// Environment variables that belong to the loader's manifest, not to the settings table.
constexpr std::string_view kManifestVariables[] = {"SPLITVK_ENABLE", "SPLITVK_DISABLE"};

const SettingInfo kSettings[] = {
    {"SERVER",
     "HOST:PORT, [IPV6]:PORT or HOST (port 1-65535), several of them comma-separated, dnssd, or dnssd:NAME",
     "127.0.0.1:7447",
     "the splitvk-agent to share frames with: an address, a list (the first that answers), or the agents "
     "advertised over DNS-SD (the one with most free slots; NAME: only that instance)"},
    {"AGENTS", "1 or 2", "1",
     "2: an agent per eye, each replaying the whole command stream and sending its own eye's foveae; needs "
     "two agents in SERVER (a list, or dnssd) and the paper's split (CLIENT_RENDERS=periphery)"},
    {"SCALE", "a number in [0.1, 1]", "0.6",
     "sampling rate of the periphery the client renders (0.6: 1440x648 of 2400x1080)"},
    {"FOVEA",
     "WxH in pixels (512x360), as fractions of the eye (0.43x0.33), auto, or auto:WxH (fractions, 0.01 to 1: "
     "the largest)",
     "512x360 of a 1200x1080 eye",
     "size of the fovea the agent renders in each eye; auto: sized per frame from measured times, as large "
     "as "
     "the agent's path keeps up with the client's own frame"},
    {"SPLIT", "auto or always", "auto",
     "auto: a window's frames are split only while that is measured to be faster than passing them "
     "through, as drawn; always: every frame the layer can split is split, whatever it costs (benchmarks, "
     "tests)"},
    {"EYES", "auto, 1 or 2", "auto",
     "eyes side by side in the swapchain image; auto: two when two viewports tile it in halves"},
    {"TARGETS", "auto or swapchain", "auto",
     "auto: the client scales every screen-space target; swapchain: only passes into the swapchain image"},
    {"AGENT_SCISSOR", "off or guard:N (N pixels, 0 to 4096)", "off",
     "guard:N: the agent also scissors its passes into screen-space targets to the foveae grown by N "
     "pixels of each target; exact only if N covers the reach of every blur or filter"},
    {"CLIENT_RENDERS", "periphery or fovea", "periphery",
     "periphery: the client renders the periphery at SCALE and the agent the foveae (the paper's split); "
     "fovea: the client renders only the foveae at full resolution and the agent the periphery, lossily"},
    {"PERIPHERY_QUALITY", "0 to 51 (x264 CRF) or lossless", "20",
     "with CLIENT_RENDERS=fovea: how the agent encodes the periphery (lower is better and larger)"},
    {"PERIPHERY_CODEC", "h264, hevc or rgb", "h264",
     "with CLIENT_RENDERS=fovea: the lossy periphery's codec: h264 (High, 4:2:0) or hevc (Main, 4:2:0), "
     "which headsets decode in hardware, or rgb (x264 High 4:4:4 on the RGB bytes, software decoding only)"},
    {"CLIENT_GUARD", "guard:N (N pixels, 0 to 4096) or full", "guard:64",
     "with CLIENT_RENDERS=fovea: the client cuts its passes into screen-space targets to the foveae grown "
     "by N pixels of each target (exact only if N covers every blur's reach); full: renders them whole"},
    {"SEAM", "feather:N (N pixels, 0 to 256) or hard", "feather:16",
     "with CLIENT_RENDERS=fovea: the client renders each fovea grown by N pixels and blends them into the "
     "agent's periphery across that band (the fovea stays exact); hard: the periphery meets the fovea at its "
     "edge"},
    {"UPSAMPLE", "bilinear or bicubic", "bilinear",
     "how the compositor upsamples the periphery outside the foveae: bilinear (a blit); bicubic: "
     "Catmull-Rom, sharper, for a client whose GPU can afford several times the upsample's cost"},
    {"FOVEA_MASK", "depth or off", "depth",
     "depth: the client leaves the foveae out of the periphery it shades, by their depth in its passes into "
     "the "
     "swapchain image, where that is exact; off: it shades them, and the tiles cover them"},
    {"GAZE", "fixed, openxr or fifo:PATH", "fixed",
     "where the foveae sit: fixed, centred in each eye; openxr, where the OpenXR runtime's eye tracking "
     "(XR_EXT_eye_gaze_interaction) says the eyes look; fifo:PATH, at the gaze points another process writes "
     "into the named pipe PATH (one line per point: x y, or lx ly rx ry, 0.5 0.5 the eye's centre)"},
    {"XR_DEADLINE", "display or off", "display",
     "display: an OpenXR eye image waits for its tiles only while it can still be shown at its display "
     "time; off: up to TILE_WAIT"},
    {"MAX_MBPS", "Mbit/s, 0 (no bound) to 100000", "0",
     "with FOVEA=auto: the most tile traffic the fovea may grow to"},
    {"CODEC", "x264, zstd or raw", "x264", "lossless codec for the fovea tiles"},
    {"TILE_WAIT", "milliseconds, 1 to 60000", "250",
     "longest a present waits for its frame's tiles; later, the centre comes from the periphery"},
    {"PRESENT_DEPTH", "0, 1 or 2", "0",
     "split frames a present may leave to the layer's present thread while the application goes on; 0: "
     "the application's present waits for the tiles itself (the least latency)"},
    {"STATS", "a file path in an existing directory", "(none)", "write per-frame statistics as CSV"},
    {"LOG_LEVEL", "off, error, warn, info or debug", "warn", "what splitvk writes to stderr"},
    {"TOKEN", "a non-empty string without whitespace", "(none)", "shared secret the agent requires"},
    {"TOKEN_FILE", "a readable file holding the token", "(none)", "file holding the shared secret"},
    {"VERIFY", "off or full", "off",
     "full: the agent returns every presented frame and the layer compares it pixel by pixel"},
    {"TLS", "auto, on or off", "auto",
     "TLS 1.3 on the link; auto: on for every agent address but loopback (the agent refuses plaintext from "
     "other addresses)"},
    {"AGENT_FINGERPRINT", "sha256: and 64 hex digits (splitvk-agent --print-fingerprint)", "(none)",
     "the agent's certificate to accept; unset: trust it on first use and record it in "
     "$XDG_CONFIG_HOME/splitvk/known_agents"},
    {"ENVELOPE", "auto or client", "auto",
     "auto: the app sees limits, features and formats that the client and every agent honour; client: the "
     "client's own, unchecked (agents then flag frames they cannot render)"},
    {"UNSUPPORTED", "fail or passthrough", "fail",
     "a device that enables an extension splitvk does not forward: fail: vkCreateDevice answers "
     "VK_ERROR_EXTENSION_NOT_PRESENT; passthrough: the device is created as asked and runs unsplit, "
     "splitvk out of its way"},
};

// Each is documented in docs/settings.md, "Variables of the scripts"; the unit tests check that
// every SPLITVK_* variable the scripts and tests read is here.
const ScriptVariable kScriptVariables[] = {
    {"SPLITVK_CACHE", "scripts/xr-runtime", "the folder Monado is built into (default ~/.cache/splitvk)"},
    {"SPLITVK_MONADO_TARBALL", "scripts/xr-runtime",
     "the Monado source snapshot to build (default ../shared/third_party/monado/)"},
    {"SPLITVK_XR_SERVICE_LOG", "scripts/xr-runtime", "a file that receives monado-service's log of each run"},
    {"SPLITVK_FUZZ_SECONDS", "scripts/test", "CPU seconds of fuzzing per target (default 60)"},
    {"SPLITVK_FUZZ_VERBOSE", "the fuzz targets (scripts/fuzz)", "one line per message that fails to decode"},
    {"SPLITVK_TEST_SHOW_LOG", "splitvk_agent_tests", "print the agent's log of a few tests"},
    {"SPLITVK_COST_SIZE", "splitvk_compositor_tests",
     "WxH of the composite whose cost the disabled test measures"},
    {"SPLITVK_E2E_BUILD_DIR", "the e2e test programs", "the build tree to test"},
    {"SPLITVK_E2E_EXPLICIT_LAYER_DIR", "the e2e test programs", "the folder of the explicit layer manifest"},
    {"SPLITVK_E2E_IMPLICIT_DATA_DIR", "the e2e test programs",
     "the data folder of the implicit layer manifest"},
    {"SPLITVK_E2E_OUTPUT_DIR", "the e2e test programs", "where the tests keep what each test ran"},
};

bool is_script_variable(std::string_view name) {
    return std::any_of(std::begin(kScriptVariables), std::end(kScriptVariables),
                       [&](const ScriptVariable &v) { return name == v.name; });
}

struct Source {
    std::string label; // "SPLITVK_SCALE" or "splitvk_split_render.scale (file:3)"
    std::string value;
};

std::string_view trim(std::string_view s) {
    while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front())))
        s.remove_prefix(1);
    while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back())))
        s.remove_suffix(1);
    return s;
}

std::string lower(std::string_view s) {
    std::string out(s);
    std::transform(out.begin(), out.end(), out.begin(), [](unsigned char c) { return std::tolower(c); });
    return out;
}

std::optional<double> parse_double(std::string_view s) {
    double value = 0;
    auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), value);
    if (ec != std::errc() || end != s.data() + s.size() || !std::isfinite(value)) return std::nullopt;
    return value;
}

std::optional<uint32_t> parse_uint(std::string_view s) {
    uint32_t value = 0;
    auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), value);
    if (ec != std::errc() || end != s.data() + s.size() || s.empty()) return std::nullopt;
    return value;
}

bool parse_server(std::string_view value, ServerAddress &out) {
    std::string_view host = value;
    std::string_view port;
    if (value.starts_with('[')) {
        const auto close = value.find(']');
        if (close == std::string_view::npos || close == 1) return false;
        host = value.substr(1, close - 1);
        const auto rest = value.substr(close + 1);
        if (!rest.empty()) {
            if (rest.front() != ':') return false;
            port = rest.substr(1);
            if (port.empty()) return false;
        }
    } else if (const auto colon = value.rfind(':'); colon != std::string_view::npos) {
        // A bare IPv6 address has several colons and must be bracketed to carry a port.
        if (value.find(':') != colon) return false;
        host = value.substr(0, colon);
        port = value.substr(colon + 1);
        if (port.empty()) return false;
    }
    if (host.empty()) return false;
    for (char c : host) {
        if (std::isspace(static_cast<unsigned char>(c)) || c == '/' || c == '[' || c == ']') return false;
    }
    ServerAddress parsed;
    parsed.host = std::string(host);
    if (!port.empty()) {
        const auto number = parse_uint(port);
        if (!number || *number == 0 || *number > 65535) return false;
        parsed.port = static_cast<uint16_t>(*number);
    }
    out = parsed;
    return true;
}

bool parse_server_list(std::string_view value, Settings &s) {
    if (lower(value) == "dnssd" || lower(value).starts_with("dnssd:")) {
        const std::string_view name = value.substr(std::min<size_t>(value.size(), 6));
        // A DNS-SD instance name is one DNS label, at most 63 bytes.
        if (value.size() > 5 && (name.empty() || name.size() > 63)) return false;
        s.dnssd = true;
        s.dnssd_name = std::string(name);
        s.servers.clear();
        return true;
    }
    std::vector<ServerAddress> servers;
    size_t start = 0;
    for (;;) {
        const size_t comma = value.find(',', start);
        ServerAddress address;
        if (!parse_server(trim(value.substr(start, comma - start)), address)) return false;
        servers.push_back(std::move(address));
        if (comma == std::string_view::npos) break;
        start = comma + 1;
    }
    s.dnssd = false;
    s.dnssd_name.clear();
    s.server = servers.front();
    s.servers = std::move(servers);
    return true;
}

bool parse_fovea(std::string_view value, FoveaSize &out) {
    const std::string text = lower(trim(value));
    if (text == "auto" || text.starts_with("auto:")) {
        FoveaSize largest{true, 1.0, 1.0};
        // Fractions only, since each frame's size is one (split::FrameFoveaSize), and at least 1/100
        // of the eye: a bound below a unit of those would be refused by the agent at every frame.
        if (text != "auto" &&
            (!parse_fovea(std::string_view(text).substr(5), largest) || !largest.fractional ||
             largest.automatic || largest.width < 0.01 || largest.height < 0.01))
            return false;
        out = largest;
        out.automatic = true;
        return true;
    }
    const auto x = value.find_first_of("xX");
    if (x == std::string_view::npos) return false;
    const auto w = value.substr(0, x);
    const auto h = value.substr(x + 1);
    const bool w_fraction = w.find('.') != std::string_view::npos;
    const bool h_fraction = h.find('.') != std::string_view::npos;
    if (w_fraction != h_fraction) return false;
    FoveaSize parsed;
    parsed.fractional = w_fraction;
    if (w_fraction) {
        const auto fw = parse_double(w);
        const auto fh = parse_double(h);
        if (!fw || !fh || *fw <= 0 || *fw > 1 || *fh <= 0 || *fh > 1) return false;
        parsed.width = *fw;
        parsed.height = *fh;
    } else {
        const auto pw = parse_uint(w);
        const auto ph = parse_uint(h);
        if (!pw || !ph || *pw == 0 || *ph == 0 || *pw > 16384 || *ph > 16384) return false;
        parsed.width = *pw;
        parsed.height = *ph;
    }
    out = parsed;
    return true;
}

std::optional<std::string> read_token_file(const std::string &path) {
    std::ifstream file(path);
    if (!file) return std::nullopt;
    std::string token;
    std::getline(file, token);
    token = std::string(trim(token));
    if (token.empty()) return std::nullopt;
    return token;
}

bool directory_exists(const std::string &path) {
    struct stat st {};
    return ::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}

// Applies one setting; false means the value is not acceptable for it.
bool apply(std::string_view name, std::string_view raw, Settings &s) {
    const std::string_view value = trim(raw);
    const std::string v = lower(value);
    if (name == "SERVER") return parse_server_list(value, s);
    if (name == "SCALE") {
        const auto scale = parse_double(value);
        if (!scale || *scale < 0.1 || *scale > 1.0) return false;
        s.scale = *scale;
        return true;
    }
    if (name == "FOVEA") return parse_fovea(value, s.fovea);
    if (name == "SPLIT") {
        if (v == "auto")
            s.split = SplitMode::Auto;
        else if (v == "always")
            s.split = SplitMode::Forced;
        else
            return false;
        return true;
    }
    if (name == "EYES") {
        if (v == "auto")
            s.eyes = EyeMode::Auto;
        else if (v == "1")
            s.eyes = EyeMode::One;
        else if (v == "2")
            s.eyes = EyeMode::Two;
        else
            return false;
        return true;
    }
    if (name == "TARGETS") {
        if (v == "auto")
            s.targets = TargetMode::Auto;
        else if (v == "swapchain")
            s.targets = TargetMode::Swapchain;
        else
            return false;
        return true;
    }
    if (name == "AGENT_SCISSOR") {
        if (v == "off") {
            s.agent_scissor = {};
            return true;
        }
        if (!v.starts_with("guard:")) return false;
        const auto pixels = parse_uint(std::string_view(v).substr(6));
        if (!pixels || *pixels > kMaxAgentScissorGuard) return false;
        s.agent_scissor = {true, *pixels};
        return true;
    }
    if (name == "AGENTS") {
        const auto agents = parse_uint(value);
        if (!agents || *agents < 1 || *agents > 2) return false;
        s.agents = *agents;
        return true;
    }
    if (name == "CLIENT_RENDERS") {
        if (v == "periphery")
            s.client_renders = ClientRenders::Periphery;
        else if (v == "fovea")
            s.client_renders = ClientRenders::Fovea;
        else
            return false;
        return true;
    }
    if (name == "PERIPHERY_QUALITY") {
        if (v == "lossless") {
            s.periphery_quality = {true, 0};
            return true;
        }
        const auto crf = parse_uint(v);
        if (!crf || *crf > kMaxPeripheryCrf) return false;
        s.periphery_quality = {false, *crf};
        return true;
    }
    if (name == "PERIPHERY_CODEC") {
        if (v == "h264")
            s.periphery_codec = PeripheryCodec::H264;
        else if (v == "hevc")
            s.periphery_codec = PeripheryCodec::Hevc;
        else if (v == "rgb")
            s.periphery_codec = PeripheryCodec::Rgb;
        else
            return false;
        return true;
    }
    if (name == "CLIENT_GUARD") {
        if (v == "full") {
            s.client_guard = {true, 0};
            return true;
        }
        if (!v.starts_with("guard:")) return false;
        const auto pixels = parse_uint(std::string_view(v).substr(6));
        if (!pixels || *pixels > kMaxAgentScissorGuard) return false;
        s.client_guard = {false, *pixels};
        return true;
    }
    if (name == "SEAM") {
        if (v == "hard") {
            s.seam = {0};
            return true;
        }
        if (!v.starts_with("feather:")) return false;
        const auto pixels = parse_uint(std::string_view(v).substr(8));
        if (!pixels || *pixels > kMaxSeamFeather) return false;
        s.seam = {*pixels};
        return true;
    }
    if (name == "UPSAMPLE") {
        if (v == "bilinear")
            s.upsample = UpsampleMode::Bilinear;
        else if (v == "bicubic")
            s.upsample = UpsampleMode::Bicubic;
        else
            return false;
        return true;
    }
    if (name == "FOVEA_MASK") {
        if (v != "depth" && v != "off") return false;
        s.fovea_mask = v == "depth";
        return true;
    }
    if (name == "GAZE") {
        if (v == "fixed" || v == "openxr") {
            s.gaze = v == "fixed" ? GazeMode::Fixed : GazeMode::OpenXR;
            s.gaze_fifo.clear();
            return true;
        }
        if (!v.starts_with("fifo:") || value.size() <= 5) return false;
        s.gaze = GazeMode::Fifo;
        s.gaze_fifo = std::string(value.substr(5)); // the path as written, not lower-cased
        return true;
    }
    if (name == "XR_DEADLINE") {
        if (v != "display" && v != "off") return false;
        s.xr_deadline = v == "display";
        return true;
    }
    if (name == "CODEC") {
        if (v == "x264")
            s.codec = TileCodec::X264;
        else if (v == "zstd")
            s.codec = TileCodec::Zstd;
        else if (v == "raw")
            s.codec = TileCodec::Raw;
        else
            return false;
        return true;
    }
    if (name == "TILE_WAIT") {
        const auto ms = parse_uint(value);
        if (!ms || *ms == 0 || *ms > 60000) return false;
        s.tile_wait_ms = *ms;
        return true;
    }
    if (name == "MAX_MBPS") {
        const auto mbps = parse_double(value);
        if (!mbps || *mbps < 0 || *mbps > 100000) return false;
        s.max_mbps = *mbps;
        return true;
    }
    if (name == "PRESENT_DEPTH") {
        const auto depth = parse_uint(value);
        if (!depth || *depth > 2) return false;
        s.present_depth = *depth;
        return true;
    }
    if (name == "STATS") {
        if (value.empty()) return false;
        const std::string path(value);
        const auto slash = path.rfind('/');
        const std::string dir = slash == std::string::npos ? "." : (slash == 0 ? "/" : path.substr(0, slash));
        if (!directory_exists(dir) || path.back() == '/') return false;
        s.stats_path = path;
        return true;
    }
    if (name == "LOG_LEVEL") {
        if (v == "off")
            s.log_level = LogLevel::Off;
        else if (v == "error")
            s.log_level = LogLevel::Error;
        else if (v == "warn" || v == "warning")
            s.log_level = LogLevel::Warn;
        else if (v == "info")
            s.log_level = LogLevel::Info;
        else if (v == "debug")
            s.log_level = LogLevel::Debug;
        else
            return false;
        return true;
    }
    if (name == "VERIFY") {
        if (v == "off")
            s.verify = false;
        else if (v == "full")
            s.verify = true;
        else
            return false;
        return true;
    }
    if (name == "ENVELOPE") {
        if (v == "auto")
            s.envelope = true;
        else if (v == "client")
            s.envelope = false;
        else
            return false;
        return true;
    }
    if (name == "UNSUPPORTED") {
        if (v == "fail")
            s.unsupported = UnsupportedMode::Fail;
        else if (v == "passthrough")
            s.unsupported = UnsupportedMode::Passthrough;
        else
            return false;
        return true;
    }
    if (name == "TLS") {
        if (v == "auto")
            s.tls = TlsMode::Auto;
        else if (v == "on")
            s.tls = TlsMode::On;
        else if (v == "off")
            s.tls = TlsMode::Off;
        else
            return false;
        return true;
    }
    if (name == "AGENT_FINGERPRINT") {
        const auto fingerprint = normalize_fingerprint(value);
        if (!fingerprint) return false;
        s.agent_fingerprint = *fingerprint;
        return true;
    }
    if (name == "TOKEN") {
        if (value.empty() || std::any_of(value.begin(), value.end(),
                                         [](unsigned char c) { return std::isspace(c) || !std::isprint(c); }))
            return false;
        s.token = std::string(value);
        return true;
    }
    if (name == "TOKEN_FILE") {
        const auto token = read_token_file(std::string(value));
        if (!token) return false;
        s.token_file = std::string(value);
        s.token = *token;
        return true;
    }
    return false;
}

const SettingInfo *find_setting(std::string_view name) {
    for (const auto &info : kSettings) {
        if (name == info.name) return &info;
    }
    return nullptr;
}

std::string known_names(std::string_view prefix, bool lowercase) {
    std::string names;
    for (const auto &info : kSettings) {
        if (!names.empty()) names += ", ";
        names += prefix;
        names += lowercase ? lower(info.name) : info.name;
    }
    return names;
}

std::string settings_file_path(const Environment &env, const std::string &working_directory) {
    for (const auto &[key, value] : env) {
        if (key != "VK_LAYER_SETTINGS_PATH" || value.empty()) continue;
        return directory_exists(value) ? value + "/" + kSettingsFileName : value;
    }
    return working_directory + "/" + kSettingsFileName;
}

} // namespace

std::pair<uint32_t, uint32_t> FoveaSize::pixels_for_eye(uint32_t eye_width, uint32_t eye_height) const {
    double w = fractional ? width * eye_width : width;
    double h = fractional ? height * eye_height : height;
    const auto clamp = [](double v, uint32_t limit) {
        return static_cast<uint32_t>(std::clamp(std::lround(v), 1L, static_cast<long>(std::max(limit, 1u))));
    };
    return {clamp(w, eye_width), clamp(h, eye_height)};
}

std::optional<std::string> normalize_fingerprint(std::string_view text) {
    while (!text.empty() && std::isspace(static_cast<unsigned char>(text.front())))
        text.remove_prefix(1);
    while (!text.empty() && std::isspace(static_cast<unsigned char>(text.back())))
        text.remove_suffix(1);
    if (text.size() >= 7) {
        std::string prefix(text.substr(0, 7));
        std::transform(prefix.begin(), prefix.end(), prefix.begin(),
                       [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
        if (prefix == "sha256:" || prefix == "sha256=") text.remove_prefix(7);
    }
    std::string hex;
    for (char c : text) {
        if (c == ':') continue;
        if (!std::isxdigit(static_cast<unsigned char>(c))) return std::nullopt;
        hex += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    }
    if (hex.size() != 64) return std::nullopt;
    return "sha256:" + hex;
}

bool is_loopback_host(const std::string &host) {
    in_addr v4{};
    if (inet_pton(AF_INET, host.c_str(), &v4) == 1) return (ntohl(v4.s_addr) >> 24) == 127;
    in6_addr v6{};
    if (inet_pton(AF_INET6, host.c_str(), &v6) == 1)
        return IN6_IS_ADDR_LOOPBACK(&v6) || (IN6_IS_ADDR_V4MAPPED(&v6) && v6.s6_addr[12] == 127);
    return host == "localhost";
}

bool Settings::use_tls() const {
    return tls == TlsMode::On || (tls == TlsMode::Auto && !is_loopback_host(server.host));
}

std::span<const SettingInfo> setting_table() {
    return kSettings;
}

std::span<const ScriptVariable> script_variable_table() {
    return kScriptVariables;
}

LoadedSettings load_settings(const Environment &environment, const std::string &working_directory) {
    LoadedSettings result;

    // name -> where its value came from; the file first so the environment overrides it.
    std::vector<std::pair<const SettingInfo *, Source>> chosen;
    const auto choose = [&](const SettingInfo *info, Source source) {
        for (auto &[existing, src] : chosen) {
            if (existing == info) {
                src = std::move(source);
                return;
            }
        }
        chosen.emplace_back(info, std::move(source));
    };

    const std::string file_path = settings_file_path(environment, working_directory);
    if (std::ifstream file(file_path); file) {
        result.file_path = file_path;
        std::string line;
        for (int line_number = 1; std::getline(file, line); ++line_number) {
            const std::string_view text = trim(line);
            if (text.empty() || text.front() == '#') continue;
            const auto eq = text.find('=');
            if (eq == std::string_view::npos) continue;
            const std::string key(trim(text.substr(0, eq)));
            if (!key.starts_with(kFilePrefix)) continue; // another layer's setting
            std::string name = key.substr(kFilePrefix.size());
            std::transform(name.begin(), name.end(), name.begin(),
                           [](unsigned char c) { return std::toupper(c); });
            const std::string label = key + " (" + file_path + ":" + std::to_string(line_number) + ")";
            if (const auto *info = find_setting(name)) {
                choose(info, Source{label, std::string(trim(text.substr(eq + 1)))});
            } else {
                result.warnings.push_back("unknown setting " + label +
                                          " ignored; known settings: " + known_names(kFilePrefix, true));
            }
        }
    }

    for (const auto &[key, value] : environment) {
        if (!key.starts_with(kEnvPrefix)) continue;
        if (std::find(std::begin(kManifestVariables), std::end(kManifestVariables), key) !=
            std::end(kManifestVariables))
            continue;
        if (is_script_variable(key)) continue;
        if (const auto *info = find_setting(std::string_view(key).substr(kEnvPrefix.size()))) {
            choose(info, Source{key, value});
        } else {
            result.warnings.push_back("unknown setting " + key +
                                      " ignored; known settings: " + known_names(kEnvPrefix, false));
        }
    }

    for (const auto &[info, source] : chosen) {
        if (!apply(info->name, source.value, result.settings)) {
            result.errors.push_back(source.label + "='" + source.value + "' is invalid: expected " +
                                    info->accepted);
        }
    }

    const bool has_token = std::any_of(chosen.begin(), chosen.end(), [](const auto &c) {
        return std::string_view(c.first->name) == "TOKEN";
    });
    const bool has_token_file = std::any_of(chosen.begin(), chosen.end(), [](const auto &c) {
        return std::string_view(c.first->name) == "TOKEN_FILE";
    });
    if (has_token && has_token_file) {
        result.errors.push_back(
            "SPLITVK_TOKEN and SPLITVK_TOKEN_FILE are both set: expected only one of them");
    }
    // An agent per eye splits the foveae between agents: it needs two of them to dial, and a split
    // whose agents send foveae (the swapped split's agent renders the one periphery, which verification
    // compares too).
    const Settings &s = result.settings;
    if (s.agents > 1 && !s.dnssd && s.servers.size() < s.agents)
        result.errors.push_back("SPLITVK_AGENTS=" + std::to_string(s.agents) +
                                " needs as many agents in SPLITVK_SERVER (a comma-separated list, or dnssd)");
    if (s.agents > 1 && s.client_renders == ClientRenders::Fovea)
        result.errors.push_back(
            "SPLITVK_AGENTS=" + std::to_string(s.agents) +
            " sends each eye's foveae from its own agent, which SPLITVK_CLIENT_RENDERS=fovea "
            "does not: expected SPLITVK_AGENTS=1 with it");
    if (s.agents > 1 && s.verify)
        result.errors.push_back("SPLITVK_AGENTS=" + std::to_string(s.agents) +
                                " and SPLITVK_VERIFY=full exclude each other: verification compares with one "
                                "agent's whole frame");
    return result;
}

LoadedSettings load_process_settings() {
    Environment environment;
    for (char **entry = environ; entry && *entry; ++entry) {
        const std::string_view text(*entry);
        const auto eq = text.find('=');
        if (eq == std::string_view::npos) continue;
        environment.emplace_back(std::string(text.substr(0, eq)), std::string(text.substr(eq + 1)));
    }
    char cwd[4096];
    const std::string working_directory = ::getcwd(cwd, sizeof(cwd)) ? cwd : ".";
    return load_settings(environment, working_directory);
}

const char *to_string(EyeMode mode) {
    switch (mode) {
    case EyeMode::Auto:
        return "auto";
    case EyeMode::One:
        return "1";
    case EyeMode::Two:
        return "2";
    }
    return "?";
}

const char *to_string(TileCodec codec) {
    switch (codec) {
    case TileCodec::X264:
        return "x264";
    case TileCodec::Zstd:
        return "zstd";
    case TileCodec::Raw:
        return "raw";
    case TileCodec::H264Yuv420:
        return "h264";
    case TileCodec::HevcYuv420:
        return "hevc";
    }
    return "?";
}

const char *to_string(PeripheryCodec codec) {
    switch (codec) {
    case PeripheryCodec::H264:
        return "h264";
    case PeripheryCodec::Hevc:
        return "hevc";
    case PeripheryCodec::Rgb:
        return "rgb";
    }
    return "?";
}

std::string to_string(const AgentScissor &scissor) {
    return scissor.guard ? "guard:" + std::to_string(scissor.pixels) : "off";
}

std::string to_string(GazeMode mode, const std::string &fifo) {
    switch (mode) {
    case GazeMode::Fixed:
        break;
    case GazeMode::OpenXR:
        return "openxr";
    case GazeMode::Fifo:
        return "fifo:" + fifo;
    }
    return "fixed";
}

const char *to_string(UnsupportedMode mode) {
    switch (mode) {
    case UnsupportedMode::Fail:
        return "fail";
    case UnsupportedMode::Passthrough:
        return "passthrough";
    }
    return "?";
}

const char *to_string(LogLevel level) {
    switch (level) {
    case LogLevel::Off:
        return "off";
    case LogLevel::Error:
        return "error";
    case LogLevel::Warn:
        return "warn";
    case LogLevel::Info:
        return "info";
    case LogLevel::Debug:
        return "debug";
    }
    return "?";
}

} // namespace splitvk
