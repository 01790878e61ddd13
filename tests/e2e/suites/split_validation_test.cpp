// The image-space split under validation on both sides: the client renders split passes
// into the scaled periphery and the agent shades only the foveae, with VK_LAYER_KHRONOS_validation
// (synchronization validation on) below splitvk on the client and --validate on the agent; neither
// may report anything. Covers dynamic viewport/scissor state (atrium stereo and mono, vkcube) and
// static-state pipelines (atrium --static-viewports), clear rects (--clear-depth-per-eye) and
// dynamic rendering (--dynamic-rendering). No
// SPLITVK_VERIFY: it turns the split off.
#include "agent.h"
#include "e2e_test.h"

#include <thread>

namespace splitvk::e2e {
namespace {

using namespace std::chrono_literals;

class Split : public XTest {
protected:
    void SetUp() override {
        XTest::SetUp();
        ASSERT_TRUE(built(explicit_layer_dir()));
        ASSERT_TRUE(built(atrium_path()));
        ASSERT_TRUE(built(agent_path()));
        ASSERT_TRUE(agent_.start(env(), out_, {"--validate"})) << agent_.error();
    }

    Env split_env() {
        Env e = env();
        use_explicit_layers(e, {kLayerName, kValidationLayerName});
        validation_log_ = configure_validation(e, out_);
        enable_layer_info_log(e);
        e["SPLITVK_SERVER"] = agent_.address();
        return e;
    }

    // The app ran split (the layer's one line naming the periphery) and both sides stayed silent.
    void expect_clean_split(const ProcessResult &r, const std::string &periphery_line) {
        std::string agent_log = read_file(out_ / "splitvk-agent.stderr");
        ASSERT_TRUE(r.ok()) << r.describe() << "\n" << tail(r.err()) << "\nagent:\n" << tail(agent_log);
        EXPECT_EQ(grep(r.err(), periphery_line).size(), 1u) << tail(r.err());
        EXPECT_TRUE(client_validation_clean(validation_log_));
        EXPECT_TRUE(agent_session_validation_clean(out_ / "splitvk-agent.stderr"));
    }

    Agent agent_;
    std::filesystem::path validation_log_;
};

struct AtriumVariant {
    std::vector<std::string> args;
    const char *name;
};
void PrintTo(const AtriumVariant &v, std::ostream *os) {
    *os << v.name;
}

class SplitAtrium : public Split, public ::testing::WithParamInterface<AtriumVariant> {};

TEST_P(SplitAtrium, CleanOnBothSides) {
    std::vector<std::string> argv = {
        atrium_path().string(), "--width", "600", "--height", "270", "--frames", "8"};
    for (auto &a : GetParam().args)
        argv.push_back(a);
    auto r = run_app(argv, split_env(), out_, "atrium", 180s);
    expect_clean_split(r, "split: passes into 600x270 swapchain images render their periphery at 360x162");
}

INSTANTIATE_TEST_SUITE_P(
    Atrium, SplitAtrium,
    ::testing::Values(AtriumVariant{{"--eyes", "2"}, "Stereo"}, AtriumVariant{{"--eyes", "1"}, "Mono"},
                      AtriumVariant{{"--eyes", "2", "--static-viewports"}, "StereoStatic"},
                      AtriumVariant{{"--eyes", "2", "--clear-depth-per-eye"}, "StereoClears"},
                      AtriumVariant{{"--eyes", "2", "--dynamic-rendering"}, "StereoDynamicRendering"}),
    [](const ::testing::TestParamInfo<AtriumVariant> &p) { return std::string(p.param.name); });

TEST_F(Split, VkcubeCleanOnBothSides) {
    ASSERT_TRUE(find_program("vkcube", env())) << "vkcube is not installed (vulkan-tools)";
    auto r = run_app({"vkcube", "--c", "20", "--width", "256", "--height", "256"}, split_env(), out_,
                     "vkcube", 180s);
    // ceil(0.6 * 256) = 154
    expect_clean_split(r, "split: passes into 256x256 swapchain images render their periphery at 154x154");
}

} // namespace
} // namespace splitvk::e2e
