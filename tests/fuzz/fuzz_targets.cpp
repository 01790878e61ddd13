#include "fuzz_targets.h"

#include "device_envelope.h"
#include "handshake.h"
#include "known_agents.h"
#include "metadata.h"
#include "settings.h"
#include "tile_codec.h"
#include "tls.h"
#include "vk_codec.h"
#include "wire.h"

extern "C" {
#include <libavutil/log.h>
}

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <span>
#include <string>
#include <variant>
#include <vector>

namespace splitvk::fuzz {
namespace {

// Reads every byte of a value through a volatile pointer, so the compiler keeps the loads and the
// sanitizers see them: the decoded data must be readable, whatever the input was.
volatile unsigned g_sink = 0;

template <class T>
void touch(const T &value) {
    const auto *bytes = reinterpret_cast<const volatile unsigned char *>(&value);
    unsigned sum = 0;
    for (size_t i = 0; i < sizeof(T); ++i)
        sum += bytes[i];
    g_sink = g_sink + sum;
}

void touch_bytes(std::span<const uint8_t> bytes) {
    unsigned sum = 0;
    for (const uint8_t b : bytes)
        sum += b;
    g_sink = g_sink + sum;
}

// The agent's decode path without a GPU: every command is decoded (the decoder itself reads and
// bounds-checks every pointee into the arena), its decoded structure is read, and the objects it
// creates are registered (with agent handle 0, as no driver created them), so that a
// later command naming them resolves like in a session. Nothing is executed.
class TouchVisitor final : public codec::CommandVisitor {
public:
    explicit TouchVisitor(codec::HandleTable &table) : table_(table) {}

    bool unhandled(codec::VkCommandId) override { return true; }

#define SPLITVK_FUZZ_VISIT(name)                                                                             \
    bool name(const codec::Decoded_##name &c) override {                                                     \
        return visit(c);                                                                                     \
    }
#include "fuzz_visitor_overrides.inc"
#undef SPLITVK_FUZZ_VISIT

private:
    template <class T>
    bool visit(const T &c) {
        touch(c);
        if constexpr (requires { codec::apply_handle_changes(table_, c, nullptr); }) {
            // A refused registration (an id reused for another type) ends the replayer's session;
            // here it ends this input's commands the same way.
            std::string error;
            return codec::apply_handle_changes(table_, c, &error);
        }
        return true;
    }

    codec::HandleTable &table_;
};

// SPLITVK_FUZZ_VERBOSE=1: one line per message that fails to decode, to see how far a seed gets
// (a recorded stream should decode to its end). Off while fuzzing: nearly every mutated input
// fails, and the writes would cost more than the decoding.
bool verbose() {
    static const bool on = std::getenv("SPLITVK_FUZZ_VERBOSE") != nullptr;
    return on;
}

// Small enough that a decompression bomb costs milliseconds per input, large enough for recorded
// Commands and MemoryData payloads; the checks against the cap are the same at any value.
constexpr uint32_t kFuzzMaxPayload = 8u << 20;

void decode_commands(std::span<const uint8_t> payload, codec::HandleTable &table, codec::Arena &arena) {
    codec::Decoder d(payload, table, arena);
    TouchVisitor visitor(table);
    // As Replayer::replay: until the payload ends or the first error, and like it, the physical
    // device vkCreateDevice names (the client's enumeration is not forwarded) is registered first.
    while (d.ok() && !d.at_end()) {
        const size_t offset = d.offset();
        if (payload.size() - offset >= 10 && protocol::load_le16(payload.data() + offset) ==
                                                 static_cast<uint16_t>(codec::VkCommandId::vkCreateDevice)) {
            const uint64_t id = protocol::load_le64(payload.data() + offset + 2);
            const auto *entry = table.find(id);
            if (id != 0 && !(entry && entry->type == VK_OBJECT_TYPE_PHYSICAL_DEVICE) &&
                !table.insert(id, VK_OBJECT_TYPE_PHYSICAL_DEVICE, uint64_t{0}))
                break;
        }
        if (!codec::dispatch_decoded(d, visitor)) break;
    }
    if (!d.ok() && verbose()) std::fprintf(stderr, "Commands: %s\n", d.error().c_str());
    arena.reset();
}

void decode_control(const protocol::Message &m) {
    using protocol::MessageType;
    const std::span<const uint8_t> p = m.payload;
    switch (static_cast<MessageType>(m.type)) {
    case MessageType::Hello:
        if (auto hello = protocol::decode_hello(p)) {
            // The server's decision: token comparison, version, capabilities, fingerprint.
            protocol::ServerHandshakeConfig config;
            config.token = {'s', 'e', 'c', 'r', 'e', 't'};
            config.codec_fingerprint = protocol::session_fingerprint(codec::kCodecFingerprint);
            // The device envelope a client sends, decoded and checked as the agent does.
            config.check_envelope = [](std::span<const uint8_t> blob) -> std::string {
                auto envelope = protocol::decode_device_description(blob);
                if (!envelope) return envelope.error();
                protocol::DeviceDescription self = *envelope;
                self.limits.minUniformBufferOffsetAlignment = 256;
                return protocol::refusal(self, *envelope);
            };
            const auto verdict = protocol::evaluate_hello(*hello, config);
            g_sink = g_sink + static_cast<unsigned>(verdict.index());
        }
        break;
    case MessageType::Welcome:
        if (auto welcome = protocol::decode_welcome(p)) {
            const std::string problem = protocol::check_welcome(protocol::Hello{}, *welcome);
            g_sink = g_sink + static_cast<unsigned>(problem.size());
        }
        break;
    case MessageType::Reject:
        if (auto reject = protocol::decode_reject(p)) touch(reject->reason);
        break;
    case MessageType::Goodbye:
        if (auto bye = protocol::decode_goodbye(p))
            g_sink = g_sink + static_cast<unsigned>(bye->message.size());
        break;
    default:
        break;
    }
}

void decode_metadata(const protocol::Message &m, codec::HandleTable &table) {
    using protocol::MessageType;
    const std::span<const uint8_t> p = m.payload;
    switch (static_cast<MessageType>(m.type)) {
    case MessageType::MemoryData:
        if (auto d = protocol::decode_memory_data(p, kFuzzMaxPayload)) touch_bytes(d->bytes);
        break;
    case MessageType::FrameBegin:
        if (auto d = protocol::decode_frame_begin(p)) touch(d->frame);
        break;
    case MessageType::FramePresent:
        if (auto d = protocol::decode_frame_present(p))
            for (const auto &image : d->images)
                touch(image);
        break;
    case MessageType::Tiles:
        if (auto d = protocol::decode_tiles(p, kFuzzMaxPayload))
            for (const auto &tile : d->tiles)
                touch_bytes(tile.data);
        break;
    case MessageType::SwapchainImages:
        if (auto d = protocol::decode_swapchain_images(p)) {
            // As the agent's SwapchainImages does: the images become objects later commands name.
            for (const uint64_t id : d->image_ids)
                if (!table.insert(id, VK_OBJECT_TYPE_IMAGE, uint64_t{0})) break;
        }
        break;
    case MessageType::SwapchainDestroyed:
        if (auto d = protocol::decode_swapchain_destroyed(p)) touch(d->swapchain_id);
        break;
    case MessageType::VerifyFrame:
        if (auto d = protocol::decode_verify_frame(p, kFuzzMaxPayload)) touch_bytes(d->pixels);
        break;
    case MessageType::SplitConfig:
        if (auto d = protocol::decode_split_config(p)) touch(d->codec);
        break;
    case MessageType::SwapchainView:
        if (auto d = protocol::decode_swapchain_view(p)) touch(d->angle_left);
        break;
    case MessageType::BufferAddress:
        if (auto d = protocol::decode_buffer_address(p)) touch(d->address);
        break;
    case MessageType::PeripheryConfig:
        if (auto d = protocol::decode_periphery_config(p)) touch(d->scale);
        break;
    case MessageType::ImageLayouts:
        if (auto d = protocol::decode_image_layouts(p)) {
            // As the agent's ImageLayouts does: the id must name a live image.
            if (const auto *image = table.find(d->image_id)) touch(image->type);
            for (const auto &sub : d->subresources)
                touch(sub);
        }
        break;
    default:
        break;
    }
}

} // namespace

void agent_messages(const uint8_t *data, size_t size) {
    // Every defined type is accepted (the agent's own policy is stricter: only what a client
    // sends), so the decoders of both directions are reached from one stream.
    protocol::ReceivePolicy policy;
    policy.max_payload = kFuzzMaxPayload;
    policy.unknown_types = protocol::UnknownTypePolicy::Reject;
    protocol::FrameDecoder frames(policy);

    std::vector<protocol::Message> messages;
    if (!frames.feed({data, size}, messages) && verbose())
        std::fprintf(stderr, "framing: %s\n", frames.error().c_str());

    codec::HandleTable table;
    codec::Arena arena;
    for (const protocol::Message &m : messages) {
        switch (protocol::message_class(m.type)) {
        case protocol::MessageClass::Control:
            decode_control(m);
            break;
        case protocol::MessageClass::Vulkan:
            decode_commands(m.payload, table, arena);
            break;
        case protocol::MessageClass::Metadata:
            decode_metadata(m, table);
            break;
        case protocol::MessageClass::Invalid:
            break;
        }
    }
}

void tile_decoder(const uint8_t *data, size_t size) {
    // FFmpeg reports every broken packet on stderr; while fuzzing that is most inputs, and the
    // writes would cost more than the decoding.
    static const bool quiet = [] {
        if (!verbose()) av_log_set_level(AV_LOG_QUIET);
        return true;
    }();
    (void)quiet;
    if (size < 2) return;
    static constexpr TileCodec kCodecs[] = {TileCodec::X264, TileCodec::Zstd, TileCodec::Raw};
    const TileCodec codec = kCodecs[data[0] % 3];
    // Half the inputs decode as the swapped split's periphery does, lossy x264 tiles accepted, and
    // half as an 8-byte image's foveae do (an x264 decoder of those is refused at once).
    const bool accept_lossy = (data[0] / 3) % 2 == 1;
    const uint32_t texel_bytes = (data[0] / 6) % 2 == 1 ? 8 : 4;
    const TileSize tile = kFuzzTileSizes[data[1] % kFuzzTileSizeCount];
    std::string error;
    auto decoder =
        tiles::make_tile_decoder(codec, tile.width, tile.height, texel_bytes, &error, accept_lossy);
    if (!decoder) return;
    std::vector<uint8_t> pixels(size_t{tile.width} * tile.height * texel_bytes);
    std::span<const uint8_t> rest(data + 2, size - 2);
    for (size_t i = 0; i < kFuzzMaxTiles && rest.size() >= 4; ++i) {
        const size_t length = std::min<size_t>(protocol::load_le32(rest.data()), rest.size() - 4);
        const std::span<const uint8_t> encoded = rest.subspan(4, length);
        rest = rest.subspan(4 + length);
        if (decoder->decode(encoded, pixels.data(), &error)) touch_bytes(pixels);
    }
}

namespace {

// One identity and both contexts for the whole run: making a key per input would be most of the
// work, and a session's contexts are made once too.
struct TlsContexts {
    std::shared_ptr<protocol::TlsContext> server;
    std::shared_ptr<protocol::TlsContext> client;
};

const TlsContexts &tls_contexts() {
    static const TlsContexts contexts = [] {
        TlsContexts made;
        auto identity = protocol::generate_tls_identity("splitvk-agent fuzz", std::chrono::hours(-1),
                                                        std::chrono::hours(24));
        if (!identity) std::abort();
        auto server = protocol::TlsContext::server(*identity);
        // The layer's verdict depends on the certificate only; refuse every other one, as a
        // changed key would be.
        auto client = protocol::TlsContext::client([](const protocol::CertificateInfo &cert) {
            return cert.fingerprint.back() < '8' ? std::string() : "changed: " + cert.fingerprint;
        });
        if (!server || !client) std::abort();
        made.server = std::move(server).value();
        made.client = std::move(client).value();
        return made;
    }();
    return contexts;
}

} // namespace

void tls_handshake(const uint8_t *data, size_t size) {
    if (size == 0) return;
    const bool client = data[0] & 1;
    const uint8_t *peer = data + 1;
    const size_t peer_size = size - 1;
    const TlsContexts &contexts = tls_contexts();
    std::vector<uint8_t> sent;
    std::vector<uint8_t> received;
    const std::string outcome = protocol::tls_over_memory(client ? *contexts.client : *contexts.server, peer,
                                                          peer_size, &sent, &received);
    touch_bytes(std::span<const uint8_t>(reinterpret_cast<const uint8_t *>(outcome.data()), outcome.size()));
    touch_bytes(sent);
    touch_bytes(received);
    if (client) return;
    // The agent's plaintext path: its first-bytes check, then the first message's payload as a
    // Hello, refused for a non-loopback peer.
    if (peer_size >= 6) g_sink = g_sink + static_cast<unsigned>(protocol::classify_first_bytes(peer));
    if (peer_size > protocol::kHeaderSize) {
        auto hello = protocol::decode_hello(
            std::span<const uint8_t>(peer + protocol::kHeaderSize, peer_size - protocol::kHeaderSize));
        if (hello) {
            protocol::ServerHandshakeConfig config;
            config.token = {'t', 'o', 'k'};
            config.require_tls = "use TLS";
            const auto decision = protocol::evaluate_hello(*hello, config);
            if (!std::holds_alternative<protocol::Reject>(decision))
                std::abort(); // plaintext must never pass
            touch_bytes(protocol::encode_reject(std::get<protocol::Reject>(decision)));
        }
    }
}

void known_agents(const uint8_t *data, size_t size) {
    const std::string_view text(reinterpret_cast<const char *>(data), size);
    const protocol::KnownAgents known = protocol::parse_known_agents(text, "known_agents");
    for (const auto &entry : known.entries) {
        const protocol::KnownAgent *found = protocol::find_known_agent(known, entry.address);
        if (!found || found->line > entry.line) std::abort(); // the first entry for an address
        if (normalize_fingerprint(entry.fingerprint) != entry.fingerprint) std::abort();
        touch_bytes(std::span<const uint8_t>(reinterpret_cast<const uint8_t *>(entry.address.data()),
                                             entry.address.size()));
    }
    for (const auto &problem : known.problems)
        if (problem.find('\n') != std::string::npos) std::abort(); // one line each
    // The same text as one SPLITVK_AGENT_FINGERPRINT value.
    if (const auto fingerprint = normalize_fingerprint(text); fingerprint && fingerprint->size() != 71)
        std::abort();
}

} // namespace splitvk::fuzz
