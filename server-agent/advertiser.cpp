#include "advertiser.h"

#include "log.h"

#include <avahi-client/client.h>
#include <avahi-client/publish.h>
#include <avahi-common/alternative.h>
#include <avahi-common/error.h>
#include <avahi-common/malloc.h>
#include <avahi-common/simple-watch.h>
#include <avahi-common/strlst.h>
#include <poll.h>
#include <unistd.h>

namespace splitvk::agent {
namespace {

AvahiStringList *txt_of(const protocol::AgentRecord &record) {
    AvahiStringList *list = nullptr;
    const std::vector<std::string> entries = protocol::encode_txt(record);
    // avahi_string_list_add prepends: add them backwards to keep the table's order.
    for (auto it = entries.rbegin(); it != entries.rend(); ++it)
        list = avahi_string_list_add(list, it->c_str());
    return list;
}

} // namespace

std::string default_advertised_name(const std::string &host, uint32_t device_index,
                                    const std::string &gpu_name) {
    std::string name = host + " GPU " + std::to_string(device_index) + " " + gpu_name;
    if (name.size() > 63) {
        name.resize(63);
        // Not in the middle of a UTF-8 sequence: drop continuation bytes and the lead byte they follow.
        while (!name.empty() && (static_cast<unsigned char>(name.back()) & 0xC0) == 0x80)
            name.pop_back();
        if (!name.empty() && (static_cast<unsigned char>(name.back()) & 0x80)) name.pop_back();
    }
    while (!name.empty() && name.back() == ' ')
        name.pop_back();
    return name;
}

Advertiser::Advertiser(std::string name, uint16_t port, protocol::AgentRecord record)
    : name_(std::move(name)), port_(port), record_(std::move(record)) {
    poll_ = avahi_simple_poll_new();
    if (!poll_) {
        SPLITVK_WARN("--advertise: cannot make avahi's poll loop; serving without advertising");
        return;
    }
    avahi_simple_poll_set_func(poll_, &Advertiser::poll_fds, this);
    int error = 0;
    // NO_FAIL: an absent avahi-daemon is a state (CONNECTING), and the client publishes when the
    // daemon appears or comes back after a restart.
    client_ = avahi_client_new(
        avahi_simple_poll_get(poll_), AVAHI_CLIENT_NO_FAIL,
        [](AvahiClient *c, AvahiClientState state, void *self) {
            on_client(c, static_cast<int>(state), self);
        },
        this, &error);
    if (!client_)
        SPLITVK_WARN("--advertise: cannot reach avahi-daemon (%s: is the D-Bus system bus running?); serving "
                     "without advertising",
                     avahi_strerror(error));
}

Advertiser::~Advertiser() {
    // Freeing the client frees its entry group, which withdraws the service (goodbye packets).
    if (group_) {
        avahi_entry_group_reset(group_);
        SPLITVK_INFO("withdrew the DNS-SD service '%s'", name_.c_str());
    }
    if (client_) avahi_client_free(client_);
    if (poll_) avahi_simple_poll_free(poll_);
}

int Advertiser::poll_fds(::pollfd *fds, unsigned count, int timeout, void *self) {
    auto *advertiser = static_cast<Advertiser *>(self);
    advertiser->fds_.clear();
    for (unsigned i = 0; i < count; ++i)
        advertiser->fds_.push_back(fds[i].fd);
    return ::poll(fds, count, timeout);
}

void Advertiser::poll() {
    if (!poll_) return;
    // Runs whatever is ready (timeouts and D-Bus messages), waiting for nothing.
    for (int i = 0; i < 16; ++i)
        if (avahi_simple_poll_iterate(poll_, 0) != 0) break;
}

void Advertiser::close_in_session() {
    for (const int fd : fds_)
        ::close(fd);
    fds_.clear();
}

void Advertiser::set_free_slots(uint32_t slots) {
    if (record_.free_slots == slots) return;
    record_.free_slots = slots;
    if (!group_ || avahi_entry_group_is_empty(group_)) return;
    AvahiStringList *txt = txt_of(record_);
    const int r = avahi_entry_group_update_service_txt_strlst(group_, AVAHI_IF_UNSPEC, AVAHI_PROTO_UNSPEC,
                                                              AvahiPublishFlags(0), name_.c_str(),
                                                              protocol::kDnssdServiceType, nullptr, txt);
    avahi_string_list_free(txt);
    if (r < 0)
        SPLITVK_WARN("--advertise: cannot update the free slots of '%s': %s", name_.c_str(),
                     avahi_strerror(r));
}

void Advertiser::on_client(AvahiClient *client, int state, void *self) {
    auto *advertiser = static_cast<Advertiser *>(self);
    // Called from within avahi_client_new too, before client_ is set.
    advertiser->client_ = client;
    switch (static_cast<AvahiClientState>(state)) {
    case AVAHI_CLIENT_S_RUNNING:
        advertiser->waiting_logged_ = false;
        advertiser->publish();
        break;
    case AVAHI_CLIENT_S_COLLISION:
    case AVAHI_CLIENT_S_REGISTERING:
        // The host name is being (re)established: publish again once it runs.
        if (advertiser->group_) avahi_entry_group_reset(advertiser->group_);
        break;
    case AVAHI_CLIENT_CONNECTING:
        if (!std::exchange(advertiser->waiting_logged_, true))
            SPLITVK_WARN(
                "--advertise: avahi-daemon is not running; serving without advertising until it starts");
        // Its entry group went with the daemon.
        advertiser->group_ = nullptr;
        break;
    case AVAHI_CLIENT_FAILURE:
        SPLITVK_WARN("--advertise: avahi-daemon: %s; serving without advertising",
                     avahi_strerror(avahi_client_errno(client)));
        break;
    }
}

void Advertiser::on_group(AvahiEntryGroup *, int state, void *self) {
    auto *advertiser = static_cast<Advertiser *>(self);
    switch (static_cast<AvahiEntryGroupState>(state)) {
    case AVAHI_ENTRY_GROUP_ESTABLISHED:
        SPLITVK_INFO("advertised as '%s' (%s, port %u, %u free slots)", advertiser->name_.c_str(),
                     protocol::kDnssdServiceType, advertiser->port_, advertiser->record_.free_slots);
        break;
    case AVAHI_ENTRY_GROUP_COLLISION:
        advertiser->rename();
        break;
    case AVAHI_ENTRY_GROUP_FAILURE:
        SPLITVK_WARN("--advertise: avahi-daemon could not publish '%s': %s", advertiser->name_.c_str(),
                     avahi_strerror(avahi_client_errno(advertiser->client_)));
        break;
    default:
        break;
    }
}

void Advertiser::rename() {
    char *alternative = avahi_alternative_service_name(name_.c_str());
    SPLITVK_WARN("--advertise: another service is called '%s' on this network; advertising as '%s'",
                 name_.c_str(), alternative);
    name_ = alternative;
    avahi_free(alternative);
    if (group_) avahi_entry_group_reset(group_);
    publish();
}

void Advertiser::publish() {
    if (!group_) {
        group_ = avahi_entry_group_new(
            client_,
            [](AvahiEntryGroup *g, AvahiEntryGroupState state, void *self) {
                on_group(g, static_cast<int>(state), self);
            },
            this);
        if (!group_) {
            SPLITVK_WARN("--advertise: avahi-daemon: %s", avahi_strerror(avahi_client_errno(client_)));
            return;
        }
    }
    if (!avahi_entry_group_is_empty(group_)) return;
    AvahiStringList *txt = txt_of(record_);
    int r = avahi_entry_group_add_service_strlst(group_, AVAHI_IF_UNSPEC, AVAHI_PROTO_UNSPEC,
                                                 AvahiPublishFlags(0), name_.c_str(),
                                                 protocol::kDnssdServiceType, nullptr, nullptr, port_, txt);
    avahi_string_list_free(txt);
    if (r == AVAHI_ERR_COLLISION) return rename();
    if (r >= 0) r = avahi_entry_group_commit(group_);
    if (r < 0) SPLITVK_WARN("--advertise: cannot publish '%s': %s", name_.c_str(), avahi_strerror(r));
}

} // namespace splitvk::agent
