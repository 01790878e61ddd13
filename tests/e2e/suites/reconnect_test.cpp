// Reliability: the agent dies or starts late, and the application goes on (with a moving
// gaze too: the agent that joins is given the gaze it follows).
//  - Late join: splitvk-atrium starts with no agent (runs unsplit), an agent starts afterwards and
//    is brought in with a snapshot of the live state; the held last frame has exact foveae.
//  - Kill and restart: the agent is SIGKILLed mid-run (listener and session), the app keeps
//    presenting complete frames (the centre from the periphery), a new agent on the same port is
//    brought in, and the held last frame has exact foveae again.
// Both sides run under validation (sync on) and must stay silent. The resync time, from the new
// agent answering to its first composited frame, is printed (the layer logs it).
// How the app is held and compared: agent_loss_fixture.h.
#include "agent_loss_fixture.h"

#include <cstring>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

namespace splitvk::e2e {
namespace {

class Reconnect : public AgentLossTest {};

TEST_F(Reconnect, AgentStartedAfterTheAppJoins) {
    auto app = start_split();
    ASSERT_TRUE(app);
    ASSERT_TRUE(wait_for_log("running unsplit until one answers", 120s)) << read_file(out_ / "split.stderr");
    Agent agent;
    ASSERT_TRUE(agent.start(env(), out_, {"--validate"}, port_)) << agent.error();
    ASSERT_NO_FATAL_FAILURE(expect_recovered(*app, "splitvk-agent"));
}

// The same with buffer device addresses (atrium --buffer-address push): the agent that joins learns
// the client's addresses from the snapshot (each BufferAddress is a live-state log entry), or it
// would flag every frame invalid for an address it does not know, and no fovea would match.
TEST_F(Reconnect, AgentStartedAfterTheAppLearnsItsBufferAddresses) {
    extra_args_ = {"--buffer-address", "push"};
    auto app = start_split();
    ASSERT_TRUE(app);
    ASSERT_TRUE(wait_for_log("running unsplit until one answers", 120s)) << read_file(out_ / "split.stderr");
    Agent agent;
    ASSERT_TRUE(agent.start(env(), out_, {"--validate"}, port_)) << agent.error();
    ASSERT_NO_FATAL_FAILURE(expect_recovered(*app, "splitvk-agent"));
    EXPECT_TRUE(grep(agent.log(), "cannot translate").empty()) << tail(agent.log(), 30);
}

TEST_F(Reconnect, AgentKilledAndRestartedIsBroughtBackIn) {
    Agent first;
    ASSERT_TRUE(first.start(env(), out_, {"--validate"}, port_, "first-agent")) << first.error();
    auto app = start_split();
    ASSERT_TRUE(app);
    ASSERT_TRUE(wait_for_log("split: passes into", 120s)) << read_file(out_ / "split.stderr");
    std::this_thread::sleep_for(1s); // some frames with tiles first
    first.kill();
    ASSERT_TRUE(wait_for_log("went away", 30s)) << read_file(out_ / "split.stderr");
    std::this_thread::sleep_for(1s); // some frames with no agent at all
    Agent second;
    ASSERT_TRUE(second.start(env(), out_, {"--validate"}, port_, "second-agent")) << second.error();
    ASSERT_NO_FATAL_FAILURE(expect_recovered(*app, "second-agent"));
}

// The swapped split (SPLITVK_CLIENT_RENDERS=fovea) through a kill and a restart: the first
// agent granted it, so the session keeps it. Meanwhile the frames are drawn whole (the first present
// after the loss answers VK_ERROR_OUT_OF_DATE_KHR); the new agent is brought in with the snapshot,
// renders the periphery again, and the held frame is the client's exact foveae in the new agent's
// periphery.
TEST_F(Reconnect, SwappedSplitAgentKilledAndRestartedIsBroughtBackIn) {
    extra_env_ = {{"SPLITVK_CLIENT_RENDERS", "fovea"}, {"SPLITVK_EYES", "2"}};
    swapped_ = true;
    Agent first;
    ASSERT_TRUE(first.start(env(), out_, {"--validate"}, port_, "first-agent")) << first.error();
    auto app = start_split();
    ASSERT_TRUE(app);
    ASSERT_TRUE(wait_for_log("swapped split: passes into", 120s)) << read_file(out_ / "split.stderr");
    std::this_thread::sleep_for(1s); // some frames with the first agent's periphery
    first.kill();
    ASSERT_TRUE(wait_for_log("went away", 30s)) << read_file(out_ / "split.stderr");
    ASSERT_TRUE(wait_for_log("this present answers VK_ERROR_OUT_OF_DATE_KHR once", 30s))
        << read_file(out_ / "split.stderr");
    std::this_thread::sleep_for(1s); // some whole frames with no agent at all
    Agent second;
    ASSERT_TRUE(second.start(env(), out_, {"--validate"}, port_, "second-agent")) << second.error();
    ASSERT_NO_FATAL_FAILURE(expect_recovered(*app, "second-agent"));
}

// A moving gaze (SPLITVK_GAZE=fifo) and an agent that joins mid-run: it learns that the
// gaze moves from the SplitConfig of its resync and each frame's rectangle from that frame's
// FramePresent, so the held frame's foveae, where the pipe's point put them rather than centred, are
// exact. The test keeps the pipe open for writing, so the one line stays the gaze of every frame.
TEST_F(Reconnect, AgentThatJoinsFollowsAMovingGaze) {
    gaze_fifo_ = out_ / "gaze";
    ASSERT_EQ(::mkfifo(gaze_fifo_.c_str(), 0600), 0) << std::strerror(errno);
    const int writer = ::open(gaze_fifo_.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC);
    ASSERT_GE(writer, 0) << std::strerror(errno);
    const std::string line = "0.25 0.25 0.75 0.75\n";
    ASSERT_EQ(::write(writer, line.data(), line.size()), static_cast<ssize_t>(line.size()));
    foveae_ = {fovea_at_gaze(0.25, 0.25, 0, kWidth / 2, kHeight),
               fovea_at_gaze(0.75, 0.75, kWidth / 2, kWidth / 2, kHeight)};
    auto app = start_split();
    ASSERT_TRUE(app);
    ASSERT_TRUE(wait_for_log("running unsplit until one answers", 120s)) << read_file(out_ / "split.stderr");
    Agent agent;
    ASSERT_TRUE(agent.start(env(), out_, {"--validate"}, port_)) << agent.error();
    expect_recovered(*app, "splitvk-agent");
    ::close(writer);
    EXPECT_FALSE(grep(read_file(out_ / "split.stderr"), "gaze: reading gaze points from").empty());
}

} // namespace
} // namespace splitvk::e2e
