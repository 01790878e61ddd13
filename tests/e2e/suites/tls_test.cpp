// TLS on the link end to end: a session to a non-loopback agent is TLS 1.3, and the bytes on
// the wire hold neither the token nor a SPIR-V module; the client trusts an agent on first use and
// records it in known_agents; a changed agent key is refused with one line and the app runs unsplit;
// plaintext from a non-loopback client is refused by the agent with one line.
//
// The non-loopback address is real: a veth pair into a network namespace this test creates (ip netns,
// which needs CAP_NET_ADMIN), the agent inside it, the bytes captured on the veth with an AF_PACKET
// socket (CAP_NET_RAW). Where either is not permitted, those tests skip with a line saying so.
#include "agent.h"
#include "e2e_test.h"

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <mutex>
#include <thread>

#include <arpa/inet.h>
#include <linux/if_ether.h>
#include <linux/if_packet.h>
#include <net/if.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

namespace splitvk::e2e {
namespace {

using namespace std::chrono_literals;

constexpr int kFrames = 3;
constexpr const char *kToken = "splitvk-tls-e2e-5f0c9a17d2b84e63";

// A network namespace with one end of a veth pair; the other end stays here. 10.213.N.1 is this
// side, 10.213.N.2 the namespace's.
class Netns {
public:
    Netns() {
        const int id = static_cast<int>(::getpid() % 100000);
        name_ = "svk-tls-" + std::to_string(id);
        outer_ = "svkt" + std::to_string(id) + "a";
        inner_ = "svkt" + std::to_string(id) + "b";
        const std::string net = "10.213." + std::to_string(id % 250) + ".";
        here_ = net + "1";
        there_ = net + "2";
        run("ip netns del " + name_); // a namespace a killed run left behind
        const std::string setup = "ip netns add " + name_ + " && ip link add " + outer_ +
                                  " type veth peer name " + inner_ + " && ip link set " + inner_ + " netns " +
                                  name_ + " && ip addr add " + here_ + "/30 dev " + outer_ +
                                  " && ip link set " + outer_ + " up && ip -n " + name_ + " addr add " +
                                  there_ + "/30 dev " + inner_ + " && ip -n " + name_ + " link set " +
                                  inner_ + " up && ip -n " + name_ + " link set lo up";
        if (!run(setup)) {
            error_ = "cannot create a network namespace with a veth pair (`ip netns add` and `ip link add "
                     "type veth` need CAP_NET_ADMIN): " +
                     setup;
            cleanup();
        }
    }
    ~Netns() { cleanup(); }

    bool ok() const { return error_.empty(); }
    const std::string &error() const { return error_; }
    const std::string &name() const { return name_; }
    const std::string &outer() const { return outer_; }
    const std::string &agent_host() const { return there_; }

private:
    static bool run(const std::string &command) {
        return std::system((command + " >/dev/null 2>&1").c_str()) == 0;
    }
    void cleanup() {
        run("ip netns del " + name_);
        run("ip link del " + outer_);
    }
    std::string name_, outer_, inner_, here_, there_, error_;
};

// Every frame crossing an interface, both directions, from an AF_PACKET socket.
class Capture {
public:
    bool start(const std::string &interface) {
        fd_ = ::socket(AF_PACKET, SOCK_RAW | SOCK_CLOEXEC, htons(ETH_P_ALL));
        if (fd_ < 0) {
            error_ = std::string("AF_PACKET socket: ") + std::strerror(errno) + " (needs CAP_NET_RAW)";
            return false;
        }
        sockaddr_ll address{};
        address.sll_family = AF_PACKET;
        address.sll_protocol = htons(ETH_P_ALL);
        address.sll_ifindex = static_cast<int>(::if_nametoindex(interface.c_str()));
        if (address.sll_ifindex == 0 ||
            ::bind(fd_, reinterpret_cast<sockaddr *>(&address), sizeof(address)) != 0) {
            error_ = "cannot capture on " + interface + ": " + std::strerror(errno);
            return false;
        }
        thread_ = std::thread([this] {
            std::vector<uint8_t> frame(1 << 18);
            while (!stop_) {
                pollfd entry{fd_, POLLIN, 0};
                if (::poll(&entry, 1, 100) <= 0) continue;
                const ssize_t n = ::recv(fd_, frame.data(), frame.size(), 0);
                if (n <= 0) continue;
                std::lock_guard lock(mutex_);
                bytes_.insert(bytes_.end(), frame.begin(), frame.begin() + n);
                ++frames_;
            }
        });
        return true;
    }
    std::vector<uint8_t> stop() {
        stop_ = true;
        if (thread_.joinable()) thread_.join();
        if (fd_ >= 0) ::close(fd_);
        fd_ = -1;
        std::lock_guard lock(mutex_);
        return bytes_;
    }
    size_t frames() {
        std::lock_guard lock(mutex_);
        return frames_;
    }
    ~Capture() { stop(); }
    const std::string &error() const { return error_; }

private:
    int fd_ = -1;
    std::atomic<bool> stop_{false};
    std::thread thread_;
    std::mutex mutex_;
    std::vector<uint8_t> bytes_;
    size_t frames_ = 0;
    std::string error_;
};

bool contains(const std::vector<uint8_t> &haystack, const std::vector<uint8_t> &needle) {
    return std::search(haystack.begin(), haystack.end(), needle.begin(), needle.end()) != haystack.end();
}

class Tls : public XTest {
protected:
    void SetUp() override {
        XTest::SetUp();
        ASSERT_TRUE(built(explicit_layer_dir()));
        ASSERT_TRUE(built(atrium_path()));
        ASSERT_TRUE(built(agent_path()));
        token_file_ = out_ / "agent.token";
        std::ofstream(token_file_) << kToken << "\n";
        config_home_ = out_ / "config";
    }

    // splitvk-atrium, small, through the layer at `agent`, with `extra` settings; the client's
    // known_agents under out_/config.
    ProcessResult run_atrium(const Agent &agent, const Env &extra, const std::string &name) {
        Env e = env();
        use_explicit_layers(e, {kLayerName});
        e["SPLITVK_SERVER"] = agent.address();
        e["SPLITVK_TILE_WAIT"] = "60000";
        e["SPLITVK_TOKEN"] = kToken;
        e["SPLITVK_LOG_LEVEL"] = "info";
        e["XDG_CONFIG_HOME"] = config_home_.string();
        for (auto &[k, v] : extra)
            e[k] = v;
        return run_app({atrium_path().string(), "--width", "320", "--height", "144", "--frames",
                        std::to_string(kFrames)},
                       e, out_, name, 120s);
    }

    std::string agent_log_after(const Agent &agent, size_t sessions) {
        std::string log = agent.log();
        const auto deadline = Clock::now() + 20s;
        while (grep(log, ") ended: ").size() < sessions && Clock::now() < deadline) {
            std::this_thread::sleep_for(50ms);
            log = agent.log();
        }
        return log;
    }

    std::string fingerprint_of(const std::filesystem::path &state_dir) {
        return agent_fingerprint(env(), out_, state_dir);
    }

    std::string known_agents() const { return read_file(config_home_ / "splitvk" / "known_agents"); }

    void expect_split(const ProcessResult &r) {
        ASSERT_TRUE(r.ok()) << r.describe() << "\n" << tail(r.err(), 30);
        EXPECT_FALSE(grep(r.err(), "[splitvk] split: " + std::to_string(kFrames) + " frames").empty())
            << "the app did not split:\n"
            << tail(r.err(), 30);
    }

    // The app ran every frame unsplit, and said why in exactly one line holding `words`.
    void expect_unsplit_with_one_line(const ProcessResult &r, const std::string &words) {
        ASSERT_TRUE(r.ok()) << "a refused app must still run: " << r.describe() << "\n" << tail(r.err(), 30);
        EXPECT_FALSE(grep(r.out(), ", " + std::to_string(kFrames) + " frames").empty()) << r.out();
        EXPECT_TRUE(grep(r.err(), "[splitvk] split:").empty()) << "a refused app split:\n"
                                                               << tail(r.err(), 30);
        const auto lines = grep(r.err(), "running unsplit");
        ASSERT_EQ(lines.size(), 1u) << tail(r.err(), 30);
        EXPECT_NE(lines[0].find(words), std::string::npos) << lines[0];
        std::cout << "  client: " << lines[0] << "\n";
    }

    std::filesystem::path token_file_;
    std::filesystem::path config_home_;
};

TEST_F(Tls, NonLoopbackSessionIsTls13AndTheLinkCarriesNoTokenAndNoSpirv) {
    Netns netns;
    if (!netns.ok()) GTEST_SKIP() << netns.error();
    Capture capture;
    if (!capture.start(netns.outer())) GTEST_SKIP() << capture.error();
    Agent agent;
    agent.set_host(netns.agent_host(), {"ip", "netns", "exec", netns.name()});
    ASSERT_TRUE(agent.start(env(), out_, {"--token-file", token_file_.string()})) << agent.error();

    const auto r = run_atrium(agent, {}, "tls-netns"); // SPLITVK_TLS unset: auto
    const std::string log = agent_log_after(agent, 1);
    const std::vector<uint8_t> wire = capture.stop();
    expect_split(r);
    EXPECT_EQ(grep(log, ", " + std::to_string(kFrames) + " frames; ").size(), 1u) << tail(log, 30);

    // Both sides say TLS 1.3.
    EXPECT_EQ(grep(log, ", TLS 1.3 (").size(), 1u) << tail(log, 30);
    EXPECT_EQ(grep(r.err(), ", TLS 1.3 (").size(), 1u) << tail(r.err(), 30);
    // The capture is of this session (the whole setup, shaders and textures, is several hundred KiB),
    // and the agent's ServerHello chose TLS 1.3: supported_versions (0x002b), length 2, 0x0304.
    std::cout << "  captured " << wire.size() << " bytes in " << capture.frames() << " frames on "
              << netns.outer() << "\n";
    EXPECT_GT(wire.size(), 100000u);
    EXPECT_TRUE(contains(wire, {0x00, 0x2b, 0x00, 0x02, 0x03, 0x04})) << "no TLS 1.3 ServerHello on the link";
    const std::string token = kToken;
    EXPECT_FALSE(contains(wire, std::vector<uint8_t>(token.begin(), token.end())))
        << "the token crossed in the clear";
    EXPECT_FALSE(contains(wire, {0x03, 0x02, 0x23, 0x07})) << "a SPIR-V module crossed in the clear";

    // Trust on first use: the agent's fingerprint, recorded for its address.
    const std::string fingerprint = fingerprint_of(out_ / "splitvk-agent-state");
    ASSERT_TRUE(fingerprint.starts_with("sha256:")) << fingerprint;
    EXPECT_NE(known_agents().find(agent.address() + " " + fingerprint), std::string::npos)
        << "known_agents:\n"
        << known_agents();
    EXPECT_EQ(grep(r.err(), "is new: trusting its certificate " + fingerprint).size(), 1u)
        << tail(r.err(), 30);
}

TEST_F(Tls, PlaintextFromANonLoopbackClientIsRefusedByTheAgent) {
    Netns netns;
    if (!netns.ok()) GTEST_SKIP() << netns.error();
    Capture capture;
    if (!capture.start(netns.outer())) GTEST_SKIP() << capture.error();
    Agent agent;
    agent.set_host(netns.agent_host(), {"ip", "netns", "exec", netns.name()});
    ASSERT_TRUE(agent.start(env(), out_, {"--token-file", token_file_.string()})) << agent.error();
    const auto r = run_atrium(agent, {{"SPLITVK_TLS", "off"}}, "tls-off");
    const std::vector<uint8_t> wire = capture.stop();
    expect_unsplit_with_one_line(r, "TLS required");
    // The control for the capture of the TLS test: a plaintext Hello shows its token on the link.
    const std::string token = kToken;
    EXPECT_TRUE(contains(wire, std::vector<uint8_t>(token.begin(), token.end())))
        << "the capture did not see the plaintext Hello's token: it would not see one in TLS either";
    const std::string log = agent_log_after(agent, 1);
    const auto refused = grep(log, "rejected the client: TLS required");
    ASSERT_EQ(refused.size(), 1u) << tail(log, 30);
    std::cout << "  agent:  " << refused[0] << "\n";
    EXPECT_EQ(grep(log, ") started").size(), 1u) << "the layer asked more than once:\n" << tail(log, 30);
}

TEST_F(Tls, AChangedAgentKeyIsRefusedAndTheAppRunsUnsplit) {
    // Loopback with SPLITVK_TLS=on: the same checks as on a LAN, without a namespace.
    Agent first;
    ASSERT_TRUE(first.start(env(), out_, {"--state-dir", (out_ / "state-first").string()}, 0, "agent-first"))
        << first.error();
    expect_split(run_atrium(first, {{"SPLITVK_TLS", "on"}}, "tls-first"));
    const std::string recorded = fingerprint_of(out_ / "state-first");
    EXPECT_NE(known_agents().find(first.address() + " " + recorded), std::string::npos) << known_agents();
    const uint16_t port = first.port();
    first.kill();

    // The same address, a new identity.
    Agent second;
    ASSERT_TRUE(
        second.start(env(), out_, {"--state-dir", (out_ / "state-second").string()}, port, "agent-second"))
        << second.error();
    const std::string changed = fingerprint_of(out_ / "state-second");
    ASSERT_NE(changed, recorded);
    const auto r = run_atrium(second, {{"SPLITVK_TLS", "on"}}, "tls-changed");
    expect_unsplit_with_one_line(r, "the agent's certificate changed: it is now " + changed + ", but ");
    const auto line = grep(r.err(), "running unsplit");
    if (!line.empty()) {
        EXPECT_NE(line[0].find("records " + recorded), std::string::npos) << line[0];
        EXPECT_NE(line[0].find("delete line 1 of "), std::string::npos) << line[0];
    }
    const std::string log = agent_log_after(second, 1);
    const auto refused = grep(log, "the client refused this agent's certificate");
    ASSERT_EQ(refused.size(), 1u) << tail(log, 30);
    std::cout << "  agent:  " << refused[0] << "\n";
    EXPECT_EQ(grep(log, ") started").size(), 1u) << "the layer asked more than once:\n" << tail(log, 30);

    // Pinning the new key accepts it, and leaves known_agents alone.
    const std::string before = known_agents();
    expect_split(
        run_atrium(second, {{"SPLITVK_TLS", "on"}, {"SPLITVK_AGENT_FINGERPRINT", changed}}, "tls-pinned"));
    EXPECT_EQ(known_agents(), before);
}

} // namespace
} // namespace splitvk::e2e
