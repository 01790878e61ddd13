#pragma once

// The one place that answers "which agent(s) to dial now, excluding these": fed by SPLITVK_SERVER's
// static list (HOST:PORT[,HOST:PORT...], first first) or by the agents advertised over DNS-SD
// (SPLITVK_SERVER=dnssd[:NAME], dnssd_browser.h). The instance's greeting, a device's session and
// its reconnector (failover to another agent when the one in use went away) all dial through
// dial_agent() below.
//
// An advertisement is never a reason to trust an agent: an advertised agent is kept only when its
// session fingerprint is the layer's, and off loopback only when the certificate it advertises is
// pinned (SPLITVK_AGENT_FINGERPRINT, or known_agents for its address); the TLS handshake then checks
// the certificate it really presents against the same pin (check_agent_certificate).

#include "core/agent_link.h"
#include "core/dnssd_browser.h"

#include <chrono>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <vector>

namespace splitvk {

struct AgentCandidate {
    ServerAddress address;
    std::string label;       // "host:port", or "'NAME' (host:port)" for an advertised agent
    uint32_t free_slots = 0; // advertised; 0 for a static address
};

class AgentCandidates {
public:
    explicit AgentCandidates(const Settings &settings);

    // The agents to dial now, best first: a static list in its order; advertised agents kept (see
    // above) by most free slots. Those named in `excluding` (labels) are left out. Waits for the
    // browser at most `wait`.
    std::vector<AgentCandidate> to_dial(const std::set<std::string> &excluding,
                                        std::chrono::milliseconds wait);

    // What SPLITVK_SERVER names, for lines about no agent answering: "127.0.0.1:7447",
    // "DNS-SD (_splitvk._tcp)".
    const std::string &description() const { return description_; }
    bool browsing() const { return browser_ != nullptr; }
    // Why to_dial() found nothing to dial (no agent advertised, avahi-daemon absent, every one left
    // out and why), for the line that says the application runs unsplit.
    std::string nothing_found();

private:
    // Says `line` once per `key` in this process.
    static void say_once(const std::string &key, const std::string &line);

    Settings settings_;
    std::string description_;
    std::shared_ptr<DnssdBrowser> browser_;
    std::mutex mutex_;
    std::set<std::string> said_; // under mutex_
    std::string last_left_out_;  // under mutex_: why the latest to_dial() kept none of those found
};

// Dials `candidates` best first until one completes its handshake, leaving out `excluding` unless
// nothing else is left (an agent that went away may be the only one, and come back), and `in_use`
// always (with an agent per eye, the other eye's: each eye has an agent of its own). The link's
// `agent` names the one that answered. *final only when retrying cannot help: every agent of a
// static list answered and refused.
protocol::Result<AgentLink> dial_agent(AgentCandidates &candidates, const Settings &settings,
                                       const protocol::Hello &hello, const std::set<std::string> &excluding,
                                       std::chrono::milliseconds browse_wait, bool *final,
                                       const std::set<std::string> &in_use = {});

} // namespace splitvk
