#include "netns.h"

#include <cstdlib>

#include <unistd.h>

namespace splitvk::e2e {
namespace {

bool run(const std::string &command) {
    return std::system((command + " >/dev/null 2>&1").c_str()) == 0;
}

} // namespace

Netns::Netns(const std::string &tag) {
    const int id = static_cast<int>(::getpid() % 100000);
    name_ = "svk-" + tag + "-" + std::to_string(id);
    // Interface names are at most 15 bytes.
    first_ = "svk" + tag.substr(0, 2) + std::to_string(id) + "a";
    second_ = "svk" + tag.substr(0, 2) + std::to_string(id) + "b";
    const std::string net = "10.214." + std::to_string(id % 250) + ".";
    address_ = net + "1";
    remove(); // one a killed run left behind
    const std::string in = "ip -n " + name_ + " ";
    const std::string setup = "ip netns add " + name_ + " && " + in + "link add " + first_ +
                              " type veth peer name " + second_ + " && " + in + "addr add " + address_ +
                              "/24 dev " + first_ + " && " + in + "addr add " + net + "2/24 dev " + second_ +
                              " && " + in + "link set " + first_ + " up && " + in + "link set " + second_ +
                              " up && " + in + "link set lo up";
    if (!run(setup)) {
        error_ =
            "cannot create a network namespace with a veth pair (`ip netns add` and `ip link add type veth` "
            "need CAP_NET_ADMIN): " +
            setup;
        remove();
    }
}

Netns::~Netns() {
    remove();
}

void Netns::remove() {
    // Deleting the namespace deletes the veth pair inside it.
    run("ip netns del " + name_);
}

std::vector<std::string> Netns::wrap(std::vector<std::string> argv) const {
    std::vector<std::string> wrapped{"ip", "netns", "exec", name_};
    wrapped.insert(wrapped.end(), argv.begin(), argv.end());
    return wrapped;
}

} // namespace splitvk::e2e
