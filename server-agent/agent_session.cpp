#include "agent_session.h"

#include "corpus_recorder.h"
#include "log.h"
#include "metadata.h"
#include "replayer.h"
#include "vk_codec.h"

#include <algorithm>
#include <chrono>
#include <unordered_map>

namespace splitvk::agent {

using namespace std::chrono_literals;
using protocol::MessageType;
using protocol::to_wire;

namespace {

constexpr auto kHandshakeTimeout = 10s;

// The types a client may send; anything else (the rest of the Vulkan range included) is a
// protocol error that ends the session.
bool client_type(uint16_t type) {
    switch (static_cast<MessageType>(type)) {
    case MessageType::Hello:
    case MessageType::Goodbye:
    case MessageType::Ping:
    case MessageType::Pong:
    case MessageType::Commands:
    case MessageType::MemoryData:
    case MessageType::FrameBegin:
    case MessageType::FramePresent:
    case MessageType::SwapchainImages:
    case MessageType::SwapchainDestroyed:
    case MessageType::SplitConfig:
    case MessageType::ImageLayouts:
    case MessageType::SwapchainView:
    case MessageType::BufferAddress:
    case MessageType::PeripheryConfig:
        return true;
    default:
        return false;
    }
}

class Session {
public:
    Session(std::unique_ptr<protocol::Connection> connection, const SessionConfig &config,
            std::string require_tls)
        : connection_(std::move(connection)), config_(config), require_tls_(std::move(require_tls)),
          replayer_(config.session_id, {config.max_host_memory, config.max_gpu_memory}, config.device) {
        if (!config.record_corpus.empty())
            recorder_ = std::make_unique<CorpusRecorder>(config.record_corpus, config.session_id);
    }

    int run();

private:
    int fail(const std::string &what, int status);
    // --max-gpu-memory for the offscreen images that stand for swapchain images, which the
    // replayer allocates outside MemoryRebind: their own count, capped like the others.
    bool swapchain_memory(const protocol::SwapchainImages &m, std::string *error);
    // Handles one message; false with `error` set ends the session.
    bool handle(protocol::Message &message, bool *done, std::string *error);
    static double milliseconds_since(std::chrono::steady_clock::time_point start);
    void log_first_frame() const;

    std::unique_ptr<protocol::Connection> connection_;
    SessionConfig config_;
    std::string require_tls_; // plaintext from a non-loopback peer: refuse its Hello with this
    Replayer replayer_;
    std::unique_ptr<CorpusRecorder> recorder_;
    std::unordered_map<uint64_t, uint64_t> swapchain_bytes_; // by swapchain id
    uint64_t swapchain_total_ = 0;
    uint64_t messages_ = 0;
    uint64_t frames_ = 0;
    uint64_t capabilities_ = 0; // granted in the Welcome
    // Where a joining session's time goes before its first frame (the client's resync):
    // from the handshake, the device set-up, waiting for messages (the client reading back and
    // sending its snapshot, the I/O thread decompressing it) and replaying them.
    struct FirstFrame {
        std::chrono::steady_clock::time_point handshake;
        double setup_ms = 0;
        double replay_ms = 0;
        double memory_ms = 0; // of replay_ms: MemoryData (the contents the snapshot carries)
        uint64_t payload_bytes = 0;
    } first_frame_;
};

double Session::milliseconds_since(std::chrono::steady_clock::time_point start) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

// Its draw and encode follow on the tile streamer's thread and reach the client's SPLITVK_STATS.
void Session::log_first_frame() const {
    const double total = milliseconds_since(first_frame_.handshake);
    SPLITVK_INFO("session %llu: first frame submitted for its tiles %.0f ms after the handshake: %.0f ms "
                 "setting up the device, %.0f replaying %.1f MiB of messages (%.0f of it memory data), %.0f "
                 "waiting for them",
                 static_cast<unsigned long long>(config_.session_id), total, first_frame_.setup_ms,
                 first_frame_.replay_ms, static_cast<double>(first_frame_.payload_bytes) / (1 << 20),
                 first_frame_.memory_ms,
                 std::max(0.0, total - first_frame_.setup_ms - first_frame_.replay_ms));
}

int Session::fail(const std::string &what, int status) {
    SPLITVK_ERROR("session %llu: %s; closing", static_cast<unsigned long long>(config_.session_id),
                  what.c_str());
    if (connection_->is_open()) {
        protocol::Goodbye bye{what};
        connection_->send(MessageType::Goodbye, protocol::encode_goodbye(bye));
        connection_->flush(1000ms);
    }
    connection_->close("session error");
    return status;
}

bool Session::swapchain_memory(const protocol::SwapchainImages &m, std::string *error) {
    // An OpenXR runtime's images are the client's own vkCreateImage, counted as images already.
    if (m.source == protocol::SwapchainImages::Source::Runtime) return true;
    // 8 bytes per pixel: the widest format a surface presents (R16G16B16A16_SFLOAT); the decoder
    // bounds every factor, so the product cannot overflow.
    const uint64_t bytes = uint64_t{m.width} * m.height * 8 * m.array_layers * m.image_ids.size();
    uint64_t &slot = swapchain_bytes_[m.swapchain_id];
    const uint64_t total = swapchain_total_ - slot + bytes;
    if (total > config_.max_gpu_memory) {
        *error = "SwapchainImages: " + std::to_string(bytes) +
                 " bytes of offscreen images would take the session's swapchain images to " +
                 std::to_string(total) + " bytes, over --max-gpu-memory (" +
                 std::to_string(config_.max_gpu_memory) + " bytes)";
        return false;
    }
    swapchain_total_ = total;
    slot = bytes;
    return true;
}

int Session::run() {
    connection_->start([](const std::string &) {});
    protocol::ServerHandshakeConfig handshake;
    handshake.token = config_.token;
    handshake.server_gpu_name = config_.gpu_name;
    handshake.session_id = config_.session_id;
    handshake.capabilities = config_.capabilities;
    handshake.full = config_.full;
    handshake.require_tls = require_tls_;
    handshake.codec_fingerprint = protocol::session_fingerprint(codec::kCodecFingerprint);
    handshake.server_device = protocol::encode(config_.device);
    handshake.check_envelope = [this](std::span<const uint8_t> blob) -> std::string {
        auto envelope = protocol::decode_device_description(blob);
        if (!envelope) return "unreadable device envelope: " + envelope.error();
        return protocol::refusal(config_.device, *envelope);
    };
    auto hs = protocol::server_handshake(*connection_, handshake, kHandshakeTimeout);
    if (!hs) {
        SPLITVK_ERROR("session %llu: handshake failed: %s; closing",
                      static_cast<unsigned long long>(config_.session_id), hs.error().c_str());
        connection_->close("handshake failed");
        return kSessionHandshake;
    }
    if (recorder_) recorder_->hello(hs->hello);
    capabilities_ = hs->welcome.capabilities;
    if (!(hs->welcome.capabilities & protocol::capability::kZstdPayloads)) {
        protocol::CompressionPolicy off;
        off.enabled = false;
        connection_->set_compression(off);
    }
    SPLITVK_INFO("session %llu: %s (%s) from %s, %s", static_cast<unsigned long long>(config_.session_id),
                 hs->hello.client_name.c_str(), hs->hello.client_gpu_name.c_str(),
                 connection_->peer_address().c_str(), connection_->security().c_str());
    if (!hs->hello.device_envelope.empty()) {
        if (auto envelope = protocol::decode_device_description(hs->hello.device_envelope)) {
            const auto gaps = protocol::format_gaps(config_.device, *envelope);
            if (!gaps.empty())
                SPLITVK_WARN(
                    "session %llu: %zu formats have features the client's application was told but this "
                    "GPU lacks (first: VkFormat %d); images that need them are flagged",
                    static_cast<unsigned long long>(config_.session_id), gaps.size(),
                    static_cast<int>(gaps.front()));
        }
    }
    std::string error;
    first_frame_.handshake = std::chrono::steady_clock::now();
    if (!replayer_.init(config_.device_index, config_.validate, &error)) return fail(error, kSessionSetup);
    first_frame_.setup_ms = milliseconds_since(first_frame_.handshake);
    // Tiles are sent from the tile streamer's worker thread; Connection::send is thread-safe and
    // keeps them in order with everything else this session sends.
    replayer_.set_tile_sender([this](std::vector<uint8_t> &&payload, std::string *send_error) {
        const auto r = connection_->send_owned(MessageType::Tiles, std::move(payload), 10000ms);
        if (r == protocol::SendResult::Queued) return true;
        // A client ends its session by closing its side without waiting for the tiles of frames it
        // will not composite (an unsplit one waits for none): the backlog of frames the session
        // still replays after that has tiles nobody reads, which is no error. Tiles it left unread
        // make its close a reset, and the send that meets it fails: its close all the same.
        if (r == protocol::SendResult::Closed && connection_->closed_by_peer()) return true;
        *send_error = std::string("sending Tiles: ") + protocol::to_string(r);
        return false;
    });

    for (;;) {
        auto message = connection_->receive(500ms);
        if (!message) {
            if (connection_->is_open()) continue;
            if (connection_->closed_by_peer()) break;
            return fail(connection_->close_reason(), kSessionError);
        }
        ++messages_;
        if (recorder_) recorder_->message(message->type, message->payload);
        bool done = false;
        // Until the first frame, each message is timed (log_first_frame); after it, none is.
        const bool before_first_frame = frames_ == 0;
        const auto start =
            before_first_frame ? std::chrono::steady_clock::now() : std::chrono::steady_clock::time_point{};
        if (!handle(*message, &done, &error)) return fail(error, kSessionError);
        if (before_first_frame) {
            const double ms = milliseconds_since(start);
            first_frame_.replay_ms += ms;
            first_frame_.payload_bytes += message->payload.size();
            if (message->type == to_wire(MessageType::MemoryData)) first_frame_.memory_ms += ms;
            if (frames_ != 0) log_first_frame();
        }
        if (done) break;
    }
    connection_->close("session over");
    const auto errors = replayer_.context().validation_errors();
    SPLITVK_INFO("session %llu: closed after %llu messages, %llu commands, %llu submits, %llu frames; %llu "
                 "validation errors, %llu validation warnings; memory data while the GPU worked: %llu queued "
                 "behind it, %llu after waiting for it",
                 static_cast<unsigned long long>(config_.session_id),
                 static_cast<unsigned long long>(messages_),
                 static_cast<unsigned long long>(replayer_.commands_replayed()),
                 static_cast<unsigned long long>(replayer_.submits()),
                 static_cast<unsigned long long>(frames_), static_cast<unsigned long long>(errors),
                 static_cast<unsigned long long>(replayer_.context().validation_warnings()),
                 static_cast<unsigned long long>(replayer_.memory_queued()),
                 static_cast<unsigned long long>(replayer_.memory_waited()));
    return closed_session_status(errors);
}

bool Session::handle(protocol::Message &message, bool *done, std::string *error) {
    switch (static_cast<MessageType>(message.type)) {
    case MessageType::Commands:
        return replayer_.replay(message.payload, error);
    case MessageType::MemoryData: {
        auto m = protocol::decode_memory_data(message.payload, config_.max_message_bytes);
        if (!m) {
            *error = "MemoryData: " + m.error();
            return false;
        }
        return replayer_.memory_data(*m, error);
    }
    case MessageType::SwapchainImages: {
        auto m = protocol::decode_swapchain_images(message.payload);
        if (!m) {
            *error = "SwapchainImages: " + m.error();
            return false;
        }
        if (!swapchain_memory(*m, error)) return false;
        return replayer_.swapchain_images(*m, error);
    }
    case MessageType::SwapchainDestroyed: {
        auto m = protocol::decode_swapchain_destroyed(message.payload);
        if (!m) {
            *error = "SwapchainDestroyed: " + m.error();
            return false;
        }
        if (auto it = swapchain_bytes_.find(m->swapchain_id); it != swapchain_bytes_.end()) {
            swapchain_total_ -= it->second;
            swapchain_bytes_.erase(it);
        }
        return replayer_.swapchain_destroyed(*m, error);
    }
    case MessageType::SplitConfig: {
        auto m = protocol::decode_split_config(message.payload);
        if (!m) {
            *error = "SplitConfig: " + m.error();
            return false;
        }
        return replayer_.split_config(*m, error);
    }
    case MessageType::PeripheryConfig: {
        if (!(capabilities_ & protocol::capability::kSwappedSplit)) {
            *error = "PeripheryConfig without capability kSwappedSplit (not granted to this session)";
            return false;
        }
        auto m = protocol::decode_periphery_config(message.payload);
        if (!m) {
            *error = "PeripheryConfig: " + m.error();
            return false;
        }
        return replayer_.periphery_config(*m, error);
    }
    case MessageType::ImageLayouts: {
        auto m = protocol::decode_image_layouts(message.payload);
        if (!m) {
            *error = "ImageLayouts: " + m.error();
            return false;
        }
        return replayer_.image_layouts(*m, error);
    }
    case MessageType::BufferAddress: {
        auto m = protocol::decode_buffer_address(message.payload);
        if (!m) {
            *error = "BufferAddress: " + m.error();
            return false;
        }
        return replayer_.buffer_address(*m, error);
    }
    case MessageType::SwapchainView: {
        auto m = protocol::decode_swapchain_view(message.payload);
        if (!m) {
            *error = "SwapchainView: " + m.error();
            return false;
        }
        return replayer_.swapchain_view(*m, error);
    }
    case MessageType::FrameBegin: {
        auto m = protocol::decode_frame_begin(message.payload);
        if (!m) {
            *error = "FrameBegin: " + m.error();
            return false;
        }
        return true; // a frame mark; the fovea work starts here
    }
    case MessageType::FramePresent: {
        auto m = protocol::decode_frame_present(message.payload);
        if (!m) {
            *error = "FramePresent: " + m.error();
            return false;
        }
        std::vector<protocol::VerifyFrame> frames;
        if (!replayer_.frame_present(*m, frames, error)) return false;
        ++frames_;
        for (auto &frame : frames) {
            const auto r =
                connection_->send_owned(MessageType::VerifyFrame, protocol::encode(frame), 10000ms);
            // Closed by the client: the loop ends the session when it has taken what came before.
            if (r == protocol::SendResult::Closed && connection_->closed_by_peer()) break;
            if (r != protocol::SendResult::Queued) {
                *error = std::string("sending VerifyFrame: ") + protocol::to_string(r);
                return false;
            }
        }
        return true;
    }
    case MessageType::Ping:
        connection_->send(MessageType::Pong, message.payload);
        return true;
    case MessageType::Pong:
        return true;
    case MessageType::Goodbye:
        *done = true;
        return true;
    default:
        *error = std::string("unexpected ") + protocol::message_type_name(message.type) +
                 " message from the client";
        return false;
    }
}

} // namespace

int closed_session_status(uint64_t validation_errors) {
    return validation_errors ? kSessionValidation : kSessionClosed;
}

const char *session_exit_name(int status) {
    switch (status) {
    case kSessionClosed:
        return "closed by the client";
    case kSessionError:
        return "error";
    case kSessionHandshake:
        return "handshake failed";
    case kSessionSetup:
        return "Vulkan setup failed";
    case kSessionValidation:
        return "closed, with validation errors";
    case kSessionConfinement:
        return "confinement failed";
    default:
        return "unknown exit status";
    }
}

int run_session(protocol::UniqueFd socket, const SessionConfig &config) {
    protocol::ConnectionOptions options;
    options.name = "session " + std::to_string(config.session_id);
    // What the client may send is capped by --max-message-bytes; what the agent sends back (a
    // whole frame for SPLITVK_VERIFY) by the protocol's own cap, which the layer receives with.
    options.max_payload = std::max(protocol::kDefaultMaxPayload, config.max_message_bytes);
    options.max_receive_payload = config.max_message_bytes;
    options.max_receive_payload_name = "--max-message-bytes";
    options.unknown_types = protocol::UnknownTypePolicy::Reject;
    options.is_known_type = client_type;
    const unsigned long long id = config.session_id;
    // TLS or plaintext, from the client's first bytes: the agent serves both on one port, and
    // refuses plaintext from anywhere but this machine (docs/security.md, "The link").
    const bool loopback = protocol::peer_is_loopback(socket.get());
    const std::string peer = protocol::peer_address_of(socket.get());
    auto first = protocol::sniff_first_bytes(socket.get(), kHandshakeTimeout);
    if (!first) {
        SPLITVK_ERROR("session %llu: handshake failed: %s (from %s); closing", id, first.error().c_str(),
                      peer.c_str());
        return kSessionHandshake;
    }
    std::string require_tls;
    if (*first == protocol::FirstBytes::Tls) {
        if (!config.tls) {
            SPLITVK_ERROR(
                "session %llu: a TLS client, but this agent has no TLS identity (see its first lines); "
                "closing",
                id);
            return kSessionHandshake;
        }
        options.tls = config.tls;
        options.tls_handshake_timeout = kHandshakeTimeout;
    } else if (!loopback) {
        require_tls =
            "this agent takes plaintext only from its own machine; use TLS (SPLITVK_TLS=auto or on)";
    }
    auto connection = protocol::Connection::adopt(std::move(socket), options);
    if (!connection) {
        SPLITVK_ERROR("session %llu: %s (from %s); closing", id, connection.error().c_str(), peer.c_str());
        return options.tls ? kSessionHandshake : kSessionError;
    }
    Session session(std::move(connection.value()), config, std::move(require_tls));
    return session.run();
}

} // namespace splitvk::agent
