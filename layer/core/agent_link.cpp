#include "core/agent_link.h"

#include "core/agent_candidates.h"
#include "core/layer_settings.h"
#include "known_agents.h"
#include "log.h"
#include "vk_codec.h"

#include <atomic>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <mutex>

namespace splitvk {
namespace {

using namespace std::chrono_literals;

// Never hang the application: a refused connection fails at once, a silent address after this.
constexpr auto kConnectTimeout = 250ms;
constexpr auto kHandshakeTimeout = 1000ms;
// The TLS handshake: one round trip and an ECDHE on each side, but the agent's session process is
// forked and confines itself first.
constexpr auto kTlsHandshakeTimeout = 2000ms;

// Serialises the known_agents read-check-append of this process's connections (the instance's
// greeting and a device's session may meet a new agent at once).
std::mutex g_known_agents_mutex;

} // namespace

std::string agent_address(const ServerAddress &server) {
    return server.host.find(':') != std::string::npos ? "[" + server.host + "]:" + std::to_string(server.port)
                                                      : server.host + ":" + std::to_string(server.port);
}

std::string check_agent_certificate(const Settings &settings, const protocol::CertificateInfo &certificate) {
    const std::string address = agent_address(settings.server);
    const std::string &seen = certificate.fingerprint;
    if (!settings.agent_fingerprint.empty()) {
        if (seen == settings.agent_fingerprint) return {};
        return "the agent's certificate is " + seen + ", not the " + settings.agent_fingerprint +
               " that SPLITVK_AGENT_FINGERPRINT pins; if the agent's identity changed on purpose, set "
               "SPLITVK_AGENT_FINGERPRINT=" +
               seen;
    }
    const std::string path = protocol::known_agents_path(std::getenv("XDG_CONFIG_HOME"), std::getenv("HOME"));
    if (path.empty())
        return "cannot check the agent's certificate " + seen +
               ": neither XDG_CONFIG_HOME nor HOME is set, so there is no known_agents file; set "
               "SPLITVK_AGENT_FINGERPRINT=" +
               seen + " if it is the one `splitvk-agent --print-fingerprint` prints";
    std::lock_guard lock(g_known_agents_mutex);
    std::string text;
    if (std::ifstream in(path, std::ios::binary); in)
        text.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    const protocol::KnownAgents known = protocol::parse_known_agents(text, path);
    for (const auto &problem : known.problems)
        SPLITVK_WARN("%s", problem.c_str());
    if (const protocol::KnownAgent *entry = protocol::find_known_agent(known, address)) {
        if (entry->fingerprint == seen) return {};
        return "the agent's certificate changed: it is now " + seen + ", but " + path + ":" +
               std::to_string(entry->line) + " records " + entry->fingerprint + " for " + address +
               "; if the change is expected, delete line " + std::to_string(entry->line) + " of " + path +
               " (or set SPLITVK_AGENT_FINGERPRINT=" + seen + ")";
    }
    const std::string failed = protocol::append_known_agent(path, address, seen);
    if (!failed.empty())
        SPLITVK_WARN("splitvk-agent at %s is new; trusting its certificate %s for this run only: %s",
                     address.c_str(), seen.c_str(), failed.c_str());
    else
        SPLITVK_WARN(
            "splitvk-agent at %s is new: trusting its certificate %s and recording it in %s (compare it "
            "with `splitvk-agent --print-fingerprint` on the agent)",
            address.c_str(), seen.c_str(), path.c_str());
    return {};
}

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
    hello.codec_fingerprint = protocol::session_fingerprint(codec::kCodecFingerprint);
    hello.capabilities = protocol::capability::kZstdPayloads;
    // SPLITVK_VERIFY compares the client's frames with the agent's replay. The paper's split makes
    // the two differ everywhere (the client's periphery is scaled), so verification turns it off.
    // The swapped split stays on: its agent renders the whole frame natively, which is what the
    // client's foveae must equal and what its periphery is measured against (verification.h).
    const bool swapped = asks_swapped_split(settings);
    if (settings.verify) hello.capabilities |= protocol::capability::kVerifyFrames;
    if (!settings.verify || swapped)
        hello.capabilities |= protocol::capability::kFoveaTiles | protocol::capability::kAgentScissor;
    if (swapped) hello.capabilities |= protocol::capability::kSwappedSplit;
    return hello;
}

bool asks_swapped_split(const Settings &settings) {
    return settings.client_renders == ClientRenders::Fovea;
}

protocol::Result<AgentLink> connect_agent(const Settings &settings, const protocol::Hello &hello,
                                          bool *final) {
    *final = false;
    protocol::ConnectionOptions options;
    options.name = "splitvk-agent " + settings.server.host + ":" + std::to_string(settings.server.port);
    // The verifier's verdict, kept so that a refused certificate counts as final: it stays refused.
    auto refused = std::make_shared<std::string>();
    if (settings.use_tls()) {
        auto context =
            protocol::TlsContext::client([settings, refused](const protocol::CertificateInfo &cert) {
                *refused = check_agent_certificate(settings, cert);
                return *refused;
            });
        if (!context) return protocol::Error{"TLS: " + context.error()};
        options.tls = std::move(context).value();
        options.tls_handshake_timeout = kTlsHandshakeTimeout;
    }
    auto connected = protocol::Connection::connect(settings.server.host, settings.server.port,
                                                   kConnectTimeout, std::move(options));
    if (!connected) {
        // An expired or unpinned certificate stays so however often it is tried.
        const std::string &e = connected.error();
        *final = !refused->empty() || e.starts_with("the agent's certificate");
        return protocol::Error{e};
    }
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
    early->candidates_ = std::make_shared<AgentCandidates>(loaded.settings);
    early->answer_ = std::async(
        std::launch::async, [settings = loaded.settings, application_name, candidates = early->candidates_] {
            Outcome outcome;
            bool final = false;
            auto link = dial_agent(*candidates, settings, base_hello(settings, application_name), {},
                                   kBrowseWait, &final);
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
