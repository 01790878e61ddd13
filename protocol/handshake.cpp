#include "handshake.h"

#include "wire.h"

#include <algorithm>
#include <cstdio>

namespace splitvk::protocol {
namespace {

std::string clean_text(std::string_view text, size_t cap) {
    std::string out(text.substr(0, cap));
    for (char &c : out) {
        const auto u = static_cast<unsigned char>(c);
        if (u < 0x20 || u == 0x7F) c = '?';
    }
    return out;
}

bool has_control_characters(std::string_view text) {
    return std::any_of(text.begin(), text.end(), [](char c) {
        const auto u = static_cast<unsigned char>(c);
        return u < 0x20 || u == 0x7F;
    });
}

// Reads a capped text field that must hold no control characters.
std::string read_text(WireReader &reader, uint32_t cap, const char *field) {
    std::string text = reader.string(cap, field);
    if (reader.ok() && has_control_characters(text))
        reader.fail(std::string(field) + " holds control characters");
    return text;
}

std::string version_string(uint32_t version) {
    return std::to_string(protocol_major(version)) + "." + std::to_string(protocol_minor(version));
}

// Trailing bytes are a newer minor's appended fields, allowed only from a newer minor.
bool finish(WireReader &reader, uint32_t peer_version, const char *what) {
    if (!reader.ok()) return false;
    if (protocol_minor(peer_version) > kProtocolMinor) return true;
    return reader.expect_end(what);
}

} // namespace

const char *to_string(RejectReason reason) {
    switch (reason) {
    case RejectReason::Unspecified:
        return "unspecified";
    case RejectReason::VersionMismatch:
        return "protocol version mismatch";
    case RejectReason::BadToken:
        return "bad token";
    case RejectReason::ServerFull:
        return "server full";
    case RejectReason::Malformed:
        return "malformed handshake";
    case RejectReason::NotAuthorised:
        return "not authorised";
    case RejectReason::DeviceMismatch:
        return "the agent's GPU cannot honour the application's device limits";
    case RejectReason::TlsRequired:
        return "TLS required";
    }
    return "unspecified";
}

std::vector<uint8_t> encode_hello(const Hello &hello) {
    WireWriter w(64 + hello.token.size() + hello.client_name.size() + hello.client_gpu_name.size());
    w.bytes(kHelloMagic);
    w.u32(hello.protocol_version);
    w.u64(hello.capabilities);
    w.blob(hello.token);
    w.string(clean_text(hello.client_name, kMaxNameBytes));
    w.string(clean_text(hello.client_gpu_name, kMaxNameBytes));
    w.u64(hello.codec_fingerprint);
    w.blob(hello.device_envelope);
    return w.take();
}

Result<Hello> decode_hello(std::span<const uint8_t> payload) {
    WireReader r(payload);
    Hello hello;
    const auto magic = r.bytes(sizeof(kHelloMagic), "magic");
    if (!r.ok()) return Error{"malformed Hello: " + r.error()};
    if (!std::equal(magic.begin(), magic.end(), std::begin(kHelloMagic)))
        return Error{"malformed Hello: bad magic (not a splitvk client)"};
    hello.protocol_version = r.u32("protocol_version");
    if (!r.ok()) return Error{"malformed Hello: " + r.error()};
    // Past the version, the layout belongs to the major: stop here on a different one.
    if (protocol_major(hello.protocol_version) != kProtocolMajor) return hello;
    hello.capabilities = r.u64("capabilities");
    const auto token = r.blob(kMaxTokenBytes, "token");
    hello.token.assign(token.begin(), token.end());
    hello.client_name = read_text(r, kMaxNameBytes, "client_name");
    hello.client_gpu_name = read_text(r, kMaxNameBytes, "client_gpu_name");
    hello.codec_fingerprint = r.u64("codec_fingerprint");
    if (protocol_minor(hello.protocol_version) >= 1) {
        const auto envelope = r.blob(kMaxDeviceBlobBytes, "device_envelope");
        hello.device_envelope.assign(envelope.begin(), envelope.end());
    }
    if (!finish(r, hello.protocol_version, "Hello")) return Error{"malformed Hello: " + r.error()};
    return hello;
}

std::vector<uint8_t> encode_welcome(const Welcome &welcome) {
    WireWriter w(32 + welcome.server_gpu_name.size() + welcome.server_device.size());
    w.u32(welcome.protocol_version);
    w.u64(welcome.capabilities);
    w.u64(welcome.session_id);
    w.string(clean_text(welcome.server_gpu_name, kMaxNameBytes));
    w.blob(welcome.server_device);
    return w.take();
}

Result<Welcome> decode_welcome(std::span<const uint8_t> payload) {
    WireReader r(payload);
    Welcome welcome;
    welcome.protocol_version = r.u32("protocol_version");
    if (r.ok() && protocol_major(welcome.protocol_version) != kProtocolMajor)
        return Error{"server speaks protocol " + version_string(welcome.protocol_version) + ", this client " +
                     version_string(kProtocolVersion)};
    welcome.capabilities = r.u64("capabilities");
    welcome.session_id = r.u64("session_id");
    welcome.server_gpu_name = read_text(r, kMaxNameBytes, "server_gpu_name");
    if (protocol_minor(welcome.protocol_version) >= 1) {
        const auto device = r.blob(kMaxDeviceBlobBytes, "server_device");
        welcome.server_device.assign(device.begin(), device.end());
    }
    if (!finish(r, welcome.protocol_version, "Welcome")) return Error{"malformed Welcome: " + r.error()};
    return welcome;
}

std::vector<uint8_t> encode_reject(const Reject &reject) {
    WireWriter w(16 + reject.message.size());
    w.u32(static_cast<uint32_t>(reject.reason));
    w.string(clean_text(reject.message, kMaxReasonBytes));
    return w.take();
}

Result<Reject> decode_reject(std::span<const uint8_t> payload) {
    WireReader r(payload);
    Reject reject;
    const uint32_t reason = r.u32("reason");
    reject.reason = reason <= static_cast<uint32_t>(RejectReason::TlsRequired)
                        ? static_cast<RejectReason>(reason)
                        : RejectReason::Unspecified;
    reject.message = read_text(r, kMaxReasonBytes, "message");
    // Reject's layout is frozen for every version; trailing bytes are ignored so that any future
    // version can still explain why it refused us.
    if (!r.ok()) return Error{"malformed Reject: " + r.error()};
    return reject;
}

std::vector<uint8_t> encode_goodbye(const Goodbye &goodbye) {
    WireWriter w(8 + goodbye.message.size());
    w.string(clean_text(goodbye.message, kMaxReasonBytes));
    return w.take();
}

Result<Goodbye> decode_goodbye(std::span<const uint8_t> payload) {
    WireReader r(payload);
    Goodbye goodbye;
    goodbye.message = read_text(r, kMaxReasonBytes, "message");
    if (!r.ok()) return Error{"malformed Goodbye: " + r.error()};
    return goodbye;
}

bool constant_time_equal(std::span<const uint8_t> a, std::span<const uint8_t> b) {
    // The loop runs over the longer length whatever the contents; a shorter input reads as zeros
    // past its end and the length difference is folded in at the end. `volatile` keeps the
    // compiler from turning the accumulation into an early exit.
    const size_t n = std::max(a.size(), b.size());
    volatile uint8_t diff = 0;
    for (size_t i = 0; i < n; ++i) {
        const uint8_t x = i < a.size() ? a[i] : 0;
        const uint8_t y = i < b.size() ? b[i] : 0;
        diff = static_cast<uint8_t>(diff | (x ^ y));
    }
    return diff == 0 && a.size() == b.size();
}

bool constant_time_equal(std::string_view a, std::string_view b) {
    return constant_time_equal(
        std::span<const uint8_t>(reinterpret_cast<const uint8_t *>(a.data()), a.size()),
        std::span<const uint8_t>(reinterpret_cast<const uint8_t *>(b.data()), b.size()));
}

std::variant<Welcome, Reject> evaluate_hello(const Hello &hello, const ServerHandshakeConfig &config) {
    if (!config.require_tls.empty()) return Reject{RejectReason::TlsRequired, config.require_tls};
    if (protocol_major(hello.protocol_version) != kProtocolMajor) {
        return Reject{RejectReason::VersionMismatch,
                      "client speaks protocol " + version_string(hello.protocol_version) + ", this server " +
                          version_string(kProtocolVersion) + " (the major version must match)"};
    }
    if (!config.token.empty()) {
        if (hello.token.empty())
            return Reject{RejectReason::NotAuthorised, "this server requires a token (SPLITVK_TOKEN)"};
        if (!constant_time_equal(hello.token, config.token))
            return Reject{RejectReason::BadToken, "the token does not match the server's"};
    }
    if (config.codec_fingerprint != 0 && hello.codec_fingerprint != config.codec_fingerprint) {
        return Reject{RejectReason::VersionMismatch,
                      "client and server were built from different Vulkan codecs or message layouts (vk.xml, "
                      "allow-list or splitvk version differ)"};
    }
    if (config.full) return Reject{RejectReason::ServerFull, "the server takes no more sessions"};
    if (config.check_envelope && !hello.device_envelope.empty()) {
        std::string why = config.check_envelope(hello.device_envelope);
        if (!why.empty()) return Reject{RejectReason::DeviceMismatch, std::move(why)};
    }
    Welcome welcome;
    welcome.protocol_version = kProtocolVersion;
    welcome.capabilities = hello.capabilities & config.capabilities;
    welcome.session_id = config.session_id;
    welcome.server_gpu_name = config.server_gpu_name;
    welcome.server_device = config.server_device;
    return welcome;
}

std::string check_welcome(const Hello &sent, const Welcome &welcome) {
    if (protocol_major(welcome.protocol_version) != protocol_major(sent.protocol_version))
        return "server speaks protocol " + version_string(welcome.protocol_version) + ", this client " +
               version_string(sent.protocol_version);
    if ((welcome.capabilities & ~sent.capabilities) != 0) {
        char line[96];
        std::snprintf(line, sizeof(line), "server granted capabilities 0x%llx that were not offered",
                      static_cast<unsigned long long>(welcome.capabilities & ~sent.capabilities));
        return line;
    }
    return {};
}

} // namespace splitvk::protocol
