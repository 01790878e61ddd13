// Self-tests of the e2e harness: each check the other suites rely on is shown to fail when it
// should, so a broken harness cannot make them pass.
#include "e2e_test.h"

#include <unistd.h>

namespace splitvk::e2e {
namespace {

TEST(Harness, HungProcessIsKilledAtTimeout) {
    auto out = test_output_dir();
    auto r =
        run_app({"sh", "-c", "sleep 60 & sleep 60"}, clean_env(), out, "sleeper", std::chrono::seconds(1));
    EXPECT_TRUE(r.started) << r.describe();
    EXPECT_TRUE(r.timed_out) << r.describe();
    EXPECT_FALSE(r.ok());
    EXPECT_LT(r.wall_s, 10.0);
}

TEST(Harness, ExitCodeAndOutputAreCaptured) {
    auto out = test_output_dir();
    auto r = run_app({"sh", "-c", "echo to-out; echo to-err >&2; exit 3"}, clean_env(), out, "sh",
                     std::chrono::seconds(10));
    ASSERT_TRUE(r.exited) << r.describe();
    EXPECT_EQ(r.exit_code, 3);
    EXPECT_EQ(r.out(), "to-out\n");
    EXPECT_EQ(r.err(), "to-err\n");
    auto missing = run_app({"/nonexistent/app"}, clean_env(), out, "missing", std::chrono::seconds(10));
    EXPECT_FALSE(missing.started);
    EXPECT_FALSE(missing.ok());
}

TEST(Harness, WaitForLineThenTerminate) {
    auto out = test_output_dir();
    ProcessSpec spec;
    spec.argv = {"sh", "-c", "trap 'exit 0' TERM; echo 'holding frame 4'; while :; do sleep 0.05; done"};
    spec.env = clean_env();
    spec.out_dir = out;
    spec.name = "holder";
    Process p(spec);
    ASSERT_TRUE(p.start()) << p.error();
    EXPECT_FALSE(p.wait_for_line("holding frame 3", std::chrono::milliseconds(300))); // whole lines only
    ASSERT_TRUE(p.wait_for_line("holding frame 4", std::chrono::seconds(10)));
    auto r = p.terminate(std::chrono::seconds(5));
    EXPECT_TRUE(r.ok()) << r.describe();
}

TEST(Harness, LeakedVulkanAndSplitvkVariablesAreStripped) {
    auto out = test_output_dir();
    ::setenv("VK_INSTANCE_LAYERS", "VK_LAYER_leaked", 1);
    ::setenv("VK_LAYER_PATH", "/leaked", 1);
    ::setenv("SPLITVK_ENABLE", "1", 1);
    ::setenv("VK_LOADER_DEBUG", "all", 1);
    Env env = clean_env();
    ::unsetenv("VK_INSTANCE_LAYERS");
    ::unsetenv("VK_LAYER_PATH");
    ::unsetenv("SPLITVK_ENABLE");
    ::unsetenv("VK_LOADER_DEBUG");
    auto r = run_app({"env"}, env, out, "env", std::chrono::seconds(10));
    ASSERT_TRUE(r.ok()) << r.describe();
    const std::string text = r.out();
    EXPECT_TRUE(grep(text, "leaked").empty()) << text;
    EXPECT_TRUE(lines_starting_with(text, "SPLITVK_").empty()) << text;
    EXPECT_TRUE(lines_starting_with(text, "VK_LOADER_DEBUG").empty()) << text;
    EXPECT_FALSE(grep(text, std::string("VK_DRIVER_FILES=") + kLavapipeIcd).empty()) << text;
}

TEST(Harness, CompareCatchesOneChangedByteAndSavesArtefacts) {
    auto out = test_output_dir();
    Image a;
    a.width = 64;
    a.height = 32;
    a.bgr0.resize(a.stride() * a.height);
    for (size_t i = 0; i < a.bgr0.size(); ++i)
        a.bgr0[i] = static_cast<uint8_t>(i * 7);
    Image b = a;
    EXPECT_TRUE(compare_exact(a, b).equal());
    b.pixel(10, 20)[3] ^= 0xff; // padding byte: invisible, ignored
    EXPECT_TRUE(compare_exact(a, b).equal());
    b.pixel(10, 20)[1] ^= 0x01; // one bit of green
    auto c = compare_exact(a, b);
    EXPECT_FALSE(c.equal());
    EXPECT_EQ(c.mismatched_pixels, 1u);
    EXPECT_EQ(c.first_x, 10u);
    EXPECT_EQ(c.first_y, 20u);
    std::string msg = save_mismatch_artefacts(out, "selftest", a, b);
    for (auto name : {"selftest.expected.png", "selftest.actual.png", "selftest.diff.png"}) {
        EXPECT_TRUE(std::filesystem::exists(out / name)) << msg;
        EXPECT_GT(std::filesystem::file_size(out / name), 0u) << msg;
    }
    Image other = a;
    other.width = 32;
    EXPECT_FALSE(compare_exact(a, other).equal());
}

// The loader's debug output is parsed the way the loading tests rely on (validation as the probe).
TEST(Harness, LoaderDebugOutputIsParsed) {
    auto out = test_output_dir();
    Env env = clean_env();
    env["VK_INSTANCE_LAYERS"] = kValidationLayerName;
    enable_loader_debug(env);
    auto r = run_app({probe_path().string()}, env, out, "probe", std::chrono::seconds(60));
    ASSERT_TRUE(r.ok()) << r.describe();
    const std::string err = r.err();
    EXPECT_TRUE(loader_inserted(err, kValidationLayerName)) << r.describe();
    EXPECT_FALSE(loader_inserted(err, kLayerName)) << r.describe();
    auto stack = instance_layer_stack(err);
    int i = stack_index(stack, kValidationLayerName);
    ASSERT_GE(i, 0) << r.describe();
    EXPECT_NE(stack[static_cast<size_t>(i)].manifest.find("VkLayer_khronos_validation.json"),
              std::string::npos);
}

class HarnessX : public XTest {};

// An empty X screen is one colour: the distinct-colour floor the pass-through tests use rejects it.
TEST_F(HarnessX, BlankScreenGrabIsOneColour) {
    Image img;
    std::string error;
    ASSERT_TRUE(grab_stable(display(), 0, 0, 640, 360, out_ / "blank.raw", &img, &error)) << error;
    EXPECT_EQ(img.width, 640u);
    EXPECT_EQ(img.height, 360u);
    EXPECT_EQ(distinct_colours(img), 1u);
}

} // namespace
} // namespace splitvk::e2e
