// The layer's locks against a slow agent: one thread's mapped memory waiting for the link must not
// hold back another thread's memory and pipeline calls. splitvk-e2e-lock-probe (lock_probe/)
// floods the link with mapped memory on its main thread while a second thread times
// vkAllocateMemory, vkMapMemory, vkUnmapMemory, vkFreeMemory and vkCreateGraphicsPipelines on
// memory and objects of its own.
//
// The link (splitvk-link) delays each direction by 500 ms and carries 80 Mbit/s: the probe writes
// 4 x 64 MiB of incompressible bytes, far more than the layer's send queue (128 MiB) and the
// link hold, so the flood's sends wait for room in the queue, up to seconds. A lock that
// one of the second thread's calls shares with those sends would make it wait as long.
//
// And the queue lock, which must hold: a queue label another thread makes waits for the present
// the layer is making on the same queue.
#include "agent.h"
#include "agent_process.h"
#include "e2e_test.h"
#include "process.h"

#include <map>
#include <regex>
#include <thread>

namespace splitvk::e2e {
namespace {

using namespace std::chrono_literals;

// The longest any of the second thread's calls may take while the link holds the flood back:
// a tenth of a second over what the same call took before the flood. The calls themselves take a
// few milliseconds on lavapipe (the pipeline: one trivial vertex shader); what they may wait for
// is CPU work (a MemoryData piece compressed and queued under the session lock takes tens of
// milliseconds on a loaded core). Waiting for the link instead costs at least the link's
// 500 ms delay, and up to the 2 s a send waits for room.
constexpr double kBoundOverIdleMs = 100.0;

std::map<std::string, std::pair<double, int>> parse_timings(const std::string &out,
                                                            const std::string &phase) {
    std::map<std::string, std::pair<double, int>> calls;
    const std::regex line("^" + phase + R"(: (\w+) max ([0-9.]+) ms over (\d+) calls$)");
    for (const auto &l : split_lines(out)) {
        std::smatch m;
        if (std::regex_search(l, m, line)) calls[m[1]] = {std::stod(m[2]), std::stoi(m[3])};
    }
    return calls;
}

class Locks : public XTest {};

TEST_F(Locks, ASlowLinkDoesNotStallAnotherThreadsMemoryOrPipelineCalls) {
    const std::filesystem::path probe = SPLITVK_E2E_LOCK_PROBE;
    ASSERT_TRUE(built(probe));
    ASSERT_TRUE(built(agent_path()));
    ASSERT_TRUE(built(bin_dir() / "splitvk-link"));
    Env e = env();
    Agent agent;
    ASSERT_TRUE(agent.start(e, out_)) << agent.error();

    const uint16_t port = free_loopback_port();
    ASSERT_NE(port, 0);
    ProcessSpec spec;
    // The delay on the way to the agent only: the handshake must still be answered within the
    // layer's 1 s.
    spec.argv = {(bin_dir() / "splitvk-link").string(), "--listen", "127.0.0.1:" + std::to_string(port),
                 "--connect", agent.address()};
    for (const char *option : {"--up-delay", "500ms", "--down-delay", "0", "--rate", "200M"})
        spec.argv.push_back(option);
    spec.env = e;
    spec.env["SPLITVK_LOG_LEVEL"] = "info";
    spec.out_dir = out_;
    spec.name = "splitvk-link";
    Process link(spec);
    ASSERT_TRUE(link.start()) << link.error();
    const auto link_log = out_ / "splitvk-link.stderr";
    for (int i = 0; i < 100 && read_file(link_log).find("listening on") == std::string::npos; ++i)
        std::this_thread::sleep_for(100ms);
    ASSERT_NE(read_file(link_log).find("listening on"), std::string::npos) << read_file(link_log);

    use_explicit_layers(e, {kLayerName});
    e["SPLITVK_SERVER"] = "127.0.0.1:" + std::to_string(port);
    e["SPLITVK_LOG_LEVEL"] = "info";
    const auto r =
        run_app({probe.string(), "--flood-mib", "64", "--rounds", "4"}, e, out_, "lock-probe", 180s);
    ASSERT_TRUE(r.ok()) << r.describe() << "\n" << tail(r.err());
    ASSERT_FALSE(grep(r.err(), "replicating to splitvk-agent").empty()) << "no session\n" << tail(r.err());
    // The session may end when a send finds the queue still full after 2 s (the send rule of a
    // link that cannot keep up): the calls that count are those made while a round was held back.

    // The scenario was real: the link held the flood back by more than its delay.
    double slowest_round = 0;
    const std::regex round(R"(^flood: round \d+ took ([0-9.]+) ms$)");
    for (const auto &l : split_lines(r.out())) {
        std::smatch m;
        if (std::regex_search(l, m, round)) slowest_round = std::max(slowest_round, std::stod(m[1]));
    }
    ASSERT_GT(slowest_round, 500.0) << "the link never held the flood back:\n" << r.out();

    const auto idle = parse_timings(r.out(), "idle");
    const auto flooded = parse_timings(r.out(), "flooded");
    for (const char *call :
         {"vkAllocateMemory", "vkMapMemory", "vkUnmapMemory", "vkFreeMemory", "vkCreateGraphicsPipelines"}) {
        ASSERT_TRUE(idle.count(call) && flooded.count(call)) << call << " was not timed:\n" << r.out();
        const auto [max_ms, calls] = flooded.at(call);
        EXPECT_GE(calls, 3) << call << ": too few calls during the flood to tell\n" << r.out();
        EXPECT_LT(max_ms, idle.at(call).first + kBoundOverIdleMs)
            << call << " waited for the other thread's sends to the slow link\n"
            << r.out();
    }
}

// A queue operation passed down through a generated entry point takes the queue's lock, as the
// layer's own presents do: VK_LAYER_SPLITVK_test_queue_guard (tests/e2e/queue_guard_layer), below
// splitvk, holds one of the presents splitvk makes while another thread inserts a queue debug label
// through splitvk on the same queue. The label must reach the driver's side only once the present
// is through.
TEST_F(Locks, QueueLabelWaitsForThePresentTheLayerMakes) {
    ASSERT_TRUE(built(atrium_path()));
    ASSERT_TRUE(built(agent_path()));
    Env e = env();
    Agent agent;
    ASSERT_TRUE(agent.start(e, out_)) << agent.error();
    use_explicit_layers(e, {kLayerName});
    use_bottom_layer(e, "VK_LAYER_SPLITVK_test_queue_guard", SPLITVK_E2E_QUEUE_GUARD_LAYER_DIR);
    e["TEST_QUEUE_GUARD_PRESENT"] = "2";
    e["TEST_QUEUE_GUARD_TOP"] = SPLITVK_E2E_LAYER_LIBRARY;
    // Frames handed to the layer's present thread, which so presents on the application's queue.
    e["SPLITVK_PRESENT_DEPTH"] = "1";
    e["SPLITVK_SERVER"] = agent.address();
    e["SPLITVK_LOG_LEVEL"] = "info";
    const auto r = run_app({atrium_path().string(), "--width", "320", "--height", "180", "--frames", "6"}, e,
                           out_, "atrium-queue-guard", 120s);
    ASSERT_TRUE(r.ok()) << r.describe() << "\n" << tail(r.err());
    ASSERT_FALSE(grep(r.err(), "replicating to splitvk-agent").empty()) << "no session\n" << tail(r.err());
    EXPECT_TRUE(grep(r.err(), "queue guard: the label overlapped the present").empty()) << tail(r.err());
    EXPECT_EQ(grep(r.err(), "queue guard: the label waited for the present").size(), 1u) << tail(r.err());
}

} // namespace
} // namespace splitvk::e2e
