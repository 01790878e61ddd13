#pragma once

// splitvk's settings (docs/architecture.md §6): environment variables SPLITVK_<NAME>, and keys
// `splitvk_split_render.<name>` in a Khronos-style vk_layer_settings.txt found through
// VK_LAYER_SETTINGS_PATH (a file or a directory holding one) or the working directory.
// The environment wins. Parsing is table-driven so the docs, the tests and the parser
// cannot disagree about names and accepted values.

#include "log.h"

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace splitvk {

enum class EyeMode { Auto, One, Two };
// SPLITVK_TLS: auto is TLS for every address but loopback.
enum class TlsMode { Auto, On, Off };
// X264, Zstd and Raw are the fovea tiles' codecs (SPLITVK_CODEC); H264Yuv420 and HevcYuv420 code
// only the swapped split's periphery, always lossily (SPLITVK_PERIPHERY_CODEC, tiles/tile_codec.h).
enum class TileCodec { X264, Zstd, Raw, H264Yuv420, HevcYuv420 };
// SPLITVK_TARGETS: Auto scales every screen-space target on the client; Swapchain only
// the passes into the swapchain image, as the first version did.
enum class TargetMode { Auto, Swapchain };
// SPLITVK_UNSUPPORTED: what vkCreateDevice does when the application enables a device
// extension splitvk does not forward (codegen/allowlist.py). Fail answers
// VK_ERROR_EXTENSION_NOT_PRESENT; Passthrough creates that device as asked and leaves it alone:
// no session, no split, every command straight to the driver.
enum class UnsupportedMode { Fail, Passthrough };

// SPLITVK_SPLIT: whether the split must pay for itself. Auto measures a window's frames split and
// passed through (layer/model/split_payoff.h) and splits only while that is faster; Forced (`always`)
// splits every frame it can, as a benchmark or a test of the split needs.
enum class SplitMode { Auto, Forced };

// SPLITVK_AGENT_SCISSOR: off replays the agent's offscreen passes in full; guard:N also
// scissors its passes into screen-space targets to the foveae grown by N pixels of each target.
struct AgentScissor {
    bool guard = false;
    uint32_t pixels = 0; // N; at most kMaxAgentScissorGuard
};
inline constexpr uint32_t kMaxAgentScissorGuard = 4096;

// SPLITVK_CLIENT_RENDERS: which side renders what. Periphery, the paper's split: the
// client renders the periphery at SPLITVK_SCALE and the agent the foveae, losslessly. Fovea, the
// swapped split: the client renders only the foveae at full resolution and the agent the periphery,
// streamed lossily (SPLITVK_PERIPHERY_QUALITY). Decided at the first connection (capability
// kSwappedSplit); an agent that cannot do it leaves the client on Periphery, with one line.
enum class ClientRenders { Periphery, Fovea };

// SPLITVK_PERIPHERY_QUALITY: the agent's periphery encoding in the swapped split: x264 at
// constant quality `crf` (0 best .. 51), or lossless.
struct PeripheryQuality {
    bool lossless = false;
    uint32_t crf = 20;
    bool operator==(const PeripheryQuality &) const = default;
};
inline constexpr uint32_t kMaxPeripheryCrf = 51;

// SPLITVK_PERIPHERY_CODEC: how a lossy periphery travels. H264 (H.264 High 4:2:0) and Hevc (HEVC Main)
// are what headsets' hardware decoders take; Rgb is x264's High 4:4:4 Predictive on the RGB bytes,
// which only software decodes, kept for measurement. A lossless periphery is always Rgb.
enum class PeripheryCodec { H264, Hevc, Rgb };

// SPLITVK_CLIENT_GUARD: in the swapped split, the client's passes into screen-space
// targets are cut to the foveae grown by `pixels` of each target (the rule of SPLITVK_AGENT_SCISSOR's
// guard:N, with its caveat), or rendered in full.
struct ClientGuard {
    bool full = false;
    uint32_t pixels = 64;
};

// SPLITVK_SEAM: in the swapped split, how the client's foveae meet the agent's lossy
// periphery. Feather: the client renders each fovea grown by `pixels` (split::seam_rect) and the
// compositor blends its pixels into the upsampled periphery across that band, from the periphery at
// the band's outer edge to the client's at the fovea's; the fovea itself stays exact. Hard (or
// feather:0): the periphery meets the fovea at its edge. The default, 16 pixels: about 10 texels of
// the periphery at SPLITVK_SCALE 0.6, wider than the bilinear upsample's reach (2 pixels) and than
// x264's 8x8 transform blocks seen at full resolution (13 pixels), so the step from sharp to blurry
// becomes a gradient; it costs the client 16% more pixels per fovea (512x360 grown to 544x392).
struct Seam {
    uint32_t feather = 16; // pixels; 0: hard
};
inline constexpr uint32_t kMaxSeamFeather = 256;

// SPLITVK_UPSAMPLE: how the compositor upsamples the periphery over the image outside the foveae
// (either split). Bilinear: one hardware-filtered tap, by vkCmdBlitImage where the format blits;
// Bicubic: Catmull-Rom through 9 bilinear taps, by a draw, sharper and several times the cost on
// a CPU rasteriser (docs/BENCHMARKS.md, "Upsample filters").
enum class UpsampleMode { Bilinear, Bicubic };

// SPLITVK_GAZE: where the foveae sit. Fixed: centred in each eye (at the view direction
// under OpenXR), the same every frame; OpenXR: where the runtime's eye tracking says the eyes look
// (layer/xr/xr_gaze.h; OpenXR eye images only); Fifo: at the gaze points another process writes into a
// named pipe (layer/model/gaze.h).
enum class GazeMode { Fixed, OpenXR, Fifo };

struct ServerAddress {
    std::string host = "127.0.0.1";
    uint16_t port = 7447;
    bool operator==(const ServerAddress &) const = default;
};

// The fovea of one eye: either absolute pixels, or fractions of the eye's extent. The default,
// 512x360 of a 1200x1080 eye, is the paper's, kept as fractions so other eye sizes scale alike.
// SPLITVK_FOVEA=auto sizes it per frame from measured times (layer/model/fovea_size.h),
// starting from the default; width and height are then the most it may grow to, as fractions (the
// whole eye unless auto:WxH says less), since the agent shades that much of every eye.
struct FoveaSize {
    bool fractional = true;
    double width = 512.0 / 1200.0;
    double height = 360.0 / 1080.0;
    bool automatic = false;

    // The fovea's size in pixels for an eye of eye_width x eye_height, clamped to the eye.
    std::pair<uint32_t, uint32_t> pixels_for_eye(uint32_t eye_width, uint32_t eye_height) const;
};

struct Settings {
    // SPLITVK_SERVER: the agent to dial (the first of `servers`, or the one chosen among those found
    // over DNS-SD, as layer/core/agent_candidates.h sets it for each dial).
    ServerAddress server;
    // HOST:PORT[,HOST:PORT...]: every agent named, first first; empty when only `server` is (the
    // default) and with dnssd.
    std::vector<ServerAddress> servers;
    // dnssd or dnssd:NAME: agents found over DNS-SD (_splitvk._tcp), or only the instance NAME.
    bool dnssd = false;
    std::string dnssd_name;
    // SPLITVK_AGENTS: agents the foveae come from, one per eye with 2 (protocol::FoveaAgents).
    uint32_t agents = 1;
    double scale = 0.6;
    FoveaSize fovea;
    SplitMode split = SplitMode::Auto;
    EyeMode eyes = EyeMode::Auto;
    TargetMode targets = TargetMode::Auto;
    AgentScissor agent_scissor;
    ClientRenders client_renders = ClientRenders::Periphery;
    PeripheryQuality periphery_quality;
    PeripheryCodec periphery_codec = PeripheryCodec::H264;
    ClientGuard client_guard;
    Seam seam;
    UpsampleMode upsample = UpsampleMode::Bilinear;
    GazeMode gaze = GazeMode::Fixed;
    // SPLITVK_FOVEA_MASK: the client leaves the foveae out of the periphery it shades,
    // through the depth of its passes into the swapchain image, where that is exact
    // (layer/capture/fovea_mask.h).
    bool fovea_mask = true;
    std::string gaze_fifo; // GazeMode::Fifo: the pipe's path
    // SPLITVK_XR_DEADLINE: an OpenXR eye image waits for its tiles only while it can still meet its
    // display time (layer/model/frame_deadline.h); off: up to tile_wait_ms, as a window's present.
    bool xr_deadline = true;
    // SPLITVK_MAX_MBPS: the most tile traffic SPLITVK_FOVEA=auto may grow the fovea to, in Mbit/s;
    // 0: no bound but the eye.
    double max_mbps = 0;
    TileCodec codec = TileCodec::X264;
    // Lockstep bound: a present waits at most this long for its own frame's tiles. Generous for a
    // LAN (a frame is ~10-20 ms), short enough that a stalled agent costs seconds, not a hang.
    uint32_t tile_wait_ms = 250;
    // Split frames the application's vkQueuePresentKHR may leave to the layer's present thread,
    // which waits for their tiles, composites and presents while the application goes on
    // (layer/present/present.cpp). 0: the application's present does all of that itself, which gives each
    // frame the least latency (docs/BENCHMARKS.md, "Present depth").
    uint32_t present_depth = 0;
    std::string stats_path; // empty: no per-frame statistics
    LogLevel log_level = LogLevel::Warn;
    std::string token; // SPLITVK_TOKEN, or the contents of SPLITVK_TOKEN_FILE
    std::string token_file;
    bool verify = false; // SPLITVK_VERIFY=full: compare every presented frame with the agent's
    // SPLITVK_ENVELOPE: auto tells the application limits both sides honour; client
    // tells it the client's own, unchecked, which only a diagnosis should want.
    bool envelope = true;
    UnsupportedMode unsupported = UnsupportedMode::Fail;
    TlsMode tls = TlsMode::Auto;
    // SPLITVK_AGENT_FINGERPRINT: the agent's certificate, canonical "sha256:<hex>"; empty: trust
    // on first use through known_agents (known_agents.h).
    std::string agent_fingerprint;

    // Whether the link to `server` runs TLS: on, off, or (auto) unless its host is loopback.
    bool use_tls() const;
};

// "sha256:ab01...", "SHA256:AB:01:...", "ab01..." (what `openssl x509 -fingerprint -sha256`
// prints, too): the canonical "sha256:<64 lowercase hex>", or nothing when it is not a SHA-256.
std::optional<std::string> normalize_fingerprint(std::string_view text);

// Numeric loopback addresses (127.0.0.0/8, ::1, ::ffff:127.x) and "localhost". A name such as
// "127.example.com" resolves to whatever its DNS says, so no textual prefix test.
bool is_loopback_host(const std::string &host);

// One row of the settings table: what the docs list and the parser accepts.
struct SettingInfo {
    const char *name;     // "SCALE": SPLITVK_SCALE / splitvk_split_render.scale
    const char *accepted; // human-readable accepted values, quoted in errors
    const char *default_value;
    const char *description;
};

std::span<const SettingInfo> setting_table();

// A SPLITVK_* environment variable that the project's scripts or test programs read, not the
// layer: the layer takes it for none of its settings and does not warn about it, since a user who
// exports one (SPLITVK_CACHE, to move the Monado build) runs every Vulkan application with it.
struct ScriptVariable {
    const char *name;    // the whole variable: "SPLITVK_CACHE"
    const char *read_by; // "scripts/xr-runtime"
    const char *description;
};

std::span<const ScriptVariable> script_variable_table();

using Environment = std::vector<std::pair<std::string, std::string>>;

struct LoadedSettings {
    Settings settings;
    std::vector<std::string> errors;   // one line each: a bad value, naming the setting and what it accepts
    std::vector<std::string> warnings; // one line each: unknown keys, unreadable files
    std::string file_path;             // the settings file read, empty if none

    bool valid() const { return errors.empty(); }
};

// Parses settings from an environment snapshot and the settings file it points to. A bad value
// leaves that setting at its default and adds an error; parsing always completes.
LoadedSettings load_settings(const Environment &environment, const std::string &working_directory);

// The same, from this process's environment and working directory.
LoadedSettings load_process_settings();

const char *to_string(EyeMode mode);
const char *to_string(TileCodec codec);
const char *to_string(PeripheryCodec codec);                   // "h264", "hevc", "rgb"
std::string to_string(const AgentScissor &scissor);            // "off", "guard:64"
std::string to_string(GazeMode mode, const std::string &fifo); // "fixed", "openxr", "fifo:/run/gaze"
const char *to_string(LogLevel level);
const char *to_string(UnsupportedMode mode);

} // namespace splitvk
