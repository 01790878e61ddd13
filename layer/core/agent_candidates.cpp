#include "core/agent_candidates.h"

#include "known_agents.h"
#include "log.h"
#include "vk_codec.h"

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <iterator>

namespace splitvk {
namespace {

// Whether `fingerprint` is what this client pins for `address`, without recording anything: an
// advertised certificate is never trusted on first use.
bool pinned(const Settings &settings, const ServerAddress &address, const std::string &fingerprint) {
    if (fingerprint.empty()) return false;
    if (!settings.agent_fingerprint.empty()) return settings.agent_fingerprint == fingerprint;
    const std::string path = protocol::known_agents_path(std::getenv("XDG_CONFIG_HOME"), std::getenv("HOME"));
    if (path.empty()) return false;
    std::string text;
    if (std::ifstream in(path, std::ios::binary); in)
        text.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    const protocol::KnownAgents known = protocol::parse_known_agents(text, path);
    const protocol::KnownAgent *entry = protocol::find_known_agent(known, agent_address(address));
    return entry && entry->fingerprint == fingerprint;
}

// The lines said once per process: the instance's greeting and each device's session dial alike.
std::mutex g_said_mutex;
std::set<std::string> g_said;

} // namespace

AgentCandidates::AgentCandidates(const Settings &settings) : settings_(settings) {
    if (settings.dnssd) {
        description_ = settings.dnssd_name.empty()
                           ? std::string("DNS-SD (") + protocol::kDnssdServiceType + ")"
                           : "DNS-SD instance '" + settings.dnssd_name + "'";
        browser_ = DnssdBrowser::shared();
    } else {
        if (settings_.servers.empty()) settings_.servers.push_back(settings.server);
        for (const ServerAddress &address : settings_.servers) {
            if (!description_.empty()) description_ += ',';
            description_ += agent_address(address);
        }
    }
}

void AgentCandidates::say_once(const std::string &key, const std::string &line) {
    {
        std::lock_guard lock(g_said_mutex);
        if (!g_said.insert(key).second) return;
    }
    SPLITVK_WARN("%s", line.c_str());
}

std::vector<AgentCandidate> AgentCandidates::to_dial(const std::set<std::string> &excluding,
                                                     std::chrono::milliseconds wait) {
    std::vector<AgentCandidate> chosen;
    if (!browser_) {
        for (const ServerAddress &address : settings_.servers) {
            AgentCandidate candidate{address, agent_address(address), 0};
            if (!excluding.count(candidate.label)) chosen.push_back(std::move(candidate));
        }
        return chosen;
    }
    const std::string session = protocol::session_text(codec::kCodecFingerprint);
    std::string left_out;
    const auto leave_out = [&](const std::string &why) {
        if (!left_out.empty()) left_out += "; ";
        left_out += why;
    };
    for (const AdvertisedAgent &agent : browser_->agents(std::chrono::steady_clock::now() + wait)) {
        if (!settings_.dnssd_name.empty() && agent.name != settings_.dnssd_name) continue;
        const std::string label = "'" + agent.name + "' (" + agent_address(agent.address) + ")";
        if (excluding.count(label)) continue;
        if (!agent.problem.empty()) {
            say_once("txt " + label, "splitvk-agent " + label +
                                         " is advertised with a TXT record this layer cannot "
                                         "read (" +
                                         agent.problem + "); not dialled");
            leave_out(label + ": unreadable TXT record");
            continue;
        }
        if (agent.record.session != session) {
            say_once("session " + label, "splitvk-agent " + label + " speaks session " +
                                             agent.record.session + ", this layer " + session +
                                             " (another splitvk version); not dialled");
            leave_out(label + ": another splitvk version");
            continue;
        }
        // The rule SPLITVK_TLS applies to the address dialled: off loopback, TLS, so a pin.
        Settings dialled = settings_;
        dialled.server = agent.address;
        if (dialled.use_tls() && !pinned(settings_, agent.address, agent.record.certificate)) {
            say_once("pin " + label,
                     "splitvk-agent " + label + " advertises the certificate " +
                         (agent.record.certificate.empty() ? std::string("none") : agent.record.certificate) +
                         ", which this client does not pin (SPLITVK_AGENT_FINGERPRINT, or its address in "
                         "known_agents); not dialled: an advertisement is no reason to trust an agent");
            leave_out(label + ": certificate not pinned");
            continue;
        }
        chosen.push_back(AgentCandidate{agent.address, label, agent.record.free_slots});
    }
    // Most free slots first; an agent that says it is full last (its slot may free before we dial).
    std::stable_sort(chosen.begin(), chosen.end(), [](const AgentCandidate &a, const AgentCandidate &b) {
        return a.free_slots > b.free_slots;
    });
    std::lock_guard lock(mutex_);
    last_left_out_ = left_out;
    return chosen;
}

std::string AgentCandidates::nothing_found() {
    if (!browser_) return {};
    std::string problem = browser_->problem();
    if (!problem.empty()) return problem;
    std::lock_guard lock(mutex_);
    return last_left_out_.empty() ? std::string("no agent advertised") : "none kept: " + last_left_out_;
}

protocol::Result<AgentLink> dial_agent(AgentCandidates &candidates, const Settings &settings,
                                       const protocol::Hello &hello, const std::set<std::string> &excluding,
                                       std::chrono::milliseconds browse_wait, bool *final,
                                       const std::set<std::string> &in_use) {
    *final = false;
    std::set<std::string> left_out = in_use;
    left_out.insert(excluding.begin(), excluding.end());
    std::vector<AgentCandidate> list = candidates.to_dial(left_out, browse_wait);
    if (list.empty() && !excluding.empty()) list = candidates.to_dial(in_use, browse_wait);
    if (list.empty()) {
        const std::string why = candidates.nothing_found();
        if (in_use.empty()) return protocol::Error{why};
        return protocol::Error{"no agent but the other eye's" + (why.empty() ? "" : " (" + why + ")")};
    }
    std::string errors;
    bool all_final = true;
    for (const AgentCandidate &candidate : list) {
        Settings dialled = settings;
        dialled.server = candidate.address;
        bool refused = false;
        auto link = connect_agent(dialled, hello, &refused);
        if (link) {
            link->agent = candidate.label;
            if (candidates.browsing())
                SPLITVK_INFO(
                    "splitvk-agent %s chosen over DNS-SD: %u free slots, the most of the %zu agents kept",
                    candidate.label.c_str(), candidate.free_slots, list.size());
            return link;
        }
        all_final = all_final && refused;
        if (!errors.empty()) errors += "; ";
        if (list.size() > 1) errors += candidate.label + ": ";
        errors += link.error();
    }
    // An advertised agent that refused may be replaced by one that does not: keep looking.
    *final = all_final && !candidates.browsing();
    return protocol::Error{errors};
}

} // namespace splitvk
