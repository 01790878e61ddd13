// Tokens end to end: an agent started with --token-file serves only clients that present
// its token, through SPLITVK_TOKEN or SPLITVK_TOKEN_FILE. A wrong token or none is refused: one
// line on the client naming the reason, one line on the agent, the app runs unsplit to the end and
// exits 0, and the layer does not ask again (a token that was wrong stays wrong), so the agent sees
// exactly one refused session per run.
#include "agent.h"
#include "e2e_test.h"

#include <fstream>
#include <regex>
#include <thread>

namespace splitvk::e2e {
namespace {

using namespace std::chrono_literals;

constexpr int kFrames = 3;
constexpr const char *kToken = "splitvk-e2e-0123456789abcdef";

class Token : public XTest {
protected:
    void SetUp() override {
        XTest::SetUp();
        ASSERT_TRUE(built(explicit_layer_dir()));
        ASSERT_TRUE(built(atrium_path()));
        ASSERT_TRUE(built(agent_path()));
        token_file_ = out_ / "agent.token";
        std::ofstream(token_file_) << kToken << "\n";
        ASSERT_TRUE(agent_.start(env(), out_, {"--token-file", token_file_.string()})) << agent_.error();
    }

    // splitvk-atrium, small, through the layer at the agent, with `extra` settings.
    ProcessResult run_atrium(const Env &extra, const std::string &name) {
        Env e = env();
        use_explicit_layers(e, {kLayerName});
        e["SPLITVK_SERVER"] = agent_.address();
        e["SPLITVK_TILE_WAIT"] = "60000";
        for (auto &[k, v] : extra)
            e[k] = v;
        return run_app({atrium_path().string(), "--width", "320", "--height", "144", "--frames",
                        std::to_string(kFrames)},
                       e, out_, name, 120s);
    }

    // The agent's log once its session for the last run has ended (its listener logs "ended").
    std::string agent_log_after(size_t sessions) {
        std::string log = agent_.log();
        const auto deadline = Clock::now() + 20s;
        while (grep(log, ") ended: ").size() < sessions && Clock::now() < deadline) {
            std::this_thread::sleep_for(50ms);
            log = agent_.log();
        }
        return log;
    }

    void expect_split(const ProcessResult &r) {
        ASSERT_TRUE(r.ok()) << r.describe() << "\n" << tail(r.err(), 30);
        const std::string err = r.err();
        EXPECT_TRUE(grep(err, "refused").empty()) << tail(err, 30);
        EXPECT_FALSE(grep(err, "[splitvk] split: " + std::to_string(kFrames) + " frames").empty())
            << "the app did not split with the right token:\n"
            << tail(err, 30);
        const std::string log = agent_log_after(1);
        EXPECT_TRUE(grep(log, "rejected the client").empty()) << tail(log, 30);
        EXPECT_EQ(grep(log, ", " + std::to_string(kFrames) + " frames; ").size(), 1u)
            << "the agent did not serve the session to its end:\n"
            << tail(log, 30);
    }

    // One refusal line on each side, naming `reason`; the app unsplit to the end.
    void expect_refused(const ProcessResult &r, const std::string &reason) {
        ASSERT_TRUE(r.ok()) << "a refused app must still run: " << r.describe() << "\n" << tail(r.err(), 30);
        const std::string err = r.err();
        EXPECT_FALSE(grep(r.out(), ", " + std::to_string(kFrames) + " frames").empty())
            << "the app did not render every frame:\n"
            << r.out();
        const auto refused = grep(err, "refused the session");
        ASSERT_EQ(refused.size(), 1u) << "expected one line saying the agent refused the session:\n"
                                      << tail(err, 30);
        EXPECT_NE(refused[0].find(agent_.address()), std::string::npos) << refused[0];
        EXPECT_NE(refused[0].find(reason), std::string::npos) << refused[0];
        EXPECT_NE(refused[0].find("running unsplit"), std::string::npos) << refused[0];
        std::cout << "  client: " << refused[0] << "\n";
        EXPECT_TRUE(grep(err, "[splitvk] split:").empty()) << "a refused app split:\n" << tail(err, 30);
        const std::string log = agent_log_after(1);
        const auto rejected = grep(log, "rejected the client: " + reason);
        EXPECT_EQ(rejected.size(), 1u) << "expected exactly one refusal on the agent (no retries):\n"
                                       << tail(log, 30);
        if (!rejected.empty()) std::cout << "  agent:  " << rejected[0] << "\n";
        EXPECT_EQ(grep(log, ") started").size(), 1u) << "the layer asked the agent more than once:\n"
                                                     << tail(log, 30);
    }

    Agent agent_;
    std::filesystem::path token_file_;
};

TEST_F(Token, RightTokenInTheEnvironmentSplits) {
    expect_split(run_atrium({{"SPLITVK_TOKEN", kToken}}, "token-env"));
}

TEST_F(Token, RightTokenInAFileSplits) {
    const auto file = out_ / "client.token";
    std::ofstream(file) << kToken << "\n";
    expect_split(run_atrium({{"SPLITVK_TOKEN_FILE", file.string()}}, "token-file"));
}

TEST_F(Token, WrongTokenIsRefusedOnceAndTheAppRunsUnsplit) {
    expect_refused(run_atrium({{"SPLITVK_TOKEN", "not-the-token"}}, "token-wrong"), "bad token");
}

TEST_F(Token, MissingTokenIsRefusedOnceAndTheAppRunsUnsplit) {
    expect_refused(run_atrium({}, "token-none"), "not authorised");
}

} // namespace
} // namespace splitvk::e2e
