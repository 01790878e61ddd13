// Reliability (issue 6): the agent dies or starts late, and the application goes on.
//  - Late join: splitvk-atrium starts with no agent (runs unsplit), an agent starts afterwards and
//    is brought in with a snapshot of the live state; the held last frame has exact foveae.
//  - Kill and restart: the agent is SIGKILLed mid-run (listener and session), the app keeps
//    presenting complete frames (the centre from the periphery), a new agent on the same port is
//    brought in, and the held last frame has exact foveae again.
// Both sides run under validation (sync on) and must stay silent. The resync time, from the new
// agent answering to its first composited frame, is printed (the layer logs it).
#include "agent.h"
#include "e2e_test.h"
#include "fovea.h"

#include <memory>
#include <regex>
#include <thread>

namespace splitvk::e2e {
namespace {

using namespace std::chrono_literals;

constexpr uint32_t kWidth = 1200;
constexpr uint32_t kHeight = 540;

class Reconnect : public XTest {
protected:
    void SetUp() override {
        XTest::SetUp();
        ASSERT_TRUE(built(explicit_layer_dir()));
        ASSERT_TRUE(built(atrium_path()));
        ASSERT_TRUE(built(agent_path()));
        port_ = free_loopback_port();
        ASSERT_NE(port_, 0);
    }

    std::vector<std::string> argv(int frames) const {
        std::vector<std::string> argv = {atrium_path().string(),
                                         "--width",
                                         std::to_string(kWidth),
                                         "--height",
                                         std::to_string(kHeight),
                                         "--eyes",
                                         "2",
                                         "--frames",
                                         std::to_string(frames),
                                         "--hold"};
        argv.insert(argv.end(), extra_args_.begin(), extra_args_.end());
        return argv;
    }

    Env split_env() {
        Env e = env();
        use_explicit_layers(e, {kLayerName, kValidationLayerName});
        validation_log_ = configure_validation(e, out_);
        e["SPLITVK_SERVER"] = "127.0.0.1:" + std::to_string(port_);
        e["SPLITVK_TILE_WAIT"] = "60000"; // a slow machine must not turn the compared frame late
        e["SPLITVK_LOG_LEVEL"] = "info";
        return e;
    }

    // Native frame `frames - 1`, grabbed from the X server.
    Image native_frame(int frames) {
        ProcessSpec spec;
        spec.argv = argv(frames);
        spec.env = env();
        spec.out_dir = out_;
        spec.name = "native";
        Process p(spec);
        EXPECT_TRUE(p.start()) << p.error();
        EXPECT_TRUE(p.wait_for_line("holding frame " + std::to_string(frames - 1), 240s));
        Image image;
        std::string error;
        EXPECT_TRUE(grab_stable(display(), 0, 0, kWidth, kHeight, out_ / "native.raw", &image, &error))
            << error;
        p.terminate(10s);
        return image;
    }

    // The app with the layer and validation, its output in split.{stdout,stderr}; null (after a
    // failure) when it does not start.
    std::unique_ptr<Process> start_split(int frames) {
        ProcessSpec spec;
        spec.argv = argv(frames);
        spec.env = split_env();
        spec.out_dir = out_;
        spec.name = "split";
        auto app = std::make_unique<Process>(spec);
        if (app->start()) return app;
        ADD_FAILURE() << app->error();
        return nullptr;
    }

    // Waits until the split run's stderr holds `text`.
    bool wait_for_log(const std::string &text, std::chrono::seconds timeout) {
        const auto deadline = Clock::now() + timeout;
        while (Clock::now() < deadline) {
            if (read_file(out_ / "split.stderr").find(text) != std::string::npos) return true;
            std::this_thread::sleep_for(50ms);
        }
        return false;
    }

    // The held last frame's foveae equal native, the app ended well, validation stayed silent.
    void expect_recovered(Process &app, int frames, const Image &native, const std::string &agent_name) {
        const bool held = app.wait_for_line("holding frame " + std::to_string(frames - 1), 240s);
        Image image;
        std::string error;
        const bool grabbed =
            held && grab_stable(display(), 0, 0, kWidth, kHeight, out_ / "split.raw", &image, &error);
        const ProcessResult r = app.terminate(10s);
        ASSERT_TRUE(held) << "the app did not complete every frame: " << r.describe() << "\n"
                          << tail(r.err(), 30);
        ASSERT_TRUE(grabbed) << error;
        ASSERT_TRUE(r.ok()) << r.describe() << "\n" << tail(r.err(), 30);
        const std::string &err = r.err();
        EXPECT_FALSE(grep(err, "brought in at frame").empty()) << tail(err, 30);
        const std::regex first(
            R"(the first split frame from the agent that joined, (\d+) ms after it answered)");
        std::smatch m;
        ASSERT_TRUE(std::regex_search(err, m, first))
            << "no frame was composited with the new agent's tiles\n"
            << tail(err, 30);
        std::cout << "  resync: first composited frame " << m[1] << " ms after the new agent answered\n";
        RecordProperty("resync_ms", m[1].str());
        for (const Rect &f : default_foveae(kWidth, kHeight, 2)) {
            const auto cmp = compare_exact(native, image, f.x, f.y, f.w, f.h);
            EXPECT_TRUE(cmp.equal()) << "fovea at " << f.x << "," << f.y
                                     << " after the resync: " << cmp.summary() << "\n"
                                     << save_mismatch_artefacts(out_, "fovea", native, image);
        }
        EXPECT_TRUE(client_validation_clean(validation_log_));
        EXPECT_TRUE(agent_session_validation_clean(out_ / (agent_name + ".stderr")));
    }

    uint16_t port_ = 0;
    std::filesystem::path validation_log_;
    std::vector<std::string> extra_args_; // atrium options of one test
};

// Frame counts: the app must still be rendering when the new agent joins, several seconds after
// the split started on a fast machine (an app that finished first would prove nothing); a slower
// machine or the sanitizer build only adds margin.
TEST_F(Reconnect, AgentStartedAfterTheAppJoins) {
    constexpr int kFrames = 120;
    const Image native = native_frame(kFrames);
    auto app = start_split(kFrames);
    ASSERT_TRUE(app);
    ASSERT_TRUE(wait_for_log("running unsplit until one answers", 120s)) << read_file(out_ / "split.stderr");
    Agent agent;
    ASSERT_TRUE(agent.start(env(), out_, {"--validate"}, port_)) << agent.error();
    ASSERT_NO_FATAL_FAILURE(expect_recovered(*app, kFrames, native, "splitvk-agent"));
}

// The same with buffer device addresses (atrium --buffer-address push): the agent that joins learns
// the client's addresses from the snapshot (each BufferAddress is a live-state log entry), or it
// would flag every frame invalid for an address it does not know, and no fovea would match.
TEST_F(Reconnect, AgentStartedAfterTheAppLearnsItsBufferAddresses) {
    constexpr int kFrames = 12; // started at frame 0's "running unsplit", the agent joins at frame 0 or 1
    extra_args_ = {"--buffer-address", "push"};
    const Image native = native_frame(kFrames);
    auto app = start_split(kFrames);
    ASSERT_TRUE(app);
    ASSERT_TRUE(wait_for_log("running unsplit until one answers", 120s)) << read_file(out_ / "split.stderr");
    Agent agent;
    ASSERT_TRUE(agent.start(env(), out_, {"--validate"}, port_)) << agent.error();
    ASSERT_NO_FATAL_FAILURE(expect_recovered(*app, kFrames, native, "splitvk-agent"));
    EXPECT_TRUE(grep(agent.log(), "cannot translate").empty()) << tail(agent.log(), 30);
}

TEST_F(Reconnect, AgentKilledAndRestartedIsBroughtBackIn) {
    constexpr int kFrames = 300;
    const Image native = native_frame(kFrames);
    Agent first;
    ASSERT_TRUE(first.start(env(), out_, {"--validate"}, port_, "first-agent")) << first.error();
    auto app = start_split(kFrames);
    ASSERT_TRUE(app);
    ASSERT_TRUE(wait_for_log("split: passes into", 120s)) << read_file(out_ / "split.stderr");
    std::this_thread::sleep_for(1s); // some frames with tiles first
    first.kill();
    ASSERT_TRUE(wait_for_log("went away", 30s)) << read_file(out_ / "split.stderr");
    std::this_thread::sleep_for(1s); // some frames with no agent at all
    Agent second;
    ASSERT_TRUE(second.start(env(), out_, {"--validate"}, port_, "second-agent")) << second.error();
    ASSERT_NO_FATAL_FAILURE(expect_recovered(*app, kFrames, native, "second-agent"));
}

} // namespace
} // namespace splitvk::e2e
