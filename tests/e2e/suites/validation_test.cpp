// Every end-to-end app also runs with Khronos validation below our layer
// (VK_INSTANCE_LAYERS=VK_LAYER_SPLITVK_split_render:VK_LAYER_KHRONOS_validation), synchronization
// validation on, and must produce no message at all (errors, warnings, performance warnings).
//
// Mechanism: a vk_layer_settings.txt in the test's output folder (found through
// VK_LAYER_SETTINGS_PATH) turns on synchronization validation and sends every message to a log
// file; the test fails on a non-empty log and prints its first message. Two negative controls
// prove the mechanism sees messages: vkcube --force_errors (core validation) and the probe's
// deliberate write-after-write hazard (synchronization validation specifically).
#include "e2e_test.h"

namespace splitvk::e2e {
namespace {

class Validation : public XTest {
protected:
    // Environment with ours on top of validation (or validation alone), loader debug on.
    Env validation_env(bool with_splitvk) {
        Env e = env();
        if (with_splitvk)
            use_explicit_layers(e, {kLayerName, kValidationLayerName});
        else
            e["VK_INSTANCE_LAYERS"] = kValidationLayerName;
        enable_loader_debug(e);
        enable_layer_info_log(e);
        log_ = configure_validation(e, out_);
        return e;
    }

    // Both layers were in the instance call stack, ours closer to the application.
    void expect_stack(const ProcessResult &r, bool with_splitvk, const std::string &app_name) {
        const std::string err = r.err();
        ASSERT_TRUE(loader_inserted(err, kValidationLayerName)) << "validation was not loaded\n"
                                                                << r.describe();
        auto stack = instance_layer_stack(err);
        const int v = stack_index(stack, kValidationLayerName);
        ASSERT_GE(v, 0) << r.describe();
        if (!with_splitvk) return;
        ASSERT_TRUE(loader_inserted(err, kLayerName)) << r.describe();
        ASSERT_TRUE(layer_reported_active(err, app_name)) << r.describe();
        const int s = stack_index(stack, kLayerName);
        ASSERT_GE(s, 0) << r.describe();
        EXPECT_LT(s, v) << "splitvk must sit above (closer to the app than) validation\n" << r.describe();
    }

    void expect_no_messages(const ProcessResult &r) {
        ASSERT_TRUE(std::filesystem::exists(log_))
            << "validation never opened its log " << log_.string() << ": the settings file was not read\n"
            << r.describe();
        const std::string log = read_file(log_);
        EXPECT_TRUE(log.empty()) << "validation reported (" << log_.string() << "), first message:\n"
                                 << first_message(log);
    }

    std::filesystem::path log_;
};

// Negative control 1: vkcube --force_errors makes invalid calls; the log must catch them.
TEST_F(Validation, ControlForceErrorsIsCaught) {
    Env e = validation_env(false);
    auto r = run_app({"vkcube", "--c", "3", "--width", "128", "--height", "128", "--force_errors"}, e, out_,
                     "vkcube", std::chrono::seconds(60));
    EXPECT_FALSE(r.timed_out) << r.describe();
    ASSERT_NO_FATAL_FAILURE(expect_stack(r, false, "vkcube"));
    const std::string log = read_file(log_);
    EXPECT_NE(log.find("Validation Error"), std::string::npos)
        << "vkcube --force_errors produced no validation error in " << log_.string()
        << ": the mechanism is broken";
}

// Negative control 2: a write-after-write hazard that only synchronization validation reports,
// with the same layer stack as the real runs (splitvk above validation).
TEST_F(Validation, ControlSyncHazardIsCaught) {
    Env e = validation_env(true);
    auto r = run_app({probe_path().string(), "--sync-hazard"}, e, out_, "probe", std::chrono::seconds(60));
    ASSERT_TRUE(r.ok()) << r.describe();
    ASSERT_NO_FATAL_FAILURE(expect_stack(r, true, "splitvk-e2e-probe"));
    const std::string log = read_file(log_);
    EXPECT_NE(log.find("SYNC-HAZARD-WRITE-AFTER-WRITE"), std::string::npos)
        << "synchronization validation did not report the probe's hazard; log:\n"
        << tail(log);
}

// The probe without its hazard is clean, so control 2 fails for the hazard and nothing else.
TEST_F(Validation, ProbeClean) {
    Env e = validation_env(true);
    auto r = run_app({probe_path().string()}, e, out_, "probe", std::chrono::seconds(60));
    ASSERT_TRUE(r.ok()) << r.describe();
    ASSERT_NO_FATAL_FAILURE(expect_stack(r, true, "splitvk-e2e-probe"));
    expect_no_messages(r);
}

TEST_F(Validation, VkcubeClean) {
    Env e = validation_env(true);
    auto r = run_app({"vkcube", "--c", "60", "--width", "256", "--height", "256"}, e, out_, "vkcube",
                     std::chrono::seconds(120));
    ASSERT_TRUE(r.ok()) << r.describe();
    ASSERT_NO_FATAL_FAILURE(expect_stack(r, true, "vkcube"));
    expect_no_messages(r);
}

TEST_F(Validation, VkcubeppClean) {
    Env e = validation_env(true);
    // No --width/--height: vkcubepp 1.3.239 mis-parses --height (see real_apps_test.cpp).
    auto r = run_app({"vkcubepp", "--c", "60"}, e, out_, "vkcubepp", std::chrono::seconds(120));
    ASSERT_TRUE(r.ok()) << r.describe();
    ASSERT_NO_FATAL_FAILURE(expect_stack(r, true, "vkcubepp"));
    expect_no_messages(r);
}

// The sample at its full 2400x1080 geometry, stereo, mono and sRGB: 10 frames, so every swapchain
// image and per-frame resource is reused a few times (validation on lavapipe is slow).
struct AtriumVariant {
    std::vector<std::string> args;
    const char *name;
};
void PrintTo(const AtriumVariant &v, std::ostream *os) {
    *os << v.name;
}

class ValidationAtrium : public Validation, public ::testing::WithParamInterface<AtriumVariant> {};

TEST_P(ValidationAtrium, Clean) {
    ASSERT_TRUE(built(atrium_path()));
    Env e = validation_env(true);
    std::vector<std::string> argv = {
        atrium_path().string(), "--width", "2400", "--height", "1080", "--frames", "10"};
    for (auto &a : GetParam().args)
        argv.push_back(a);
    auto r = run_app(argv, e, out_, "splitvk-atrium", std::chrono::seconds(180));
    ASSERT_TRUE(r.ok()) << r.describe() << "\n" << tail(r.err());
    ASSERT_NO_FATAL_FAILURE(expect_stack(r, true, "splitvk-atrium"));
    expect_no_messages(r);
}

INSTANTIATE_TEST_SUITE_P(Atrium, ValidationAtrium,
                         ::testing::Values(AtriumVariant{{"--eyes", "2"}, "Stereo"},
                                           AtriumVariant{{"--eyes", "1"}, "Mono"},
                                           AtriumVariant{{"--eyes", "2", "--srgb"}, "StereoSrgb"}),
                         [](const ::testing::TestParamInfo<AtriumVariant> &p) {
                             return std::string(p.param.name);
                         });

// Every render path of the sample (--path, samples/README.md), natively: validation alone, no
// splitvk, 10 frames at 2400x1080. Stereo with a UNORM swapchain, and mono with an sRGB swapchain
// whose window is resized (to an odd size) mid-run, so each path rebuilds its offscreen targets.
// Every path also in stereo with --linear-textures: the textures every path samples then come
// from linear images the host wrote (PREINITIALIZED, a host-to-transfer barrier, image copies).
struct PathVariant {
    const char *path;
    bool stereo_unorm;            // else mono, sRGB, resized
    bool linear_textures = false; // --linear-textures
};
void PrintTo(const PathVariant &v, std::ostream *os) {
    *os << v.path << (v.stereo_unorm ? "/stereo" : "/mono-srgb-resize")
        << (v.linear_textures ? "/linear" : "");
}

class ValidationAtriumPath : public Validation, public ::testing::WithParamInterface<PathVariant> {};

TEST_P(ValidationAtriumPath, NativeClean) {
    ASSERT_TRUE(built(atrium_path()));
    const PathVariant v = GetParam();
    Env e = validation_env(false);
    std::vector<std::string> argv = {
        atrium_path().string(), "--width", "2400", "--height", "1080", "--frames", "10", "--path", v.path};
    if (v.stereo_unorm)
        argv.insert(argv.end(), {"--eyes", "2"});
    else
        argv.insert(argv.end(), {"--eyes", "1", "--srgb", "--resize-at", "4", "1601x901"});
    if (v.linear_textures) argv.push_back("--linear-textures");
    auto r = run_app(argv, e, out_, "splitvk-atrium", std::chrono::seconds(220));
    ASSERT_TRUE(r.ok()) << r.describe() << "\n" << tail(r.err());
    EXPECT_NE(r.out().find(std::string("path ") + v.path), std::string::npos) << r.out();
    ASSERT_NO_FATAL_FAILURE(expect_stack(r, false, "splitvk-atrium"));
    expect_no_messages(r);
}

INSTANTIATE_TEST_SUITE_P(
    Paths, ValidationAtriumPath,
    ::testing::Values(PathVariant{"direct", false}, PathVariant{"hdr", true}, PathVariant{"hdr", false},
                      PathVariant{"deferred", true}, PathVariant{"deferred", false},
                      PathVariant{"multiview", true}, PathVariant{"multiview", false},
                      PathVariant{"secondary", true}, PathVariant{"secondary", false},
                      PathVariant{"compute", true}, PathVariant{"compute", false},
                      PathVariant{"direct", true, true}, PathVariant{"hdr", true, true},
                      PathVariant{"deferred", true, true}, PathVariant{"multiview", true, true},
                      PathVariant{"secondary", true, true}, PathVariant{"compute", true, true}),
    [](const ::testing::TestParamInfo<PathVariant> &p) {
        return std::string(p.param.path) + (p.param.stereo_unorm ? "Stereo" : "MonoSrgbResize") +
               (p.param.linear_textures ? "LinearTextures" : "");
    });

} // namespace
} // namespace splitvk::e2e
