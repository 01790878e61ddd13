// An application that uses its swapchain images in an order of its own, split.
// gfxrecon-replay --use-captured-swapchain-indices draws each frame into the image the capture
// had and presents the one the driver acquired now; lavapipe's X11 WSI hands out the lowest free
// image (0 every frame of vkcube, natively), so the replay is right only while the driver's
// picks match the capture's. The layer's present thread used to hold frame N's image when frame
// N+1 acquired, the driver picked another image, and every other frame showed an image nothing
// had drawn (black, unsplit, VUID-VkPresentInfoKHR-pImageIndices-01296). Now every frame must be
// split, its fovea equal to native's at the frame where the order first diverges (1) and at a
// later one (3), and validation (synchronization included) silent on both sides, at
// SPLITVK_PRESENT_DEPTH 0, 1 and 2, for mailbox and immediate captures.
#include "agent.h"
#include "e2e_test.h"
#include "fovea.h"

#include <regex>

namespace splitvk::e2e {
namespace {

using namespace std::chrono_literals;

constexpr uint32_t kCube = 600; // vkcube's window, which the replay's window takes
constexpr int kCapturedFrames = 60;
constexpr int kHeldFrames[] = {1, 3};

struct Order {
    int present_mode; // vkcube --present_mode
    int depth;        // SPLITVK_PRESENT_DEPTH
    const char *name;
};
void PrintTo(const Order &o, std::ostream *os) {
    *os << o.name;
}

// "[splitvk] split: N frames, ... L late"
bool split_summary(const std::string &err, uint64_t *frames, uint64_t *late) {
    const std::regex line(R"(^\[splitvk\] split: (\d+) frames, .* (\d+) late$)");
    for (const auto &l : split_lines(err)) {
        std::smatch m;
        if (!std::regex_search(l, m, line)) continue;
        *frames = std::stoull(m[1]);
        *late = std::stoull(m[2]);
        return true;
    }
    return false;
}

class PresentOrder : public XTest, public ::testing::WithParamInterface<Order> {
protected:
    void SetUp() override {
        XTest::SetUp();
        capture_ = out_ / "vkcube.gfxr";
        ASSERT_TRUE(built(explicit_layer_dir()));
        ASSERT_TRUE(built(agent_path()));
        ASSERT_TRUE(find_program("vkcube", env())) << "vkcube is not installed (vulkan-tools)";
        ASSERT_TRUE(find_program("gfxrecon-replay", env()))
            << "gfxrecon-replay is not installed (gfxreconstruct)";
        Env capture = env();
        capture["VK_INSTANCE_LAYERS"] = "VK_LAYER_LUNARG_gfxreconstruct";
        capture["GFXRECON_CAPTURE_FILE"] = capture_.string();
        capture["GFXRECON_CAPTURE_FILE_TIMESTAMP"] = "false";
        auto r = run_app({"vkcube", "--present_mode", std::to_string(GetParam().present_mode), "--width",
                          std::to_string(kCube), "--height", std::to_string(kCube), "--c",
                          std::to_string(kCapturedFrames)},
                         capture, out_, "capture", 120s);
        ASSERT_TRUE(r.ok()) << r.describe() << "\n" << tail(r.err());
        ASSERT_TRUE(std::filesystem::exists(capture_)) << tail(r.err());
        ASSERT_TRUE(agent_.start(env(), out_, {"--validate"})) << agent_.error();
    }

    std::vector<std::string> replay_argv() const {
        return {"gfxrecon-replay", "--use-captured-swapchain-indices", capture_.string()};
    }

    Env split_env() {
        Env e = env();
        use_explicit_layers(e, {kLayerName, kValidationLayerName});
        validation_log_ = configure_validation(e, out_);
        e["SPLITVK_SERVER"] = agent_.address();
        e["SPLITVK_TILE_WAIT"] = "60000"; // a slow machine must not turn a late frame into a mismatch
        e["SPLITVK_EYES"] = "1";
        e["SPLITVK_PRESENT_DEPTH"] = std::to_string(GetParam().depth);
        e["SPLITVK_LOG_LEVEL"] = "info";
        return e;
    }

    // The replay frozen (test hold layer) after presenting `frame`, its window grabbed.
    void grab_held(Env env, int frame, const std::string &name, Image *image) {
        use_hold_layer(env, frame);
        ProcessSpec spec;
        spec.argv = replay_argv();
        spec.env = env;
        spec.out_dir = out_;
        spec.name = name;
        Process p(spec);
        ASSERT_TRUE(p.start()) << p.error();
        const std::string holding = "holding frame " + std::to_string(frame);
        if (!p.wait_for_line(holding, 240s)) {
            auto r = p.terminate(5s);
            FAIL() << name << " never printed '" << holding << "': " << r.describe() << "\n"
                   << tail(r.err(), 30);
        }
        std::string error;
        int x = 0, y = 0;
        bool grabbed = window_origin(display(), kCube, kCube, &x, &y, out_, &error) &&
                       grab_stable(display(), x, y, kCube, kCube, out_ / (name + ".raw"), image, &error);
        const auto r = p.terminate(10s);
        ASSERT_TRUE(grabbed) << error << "\n" << tail(r.err(), 30);
        EXPECT_TRUE(grep(r.err(), "[splitvk] error:").empty()) << tail(r.err(), 30);
    }

    std::filesystem::path capture_;
    Agent agent_;
    std::filesystem::path validation_log_;
};

TEST_P(PresentOrder, CapturedIndicesReplayIsSplitEveryFrame) {
    // Every frame split, none late, both sides' validation silent.
    auto r = run_app(replay_argv(), split_env(), out_, "split", 240s);
    ASSERT_TRUE(r.ok()) << r.describe() << "\n" << tail(r.err(), 30);
    const std::string err = r.err();
    uint64_t frames = 0, late = 0;
    ASSERT_TRUE(split_summary(err, &frames, &late)) << tail(err, 30);
    EXPECT_EQ(frames, static_cast<uint64_t>(kCapturedFrames)) << "frames not split:\n" << tail(err, 30);
    EXPECT_EQ(late, 0u) << tail(err, 30);
    EXPECT_TRUE(grep(err, "[splitvk] error:").empty()) << tail(err, 30);
    EXPECT_TRUE(grep(err, "none split").empty()) << tail(err, 30);
    EXPECT_TRUE(client_validation_clean(validation_log_));
    EXPECT_TRUE(agent_session_validation_clean(out_ / "splitvk-agent.stderr"));

    // The foveae shown equal native's where the order first diverges and after.
    const auto foveae = default_foveae(kCube, kCube, 1);
    for (const int frame : kHeldFrames) {
        SCOPED_TRACE("frame " + std::to_string(frame));
        Image native, split;
        ASSERT_NO_FATAL_FAILURE(grab_held(env(), frame, "native-" + std::to_string(frame), &native));
        ASSERT_NO_FATAL_FAILURE(grab_held(split_env(), frame, "split-" + std::to_string(frame), &split));
        ASSERT_GT(distinct_colours(native), 100u) << "the native grab looks blank";
        for (const Rect &f : foveae) {
            const auto cmp = compare_exact(native, split, f.x, f.y, f.w, f.h);
            EXPECT_TRUE(cmp.equal()) << "fovea (" << f.x << "," << f.y << " " << f.w << "x" << f.h
                                     << ") differs from native: " << cmp.summary() << "\n"
                                     << save_mismatch_artefacts(out_, "fovea-" + std::to_string(frame),
                                                                native, split);
        }
        // Split for real: the periphery was rendered scaled, so the frame is not native's.
        const auto whole = compare_exact(native, split);
        EXPECT_GT(whole.mismatched_pixels, whole.pixels / 100) << "the frame equals native: was it split?";
        EXPECT_TRUE(client_validation_clean(validation_log_));
    }
}

INSTANTIATE_TEST_SUITE_P(Replay, PresentOrder,
                         ::testing::Values(Order{1, 0, "MailboxDepth0"}, Order{1, 1, "MailboxDepth1"},
                                           Order{1, 2, "MailboxDepth2"}, Order{0, 0, "ImmediateDepth0"},
                                           Order{0, 1, "ImmediateDepth1"}, Order{0, 2, "ImmediateDepth2"}),
                         [](const ::testing::TestParamInfo<Order> &p) { return std::string(p.param.name); });

} // namespace
} // namespace splitvk::e2e
