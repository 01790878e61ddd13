#pragma once

// `splitvk-agent --advertise`: the agent as one DNS-SD service instance (_splitvk._tcp) published
// through avahi-daemon, with the TXT record of protocol/dnssd_record.h. The listener owns it and
// drives it from its own loop (poll()), so the listener stays single-threaded across its forks;
// the free session slots it advertises follow the sessions it runs. Advertising never stops the
// agent from serving: without avahi-daemon (or the system bus) it says so in one line, and
// advertises once the daemon appears. Destroying it withdraws the service.

#include "dnssd_record.h"

#include <memory>
#include <string>
#include <vector>

struct AvahiSimplePoll;
struct AvahiClient;
struct AvahiEntryGroup;
struct pollfd;

namespace splitvk::agent {

// What --advertise publishes; the port is the listener's.
struct Advertisement {
    std::string name;
    protocol::AgentRecord record;
};

// The default instance name: the host and the GPU, one DNS label (at most 63 bytes).
std::string default_advertised_name(const std::string &host, uint32_t device_index,
                                    const std::string &gpu_name);

class Advertiser {
public:
    Advertiser(std::string name, uint16_t port, protocol::AgentRecord record);
    ~Advertiser();
    Advertiser(const Advertiser &) = delete;
    Advertiser &operator=(const Advertiser &) = delete;

    // The sessions it can take now; republished only when it changed.
    void set_free_slots(uint32_t slots);
    // Does the D-Bus work that is due, without blocking.
    void poll();
    // In a forked session process: closes this process's copies of the D-Bus socket, so that a
    // session outliving its listener cannot keep the service advertised.
    void close_in_session();

    // The instance name (after avahi resolved a collision with another's).
    const std::string &name() const { return name_; }

private:
    static void on_client(AvahiClient *client, int state, void *self);
    static void on_group(AvahiEntryGroup *group, int state, void *self);
    static int poll_fds(::pollfd *fds, unsigned count, int timeout, void *self);
    void publish();
    void rename();

    std::string name_;
    uint16_t port_;
    protocol::AgentRecord record_;
    AvahiSimplePoll *poll_ = nullptr;
    AvahiClient *client_ = nullptr;
    AvahiEntryGroup *group_ = nullptr;
    bool waiting_logged_ = false;
    std::vector<int> fds_; // what avahi polled last: the D-Bus connection's sockets
};

} // namespace splitvk::agent
