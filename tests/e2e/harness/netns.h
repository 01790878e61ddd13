// A network namespace of the test's own with a veth pair whose both ends are inside it, so that
// nothing the test sends (multicast DNS included) can reach one of the machine's interfaces. The
// first end has 10.214.N.1, the second 10.214.N.2 (N from the test's pid). Programs run inside it
// through wrap(): `ip netns exec`, which also gives them a mount namespace of their own.
#pragma once

#include <string>
#include <vector>

namespace splitvk::e2e {

class Netns {
public:
    // `tag`: a few letters that tell one suite's namespaces from another's.
    explicit Netns(const std::string &tag);
    ~Netns();
    Netns(const Netns &) = delete;
    Netns &operator=(const Netns &) = delete;

    bool ok() const { return error_.empty(); }
    const std::string &error() const { return error_; } // one line: why there is none
    const std::string &name() const { return name_; }
    const std::string &interface() const { return first_; } // the end with address()
    const std::string &address() const { return address_; }
    // argv prefixed to run a program inside the namespace.
    std::vector<std::string> wrap(std::vector<std::string> argv) const;

private:
    void remove();
    std::string name_, first_, second_, address_, error_;
};

} // namespace splitvk::e2e
