// Failover (layer/core/agent_candidates.h): the agent in use is SIGKILLed mid-run (listener and
// session, as a crash), and the layer brings another in with the resync from the live-state
// snapshot. The frames in between show the periphery; the layer says so in one line naming both
// agents; SPLITVK_STATS names the agent of each frame, the first before the loss and the other
// after it; the held frame's foveae equal native's; and the time from the loss to the first frame
// composited with the new agent's tiles, as the layer measures it, is at most 1 s (plus one browse
// wait when the agents are found over DNS-SD).
//  - FirstAgentKilledFailsOverToTheSecond: SPLITVK_SERVER lists two agents on loopback.
//  - AdvertisedAgentKilledFailsOverToTheOther: SPLITVK_SERVER=dnssd, two agents with --advertise
//    inside a network namespace of the test's with an avahi-daemon of its own (pool_test.cpp's
//    set-up: netns.h, avahi.h), sharing one pinned identity as a venue's would.
//  - AnAgentPerEyeAndAnEyeOutlivesItsAgent: SPLITVK_AGENTS=2 over three agents on loopback. Each eye's
//    foveae come from an agent of its own; the second eye's agent is killed, the first eye's foveae
//    go on coming from the first agent while the second eye shows the periphery, and the third agent
//    takes the second eye over.
//  - AdvertisedAgentPerEyeAndAnEyeOutlivesItsAgent: the same with SPLITVK_SERVER=dnssd picking the
//    agents among three advertised ones in the test's namespace.
// Validation is off here: it is the layer's time that is bounded, and the same resync path runs
// under validation on both sides in Reconnect.AgentKilledAndRestartedIsBroughtBackIn.
#include "agent_loss_fixture.h"
#include "avahi.h"
#include "netns.h"

#include <algorithm>
#include <array>
#include <fstream>
#include <functional>
#include <vector>

namespace splitvk::e2e {
namespace {

// The target: exact foveae again within a second of the loss, for an app whose frames take at most
// kBusyFrameMs. On a machine so loaded that they take longer (other builds on the 2 cores: 500 ms
// frames were seen), the bound is kFramesWithoutFovea of its median frame, and the test says so.
constexpr double kMostMsWithoutFovea = 1000;
constexpr double kBusyFrameMs = 100;
constexpr double kFramesWithoutFovea = 10;
constexpr const char *kToken = "splitvk-failover-e2e-51c0a7d2e93b4f68";
// How long the layer waits for the DNS-SD browser when it dials (EarlyAgent::kBrowseWait in
// layer/core/agent_link.h): the failover's bound over DNS-SD is one such wait longer.
constexpr double kBrowseWaitMs = 250;

class Pool : public AgentLossTest {
protected:
    void TearDown() override {
        avahi_.reset(); // before the namespace it runs in
        netns_.reset();
        AgentLossTest::TearDown();
    }

    // The namespace and its avahi-daemon; false (the test skips, saying why) where there are none.
    bool enter_namespace() {
        netns_ = std::make_unique<Netns>("fail");
        if (!netns_->ok()) {
            skip_reason_ = netns_->error();
            return false;
        }
        avahi_ = std::make_unique<PrivateAvahi>();
        if (!avahi_->start(*netns_, out_ / "avahi", env())) {
            skip_reason_ = avahi_->error();
            return false;
        }
        wrapper_ = netns_->wrap({});
        return true;
    }

    // One identity for every agent, pinned once, as HAProxy's pool has it (docs/security.md); off
    // loopback the agents want a token.
    void pin_venue_identity() {
        identity_ = out_ / "venue-identity";
        token_file_ = out_ / "agent.token";
        std::ofstream(token_file_) << kToken << "\n";
        fingerprint_ = agent_fingerprint(env(), out_, identity_);
        ASSERT_TRUE(fingerprint_.starts_with("sha256:")) << fingerprint_;
    }
    // The arguments of an agent with that identity advertised as `name`.
    std::vector<std::string> venue_agent_args(const std::string &name) const {
        return {"--state-dir", identity_.string(), "--token-file", token_file_.string(), "--advertise", name};
    }
    // The app finds them over DNS-SD, with the token and the pin.
    void use_venue_agents() {
        servers_ = "dnssd";
        extra_env_ = avahi_->bus_env({});
        extra_env_["SPLITVK_TOKEN"] = kToken;
        extra_env_["SPLITVK_AGENT_FINGERPRINT"] = fingerprint_;
    }

    // Kills the agent the app splits with (`a`, or whichever `label` names in the line that says it
    // was chosen over DNS-SD), and checks that the other takes over as above. `label`: how the layer
    // names an agent (its address, or 'NAME' (address) for an advertised one).
    void expect_failover(Agent &a, Agent &b, const std::function<std::string(const Agent &)> &label,
                         double browse_ms) {
        const std::filesystem::path stats = out_ / "stats.csv";
        extra_env_["SPLITVK_STATS"] = stats.string();
        auto app = start_split();
        ASSERT_TRUE(app);
        ASSERT_TRUE(wait_for_log("split: passes into", 120s)) << read_file(out_ / "split.stderr");
        std::this_thread::sleep_for(1s); // some frames with the first agent's tiles
        const auto chosen = grep(read_file(out_ / "split.stderr"), "chosen over DNS-SD");
        const bool b_chosen =
            !chosen.empty() && chosen.front().find(label(b) + " chosen") != std::string::npos;
        if (!chosen.empty()) std::cout << "  " << chosen.front() << "\n";
        Agent &first = b_chosen ? b : a;
        const std::string first_label = label(first), second_label = label(b_chosen ? a : b);
        const auto killed = Clock::now();
        first.kill();
        int since_loss_ms = -1;
        ASSERT_NO_FATAL_FAILURE(expect_recovered(*app, "", &since_loss_ms));
        const double seen_ms = std::chrono::duration<double, std::milli>(Clock::now() - killed).count();
        const std::string err = read_file(out_ / "split.stderr");

        // One line says it, naming both agents.
        const auto failovers = grep(err, "failover: splitvk-agent ");
        ASSERT_EQ(failovers.size(), 1u) << tail(err, 30);
        std::cout << "  " << failovers.front() << "\n";
        EXPECT_NE(failovers.front().find("failover: splitvk-agent " + first_label + " went away; " +
                                         second_label + " answered and joins at the next present"),
                  std::string::npos)
            << failovers.front();
        EXPECT_EQ(grep(err, "went away (").size(), 1u) << tail(err, 30);

        // The loss to the first fovea of the second agent, as the layer measured it (the held frame,
        // a frame later, is the exact one compared above).
        ASSERT_GE(since_loss_ms, 0) << "no loss time in the first frame line: " << tail(err, 30);
        std::cout << "  failover: first frame with the second agent's foveae " << since_loss_ms
                  << " ms after the first agent went away (" << static_cast<int>(seen_ms)
                  << " ms from the kill to the held frame compared, as the test saw it)\n";
        RecordProperty("failover_ms", std::to_string(since_loss_ms));

        // SPLITVK_STATS: each frame with tiles names its agent, the first before the loss and the
        // second from the first frame after it that has any; the frames in between have none.
        const auto rows = stats_text_rows(read_file(stats));
        ASSERT_FALSE(rows.empty());
        std::vector<double> frame_ms;
        for (const auto &row : stats_rows(read_file(stats)))
            if (row.count("frame_ms") && row.at("frame_ms") > 0) frame_ms.push_back(row.at("frame_ms"));
        ASSERT_FALSE(frame_ms.empty());
        std::sort(frame_ms.begin(), frame_ms.end());
        const double median_frame_ms = frame_ms[frame_ms.size() / 2];
        const double bound =
            browse_ms +
            (median_frame_ms <= kBusyFrameMs ? kMostMsWithoutFovea : kFramesWithoutFovea * median_frame_ms);
        std::cout << "  median frame " << median_frame_ms << " ms: bound " << bound << " ms"
                  << (median_frame_ms > kBusyFrameMs ? " (a loaded machine: 10 frames, not 1 s)" : "")
                  << "\n";
        EXPECT_LE(since_loss_ms, bound);
        size_t first_rows = 0, second_rows = 0, without = 0;
        bool second_seen = false;
        for (const auto &row : rows) {
            const std::string &agent = row.at("agent");
            const bool late = row.at("late") == "1";
            if (agent.empty()) {
                EXPECT_TRUE(late || !second_seen)
                    << "frame " << row.at("frame") << " has no agent but is not late";
                ++without;
                continue;
            }
            EXPECT_EQ(row.at("late"), "0") << "frame " << row.at("frame");
            if (agent == first_label) {
                EXPECT_FALSE(second_seen)
                    << "frame " << row.at("frame") << ": the first agent after the second";
                ++first_rows;
            } else {
                EXPECT_EQ(agent, second_label) << "frame " << row.at("frame");
                second_seen = true;
                ++second_rows;
            }
        }
        std::cout << "  stats: " << first_rows << " frames from the first agent, " << without
                  << " without one, " << second_rows << " from the second\n";
        EXPECT_GT(first_rows, 0u);
        EXPECT_GT(second_rows, 0u);
    }

    // SPLITVK_AGENTS=2 among three agents: two take an eye each, never the same one; the second eye's
    // agent is killed; the first eye's foveae go on coming from its agent while the second eye shows
    // the periphery; the third agent takes the second eye over; and the frame held after that has
    // both foveae equal to native's. `label`: how the layer names an agent.
    void expect_eye_outlives_its_agent(std::array<Agent *, 3> agents,
                                       const std::function<std::string(const Agent &)> &label) {
        const std::filesystem::path stats = out_ / "stats.csv";
        extra_env_["SPLITVK_AGENTS"] = "2";
        extra_env_["SPLITVK_STATS"] = stats.string();
        auto app = start_split();
        ASSERT_TRUE(app);
        ASSERT_TRUE(wait_for_log("split: passes into", 120s)) << read_file(out_ / "split.stderr");
        // Which agent took which eye: the list's first two, or the two DNS-SD found freest (one of
        // which may answer only after the app started, and join at a present).
        Agent *eye[2] = {nullptr, nullptr};
        const auto deadline = Clock::now() + 120s;
        while (Clock::now() < deadline && !(eye[0] && eye[1])) {
            const std::string started = read_file(out_ / "split.stderr");
            for (Agent *agent : agents)
                for (int e = 0; e < 2; ++e)
                    if (!grep(started, "replicating to splitvk-agent at " + label(*agent) + " for eye " +
                                           std::to_string(e + 1) + " of 2")
                             .empty())
                        eye[e] = agent;
            std::this_thread::sleep_for(50ms);
        }
        ASSERT_TRUE(eye[0] && eye[1]) << tail(read_file(out_ / "split.stderr"), 30);
        ASSERT_NE(eye[0], eye[1]) << "both eyes on one agent";
        // A frame with both eyes' tiles before the loss.
        const std::string both = label(*eye[0]) + "+" + label(*eye[1]);
        const auto has_both = [&] {
            for (const auto &row : stats_text_rows(read_file(stats)))
                if (row.count("agent") && row.at("agent") == both) return true;
            return false;
        };
        while (Clock::now() < deadline && !has_both())
            std::this_thread::sleep_for(50ms);
        ASSERT_TRUE(has_both()) << "no frame had both eyes' foveae: "
                                << tail(read_file(out_ / "split.stderr"), 30);
        Agent *spare = nullptr;
        for (Agent *agent : agents)
            if (agent != eye[0] && agent != eye[1]) spare = agent;
        eye[1]->kill();
        int since_loss_ms = -1;
        ASSERT_NO_FATAL_FAILURE(expect_recovered(*app, "", &since_loss_ms));
        const std::string err = read_file(out_ / "split.stderr");
        // One line for the loss, which costs only the second eye, and one for the failover.
        const auto gone = grep(err, "went away (");
        ASSERT_EQ(gone.size(), 1u) << tail(err, 30);
        EXPECT_NE(gone.front().find("eye 2's foveae show the periphery until another agent is brought in"),
                  std::string::npos)
            << gone.front();
        const auto failovers = grep(err, "failover: splitvk-agent ");
        ASSERT_EQ(failovers.size(), 1u) << tail(err, 30);
        EXPECT_NE(failovers.front().find("failover: splitvk-agent " + label(*eye[1]) + " went away; " +
                                         label(*spare) + " answered for eye 2"),
                  std::string::npos)
            << failovers.front();
        std::cout << "  " << failovers.front() << "\n  second eye's foveae again " << since_loss_ms
                  << " ms after its agent went away\n";

        // SPLITVK_STATS: both agents' tiles, then the first eye's agent's alone (late: the second eye
        // is the periphery's), then its and the spare's; never a frame without the first eye's agent
        // once it sent tiles.
        const std::string alone = label(*eye[0]);
        const std::string replaced = label(*eye[0]) + "+" + label(*spare);
        size_t both_rows = 0, alone_rows = 0, replaced_rows = 0;
        int phase = 0;
        for (const auto &row : stats_text_rows(read_file(stats))) {
            const std::string &agent = row.at("agent");
            // Before both eyes' agents were in, a frame may have had either's tiles or none.
            if (both_rows == 0 && agent != both) continue;
            if (agent.empty()) {
                ADD_FAILURE() << "frame " << row.at("frame") << ": the first eye lost its foveae";
                continue;
            }
            if (agent == both) {
                EXPECT_EQ(phase, 0) << "frame " << row.at("frame");
                EXPECT_EQ(row.at("late"), "0") << "frame " << row.at("frame");
                ++both_rows;
            } else if (agent == alone) {
                EXPECT_LE(phase, 1) << "frame " << row.at("frame");
                EXPECT_EQ(row.at("late"), "1")
                    << "frame " << row.at("frame") << ": one eye is the periphery's";
                phase = 1;
                ++alone_rows;
            } else {
                EXPECT_EQ(agent, replaced) << "frame " << row.at("frame");
                EXPECT_EQ(row.at("late"), "0") << "frame " << row.at("frame");
                phase = 2;
                ++replaced_rows;
            }
        }
        std::cout << "  stats: " << both_rows << " frames from both agents, " << alone_rows
                  << " from the first eye's alone, " << replaced_rows << " from it and the spare\n";
        EXPECT_GT(both_rows, 0u);
        EXPECT_GT(alone_rows, 0u);
        EXPECT_GT(replaced_rows, 0u);
    }

    std::unique_ptr<Netns> netns_;
    std::unique_ptr<PrivateAvahi> avahi_;
    std::filesystem::path identity_, token_file_;
    std::string fingerprint_;
    std::string skip_reason_;
};

TEST_F(Pool, FirstAgentKilledFailsOverToTheSecond) {
    Agent first, second;
    validate_ = false;
    ASSERT_TRUE(first.start(env(), out_, {}, 0, "first-agent")) << first.error();
    ASSERT_TRUE(second.start(env(), out_, {}, 0, "second-agent")) << second.error();
    servers_ = first.address() + "," + second.address();
    expect_failover(
        first, second, [](const Agent &agent) { return agent.address(); }, 0);
}

TEST_F(Pool, AdvertisedAgentKilledFailsOverToTheOther) {
    if (!enter_namespace()) GTEST_SKIP() << skip_reason_;
    validate_ = false;
    ASSERT_NO_FATAL_FAILURE(pin_venue_identity());

    // Both advertised with the same free slots: the layer picks one, which is killed.
    Agent first, second;
    for (auto [agent, name] : {std::pair{&first, "venue first"}, std::pair{&second, "venue second"}}) {
        agent->set_host(netns_->address(), wrapper_);
        const std::string stem = name == std::string("venue first") ? "first-agent" : "second-agent";
        ASSERT_TRUE(agent->start(avahi_->bus_env(env()), out_, venue_agent_args(name), 0, stem))
            << agent->error();
    }
    use_venue_agents();
    expect_failover(
        first, second,
        [&](const Agent &agent) {
            return std::string(&agent == &first ? "'venue first' (" : "'venue second' (") + agent.address() +
                   ")";
        },
        kBrowseWaitMs);
}

TEST_F(Pool, AnAgentPerEyeAndAnEyeOutlivesItsAgent) {
    validate_ = false;
    Agent left, right, spare;
    ASSERT_TRUE(left.start(env(), out_, {}, 0, "left-agent")) << left.error();
    ASSERT_TRUE(right.start(env(), out_, {}, 0, "right-agent")) << right.error();
    ASSERT_TRUE(spare.start(env(), out_, {}, 0, "spare-agent")) << spare.error();
    servers_ = left.address() + "," + right.address() + "," + spare.address();
    expect_eye_outlives_its_agent({&left, &right, &spare},
                                  [](const Agent &agent) { return agent.address(); });
}

TEST_F(Pool, AdvertisedAgentPerEyeAndAnEyeOutlivesItsAgent) {
    if (!enter_namespace()) GTEST_SKIP() << skip_reason_;
    validate_ = false;
    ASSERT_NO_FATAL_FAILURE(pin_venue_identity());
    Agent agents[3];
    const char *names[3] = {"venue one", "venue two", "venue three"};
    for (size_t i = 0; i < 3; ++i) {
        agents[i].set_host(netns_->address(), wrapper_);
        ASSERT_TRUE(agents[i].start(avahi_->bus_env(env()), out_, venue_agent_args(names[i]), 0,
                                    "agent-" + std::to_string(i + 1)))
            << agents[i].error();
    }
    use_venue_agents();
    expect_eye_outlives_its_agent({&agents[0], &agents[1], &agents[2]}, [&](const Agent &agent) {
        const size_t i = static_cast<size_t>(&agent - agents);
        return "'" + std::string(names[i]) + "' (" + agent.address() + ")";
    });
}

} // namespace
} // namespace splitvk::e2e
