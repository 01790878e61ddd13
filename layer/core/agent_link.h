#pragma once

// A connection to splitvk-agent that has passed its handshake, and the two places that make one:
// a device's Session (session.h) and the instance, which greets the agent at vkCreateInstance so
// that the device envelope (physical_device.h) can include the agent's own GPU. The first device
// of the instance then adopts that connection instead of dialling again, so one application run
// is one session on the agent, as before.

#include "device_envelope.h"
#include "handshake.h"
#include "settings.h"
#include "transport.h"

#include <chrono>
#include <functional>
#include <future>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

namespace splitvk {

// Where a connection's closure is reported. A connection starts reading (and so may close) before
// its owner exists: the instance greets the agent before any Session. The owner sets the target
// when it takes the connection, then checks is_open(), so no closure is lost in between.
class ClosedSlot {
public:
    void set(std::function<void(const std::string &)> target);
    void report(const std::string &reason);

private:
    std::mutex mutex_;
    std::function<void(const std::string &)> target_;
};

struct AgentLink {
    std::unique_ptr<protocol::Connection> connection;
    protocol::Welcome welcome;
    std::shared_ptr<ClosedSlot> on_closed;
    std::string agent; // which agent answered, as agent_candidates.h labels it
};

// "host:port", "[v6]:port": how known_agents and the lines the layer writes name an address.
std::string agent_address(const ServerAddress &server);

class AgentCandidates;

// The Hello every connection of this process starts with; the caller adds what it knows more
// (the GPU's name, the device envelope).
protocol::Hello base_hello(const Settings &settings, const std::string &client_name);

// Whether this process asks agents for the swapped split (SPLITVK_CLIENT_RENDERS=fovea), window and
// OpenXR applications alike.
bool asks_swapped_split(const Settings &settings);

// The client's verdict on the agent's certificate (tls.h's Verifier): SPLITVK_AGENT_FINGERPRINT
// when set, else the known_agents file, where an agent met for the first time is recorded. Empty
// to accept, else one line saying what changed and how to accept it.
std::string check_agent_certificate(const Settings &settings, const protocol::CertificateInfo &certificate);

// Connects (over TLS when settings.use_tls()) and handshakes. *final when retrying cannot help: the agent
// answered and refused (a wrong token, another protocol, a GPU that cannot honour the envelope), but not when
// it was full.
protocol::Result<AgentLink> connect_agent(const Settings &settings, const protocol::Hello &hello,
                                          bool *final);

// The instance's greeting (vkCreateInstance), run in the background. The envelope waits for its
// answer at most until kBudget after the instance was created; the first Session takes the
// connection, and what nobody takes is closed with the instance.
class EarlyAgent {
public:
    static constexpr std::chrono::milliseconds kBudget{300};

    // nullptr when the settings are invalid: the application then runs unsplit.
    static std::unique_ptr<EarlyAgent> start(const std::string &application_name);
    // How long the greeting waits for agents advertised over DNS-SD (SPLITVK_SERVER=dnssd) before it
    // dials what was found: within the connect's own bound, so the envelope's budget holds.
    static constexpr std::chrono::milliseconds kBrowseWait{250};
    ~EarlyAgent();

    // The agent's device, if it answered within the budget. The first call waits, later ones
    // return what it found: the envelope must not change once the application has seen it.
    const std::optional<protocol::DeviceDescription> &agent_device();

    // What the greeting came to, for the first Session: an open connection, or an agent that
    // refused (`error` says why), or nothing (no agent answered). Waits for the greeting to end
    // (bounded by the connect and handshake timeouts); later calls return nothing.
    struct Outcome {
        std::optional<AgentLink> link;
        bool refused = false;
        std::string error;
    };
    Outcome take();

private:
    EarlyAgent() = default;

    // Where the greeting dials; kept so that agents found over DNS-SD are still known when the first
    // device's session asks.
    std::shared_ptr<AgentCandidates> candidates_;

    std::chrono::steady_clock::time_point deadline_;
    std::mutex mutex_;
    std::future<Outcome> answer_; // valid until taken
    std::optional<Outcome> outcome_;
    bool device_settled_ = false;
    std::optional<protocol::DeviceDescription> agent_device_;
};

} // namespace splitvk
