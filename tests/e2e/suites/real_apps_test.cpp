// Real, unmodified applications from Debian's vulkan-tools run 200 frames with the layer loaded
// (proven by its log line and the loader's) and exit 0.
#include "agent.h"
#include "e2e_test.h"

#include <thread>

namespace splitvk::e2e {
namespace {

struct App {
    const char *program;
    const char *app_name; // VkApplicationInfo::pApplicationName, as the layer reports it
};
void PrintTo(const App &a, std::ostream *os) {
    *os << a.program;
}

class RealApps : public XTest, public ::testing::WithParamInterface<App> {};

TEST_P(RealApps, Run200FramesWithLayer) {
    ASSERT_TRUE(built(explicit_layer_dir()));
    const App app = GetParam();
    Env e = env();
    use_explicit_layers(e, {kLayerName});
    enable_layer_info_log(e);
    enable_loader_debug(e);
    // Default window size (500x500): vkcubepp 1.3.239 mis-parses --height ("Could not find both
    // graphics and present queues", also without the layer), so neither app gets size options.
    auto r = run_app({app.program, "--c", "200"}, e, out_, app.program, std::chrono::seconds(120));
    ASSERT_TRUE(r.ok()) << r.describe() << "\n" << tail(r.err());
    EXPECT_TRUE(layer_reported_active(r.err(), app.app_name))
        << "no '" << layer_active_line(app.app_name) << "'\n"
        << r.describe();
    EXPECT_TRUE(loader_inserted(r.err(), kLayerName)) << r.describe();
    auto errors = lines_starting_with(r.err(), "[splitvk] error:");
    EXPECT_TRUE(errors.empty()) << joined(errors);
}

INSTANTIATE_TEST_SUITE_P(VulkanTools, RealApps,
                         ::testing::Values(App{"vkcube", "vkcube"}, App{"vkcubepp", "vkcubepp"}),
                         [](const ::testing::TestParamInfo<App> &p) { return std::string(p.param.program); });

} // namespace
} // namespace splitvk::e2e

namespace splitvk::e2e {
namespace {

using namespace std::chrono_literals;

// gfxrecon-replay (Debian's gfxreconstruct) of a vkcube capture, split against a real agent. In
// its default virtual-swapchain mode it renders into images of its own and copies them into the
// swapchain, which is split (below). Both ends must close cleanly, also when the
// agent still replays frames as the client goes (that used to end the agent's session with
// "sending Tiles: connection closed"). No --validate for the agent:
// gfxrecon-replay's own copy into the swapchain has a hazard of its own. With
// --use-captured-swapchain-indices the replay renders into the swapchain and is split.
class GfxreconReplay : public XTest {
protected:
    void SetUp() override {
        XTest::SetUp();
        ASSERT_TRUE(built(explicit_layer_dir()));
        ASSERT_TRUE(built(agent_path()));
        ASSERT_TRUE(find_program("gfxrecon-replay", env()))
            << "gfxrecon-replay is not installed (gfxreconstruct)";
        Env capture = env();
        capture["VK_INSTANCE_LAYERS"] = "VK_LAYER_LUNARG_gfxreconstruct";
        capture["GFXRECON_CAPTURE_FILE"] = (out_ / "vkcube.gfxr").string();
        capture["GFXRECON_CAPTURE_FILE_TIMESTAMP"] = "false";
        auto r = run_app({"vkcube", "--c", "150"}, capture, out_, "capture", 120s);
        ASSERT_TRUE(r.ok()) << r.describe();
        ASSERT_TRUE(std::filesystem::exists(out_ / "vkcube.gfxr")) << tail(r.err());
    }

    ProcessResult replay(const std::string &name, std::vector<std::string> options) {
        if (!agent_.start(env(), out_, {}, 0, "agent-" + name)) {
            ADD_FAILURE() << agent_.error();
            return {};
        }
        Env e = env();
        use_explicit_layers(e, {kLayerName});
        enable_layer_info_log(e);
        e["SPLITVK_SERVER"] = agent_.address();
        std::vector<std::string> argv = {"gfxrecon-replay"};
        argv.insert(argv.end(), options.begin(), options.end());
        argv.push_back((out_ / "vkcube.gfxr").string());
        auto r = run_app(argv, e, out_, name, 240s);
        EXPECT_TRUE(r.ok()) << r.describe() << "\n" << tail(r.err());
        EXPECT_TRUE(lines_starting_with(r.err(), "[splitvk] error:").empty()) << tail(r.err());
        EXPECT_TRUE(grep(r.err(), "running unsplit").empty()) << tail(r.err());
        return r;
    }

    // The agent's session ended as closed by the client, with no error on the way.
    void expect_agent_closed_cleanly() {
        const auto deadline = std::chrono::steady_clock::now() + 60s;
        while (grep(agent_.log(), "ended: ").empty() && std::chrono::steady_clock::now() < deadline)
            std::this_thread::sleep_for(100ms);
        const std::string log = agent_.log();
        EXPECT_EQ(grep(log, "ended: closed by the client (exit status 0)").size(), 1u) << tail(log, 20);
        EXPECT_TRUE(grep(log, "] error:").empty()) << joined(grep(log, "] error:"));
    }

    Agent agent_;
};

// Its default virtual-swapchain mode renders into images of its own and copies them into the
// swapchain at present: those images are screen-space targets, rendered scaled, and the
// copy into the swapchain image lands in its scaled top-left like a pass, so every frame is split
// and the agent's foveae match the client's.
TEST_F(GfxreconReplay, VirtualSwapchainCopiesAreSplit) {
    auto r = replay("replay", {});
    const std::string err = r.err();
    EXPECT_TRUE(grep(err, "none split").empty()) << tail(err);
    EXPECT_FALSE(grep(err, "is screen-space").empty()) << tail(err);
    EXPECT_FALSE(grep(err, "[splitvk] split: ").empty()) << tail(err);
    EXPECT_TRUE(grep(err, "do not match the frame's foveae").empty()) << tail(err);
    EXPECT_TRUE(grep(err, "late").empty() || !grep(err, " 0 late").empty()) << tail(err);
    expect_agent_closed_cleanly();
}

TEST_F(GfxreconReplay, CapturedSwapchainIndicesAreSplit) {
    auto r = replay("replay", {"--use-captured-swapchain-indices"});
    const std::string err = r.err();
    EXPECT_FALSE(grep(err, "split: passes into").empty()) << tail(err);
    EXPECT_TRUE(grep(err, "none split").empty()) << tail(err);
    expect_agent_closed_cleanly();
}

} // namespace
} // namespace splitvk::e2e
