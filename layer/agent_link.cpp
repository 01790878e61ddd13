#include "agent_link.h"

#include "layer_settings.h"
#include "log.h"
#include "vk_codec.h"

namespace splitvk {
namespace {

using namespace std::chrono_literals;

// Never hang the application: a refused connection fails at once, a silent address after this.
constexpr auto kConnectTimeout = 250ms;
constexpr auto kHandshakeTimeout = 1000ms;

} // namespace

void ClosedSlot::set(std::function<void(const std::string &)> target) {
    std::lock_guard lock(mutex_);
    target_ = std::move(target);
}

void ClosedSlot::report(const std::string &reason) {
    std::function<void(const std::string &)> target;
    {
        std::lock_guard lock(mutex_);
        target = target_;
    }
    if (target) target(reason);
}

protocol::Hello base_hello(const Settings &settings, const std::string &client_name) {
    protocol::Hello hello;
    hello.token.assign(settings.token.begin(), settings.token.end());
    hello.client_name = client_name;
    hello.codec_fingerprint = codec::kCodecFingerprint;
    hello.capabilities = protocol::capability::kZstdPayloads;
    // SPLITVK_VERIFY compares whole frames with the agent's replay, which only an unsplit frame
    // can match: verification and the split exclude each other.
    hello.capabilities |=
        settings.verify ? protocol::capability::kVerifyFrames : protocol::capability::kFoveaTiles;
    return hello;
}

protocol::Result<AgentLink> connect_agent(const Settings &settings, const protocol::Hello &hello,
                                          bool *final) {
    *final = false;
    protocol::ConnectionOptions options;
    options.name = "splitvk-agent " + settings.server.host + ":" + std::to_string(settings.server.port);
    auto connected = protocol::Connection::connect(settings.server.host, settings.server.port,
                                                   kConnectTimeout, std::move(options));
    if (!connected) return protocol::Error{connected.error()};
    AgentLink link;
    link.connection = std::move(connected.value());
    link.on_closed = std::make_shared<ClosedSlot>();
    link.connection->start([slot = link.on_closed](const std::string &reason) { slot->report(reason); });
    auto welcome = protocol::client_handshake(*link.connection, hello, kHandshakeTimeout);
    if (!welcome) {
        // A wrong token, protocol version or GPU stays wrong however often it is tried; a full
        // agent may have room later.
        const std::string &e = welcome.error();
        *final = e.starts_with("server rejected the session") && e.find("server full") == std::string::npos;
        return protocol::Error{e};
    }
    link.welcome = std::move(welcome).value();
    return link;
}

std::unique_ptr<EarlyAgent> EarlyAgent::start(const std::string &application_name) {
    const LoadedSettings &loaded = layer_settings();
    if (!loaded.valid()) return nullptr;
    std::unique_ptr<EarlyAgent> early(new EarlyAgent());
    early->deadline_ = std::chrono::steady_clock::now() + kBudget;
    early->answer_ = std::async(std::launch::async, [settings = loaded.settings, application_name] {
        Outcome outcome;
        bool final = false;
        auto link = connect_agent(settings, base_hello(settings, application_name), &final);
        if (link)
            outcome.link = std::move(link).value();
        else
            outcome.error = link.error();
        outcome.refused = final;
        return outcome;
    });
    return early;
}

EarlyAgent::~EarlyAgent() {
    // An instance that created no device: end the agent's session in words it logs as normal.
    Outcome outcome = take();
    if (outcome.link && outcome.link->connection->is_open()) {
        outcome.link->connection->send(protocol::MessageType::Goodbye,
                                       protocol::encode_goodbye({"the application created no device"}));
        outcome.link->connection->flush(500ms);
        outcome.link->connection->close("instance destroyed");
    }
}

const std::optional<protocol::DeviceDescription> &EarlyAgent::agent_device() {
    std::lock_guard lock(mutex_);
    if (device_settled_) return agent_device_;
    device_settled_ = true;
    if (!outcome_ && answer_.valid() && answer_.wait_until(deadline_) == std::future_status::ready)
        outcome_ = answer_.get();
    if (!outcome_ || !outcome_->link || outcome_->link->welcome.server_device.empty()) return agent_device_;
    auto device = protocol::decode_device_description(outcome_->link->welcome.server_device);
    if (device)
        agent_device_ = std::move(device).value();
    else
        SPLITVK_WARN("splitvk-agent described its GPU in a form this layer cannot read (%s); the device "
                     "envelope uses the agent baseline",
                     device.error().c_str());
    return agent_device_;
}

EarlyAgent::Outcome EarlyAgent::take() {
    std::lock_guard lock(mutex_);
    if (!outcome_ && answer_.valid()) outcome_ = answer_.get();
    Outcome outcome = outcome_ ? std::move(*outcome_) : Outcome{};
    outcome_ = Outcome{};
    return outcome;
}

} // namespace splitvk
