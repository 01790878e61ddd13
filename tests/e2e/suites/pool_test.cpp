// Agents for a venue: found over DNS-SD, and a pool behind one HAProxy address.
//  - An agent with --advertise is one _splitvk._tcp instance whose TXT record avahi-browse sees
//    (session fingerprint, certificate, GPU, TLS, free slots), whose free slots follow its sessions,
//    and which is withdrawn when the agent stops.
//  - A client with SPLITVK_SERVER=dnssd dials the kept agent with most free slots, and never one
//    whose advertised certificate it does not pin.
//  - HAProxy (TCP, maxconn 1 per agent) in front of two agents that share one identity: two clients
//    split, a third runs unsplit with one line and is taken in when a slot frees.
//
// Everything runs inside a network namespace the test makes (netns.h: a veth pair with both ends
// inside), with an avahi-daemon of the test's own on a private D-Bus system bus (avahi.h), so no
// multicast reaches one of the machine's interfaces. Where the namespace or avahi cannot be had,
// each test skips with a line saying why.
#include "agent.h"
#include "avahi.h"
#include "e2e_test.h"
#include "netns.h"

#include <fstream>
#include <memory>
#include <regex>
#include <thread>

namespace splitvk::e2e {
namespace {

using namespace std::chrono_literals;

constexpr const char *kToken = "splitvk-pool-e2e-3a9c51d07be24f86";
constexpr const char *kServiceType = "_splitvk._tcp";

class Pool : public XTest {
protected:
    void SetUp() override {
        XTest::SetUp();
        ASSERT_TRUE(built(explicit_layer_dir()));
        ASSERT_TRUE(built(atrium_path()));
        ASSERT_TRUE(built(agent_path()));
        netns_ = std::make_unique<Netns>("pool");
        if (!netns_->ok()) GTEST_SKIP() << netns_->error();
        avahi_ = std::make_unique<PrivateAvahi>();
        if (!avahi_->start(*netns_, out_ / "avahi", env())) GTEST_SKIP() << avahi_->error();
        token_file_ = out_ / "agent.token";
        std::ofstream(token_file_) << kToken << "\n";
        config_home_ = out_ / "config";
        std::filesystem::create_directories(config_home_);
    }
    void TearDown() override {
        avahi_.reset(); // before the namespace it runs in
        netns_.reset();
    }

    // An agent inside the namespace on its veth address, with a token (it is off loopback).
    void start_agent(Agent &agent, const std::string &name, std::vector<std::string> args) {
        agent.set_host(netns_->address(), netns_->wrap({}));
        args.insert(args.end(), {"--token-file", token_file_.string()});
        ASSERT_TRUE(agent.start(avahi_->bus_env(env()), out_, args, 0, name)) << agent.error();
    }

    std::string fingerprint_of(const std::filesystem::path &state_dir) {
        return agent_fingerprint(env(), out_, state_dir);
    }

    // splitvk-atrium through the layer inside the namespace, small, SPLITVK_SERVER=`server`.
    ProcessSpec client(const std::string &name, int frames, const std::string &server,
                       const Env &extra = {}) {
        Env e = env();
        use_explicit_layers(e, {kLayerName});
        e["SPLITVK_SERVER"] = server;
        e["SPLITVK_TOKEN"] = kToken;
        e["SPLITVK_TILE_WAIT"] = "60000";
        e["SPLITVK_LOG_LEVEL"] = "info";
        e["XDG_CONFIG_HOME"] = config_home_.string();
        for (const auto &[k, v] : extra)
            e[k] = v;
        ProcessSpec spec;
        spec.argv = netns_->wrap({atrium_path().string(), "--width", "320", "--height", "144", "--frames",
                                  std::to_string(frames)});
        spec.env = avahi_->bus_env(e);
        spec.out_dir = out_;
        spec.name = name;
        return spec;
    }

    // The instance called `name` once avahi-browse sees it with `key` at `value` (any value when
    // empty), within `timeout`; nullopt if not.
    std::optional<BrowsedService> browse_until(const std::string &name, const std::string &key,
                                               const std::string &value, std::chrono::seconds timeout) {
        const auto deadline = Clock::now() + timeout;
        do {
            std::string raw;
            for (const BrowsedService &service : avahi_->browse(kServiceType, env(), &raw)) {
                if (service.name != name) continue;
                if (key.empty() || (service.txt.count(key) && service.txt.at(key) == value)) return service;
            }
            last_browse_ = raw;
        } while (Clock::now() < deadline);
        return std::nullopt;
    }
    bool gone_within(const std::string &name, std::chrono::seconds timeout) {
        const auto deadline = Clock::now() + timeout;
        do {
            bool seen = false;
            for (const BrowsedService &service : avahi_->browse(kServiceType, env(), &last_browse_))
                seen = seen || service.name == name;
            if (!seen) return true;
        } while (Clock::now() < deadline);
        return false;
    }

    static bool wait_for(const std::function<bool()> &done, std::chrono::seconds timeout) {
        const auto deadline = Clock::now() + timeout;
        while (Clock::now() < deadline) {
            if (done()) return true;
            std::this_thread::sleep_for(100ms);
        }
        return done();
    }

    // Sessions the agent served. HAProxy may hand a queued client to an agent whose last session
    // is still ending (the client's side closed first); the agent forks it and rejects it over
    // --max-sessions, and the client dials again: that one is not a session served.
    static size_t sessions_started(const Agent &agent) {
        const std::string log = agent.log();
        return grep(log, ") started").size() - grep(log, ") started over --max-sessions").size();
    }

    void expect_split(const ProcessResult &r, int frames) {
        ASSERT_TRUE(r.ok()) << r.describe() << "\n" << tail(r.err(), 30);
        EXPECT_FALSE(grep(r.err(), "[splitvk] split: " + std::to_string(frames) + " frames").empty())
            << "the app did not split every frame:\n"
            << tail(r.err(), 30);
    }

    std::unique_ptr<Netns> netns_;
    std::unique_ptr<PrivateAvahi> avahi_;
    std::filesystem::path token_file_;
    std::filesystem::path config_home_;
    std::string last_browse_;
};

TEST_F(Pool, AdvertisedWithItsRecordAndWithdrawnWhenTheAgentStops) {
    Agent agent;
    start_agent(agent, "agent", {"--advertise", "pool agent", "--max-sessions", "3"});
    const auto service = browse_until("pool agent", "", "", 15s);
    ASSERT_TRUE(service) << "avahi-browse does not see the agent:\n" << last_browse_ << tail(agent.log(), 20);
    std::cout << "  avahi-browse:";
    for (const auto &[k, v] : service->txt)
        std::cout << " " << k << "=" << v;
    std::cout << "\n";
    EXPECT_EQ(service->address, netns_->address());
    EXPECT_EQ(service->port, agent.port());
    const auto &txt = service->txt;
    EXPECT_TRUE(
        std::regex_match(txt.count("session") ? txt.at("session") : "", std::regex(R"(\d+-[0-9a-f]{16})")));
    EXPECT_EQ(txt.count("cert") ? txt.at("cert") : "", fingerprint_of(out_ / "agent-state"));
    EXPECT_NE((txt.count("gpu") ? txt.at("gpu") : "").find("llvmpipe"), std::string::npos);
    EXPECT_TRUE(std::regex_match(txt.count("uuid") ? txt.at("uuid") : "", std::regex("[0-9a-f]{32}")));
    EXPECT_EQ(txt.count("tls") ? txt.at("tls") : "", "on");
    EXPECT_EQ(txt.count("slots") ? txt.at("slots") : "", "3");
    EXPECT_EQ(txt.count("max") ? txt.at("max") : "", "3");
    EXPECT_FALSE(grep(agent.log(), "advertised as 'pool agent' (_splitvk._tcp").empty())
        << tail(agent.log(), 20);

    const ProcessResult stopped = agent.stop(10s);
    EXPECT_TRUE(gone_within("pool agent", 15s)) << "still advertised after the agent stopped:\n"
                                                << last_browse_;
    EXPECT_FALSE(grep(agent.log(), "withdrew the DNS-SD service 'pool agent'").empty())
        << tail(agent.log(), 20);
}

TEST_F(Pool, FreeSlotsFollowTheSessions) {
    Agent agent;
    start_agent(agent, "agent", {"--advertise", "pool agent", "--max-sessions", "2"});
    ASSERT_TRUE(browse_until("pool agent", "slots", "2", 15s)) << last_browse_;
    const std::string fingerprint = fingerprint_of(out_ / "agent-state");
    // A client that keeps its session until it is ended.
    Process app(client("held", 1'000'000, "dnssd", {{"SPLITVK_AGENT_FINGERPRINT", fingerprint}}));
    ASSERT_TRUE(app.start()) << app.error();
    EXPECT_TRUE(browse_until("pool agent", "slots", "1", 30s))
        << "one session running, but not 1 free slot:\n"
        << last_browse_ << tail(agent.log(), 20) << tail(read_file(out_ / "held.stderr"), 20);
    EXPECT_EQ(sessions_started(agent), 1u) << tail(agent.log(), 20);
    app.terminate(10s);
    EXPECT_TRUE(browse_until("pool agent", "slots", "2", 30s))
        << "the session ended, but not 2 free slots again:\n"
        << last_browse_ << tail(agent.log(), 20);
}

TEST_F(Pool, ClientPicksTheAdvertisedAgentWithMostFreeSlots) {
    Agent first, second;
    start_agent(first, "agent-first", {"--advertise", "pool first", "--max-sessions", "2"});
    start_agent(second, "agent-second", {"--advertise", "pool second", "--max-sessions", "2"});
    // Both pinned through known_agents, as a venue's headsets would have them.
    std::filesystem::create_directories(config_home_ / "splitvk");
    std::ofstream(config_home_ / "splitvk" / "known_agents")
        << first.address() << " " << fingerprint_of(out_ / "agent-first-state") << "\n"
        << second.address() << " " << fingerprint_of(out_ / "agent-second-state") << "\n";
    // One session on the first agent, dialled by its address.
    Process held(client("held", 1'000'000, first.address()));
    ASSERT_TRUE(held.start()) << held.error();
    ASSERT_TRUE(browse_until("pool first", "slots", "1", 30s)) << last_browse_ << tail(first.log(), 20);
    ASSERT_TRUE(browse_until("pool second", "slots", "2", 15s)) << last_browse_;

    const ProcessResult r = run_process(client("picked", 3, "dnssd"), 120s);
    expect_split(r, 3);
    const auto chosen = grep(r.err(), "chosen over DNS-SD");
    ASSERT_EQ(chosen.size(), 1u) << tail(r.err(), 30);
    std::cout << "  client: " << chosen[0] << "\n";
    EXPECT_NE(chosen[0].find("'pool second' (" + second.address() + ") chosen over DNS-SD: 2 free slots"),
              std::string::npos)
        << chosen[0];
    EXPECT_EQ(sessions_started(second), 1u) << tail(second.log(), 20);
    EXPECT_EQ(sessions_started(first), 1u) << "the client dialled the fuller agent too:\n"
                                           << tail(first.log(), 20);
    held.terminate(10s);
}

TEST_F(Pool, AnAdvertisedAgentWhoseCertificateIsNotPinnedIsNotDialled) {
    Agent agent;
    start_agent(agent, "agent", {"--advertise", "pool agent"});
    ASSERT_TRUE(browse_until("pool agent", "", "", 15s)) << last_browse_;
    const std::string fingerprint = fingerprint_of(out_ / "agent-state");
    // No SPLITVK_AGENT_FINGERPRINT, no known_agents: nothing pins the advertised certificate.
    const ProcessResult r = run_process(client("unpinned", 3, "dnssd"), 120s);
    ASSERT_TRUE(r.ok()) << "a client that finds no agent must still run: " << r.describe() << "\n"
                        << tail(r.err(), 30);
    EXPECT_TRUE(grep(r.err(), "[splitvk] split:").empty()) << tail(r.err(), 30);
    const auto refused =
        grep(r.err(), "advertises the certificate " + fingerprint + ", which this client does not pin");
    ASSERT_EQ(refused.size(), 1u) << tail(r.err(), 30);
    std::cout << "  client: " << refused[0] << "\n";
    const auto unsplit = grep(r.err(), "running unsplit");
    ASSERT_EQ(unsplit.size(), 1u) << tail(r.err(), 30);
    EXPECT_NE(unsplit[0].find("certificate not pinned"), std::string::npos) << unsplit[0];
    EXPECT_EQ(sessions_started(agent), 0u) << "the client dialled an unpinned agent:\n"
                                           << tail(agent.log(), 20);
    EXPECT_FALSE(std::filesystem::exists(config_home_ / "splitvk" / "known_agents"))
        << "an advertised certificate was recorded (trusted on first use)";
}

TEST_F(Pool, HaproxyServesTwoClientsAndTakesTheThirdInWhenASlotFrees) {
    if (!find_program("haproxy", env())) GTEST_SKIP() << "haproxy is not installed (Debian package haproxy)";
    // One identity for the pool: both agents read the same state directory, so one pin fits the
    // pool's one address whichever agent HAProxy picks.
    const std::filesystem::path identity = out_ / "pool-identity";
    const std::string fingerprint = fingerprint_of(identity);
    ASSERT_TRUE(fingerprint.starts_with("sha256:")) << fingerprint;
    Agent first, second;
    start_agent(first, "agent-first", {"--state-dir", identity.string(), "--max-sessions", "1"});
    start_agent(second, "agent-second", {"--state-dir", identity.string(), "--max-sessions", "1"});
    const uint16_t port = free_loopback_port();
    const std::string pool = netns_->address() + ":" + std::to_string(port);
    std::ofstream(out_ / "haproxy.cfg")
        << "global\n  maxconn 64\n"
           "defaults\n  mode tcp\n  timeout connect 1s\n  timeout client 120s\n"
           "  timeout server 120s\n  timeout queue 1s\n"
           "frontend pool\n  bind "
        << pool
        << "\n  default_backend agents\n"
           "backend agents\n  balance leastconn\n"
           "  server first "
        << first.address() << " maxconn 1\n  server second " << second.address() << " maxconn 1\n";
    ProcessSpec proxy_spec;
    proxy_spec.argv = netns_->wrap({"haproxy", "-db", "-f", (out_ / "haproxy.cfg").string()});
    proxy_spec.env = env();
    proxy_spec.out_dir = out_;
    proxy_spec.name = "haproxy";
    Process proxy(proxy_spec);
    ASSERT_TRUE(proxy.start()) << proxy.error();
    std::this_thread::sleep_for(500ms);
    ASSERT_TRUE(proxy.running()) << read_file(out_ / "haproxy.stderr");

    const Env pinned{{"SPLITVK_AGENT_FINGERPRINT", fingerprint}};
    constexpr int kShort = 40, kLong = 100000;
    Process one(client("client-1", kShort, pool, pinned));
    Process two(client("client-2", kShort, pool, pinned));
    ASSERT_TRUE(one.start()) << one.error();
    ASSERT_TRUE(two.start()) << two.error();
    ASSERT_TRUE(wait_for([&] { return sessions_started(first) == 1 && sessions_started(second) == 1; }, 60s))
        << tail(first.log(), 10) << tail(second.log(), 10);
    // The pool is full: the third waits in HAProxy's queue past its bound and is let go.
    Process three(client("client-3", kLong, pool, pinned));
    ASSERT_TRUE(three.start()) << three.error();
    const ProcessResult r1 = one.wait(180s);
    const ProcessResult r2 = two.wait(180s);
    expect_split(r1, kShort);
    expect_split(r2, kShort);
    const bool joined = wait_for(
        [&] { return !grep(read_file(out_ / "client-3.stderr"), "brought in at frame").empty(); }, 60s);
    const ProcessResult r3 = three.terminate(10s);
    const std::string err3 = read_file(out_ / "client-3.stderr");
    const auto unsplit = grep(err3, "running unsplit");
    ASSERT_EQ(unsplit.size(), 1u) << tail(err3, 30);
    std::cout << "  third client: " << unsplit[0] << "\n";
    EXPECT_NE(unsplit[0].find("no splitvk-agent at " + pool), std::string::npos) << unsplit[0];
    ASSERT_TRUE(joined) << "the third client was not taken in when a slot freed:\n" << tail(err3, 30);
    std::cout << "  third client: " << grep(err3, "brought in at frame")[0] << "\n";
    EXPECT_EQ(sessions_started(first) + sessions_started(second), 3u)
        << tail(first.log(), 10) << tail(second.log(), 10);
    (void)r3;
}

} // namespace
} // namespace splitvk::e2e
