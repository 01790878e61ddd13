// Command-stream replication: a real splitvk-agent on loopback replays what the layer
// captures, and SPLITVK_VERIFY=full proves every presented frame identical, pixel for pixel.
// Also: with no agent the application runs unsplit, says so once, and exits 0.
//
// Loopback only: the agent listens on 127.0.0.1 and a port picked free for each test.
#include "agent.h"
#include "e2e_test.h"

#include <regex>
#include <thread>

namespace splitvk::e2e {
namespace {

using namespace std::chrono_literals;

struct VerifySummary {
    bool found = false;
    uint64_t frames = 0;
    uint64_t mismatches = 0;
};

VerifySummary verify_summary(const std::string &err) {
    VerifySummary s;
    const std::regex line(R"(^\[splitvk\] verify: (\d+) frames, (\d+) mismatching pixels$)");
    int count = 0;
    for (const auto &l : split_lines(err)) {
        std::smatch m;
        if (std::regex_search(l, m, line)) {
            ++count;
            s.found = true;
            s.frames = std::stoull(m[1]);
            s.mismatches = std::stoull(m[2]);
        }
    }
    if (count != 1) s.found = false; // exactly one line
    return s;
}

class Replication : public XTest {
protected:
    void SetUp() override {
        XTest::SetUp();
        ASSERT_TRUE(built(explicit_layer_dir()));
        ASSERT_TRUE(built(atrium_path()));
    }

    // The agent, with the validation layer in its sessions; `extra` adds options.
    void start_agent(const std::vector<std::string> &extra = {}) {
        ASSERT_TRUE(built(agent_path()));
        std::vector<std::string> args = {"--validate"};
        args.insert(args.end(), extra.begin(), extra.end());
        ASSERT_TRUE(agent_.start(env(), out_, args)) << agent_.error();
        port_ = agent_.port();
    }

    // The client runs with the Khronos validation layer (synchronization validation on) below
    // splitvk, so what splitvk adds to the app's stream (verify read-backs, its own semaphores) is
    // validated too.
    Env split_env() {
        Env e = env();
        use_explicit_layers(e, {kLayerName, kValidationLayerName});
        validation_log_ = configure_validation(e, out_);
        e["SPLITVK_SERVER"] = "127.0.0.1:" + std::to_string(port_);
        e["SPLITVK_VERIFY"] = "full";
        return e;
    }

    void expect_verified(const ProcessResult &r, uint64_t frames) {
        std::string agent_log = read_file(out_ / "splitvk-agent.stderr");
        ASSERT_TRUE(r.ok()) << r.describe() << "\n" << tail(r.err()) << "\nagent:\n" << tail(agent_log);
        EXPECT_TRUE(grep(r.err(), "running unsplit").empty()) << tail(r.err()) << "\nagent:\n"
                                                              << tail(agent_log);
        const VerifySummary s = verify_summary(r.err());
        ASSERT_TRUE(s.found) << "no single verify line:\n"
                             << tail(r.err()) << "\nagent:\n"
                             << tail(agent_log);
        EXPECT_EQ(s.frames, frames) << tail(r.err());
        EXPECT_EQ(s.mismatches, 0u) << tail(r.err(), 40) << "\nagent:\n" << tail(agent_log);

        // Validation on both sides: the client's log is empty, and the agent's session, which
        // ends when the app disconnects, reports no validation message.
        EXPECT_TRUE(client_validation_clean(validation_log_));
        EXPECT_TRUE(agent_session_validation_clean(out_ / "splitvk-agent.stderr"));
    }

    uint16_t port_ = 0;
    Agent agent_;
    std::filesystem::path validation_log_;
};

constexpr int kFrames = 12;

TEST_F(Replication, AtriumStereoVerifies) {
    ASSERT_NO_FATAL_FAILURE(start_agent());
    auto r = run_app({atrium_path().string(), "--width", "600", "--height", "270", "--eyes", "2", "--frames",
                      std::to_string(kFrames)},
                     split_env(), out_, "atrium-stereo", 180s);
    expect_verified(r, kFrames);
}

TEST_F(Replication, AtriumMonoVerifies) {
    ASSERT_NO_FATAL_FAILURE(start_agent());
    auto r = run_app({atrium_path().string(), "--width", "600", "--height", "270", "--eyes", "1", "--frames",
                      std::to_string(kFrames)},
                     split_env(), out_, "atrium-mono", 180s);
    expect_verified(r, kFrames);
}

// The textures reach the GPU through linear images the host wrote at the client driver's row
// pitch: the layer sends their layouts (ImageLayouts) and the agent lays the bytes out for its own
// driver. Both are lavapipe here, so this proves the path end to end, not a re-pitch (the agent
// test does that with a client layout lavapipe would not make).
TEST_F(Replication, AtriumLinearTexturesVerifies) {
    ASSERT_NO_FATAL_FAILURE(start_agent());
    auto r = run_app({atrium_path().string(), "--width", "600", "--height", "270", "--eyes", "2", "--frames",
                      std::to_string(kFrames), "--linear-textures"},
                     split_env(), out_, "atrium-linear", 180s);
    expect_verified(r, kFrames);
    EXPECT_TRUE(grep(read_file(out_ / "splitvk-agent.stderr"), "copied 1:1").empty());
}

class ReplicationCube : public Replication, public ::testing::WithParamInterface<const char *> {};

TEST_P(ReplicationCube, Verifies) {
    ASSERT_NO_FATAL_FAILURE(start_agent());
    const std::string program = GetParam();
    ASSERT_TRUE(find_program(program, env())) << program << " is not installed (vulkan-tools)";
    auto r = run_app({program, "--c", std::to_string(kFrames)}, split_env(), out_, program, 180s);
    expect_verified(r, kFrames);
}

INSTANTIATE_TEST_SUITE_P(VulkanTools, ReplicationCube, ::testing::Values("vkcube", "vkcubepp"),
                         [](const ::testing::TestParamInfo<const char *> &p) {
                             return std::string(p.param);
                         });

// The agent behaves as a GPU with 256-byte buffer alignments (a desktop GPU's), the client is
// lavapipe (16): the device envelope tells the application 256, so what it aligns by that replays
// exactly on the agent. Without the envelope, atrium's second uniform slot sits at 0x110 and the
// agent flags every second frame (on an NVIDIA GPU those frames drew a flat fovea).
class ReplicationStricterAgent : public Replication, public ::testing::WithParamInterface<const char *> {};

TEST_P(ReplicationStricterAgent, VerifiesWithNoViolation) {
    ASSERT_NO_FATAL_FAILURE(start_agent(
        {"--emulate-limits", (source_dir() / "tests/e2e/profiles/strict_alignment.json").string()}));
    const std::string program = GetParam();
    std::vector<std::string> argv;
    if (program == "atrium") {
        argv = {atrium_path().string(), "--width", "600", "--height", "270", "--eyes", "2", "--frames",
                std::to_string(kFrames)};
    } else {
        ASSERT_TRUE(find_program(program, env())) << program << " is not installed (vulkan-tools)";
        argv = {program, "--c", std::to_string(kFrames)};
    }
    Env e = split_env();
    e["SPLITVK_LOG_LEVEL"] = "info";
    auto r = run_app(argv, e, out_, program, 180s);
    // The application was told the stricter GPU's alignment, by the agent that answered at
    // vkCreateInstance.
    EXPECT_FALSE(grep(r.err(), "minUniformBufferOffsetAlignment 16 -> 256").empty()) << tail(r.err());
    EXPECT_FALSE(grep(r.err(), "the agent's 'llvmpipe").empty()) << tail(r.err());
    expect_verified(r, kFrames);
    const std::string agent_log = read_file(out_ / "splitvk-agent.stderr");
    EXPECT_TRUE(grep(agent_log, "flagged invalid").empty()) << tail(agent_log);
    EXPECT_TRUE(grep(agent_log, "rejected the client").empty()) << tail(agent_log);
    // One application run, one session: the device adopted the connection made at vkCreateInstance.
    EXPECT_EQ(grep(agent_log, ") started").size(), 1u) << tail(agent_log);
}

INSTANTIATE_TEST_SUITE_P(Envelope, ReplicationStricterAgent,
                         ::testing::Values("atrium", "vkcube", "vkcubepp"),
                         [](const ::testing::TestParamInfo<const char *> &p) {
                             return std::string(p.param);
                         });

// An agent that joins after the application was told its limits, on a GPU that cannot honour them
// (images up to 1024 where the app was told 8192): it refuses the session, one line on each side,
// and the application runs on unsplit and exits 0.
TEST_F(Replication, LateAgentThatCannotHonourTheEnvelopeIsRefused) {
    ASSERT_TRUE(built(agent_path()));
    port_ = free_loopback_port();
    ASSERT_NE(port_, 0);
    Env e = env();
    use_explicit_layers(e, {kLayerName});
    e["SPLITVK_SERVER"] = "127.0.0.1:" + std::to_string(port_);
    ProcessSpec spec;
    spec.argv = {atrium_path().string(), "--width", "600", "--height", "270", "--frames", "100000"};
    spec.env = e;
    spec.out_dir = out_;
    spec.name = "atrium-late-agent";
    Process app(spec);
    ASSERT_TRUE(app.start()) << app.error();
    const auto stderr_says = [&](const std::string &text, std::chrono::seconds timeout) {
        const auto deadline = Clock::now() + timeout;
        while (Clock::now() < deadline && app.running()) {
            if (read_file(out_ / (spec.name + ".stderr")).find(text) != std::string::npos) return true;
            std::this_thread::sleep_for(50ms);
        }
        return read_file(out_ / (spec.name + ".stderr")).find(text) != std::string::npos;
    };
    ASSERT_TRUE(stderr_says("no splitvk-agent at", 120s)) << tail(read_file(out_ / (spec.name + ".stderr")));
    ASSERT_TRUE(agent_.start(
        env(), out_, {"--emulate-limits", (source_dir() / "tests/e2e/profiles/tiny_images.json").string()},
        port_))
        << agent_.error();
    const bool refused = stderr_says("refused the session", 60s);
    // An unbounded app ends at its next frame: under ASan on a loaded 2-core CI machine that frame
    // and the teardown took longer than 10 s once.
    auto r = app.terminate(30s);
    ASSERT_TRUE(refused) << tail(r.err());
    ASSERT_TRUE(r.ok()) << r.describe() << "\n" << tail(r.err());
    const auto lines = grep(r.err(), "refused the session");
    ASSERT_EQ(lines.size(), 1u) << r.err();
    EXPECT_NE(lines[0].find("maxImageDimension2D: told 8192, this device 1024"), std::string::npos)
        << lines[0];
    EXPECT_NE(lines[0].find("running unsplit"), std::string::npos) << lines[0];
    const std::string agent_log = read_file(out_ / "splitvk-agent.stderr");
    EXPECT_EQ(grep(agent_log, "rejected the client: the agent's GPU cannot honour").size(), 1u)
        << tail(agent_log);
}

// No agent at the address: one warning line, then the application runs unsplit and exits 0.
TEST_F(Replication, NoAgentRunsUnsplit) {
    port_ = free_loopback_port();
    ASSERT_NE(port_, 0);
    Env e = env();
    use_explicit_layers(e, {kLayerName});
    e["SPLITVK_SERVER"] = "127.0.0.1:" + std::to_string(port_);
    auto r = run_app({atrium_path().string(), "--width", "600", "--height", "270", "--frames", "3"}, e, out_,
                     "atrium-no-agent", 120s);
    ASSERT_TRUE(r.ok()) << r.describe() << "\n" << tail(r.err());
    const auto lines = grep(r.err(), "running unsplit");
    ASSERT_EQ(lines.size(), 1u) << r.err();
    EXPECT_NE(lines[0].find("no splitvk-agent at 127.0.0.1:" + std::to_string(port_)), std::string::npos)
        << lines[0];
    EXPECT_TRUE(lines_starting_with(r.err(), "[splitvk] error:").empty()) << r.err();
}

} // namespace
} // namespace splitvk::e2e
