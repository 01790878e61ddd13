// Real, unmodified applications from Debian's vulkan-tools run 200 frames with the layer loaded
// (proven by its log line and the loader's) and exit 0.
#include "e2e_test.h"

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
