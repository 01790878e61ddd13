// The live-state log (docs/architecture.md §3, layer/capture/session.h) is complete and ordered: with
// SPLITVK_LOG_LEVEL=debug the layer builds a snapshot of it at the second present and at
// vkDestroyDevice, replays its handle changes through the codec's decoder and HandleTable as a
// fresh agent would (every id a command names must already be live), and logs one line:
//   live-state log at frame 1: N objects, D descriptor sets, C command buffers, B bytes, replay ok
// A real splitvk-agent on a free loopback port keeps the session live.
#include "agent.h"
#include "e2e_test.h"

#include <regex>
#include <thread>

namespace splitvk::e2e {
namespace {

using namespace std::chrono_literals;

struct LiveStateLine {
    bool found = false;
    uint64_t objects = 0, descriptor_sets = 0, command_buffers = 0, bytes = 0;
    std::string replay;
    std::string text;
};

// The one line logged `when` ("at frame 1", "at vkDestroyDevice").
LiveStateLine live_state_line(const std::string &err, const std::string &when) {
    LiveStateLine s;
    const std::regex line(
        "live-state log " + when +
        R"(: (\d+) objects, (\d+) descriptor sets, (\d+) command buffers, (\d+) bytes, replay (.*)$)");
    int count = 0;
    for (const auto &l : split_lines(err)) {
        std::smatch m;
        if (!std::regex_search(l, m, line)) continue;
        ++count;
        s.found = true;
        s.objects = std::stoull(m[1]);
        s.descriptor_sets = std::stoull(m[2]);
        s.command_buffers = std::stoull(m[3]);
        s.bytes = std::stoull(m[4]);
        s.replay = m[5];
        s.text = l;
    }
    if (count != 1) s.found = false;
    return s;
}

class ReplicationLiveState : public XTest {
protected:
    void SetUp() override {
        XTest::SetUp();
        ASSERT_TRUE(built(explicit_layer_dir()));
        ASSERT_TRUE(built(agent_path()));
        ASSERT_TRUE(agent_.start(env(), out_)) << agent_.error();
        port_ = agent_.port();
    }

    Env debug_env() {
        Env e = env();
        use_explicit_layers(e, {kLayerName});
        e["SPLITVK_SERVER"] = "127.0.0.1:" + std::to_string(port_);
        e["SPLITVK_LOG_LEVEL"] = "debug";
        return e;
    }

    // Both lines present and replayable; returns the one at frame 1.
    LiveStateLine check(const ProcessResult &r) {
        const std::string agent_log = read_file(out_ / "splitvk-agent.stderr");
        EXPECT_TRUE(r.ok()) << r.describe() << "\n" << tail(r.err()) << "\nagent:\n" << tail(agent_log);
        EXPECT_TRUE(grep(r.err(), "running unsplit").empty()) << tail(r.err());
        const LiveStateLine running = live_state_line(r.err(), "at frame 1");
        const LiveStateLine teardown = live_state_line(r.err(), "at vkDestroyDevice");
        EXPECT_TRUE(running.found) << tail(r.err(), 40);
        EXPECT_TRUE(teardown.found) << tail(r.err(), 40);
        EXPECT_EQ(running.replay, "ok") << running.text;
        EXPECT_EQ(teardown.replay, "ok") << teardown.text;
        // The application destroyed what it created: what is left is the device and its queues.
        EXPECT_LT(teardown.objects, running.objects) << teardown.text;
        EXPECT_EQ(teardown.descriptor_sets, 0u) << teardown.text;
        EXPECT_EQ(teardown.command_buffers, 0u) << teardown.text;
        return running;
    }

    uint16_t port_ = 0;
    Agent agent_;
};

TEST_F(ReplicationLiveState, AtriumSnapshotIsCompleteAndOrdered) {
    ASSERT_TRUE(built(atrium_path()));
    auto r =
        run_app({atrium_path().string(), "--width", "320", "--height", "180", "--eyes", "2", "--frames", "3"},
                debug_env(), out_, "atrium", 120s);
    const LiveStateLine s = check(r);
    // atrium's descriptor sets (one per material and frame), its pipelines, buffers, images and
    // memory, and the command buffers it recorded for the frames in flight.
    EXPECT_GE(s.objects, 40u) << s.text;
    EXPECT_GE(s.descriptor_sets, 49u) << s.text;
    EXPECT_GE(s.command_buffers, 1u) << s.text;
    EXPECT_GT(s.bytes, 10000u) << s.text;
}

TEST_F(ReplicationLiveState, VkcubeSnapshotIsCompleteAndOrdered) {
    ASSERT_TRUE(find_program("vkcube", env())) << "vkcube is not installed (vulkan-tools)";
    auto r = run_app({"vkcube", "--c", "3"}, debug_env(), out_, "vkcube", 120s);
    const LiveStateLine s = check(r);
    // vkcube: one descriptor set and one recorded command buffer per swapchain image.
    EXPECT_GE(s.objects, 20u) << s.text;
    EXPECT_GE(s.descriptor_sets, 2u) << s.text;
    EXPECT_GE(s.command_buffers, 2u) << s.text;
}

} // namespace
} // namespace splitvk::e2e
