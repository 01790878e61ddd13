#pragma once

// The versioned handshake (docs/architecture.md §3). The client's first message is Hello; the server answers
// Welcome or Reject (and then closes). Nothing else may be sent before Hello / Welcome.
//
// Version policy: protocol_version is (major << 16) | minor. The major must match exactly: a
// different major may lay out any message differently, so the server rejects it with
// RejectReason::VersionMismatch. Minors of one major are compatible: features added in a minor
// are used only when both sides advertise their capability bit, and a decoder ignores fields a
// newer minor appended at the end of Hello / Welcome. Welcome carries the server's own version.
//
// Frozen across every version, so that a mismatch can always be reported: the first 8 bytes of
// Hello (magic, protocol_version) and the whole Reject layout (u32 reason, string message).

#include "result.h"

#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

namespace splitvk::protocol {

inline constexpr uint16_t kProtocolMajor = 1;
// Minor 1: Hello carries the device envelope, Welcome the agent's device.
inline constexpr uint16_t kProtocolMinor = 1;

constexpr uint32_t make_protocol_version(uint16_t major, uint16_t minor) {
    return (static_cast<uint32_t>(major) << 16) | minor;
}
constexpr uint16_t protocol_major(uint32_t version) {
    return static_cast<uint16_t>(version >> 16);
}
constexpr uint16_t protocol_minor(uint32_t version) {
    return static_cast<uint16_t>(version & 0xFFFF);
}
inline constexpr uint32_t kProtocolVersion = make_protocol_version(kProtocolMajor, kProtocolMinor);

// The layouts of the metadata messages (metadata.h), which the generated codec's fingerprint does not
// cover. Bumped whenever one changes, and folded into the fingerprint Hello carries
// (session_fingerprint), so that peers laying them out differently refuse each other at the
// handshake instead of misreading a message mid-session.
//   2: SwapchainView carries the eye's array layer and sub-image rectangle, EncodedTile its layer.
//   3: VerifyFrame carries every array layer of the image, with their count.
//   4: FramePresent carries the frame's gaze, SplitConfig whether the gaze moves (SPLITVK_GAZE).
//   5: FramePresent carries the frame's fovea size (SPLITVK_FOVEA=auto).
//   6: FramePresent's gaze also places an OpenXR eye image's first two eyes (SPLITVK_GAZE=openxr, or
//      fifo under OpenXR), where an older agent kept them at the view directions.
//   7: PeripheryConfig says whether the agent replays whole frames (the client verifies) or draws the
//      periphery scaled.
//   8: PeripheryConfig carries the periphery's codec (SPLITVK_PERIPHERY_CODEC), and EncodedTile may
//      name the 4:2:0 codecs.
//   9: SplitConfig says which of the foveae the agent sends, and FramePresent the number of the image's
//      first eye (SPLITVK_AGENTS: an agent per eye).
inline constexpr uint64_t kMetadataLayout = 9;

// What Hello's codec_fingerprint carries and the server compares: the generated codec's
// kCodecFingerprint with kMetadataLayout mixed in (FNV-1a over its 8 bytes).
constexpr uint64_t session_fingerprint(uint64_t codec_fingerprint) {
    uint64_t h = codec_fingerprint;
    for (int i = 0; i < 8; ++i) {
        h ^= (kMetadataLayout >> (8 * i)) & 0xFF;
        h *= 0x100000001b3ull;
    }
    return h;
}

// "SPVK", the first four bytes of every Hello payload.
inline constexpr uint8_t kHelloMagic[4] = {'S', 'P', 'V', 'K'};

// Capability bits. Welcome carries the intersection of the client's and the server's; a feature
// is used only if its bit is in it. Bits not listed are reserved and must be ignored.
namespace capability {
inline constexpr uint64_t kZstdPayloads = 1ull << 0; // compressed payloads (kFlagCompressed) accepted
inline constexpr uint64_t kVerifyFrames = 1ull
                                          << 1; // the server returns whole presented frames (SPLITVK_VERIFY)
inline constexpr uint64_t kFoveaTiles = 1ull << 2; // the split: SplitConfig, fovea shading, Tiles
// SplitConfig may carry SPLITVK_AGENT_SCISSOR; an agent without it refuses the longer
// message, so the client sends it only when this bit was granted.
inline constexpr uint64_t kAgentScissor = 1ull << 3;
// The swapped split (SPLITVK_CLIENT_RENDERS=fovea): the agent renders the periphery and
// streams it lossily; the client renders the foveae. Offered only by a client that asks for it;
// granted by an agent unless it runs with --no-periphery. With it the client may send
// PeripheryConfig (metadata.h) after SplitConfig.
inline constexpr uint64_t kSwappedSplit = 1ull << 4;
} // namespace capability
inline constexpr uint64_t kSupportedCapabilities = capability::kZstdPayloads | capability::kVerifyFrames |
                                                   capability::kFoveaTiles | capability::kAgentScissor |
                                                   capability::kSwappedSplit;

// Field caps, enforced by the decoders (and by the encoders, which clamp text to them).
inline constexpr uint32_t kMaxTokenBytes = 256;
inline constexpr uint32_t kMaxNameBytes = 256; // VK_MAX_PHYSICAL_DEVICE_NAME_SIZE
inline constexpr uint32_t kMaxReasonBytes = 512;
inline constexpr uint32_t kMaxDeviceBlobBytes = 64 * 1024; // an encoded DeviceDescription

struct Hello {
    uint32_t protocol_version = kProtocolVersion;
    uint64_t capabilities = kSupportedCapabilities;
    std::vector<uint8_t> token; // the session secret (docs/architecture.md §6 TOKEN); empty: none
    std::string client_name;    // the application, for the server's logs
    std::string client_gpu_name;
    // kCodecFingerprint of the client's generated codec: both sides must be built from the same
    // vk.xml and allow-list, or their command encodings differ.
    uint64_t codec_fingerprint = 0;
    // The device envelope the application was told (protocol/device_envelope.h, encoded); empty
    // when the client checks nothing (SPLITVK_ENVELOPE=client) or greets the agent at
    // vkCreateInstance, before it has told the application anything.
    std::vector<uint8_t> device_envelope;
};

struct Welcome {
    uint32_t protocol_version = kProtocolVersion;
    uint64_t capabilities = 0; // intersection of both sides' capabilities
    uint64_t session_id = 0;
    std::string server_gpu_name;
    std::vector<uint8_t> server_device; // the agent's device as it replays (encoded DeviceDescription)
};

enum class RejectReason : uint32_t {
    Unspecified = 0, // also what an unknown reason from a newer peer decodes to
    VersionMismatch = 1,
    BadToken = 2,
    ServerFull = 3,
    Malformed = 4,
    NotAuthorised = 5,
    DeviceMismatch = 6, // the agent's GPU cannot honour the device envelope the app was told
    TlsRequired = 7,    // plaintext from a peer that must use TLS (a non-loopback address)
};
const char *to_string(RejectReason reason);

struct Reject {
    RejectReason reason = RejectReason::Unspecified;
    std::string message; // one line
};

// Goodbye: an orderly end of the session, with a one-line reason, before closing.
struct Goodbye {
    std::string message;
};

// Encoders clamp text fields to their caps and replace control characters (which would break
// one-line logs) with '?'. The token is written as given: a token over kMaxTokenBytes makes the
// peer reject the Hello as malformed.
std::vector<uint8_t> encode_hello(const Hello &hello);
std::vector<uint8_t> encode_welcome(const Welcome &welcome);
std::vector<uint8_t> encode_reject(const Reject &reject);
std::vector<uint8_t> encode_goodbye(const Goodbye &goodbye);

// Decoders never trust the input: a one-line error on anything malformed (bad magic, truncation,
// over-cap lengths, control characters in text, trailing bytes from a peer of the same or an
// older minor). decode_hello stops after the version when the major differs and returns a Hello
// holding only protocol_version, so the server can reject it as a version mismatch rather than as
// malformed.
Result<Hello> decode_hello(std::span<const uint8_t> payload);
Result<Welcome> decode_welcome(std::span<const uint8_t> payload);
Result<Reject> decode_reject(std::span<const uint8_t> payload);
Result<Goodbye> decode_goodbye(std::span<const uint8_t> payload);

// Compares secrets in time that depends only on the lengths, never on where they differ: every
// byte position up to the longer length is compared, with no early exit.
bool constant_time_equal(std::span<const uint8_t> a, std::span<const uint8_t> b);
bool constant_time_equal(std::string_view a, std::string_view b);

// The server's decision on a Hello.
struct ServerHandshakeConfig {
    std::vector<uint8_t> token; // required token; empty: any token (or none) is accepted
    uint64_t capabilities = kSupportedCapabilities;
    std::string server_gpu_name;
    uint64_t session_id = 0;
    bool full = false;                  // the server takes no more sessions
    uint64_t codec_fingerprint = 0;     // the server's kCodecFingerprint; 0: not checked
    std::vector<uint8_t> server_device; // sent in Welcome
    // Whether this server can honour a client's device envelope: empty when it can, else one line
    // saying why not. Unset: not checked.
    std::function<std::string(std::span<const uint8_t> envelope)> check_envelope;
    // Non-empty: this client must not be served over this connection (plaintext from a
    // non-loopback peer); every Hello is refused as TlsRequired with this line, before its token
    // is looked at, so that a plaintext peer learns nothing about the token either.
    std::string require_tls;
};
std::variant<Welcome, Reject> evaluate_hello(const Hello &hello, const ServerHandshakeConfig &config);

// The client's check of a Welcome against its Hello: the major matches and the capabilities are a
// subset of what it offered. Empty when fine, else one line.
std::string check_welcome(const Hello &sent, const Welcome &welcome);

} // namespace splitvk::protocol
