// The replication session of one VkDevice: connect, handshake, the global command stream.

#include "session.h"

#include "device.h"
#include "instance.h"
#include "layer_settings.h"
#include "log.h"

#include <chrono>

namespace splitvk {
namespace {

using namespace std::chrono_literals;

// Never hang the application: a refused connection fails at once, a silent address after this.
constexpr auto kConnectTimeout = 250ms;
constexpr auto kHandshakeTimeout = 1000ms;
// A full send queue (128 MiB) means the agent is not keeping up; wait this long, then give up.
constexpr auto kSendWait = 2000ms;
constexpr auto kCloseFlush = 500ms;

} // namespace

void CaptureHooks::skipped_structure(VkStructureType stype, const char *parent) {
    // The loader's own chain links in vkCreateDevice's pNext are not the application's.
    if (stype == VK_STRUCTURE_TYPE_LOADER_INSTANCE_CREATE_INFO ||
        stype == VK_STRUCTURE_TYPE_LOADER_DEVICE_CREATE_INFO)
        return;
    std::lock_guard lock(mutex_);
    if (seen_.emplace(static_cast<uint32_t>(stype), true).second)
        SPLITVK_WARN(
            "cannot forward structure type %u in the pNext chain of %s; the agent replays without it",
            static_cast<unsigned>(stype), parent);
}

bool set_binding_has_immutable_samplers(VkDescriptorSet set, uint32_t binding); // descriptor_set.cpp

bool CaptureHooks::has_immutable_samplers(VkDescriptorSet set, uint32_t binding) {
    return set_binding_has_immutable_samplers(set, binding);
}

void CaptureHooks::chain_truncated(const char *parent) {
    std::lock_guard lock(mutex_);
    if (!truncation_logged_)
        SPLITVK_WARN("a pNext chain of %s is too long or loops; the agent gets it cut", parent);
    truncation_logged_ = true;
}

std::unique_ptr<Session> Session::open(const DeviceState &device, const VkDeviceCreateInfo *create_info,
                                       const std::string &application_name) {
    const LoadedSettings &loaded = layer_settings();
    if (!loaded.valid()) return nullptr;
    const Settings &settings = loaded.settings;
    const std::string address = settings.server.host + ":" + std::to_string(settings.server.port);

    protocol::ConnectionOptions options;
    options.name = "splitvk-agent " + address;
    auto connected = protocol::Connection::connect(settings.server.host, settings.server.port,
                                                   kConnectTimeout, std::move(options));
    if (!connected) {
        SPLITVK_WARN("no splitvk-agent at %s (%s); running unsplit", address.c_str(),
                     connected.error().c_str());
        return nullptr;
    }

    std::unique_ptr<Session> session(new Session());
    session->address_ = address;
    session->connection_ = std::move(connected.value());
    session->device_id_ = codec::handle_value(device.handle);
    session->encoder_.set_hooks(&session->hooks_);
    Session *raw = session.get();
    // Until the handshake succeeded, a closure is reported by the "no splitvk-agent" line alone.
    session->failure_logged_.store(true);
    session->connection_->start([raw](const std::string &reason) { raw->fail(reason); });

    VkPhysicalDeviceProperties properties{};
    device.instance->dispatch.GetPhysicalDeviceProperties(device.physical_device, &properties);
    protocol::Hello hello;
    hello.token.assign(settings.token.begin(), settings.token.end());
    hello.client_name = application_name;
    hello.client_gpu_name = properties.deviceName;
    hello.codec_fingerprint = codec::kCodecFingerprint;
    hello.capabilities = protocol::capability::kZstdPayloads;
    if (settings.verify) hello.capabilities |= protocol::capability::kVerifyFrames;
    auto welcome = protocol::client_handshake(*session->connection_, hello, kHandshakeTimeout);
    if (!welcome) {
        SPLITVK_WARN("no splitvk-agent at %s (%s); running unsplit", address.c_str(),
                     welcome.error().c_str());
        return nullptr; // the destructor closes the connection without calling back
    }
    if (!(welcome->capabilities & protocol::capability::kZstdPayloads)) {
        protocol::CompressionPolicy policy;
        policy.enabled = false;
        session->connection_->set_compression(policy);
    }
    session->verify_ = settings.verify && (welcome->capabilities & protocol::capability::kVerifyFrames);
    if (settings.verify && !session->verify_)
        SPLITVK_WARN("splitvk-agent at %s cannot verify frames; SPLITVK_VERIFY ignored", address.c_str());
    session->failure_logged_.store(false);
    session->live_.store(true);
    SPLITVK_INFO("replicating to splitvk-agent at %s (%s, session %llu)", address.c_str(),
                 welcome->server_gpu_name.c_str(), static_cast<unsigned long long>(welcome->session_id));

    // The first message: the device itself, which the agent mirrors and registers the
    // physical device and device ids from.
    VkDevice handle = device.handle;
    session->record(LiveChange::Unchanged, 0, [&](codec::Encoder &e) {
        encode_vkCreateDevice(e, device.physical_device, create_info, nullptr, &handle);
    });
    session->flush();
    return session;
}

Session::~Session() {
    if (connection_) connection_->close();
}

void Session::fail(const std::string &reason) {
    live_.store(false);
    if (!failure_logged_.exchange(true))
        SPLITVK_WARN("splitvk-agent at %s went away (%s); running unsplit from now on", address_.c_str(),
                     reason.c_str());
}

void Session::note_live_change(LiveChange change, uint64_t id, size_t start) {
    if (change == LiveChange::Created && id != 0) {
        const auto bytes = encoder_.data().subspan(start);
        live_objects_[id].assign(bytes.begin(), bytes.end());
    } else if (change == LiveChange::Destroyed && id != 0) {
        live_objects_.erase(id);
    }
}

size_t Session::live_object_count() {
    std::lock_guard lock(mutex_);
    return live_objects_.size();
}

void Session::send_locked(protocol::MessageType type, std::vector<uint8_t> &&payload) {
    if (!live()) return;
    const protocol::SendResult result = connection_->send_owned(type, std::move(payload), kSendWait);
    if (result == protocol::SendResult::Queued) return;
    std::string reason = protocol::to_string(result);
    if (result == protocol::SendResult::Closed) reason = connection_->close_reason();
    live_.store(false);
    if (!failure_logged_.exchange(true))
        SPLITVK_WARN("splitvk-agent at %s: cannot send (%s); running unsplit from now on", address_.c_str(),
                     reason.c_str());
}

void Session::flush_locked() {
    if (encoder_.size() == 0) return;
    send_locked(protocol::MessageType::Commands, encoder_.take());
}

void Session::flush() {
    std::lock_guard lock(mutex_);
    flush_locked();
}

void Session::send_commands(std::span<const uint8_t> payload) {
    std::lock_guard lock(mutex_);
    flush_locked();
    send_locked(protocol::MessageType::Commands, std::vector<uint8_t>(payload.begin(), payload.end()));
}

void Session::send_metadata(protocol::MessageType type, std::vector<uint8_t> &&payload) {
    std::lock_guard lock(mutex_);
    flush_locked();
    send_locked(type, std::move(payload));
}

std::optional<protocol::Message> Session::receive(std::chrono::milliseconds timeout) {
    if (timeout.count() <= 0) return connection_->try_receive();
    return connection_->receive(timeout);
}

void Session::close() {
    {
        std::lock_guard lock(mutex_);
        flush_locked();
        live_.store(false);
        failure_logged_.store(true);
    }
    connection_->flush(kCloseFlush);
    const protocol::ConnectionStats stats = connection_->stats();
    SPLITVK_INFO("session to %s: %llu frames, %.2f ms comparing memory, %llu messages, %llu payload bytes, "
                 "%llu bytes on the wire",
                 address_.c_str(), static_cast<unsigned long long>(current_frame()),
                 static_cast<double>(memory_compare_ns.load()) / 1e6,
                 static_cast<unsigned long long>(stats.messages_sent),
                 static_cast<unsigned long long>(stats.payload_bytes_sent),
                 static_cast<unsigned long long>(stats.wire_bytes_sent));
    connection_->close("the application destroyed the device");
}

} // namespace splitvk
