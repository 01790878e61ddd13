#pragma once

// SPLITVK_SERVER=dnssd: the agents advertised over DNS-SD (_splitvk._tcp, protocol/dnssd_record.h),
// as avahi-daemon reports them. Everything avahi does (the D-Bus connection, the browser, one
// resolver per instance kept open so that its TXT changes reach us) happens on the browser's own
// thread: the application's threads only read what it found, waiting for it at most until a
// deadline they choose. Without avahi-daemon or the system bus the browser keeps trying, and the
// layer meanwhile sees no agent.

#include "dnssd_record.h"
#include "settings.h"

#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace splitvk {

struct AdvertisedAgent {
    std::string name;      // the instance name
    ServerAddress address; // as resolved (IPv4)
    protocol::AgentRecord record;
    std::string problem; // a TXT record that does not decode: why; `record` is then empty
};

class DnssdBrowser {
public:
    // The process's browser, started on first use and shared by every instance and device; it
    // ends when the last holder lets it go.
    static std::shared_ptr<DnssdBrowser> shared();
    ~DnssdBrowser();

    // What the browser knows, once its first browse has come to an end (avahi's "all for now"
    // and every instance resolved) or at `deadline`, whichever is first.
    std::vector<AdvertisedAgent> agents(std::chrono::steady_clock::time_point deadline);
    // Why no agent can be found now (avahi-daemon absent), or empty.
    std::string problem();

    struct State; // what the thread and the readers share; the thread keeps it alive

private:
    DnssdBrowser() = default;
    std::shared_ptr<State> state_;
    std::thread thread_;
};

} // namespace splitvk
