// avahi-daemon for one test, on a D-Bus system bus of its own, inside the test's network
// namespace (netns.h) on its veth only: a private dbus-daemon (a system-bus configuration whose
// socket is a file in the test's output folder), and avahi-daemon with its own configuration
// (IPv4, allow-interfaces the veth, D-Bus on, no workstation or host-info records, a host name of
// the test's) as root without dropping privileges or chrooting, its pid file on a tmpfs of its own
// mount namespace. Programs that should reach it get bus_env(): DBUS_SYSTEM_BUS_ADDRESS.
#pragma once

#include "netns.h"
#include "process.h"

#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace splitvk::e2e {

// One resolved service as `avahi-browse -rpt` prints it.
struct BrowsedService {
    std::string name; // unescaped
    std::string address;
    int port = 0;
    std::map<std::string, std::string> txt;
};

class PrivateAvahi {
public:
    // Starts both; false with error() saying why (a missing program, or its last words).
    bool start(const Netns &netns, const std::filesystem::path &dir, const Env &env);
    ~PrivateAvahi();

    // DBUS_SYSTEM_BUS_ADDRESS of the private bus, added to `env`.
    Env bus_env(Env env) const;
    // `avahi-browse -rpt TYPE` inside the namespace: the resolved instances.
    std::vector<BrowsedService> browse(const std::string &type, const Env &env,
                                       std::string *raw = nullptr) const;
    const std::string &error() const { return error_; }

private:
    const Netns *netns_ = nullptr;
    std::filesystem::path dir_;
    std::filesystem::path socket_dir_;
    std::string bus_address_;
    std::unique_ptr<Process> bus_;
    std::unique_ptr<Process> daemon_;
    std::string error_;
};

} // namespace splitvk::e2e
