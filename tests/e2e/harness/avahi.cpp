#include "avahi.h"

#include <cctype>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <thread>

#include <stdlib.h>

namespace splitvk::e2e {
namespace {

using namespace std::chrono_literals;

// avahi-browse -p writes a name's dots, semicolons, spaces and backslashes as \DDD (decimal).
std::string unescape(const std::string &text) {
    std::string out;
    for (size_t i = 0; i < text.size(); ++i) {
        const auto digit = [&](size_t at) { return std::isdigit(static_cast<unsigned char>(text[at])) != 0; };
        if (text[i] == '\\' && i + 3 < text.size() && digit(i + 1) && digit(i + 2) && digit(i + 3)) {
            out += static_cast<char>(std::stoi(text.substr(i + 1, 3)));
            i += 3;
        } else if (text[i] == '\\' && i + 1 < text.size()) {
            out += text[++i];
        } else {
            out += text[i];
        }
    }
    return out;
}

std::vector<std::string> fields(const std::string &line) {
    std::vector<std::string> out(1);
    for (const char c : line) {
        if (c == ';')
            out.emplace_back();
        else
            out.back() += c;
    }
    return out;
}

// `"a=1" "b=2"` as avahi-browse prints a TXT record.
std::map<std::string, std::string> txt_of(const std::string &text) {
    std::map<std::string, std::string> txt;
    size_t at = 0;
    while ((at = text.find('"', at)) != std::string::npos) {
        const size_t end = text.find('"', at + 1);
        if (end == std::string::npos) break;
        const std::string entry = text.substr(at + 1, end - at - 1);
        const size_t equals = entry.find('=');
        if (equals != std::string::npos) txt[entry.substr(0, equals)] = entry.substr(equals + 1);
        at = end + 1;
    }
    return txt;
}

bool wait_for_text(const std::filesystem::path &file, const std::string &text, Process &process,
                   std::chrono::milliseconds timeout) {
    const auto deadline = Clock::now() + timeout;
    while (Clock::now() < deadline) {
        if (read_file(file).find(text) != std::string::npos) return true;
        if (!process.running()) return false;
        std::this_thread::sleep_for(50ms);
    }
    return false;
}

} // namespace

bool PrivateAvahi::start(const Netns &netns, const std::filesystem::path &dir, const Env &env) {
    netns_ = &netns;
    dir_ = dir;
    std::filesystem::create_directories(dir);
    for (const char *program : {"dbus-daemon", "avahi-daemon", "avahi-browse"}) {
        if (!find_program(program, env)) {
            error_ = std::string(program) +
                     " is not installed (Debian packages dbus-daemon, avahi-daemon, avahi-utils)";
            return false;
        }
    }
    // A UNIX socket's path has at most 107 bytes: the bus's lives in a short folder of its own.
    char socket_dir[] = "/tmp/svk-bus-XXXXXX";
    if (!::mkdtemp(socket_dir)) {
        error_ = std::string("mkdtemp: ") + std::strerror(errno);
        return false;
    }
    socket_dir_ = socket_dir;
    const std::filesystem::path socket = socket_dir_ / "system_bus_socket";
    bus_address_ = "unix:path=" + socket.string();
    std::ofstream(dir / "bus.conf")
        << "<!DOCTYPE busconfig PUBLIC \"-//freedesktop//DTD D-Bus Bus Configuration 1.0//EN\"\n"
           " \"http://www.freedesktop.org/standards/dbus/1.0/busconfig.dtd\">\n"
           "<busconfig>\n  <type>system</type>\n  <listen>"
        << bus_address_
        << "</listen>\n  <auth>EXTERNAL</auth>\n  <policy context=\"default\">\n"
           "    <allow user=\"*\"/>\n    <allow own=\"*\"/>\n"
           "    <allow send_type=\"method_call\"/>\n    <allow send_type=\"signal\"/>\n"
           "    <allow send_type=\"method_return\"/>\n    <allow send_type=\"error\"/>\n"
           "    <allow receive_type=\"method_call\"/>\n    <allow receive_type=\"signal\"/>\n"
           "    <allow receive_type=\"method_return\"/>\n    <allow receive_type=\"error\"/>\n"
           "  </policy>\n</busconfig>\n";
    std::ofstream(dir / "avahi-daemon.conf")
        << "[server]\nhost-name=splitvk-pool-test\nuse-ipv4=yes\nuse-ipv6=no\n"
           "allow-interfaces="
        << netns.interface()
        << "\nenable-dbus=yes\n"
           "[wide-area]\nenable-wide-area=no\n"
           "[publish]\npublish-addresses=yes\npublish-hinfo=no\n"
           "publish-workstation=no\npublish-domain=no\n"
           "[reflector]\nenable-reflector=no\n";
    ProcessSpec bus;
    bus.argv = {"dbus-daemon", "--config-file=" + (dir / "bus.conf").string(), "--nofork", "--print-address"};
    bus.env = env;
    bus.out_dir = dir;
    bus.name = "dbus-daemon";
    bus_ = std::make_unique<Process>(bus);
    if (!bus_->start() || !wait_for_text(dir / "dbus-daemon.stdout", "unix:path=", *bus_, 10s)) {
        error_ = "the private dbus-daemon did not start: " + read_file(dir / "dbus-daemon.stderr");
        return false;
    }
    // avahi-daemon's pid file and socket are at a path it was built with (/run/avahi-daemon): a
    // tmpfs there, in the mount namespace `ip netns exec` gives it, keeps them its own.
    ProcessSpec daemon;
    daemon.argv = netns.wrap({"sh", "-c",
                              "mkdir -p /run/avahi-daemon && mount -t tmpfs tmpfs /run/avahi-daemon && exec "
                              "avahi-daemon --no-drop-root --no-chroot --no-rlimits --no-proc-title -f " +
                                  (dir / "avahi-daemon.conf").string()});
    daemon.env = bus_env(env);
    daemon.out_dir = dir;
    daemon.name = "avahi-daemon";
    daemon_ = std::make_unique<Process>(daemon);
    if (!daemon_->start() ||
        !wait_for_text(dir / "avahi-daemon.stderr", "Server startup complete", *daemon_, 15s)) {
        error_ = "avahi-daemon did not start: " + read_file(dir / "avahi-daemon.stderr");
        return false;
    }
    return true;
}

PrivateAvahi::~PrivateAvahi() {
    if (daemon_) daemon_->terminate(3s);
    if (bus_) bus_->terminate(3s);
    std::error_code ignored;
    if (!socket_dir_.empty()) std::filesystem::remove_all(socket_dir_, ignored);
}

Env PrivateAvahi::bus_env(Env env) const {
    env["DBUS_SYSTEM_BUS_ADDRESS"] = bus_address_;
    return env;
}

std::vector<BrowsedService> PrivateAvahi::browse(const std::string &type, const Env &env,
                                                 std::string *raw) const {
    ProcessSpec spec;
    spec.argv = netns_->wrap({"avahi-browse", "-rpt", "-k", type});
    spec.env = bus_env(env);
    spec.out_dir = dir_;
    spec.name = "avahi-browse";
    const ProcessResult result = run_process(spec, 20s);
    const std::string out = result.out();
    if (raw) *raw = out;
    std::vector<BrowsedService> services;
    for (const std::string &line : split_lines(out)) {
        const std::vector<std::string> f = fields(line);
        // =;interface;protocol;name;type;domain;host;address;port;txt
        if (f.size() < 10 || f[0] != "=") continue;
        BrowsedService service;
        service.name = unescape(f[3]);
        service.address = f[7];
        service.port = std::atoi(f[8].c_str());
        std::string txt = f[9];
        for (size_t i = 10; i < f.size(); ++i)
            txt += ";" + f[i]; // a semicolon inside the TXT record
        service.txt = txt_of(txt);
        services.push_back(std::move(service));
    }
    return services;
}

} // namespace splitvk::e2e
