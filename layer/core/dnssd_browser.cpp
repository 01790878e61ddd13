#include "core/dnssd_browser.h"

#include "log.h"

#include <atomic>
#include <map>
#include <set>
#include <tuple>

#include <avahi-client/client.h>
#include <avahi-client/lookup.h>
#include <avahi-common/error.h>
#include <avahi-common/simple-watch.h>
#include <avahi-common/strlst.h>

namespace splitvk {

using namespace std::chrono_literals;

struct DnssdBrowser::State {
    std::mutex mutex;
    std::condition_variable changed;
    // Under mutex: what the readers see.
    std::map<std::tuple<int, int, std::string>, AdvertisedAgent> agents; // by interface, protocol, name
    bool browsed = false;                                 // the first browse came to "all for now"
    int resolving = 0;                                    // instances seen and not resolved yet
    std::set<std::tuple<int, int, std::string>> answered; // resolvers that answered at least once
    std::string problem;
    std::atomic<bool> stop{false};
    // The thread's own, never touched by readers.
    AvahiSimplePoll *poll = nullptr;
    AvahiClient *client = nullptr;
    AvahiServiceBrowser *browser = nullptr;
    std::map<std::tuple<int, int, std::string>, AvahiServiceResolver *> resolvers;
    std::atomic<bool> finished{false};
};

namespace {

using State = DnssdBrowser::State;
using Key = std::tuple<int, int, std::string>;

std::mutex g_shared_mutex;
std::weak_ptr<DnssdBrowser> g_shared;

void on_resolved(AvahiServiceResolver *, AvahiIfIndex interface, AvahiProtocol protocol,
                 AvahiResolverEvent event, const char *name, const char *, const char *, const char *,
                 const AvahiAddress *address, uint16_t port, AvahiStringList *txt, AvahiLookupResultFlags,
                 void *userdata) {
    auto *state = static_cast<State *>(userdata);
    const Key key{interface, protocol, name};
    std::lock_guard lock(state->mutex);
    // A kept resolver reports again when the TXT record changes: count only its first answer.
    const bool first = state->answered.insert(key).second;
    if (event == AVAHI_RESOLVER_FOUND && address) {
        AdvertisedAgent agent;
        agent.name = name;
        char text[AVAHI_ADDRESS_STR_MAX] = {};
        avahi_address_snprint(text, sizeof(text), address);
        agent.address.host = text;
        agent.address.port = port;
        std::vector<std::string> entries;
        for (AvahiStringList *entry = txt; entry; entry = avahi_string_list_get_next(entry))
            entries.emplace_back(reinterpret_cast<const char *>(avahi_string_list_get_text(entry)),
                                 avahi_string_list_get_size(entry));
        auto record = protocol::decode_txt(entries);
        if (record)
            agent.record = std::move(record).value();
        else
            agent.problem = record.error();
        state->agents[key] = std::move(agent);
    } else {
        // Failed to resolve (or no longer resolves): not an agent we can dial.
        state->agents.erase(key);
    }
    if (first && state->resolving > 0) --state->resolving;
    state->changed.notify_all();
}

void on_browsed(AvahiServiceBrowser *, AvahiIfIndex interface, AvahiProtocol protocol,
                AvahiBrowserEvent event, const char *name, const char *type, const char *domain,
                AvahiLookupResultFlags, void *userdata) {
    auto *state = static_cast<State *>(userdata);
    switch (event) {
    case AVAHI_BROWSER_NEW: {
        const Key key{interface, protocol, name};
        if (state->resolvers.count(key)) break;
        AvahiServiceResolver *resolver =
            avahi_service_resolver_new(state->client, interface, protocol, name, type, domain,
                                       AVAHI_PROTO_INET, AvahiLookupFlags(0), on_resolved, state);
        if (!resolver) break;
        state->resolvers[key] = resolver;
        std::lock_guard lock(state->mutex);
        ++state->resolving;
        break;
    }
    case AVAHI_BROWSER_REMOVE: {
        const Key key{interface, protocol, name};
        if (auto it = state->resolvers.find(key); it != state->resolvers.end()) {
            avahi_service_resolver_free(it->second);
            state->resolvers.erase(it);
        }
        std::lock_guard lock(state->mutex);
        if (!state->answered.erase(key) && state->resolving > 0) --state->resolving;
        state->agents.erase(key);
        state->changed.notify_all();
        break;
    }
    case AVAHI_BROWSER_ALL_FOR_NOW: {
        std::lock_guard lock(state->mutex);
        state->browsed = true;
        state->changed.notify_all();
        break;
    }
    case AVAHI_BROWSER_FAILURE:
    case AVAHI_BROWSER_CACHE_EXHAUSTED:
        break;
    }
}

void forget_daemon(State &state, const std::string &problem) {
    for (auto &[key, resolver] : state.resolvers)
        avahi_service_resolver_free(resolver);
    state.resolvers.clear();
    if (state.browser) avahi_service_browser_free(state.browser);
    state.browser = nullptr;
    std::lock_guard lock(state.mutex);
    state.agents.clear();
    state.answered.clear();
    state.resolving = 0;
    // Nobody is there to ask: a reader waiting for the first browse need not wait.
    state.browsed = true;
    state.problem = problem;
    state.changed.notify_all();
}

void on_client(AvahiClient *client, AvahiClientState client_state, void *userdata) {
    auto *state = static_cast<State *>(userdata);
    state->client = client; // also called from within avahi_client_new
    if (client_state == AVAHI_CLIENT_S_RUNNING && !state->browser) {
        {
            std::lock_guard lock(state->mutex);
            state->problem.clear();
            state->browsed = false;
        }
        state->browser =
            avahi_service_browser_new(client, AVAHI_IF_UNSPEC, AVAHI_PROTO_INET, protocol::kDnssdServiceType,
                                      nullptr, AvahiLookupFlags(0), on_browsed, state);
        if (!state->browser)
            forget_daemon(*state, std::string("avahi-daemon cannot browse: ") +
                                      avahi_strerror(avahi_client_errno(client)));
    } else if (client_state == AVAHI_CLIENT_CONNECTING) {
        forget_daemon(*state, "avahi-daemon is not running");
    } else if (client_state == AVAHI_CLIENT_FAILURE) {
        forget_daemon(*state, std::string("avahi-daemon: ") + avahi_strerror(avahi_client_errno(client)));
    }
}

void run(std::shared_ptr<State> state) {
    constexpr auto kRetry = 2000ms;
    while (!state->stop.load()) {
        int error = 0;
        state->client = avahi_client_new(avahi_simple_poll_get(state->poll), AVAHI_CLIENT_NO_FAIL, on_client,
                                         state.get(), &error);
        if (!state->client) {
            forget_daemon(*state, std::string("cannot reach avahi-daemon (") + avahi_strerror(error) +
                                      "; is the D-Bus system bus running?)");
            std::unique_lock lock(state->mutex);
            state->changed.wait_for(lock, kRetry, [&] { return state->stop.load(); });
            continue;
        }
        // One iteration waits at most 100 ms, so a stop is seen that soon; avahi_simple_poll_wakeup
        // ends the wait at once.
        while (!state->stop.load() && avahi_simple_poll_iterate(state->poll, 100) == 0) {
        }
        forget_daemon(*state, "stopped");
        avahi_client_free(state->client);
        state->client = nullptr;
    }
    state->finished.store(true);
    state->changed.notify_all();
}

} // namespace

std::shared_ptr<DnssdBrowser> DnssdBrowser::shared() {
    std::lock_guard lock(g_shared_mutex);
    if (auto browser = g_shared.lock()) return browser;
    std::shared_ptr<DnssdBrowser> browser(new DnssdBrowser());
    browser->state_ = std::make_shared<State>();
    browser->state_->poll = avahi_simple_poll_new();
    if (browser->state_->poll) {
        browser->thread_ = std::thread(run, browser->state_);
    } else {
        browser->state_->problem = "cannot make avahi's poll loop";
        browser->state_->browsed = true;
    }
    g_shared = browser;
    return browser;
}

DnssdBrowser::~DnssdBrowser() {
    if (!thread_.joinable()) {
        if (state_->poll) avahi_simple_poll_free(state_->poll);
        return;
    }
    state_->stop.store(true);
    avahi_simple_poll_wakeup(state_->poll);
    state_->changed.notify_all();
    // Bounded: a D-Bus call the thread is in (avahi_client_new, a resolver's creation) may be slow
    // to answer when the bus is stuck. Then the thread is left to end on its own; it holds the state.
    std::unique_lock lock(state_->mutex);
    if (state_->changed.wait_for(lock, 500ms, [&] { return state_->finished.load(); })) {
        lock.unlock();
        thread_.join();
        avahi_simple_poll_free(state_->poll);
    } else {
        thread_.detach();
    }
}

std::vector<AdvertisedAgent> DnssdBrowser::agents(std::chrono::steady_clock::time_point deadline) {
    std::unique_lock lock(state_->mutex);
    state_->changed.wait_until(lock, deadline, [&] { return state_->browsed && state_->resolving == 0; });
    std::vector<AdvertisedAgent> found;
    for (const auto &[key, agent] : state_->agents)
        found.push_back(agent);
    return found;
}

std::string DnssdBrowser::problem() {
    std::lock_guard lock(state_->mutex);
    return state_->problem;
}

} // namespace splitvk
