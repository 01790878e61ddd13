// The layer's glue under what applications may legally do, through the real layer on lavapipe:
// queues got from several threads at once, an exit with the device still alive, and an exception
// inside the layer. Each must end the application normally: exit 0, no hang, no signal.
#include "agent.h"
#include "e2e_test.h"

#include <regex>
#include <string>
#include <thread>
#include <vector>

namespace splitvk::e2e {
namespace {

using namespace std::chrono_literals;

constexpr const char *kKeepLayerName = "VK_LAYER_SPLITVK_test_keep";
// The call of vkCmdEndRenderPass that throws: a few frames into splitvk-atrium's.
constexpr int kThrowingCall = 6;

// The `[splitvk] split: N frames, ...` summary line's frame count; -1 without one.
long long split_frames(const std::string &err) {
    const std::regex line(R"(^\[splitvk\] split: (\d+) frames, )");
    long long frames = -1;
    for (const std::string &l : split_lines(err)) {
        std::smatch m;
        if (std::regex_search(l, m, line)) frames = std::stoll(m[1]);
    }
    return frames;
}

class Boundary : public XTest {
protected:
    void SetUp() override {
        XTest::SetUp();
        ASSERT_TRUE(built(explicit_layer_dir()));
        ASSERT_TRUE(built(atrium_path()));
        ASSERT_TRUE(built(agent_path()));
    }

    void start_agent() { ASSERT_TRUE(agent_.start(env(), out_)) << agent_.error(); }

    // splitvk against the test's agent, its present thread in use (one frame may wait in it).
    Env split_env() {
        Env e = env();
        use_explicit_layers(e, {kLayerName});
        e["SPLITVK_SERVER"] = agent_.address();
        e["SPLITVK_TILE_WAIT"] = "60000";
        e["SPLITVK_PRESENT_DEPTH"] = "1";
        e["SPLITVK_LOG_LEVEL"] = "info";
        return e;
    }

    // VK_LAYER_SPLITVK_test_keep above splitvk (its folder searched first: this loader chains
    // explicit layers in the order their manifests are found), keeping the device and the instance.
    static void keep_device_alive(Env &e) {
        e["VK_INSTANCE_LAYERS"] = std::string(kKeepLayerName) + ":" + e["VK_INSTANCE_LAYERS"];
        e["VK_ADD_LAYER_PATH"] = std::string(SPLITVK_E2E_KEEP_LAYER_DIR) + ":" + e["VK_ADD_LAYER_PATH"];
        e["TEST_KEEP_ALIVE"] = "1";
    }

    std::vector<std::string> atrium_argv(int frames) const {
        return {atrium_path().string(), "--width", "640", "--height", "288", "--eyes", "2", "--frames",
                std::to_string(frames)};
    }

    Agent agent_;
};

// vkGetDeviceQueue needs no external synchronisation: eight threads get the same queue at once, the
// first time on each of 500 fresh devices, and vkDeviceWaitIdle follows. The layer learns of a queue
// at its first vkGetDeviceQueue; were that a check and then an insert, two threads could each insert
// it, and vkDeviceWaitIdle, which locks every queue it knows once, would lock one twice and hang.
// The probe's time bound is the test's: 500 rounds take about 3 s on two busy cores.
TEST_F(Boundary, QueuesGotFromManyThreadsAtOnceThenDeviceWaitIdle) {
    Env e = env();
    use_explicit_layers(e, {kLayerName});
    // A session without an agent: the layer tracks queues whether or not one answers.
    e["SPLITVK_SERVER"] = "127.0.0.1:" + std::to_string(free_loopback_port());
    const auto r = run_app({probe_path().string(), "--concurrent-queues", "500"}, e, out_, "probe", 60s);
    ASSERT_FALSE(r.timed_out) << "hung (vkDeviceWaitIdle after concurrent vkGetDeviceQueue): " << r.describe()
                              << "\n"
                              << tail(r.err());
    ASSERT_TRUE(r.ok()) << r.describe() << "\n" << tail(r.err());
    EXPECT_FALSE(grep(r.out(), "concurrent queues: 500 rounds, 8 threads").empty()) << r.out();
    EXPECT_TRUE(grep(r.err(), "[splitvk] error").empty()) << tail(r.err());
}

// A window application that exits with its device and instance alive (the keep layer above splitvk
// never passes their destroys down), split against an agent with a frame in the present thread:
// the layer's exit handler drains and stops that thread, closes the session and prints the split
// summary. Without it the thread, still joinable at exit, ends the process in std::terminate.
TEST_F(Boundary, WindowAppExitingWithItsDeviceAliveEndsCleanly) {
    ASSERT_TRUE(built(std::filesystem::path(SPLITVK_E2E_KEEP_LAYER_DIR) / "VkLayer_splitvk_test_keep.json"));
    ASSERT_NO_FATAL_FAILURE(start_agent());
    constexpr int kFrames = 12;
    Env e = split_env();
    keep_device_alive(e);
    const auto r = run_app(atrium_argv(kFrames), e, out_, "atrium-keep", 180s);
    const std::string err = r.err();
    ASSERT_TRUE(r.ok()) << r.describe() << "\n" << tail(err, 30);
    // The keep layer was in the chain and kept both.
    EXPECT_FALSE(grep(err, "keep alive: vkDestroyDevice not passed down").empty()) << tail(err, 30);
    EXPECT_FALSE(grep(err, "keep alive: vkDestroyInstance not passed down").empty()) << tail(err, 30);
    EXPECT_TRUE(grep(err, "terminate").empty()) << tail(err, 30);
    EXPECT_TRUE(grep(err, "[splitvk] error").empty()) << tail(err, 30);
    EXPECT_EQ(split_frames(err), kFrames) << tail(err, 30);
    // The agent heard a normal end, not a dropped connection.
    const auto closed = [&] { return !grep(agent_.log(), "closed by the client").empty(); };
    for (int i = 0; i < 100 && !closed(); ++i)
        std::this_thread::sleep_for(100ms);
    EXPECT_TRUE(closed()) << tail(agent_.log(), 20);
}

// An exception inside the layer (TEST_SPLITVK_THROW: a std::bad_alloc thrown in vkCmdEndRenderPass's
// boundary right after one of its calls went through the layer and down, as a capture that fails to
// allocate would) never reaches the application: one error line naming the entry point and what was
// thrown, the device stops splitting (the frames before it have the agent's tiles, those after it
// none: their centre is the periphery's) and atrium, whose call returns nothing, runs to its end.
TEST_F(Boundary, ExceptionInsideTheLayerStopsTheSplitNotTheApp) {
    ASSERT_NO_FATAL_FAILURE(start_agent());
    constexpr int kFrames = 12;
    Env e = split_env();
    e["TEST_SPLITVK_THROW"] = "vkCmdEndRenderPass:" + std::to_string(kThrowingCall);
    const auto stats_path = out_ / "stats.csv";
    e["SPLITVK_STATS"] = stats_path.string();
    const auto r = run_app(atrium_argv(kFrames), e, out_, "atrium-throw", 180s);
    const std::string err = r.err();
    ASSERT_TRUE(r.ok()) << r.describe() << "\n" << tail(err, 30);
    const auto errors = lines_starting_with(err, "[splitvk] error: ");
    ASSERT_EQ(errors.size(), 1u) << tail(err, 30);
    EXPECT_EQ(errors[0], "[splitvk] error: vkCmdEndRenderPass: std::bad_alloc (std::bad_alloc) thrown inside "
                         "splitvk; the call returns no result; splitvk stops splitting this device: the "
                         "periphery alone fills the frames from now on");
    const auto rows = stats_rows(read_file(stats_path));
    ASSERT_EQ(rows.size(), static_cast<size_t>(kFrames)) << read_file(stats_path);
    int with_tiles = 0;
    bool tiles_after_the_throw = false;
    for (const auto &row : rows) {
        const bool tiles = row.at("tile_bytes") > 0;
        if (tiles && with_tiles != static_cast<int>(row.at("frame"))) tiles_after_the_throw = true;
        with_tiles += tiles;
    }
    std::cout << "  " << with_tiles << " of " << kFrames << " frames had tiles\n";
    EXPECT_GE(with_tiles, 1) << read_file(stats_path);
    EXPECT_LT(with_tiles, kFrames - 2) << read_file(stats_path);
    EXPECT_FALSE(tiles_after_the_throw) << "a frame after one without tiles had them:\n"
                                        << read_file(stats_path);
}

// A command that returns a VkResult and creates an object: the exception after the driver made the
// fence fails the call with VK_ERROR_OUT_OF_HOST_MEMORY (the probe stops there, exit 1, its own
// line with -1), and the layer's one line says the fence stays alive below it.
TEST_F(Boundary, ExceptionInACreateFailsItWithOutOfHostMemory) {
    Env e = env();
    use_explicit_layers(e, {kLayerName});
    e["SPLITVK_SERVER"] = "127.0.0.1:" + std::to_string(free_loopback_port());
    e["TEST_SPLITVK_THROW"] = "vkCreateFence";
    const auto r = run_app({probe_path().string()}, e, out_, "probe-throw", 60s);
    ASSERT_TRUE(r.exited) << r.describe() << "\n" << tail(r.err());
    EXPECT_EQ(r.exit_code, 1) << tail(r.err());
    EXPECT_FALSE(
        grep(r.err(), "splitvk-e2e-probe: vkCreateFence(device, &fci, nullptr, &fence) failed: -1").empty())
        << tail(r.err());
    const auto errors = lines_starting_with(r.err(), "[splitvk] error: ");
    ASSERT_EQ(errors.size(), 1u) << tail(r.err());
    EXPECT_EQ(errors[0],
              "[splitvk] error: vkCreateFence: std::bad_alloc (std::bad_alloc) thrown inside splitvk; "
              "the call returns VK_ERROR_OUT_OF_HOST_MEMORY (what was made for it below splitvk, if "
              "anything, is not destroyed: it stays alive until its parent is); splitvk stops splitting "
              "this device: running unsplit from now on");
}

} // namespace
} // namespace splitvk::e2e
