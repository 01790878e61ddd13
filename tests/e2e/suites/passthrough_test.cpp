// Pass-through is invisible: what the X server shows for splitvk-atrium's frame K with the layer
// loaded equals, bit for bit, what it shows without the layer. Stereo, mono, and stereo on an sRGB
// swapchain. The grab must also be a real picture (many distinct colours), so a black or blank
// window cannot pass by being equally blank twice.
//
// Window size: the full 2400x1080 (two 1200x1080 eyes). Measured on the 2-core machine with
// lavapipe: atrium renders a 2400x1080 frame in about 0.1-0.3 s (depending on what else runs), so
// a 4-frame run with start-up takes about 1-3 s and one test (native run, layer run, two grabs
// each) about 3-7 s. That is affordable, so there is no reason to shrink the window to 1200x540
// and lose the 1200-wide eyes that the split will later cut.
#include "e2e_test.h"

namespace splitvk::e2e {
namespace {

constexpr uint32_t kWidth = 2400;
constexpr uint32_t kHeight = 1080;
constexpr int kFrames = 4; // frames 0..3; the picture compared is frame 3, after some animation
// A rendered atrium frame has thousands of colours; a blank, cleared or flat-shaded window a handful.
constexpr size_t kMinDistinctColours = 1000;

struct Grab {
    Image image;
    ProcessResult result;
};

struct Variant {
    int eyes;
    bool srgb; // B8G8R8A8_SRGB swapchain instead of UNORM
    const char *name;
};
void PrintTo(const Variant &v, std::ostream *os) {
    *os << v.name;
}

class Passthrough : public XTest, public ::testing::WithParamInterface<Variant> {
protected:
    void SetUp() override {
        XTest::SetUp();
        ASSERT_TRUE(built(atrium_path()));
        ASSERT_TRUE(built(explicit_layer_dir()));
    }

    // Runs atrium with --hold, grabs the screen once it holds the last frame, then SIGTERMs it.
    void run_and_grab(const Env &env, const std::string &name, Grab *grab) {
        ProcessSpec spec;
        spec.argv = {atrium_path().string(),  "--width", std::to_string(kWidth),          "--height",
                     std::to_string(kHeight), "--eyes",  std::to_string(GetParam().eyes), "--frames",
                     std::to_string(kFrames), "--hold"};
        if (GetParam().srgb) spec.argv.push_back("--srgb");
        spec.env = env;
        spec.out_dir = out_;
        spec.name = name;
        Process p(spec);
        ASSERT_TRUE(p.start()) << p.error();
        const std::string holding = "holding frame " + std::to_string(kFrames - 1);
        const bool held = p.wait_for_line(holding, std::chrono::seconds(90));
        if (!held) {
            auto r = p.terminate(std::chrono::seconds(5));
            FAIL() << name << " never printed '" << holding << "': " << r.describe() << "\n" << r.err();
        }
        std::string error;
        const bool grabbed =
            grab_stable(display(), 0, 0, kWidth, kHeight, out_ / (name + ".raw"), &grab->image, &error);
        grab->result = p.terminate(std::chrono::seconds(10));
        ASSERT_TRUE(grabbed) << error;
        ASSERT_TRUE(grab->result.ok())
            << name << " did not exit 0 on SIGTERM: " << grab->result.describe() << "\n"
            << grab->result.err();
    }
};

TEST_P(Passthrough, LayerFrameEqualsNativeFrame) {
    Env native_env = env();
    enable_layer_info_log(native_env);
    Env layer_env = native_env;
    use_explicit_layers(layer_env, {kLayerName});

    Grab native, layered;
    ASSERT_NO_FATAL_FAILURE(run_and_grab(native_env, "native", &native));
    ASSERT_NO_FATAL_FAILURE(run_and_grab(layer_env, "layer", &layered));

    EXPECT_FALSE(layer_reported_active(native.result.err(), "splitvk-atrium")) << native.result.describe();
    ASSERT_TRUE(layer_reported_active(layered.result.err(), "splitvk-atrium"))
        << "the layer did not report itself active, so this compared native with native\n"
        << layered.result.describe();

    const size_t colours = distinct_colours(native.image);
    std::cout << "  frame " << kFrames - 1 << ": " << colours << " distinct colours\n";
    EXPECT_GT(colours, kMinDistinctColours)
        << "the native grab looks blank (" << colours
        << " colours): " << save_mismatch_artefacts(out_, "blank", native.image, layered.image);
    auto cmp = compare_exact(native.image, layered.image);
    EXPECT_TRUE(cmp.equal()) << "frame " << kFrames - 1
                             << " with the layer differs from native: " << cmp.summary() << "\n"
                             << save_mismatch_artefacts(out_, "frame", native.image, layered.image);
}

// Stereo and mono, and stereo on an sRGB swapchain (where a layer that re-encoded through a view
// would change bytes).
INSTANTIATE_TEST_SUITE_P(Atrium, Passthrough,
                         ::testing::Values(Variant{2, false, "Stereo"}, Variant{1, false, "Mono"},
                                           Variant{2, true, "StereoSrgb"}),
                         [](const ::testing::TestParamInfo<Variant> &p) {
                             return std::string(p.param.name);
                         });

} // namespace
} // namespace splitvk::e2e
