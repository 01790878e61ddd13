// The layer loads when asked (explicitly through VK_INSTANCE_LAYERS, implicitly through
// SPLITVK_ENABLE=1), does not load otherwise, and SPLITVK_DISABLE=1 beats both ways of enabling.
// Loading is proven, not assumed: the layer's own log line and the loader's debug output
// (VK_LOADER_DEBUG=layer) are both checked, and the manifest the loader used must be the build tree's.
#include "e2e_test.h"

namespace splitvk::e2e {
namespace {

class Loading : public XTest {
protected:
    void SetUp() override {
        XTest::SetUp();
        ASSERT_TRUE(built(explicit_layer_dir()));
        ASSERT_TRUE(built(implicit_data_dir() / "vulkan" / "implicit_layer.d"));
        base_ = env();
        enable_loader_debug(base_);
        enable_layer_info_log(base_); // in every case, so that silence means "not loaded"
    }

    // vkcube, a real app, 5 frames in a small window.
    ProcessResult run_vkcube(const Env &env, const std::string &name) {
        auto r = run_app({"vkcube", "--c", "5", "--width", "128", "--height", "128"}, env, out_, name,
                         std::chrono::seconds(60));
        EXPECT_TRUE(r.ok()) << r.describe();
        return r;
    }

    void expect_loaded(const ProcessResult &r, const std::filesystem::path &manifest_dir) {
        const std::string err = r.err();
        EXPECT_EQ(grep(err, layer_active_line("vkcube")).size(), 1u)
            << "expected the layer's line once: " << layer_active_line("vkcube") << "\n"
            << r.describe();
        EXPECT_TRUE(loader_inserted(err, kLayerName))
            << "the loader did not report inserting " << kLayerName << "\n"
            << r.describe();
        auto stack = instance_layer_stack(err);
        int i = stack_index(stack, kLayerName);
        ASSERT_GE(i, 0) << "not in the loader's instance call stack\n" << r.describe();
        // The build tree's manifest, not an installed one.
        const std::string manifest = stack[static_cast<size_t>(i)].manifest;
        EXPECT_EQ(std::filesystem::path(manifest).parent_path(), manifest_dir)
            << "loaded from " << manifest << "\n"
            << r.describe();
    }

    // SPLITVK_DISABLE=1 keeps the layer out of an environment that loads it without the variable:
    // the control run (same environment, no SPLITVK_DISABLE) must load it, so a broken manifest
    // cannot make the disable tests pass.
    void expect_disable_wins(Env e, const std::filesystem::path &manifest_dir) {
        e.erase("SPLITVK_DISABLE");
        {
            SCOPED_TRACE("control run without SPLITVK_DISABLE");
            expect_loaded(run_vkcube(e, "vkcube-control"), manifest_dir);
        }
        e["SPLITVK_DISABLE"] = "1";
        expect_not_loaded(run_vkcube(e, "vkcube"));
    }

    void expect_not_loaded(const ProcessResult &r) {
        const std::string err = r.err();
        EXPECT_TRUE(grep(err, "[splitvk] info:").empty())
            << "the layer spoke:" << joined(grep(err, "[splitvk]")) << "\n"
            << r.describe();
        EXPECT_FALSE(loader_inserted(err, kLayerName)) << "the loader inserted " << kLayerName << "\n"
                                                       << r.describe();
    }

    Env base_;
};

TEST_F(Loading, ExplicitViaInstanceLayers) {
    Env e = base_;
    use_explicit_layers(e, {kLayerName});
    expect_loaded(run_vkcube(e, "vkcube"), explicit_layer_dir());
}

TEST_F(Loading, ImplicitViaEnable) {
    Env e = base_;
    make_implicit_layer_visible(e);
    e["SPLITVK_ENABLE"] = "1";
    expect_loaded(run_vkcube(e, "vkcube"), implicit_data_dir() / "vulkan" / "implicit_layer.d");
}

// Both ways at once: still one layer in the stack, one log line.
TEST_F(Loading, ExplicitAndImplicitTogetherLoadOnce) {
    Env e = base_;
    use_explicit_layers(e, {kLayerName});
    make_implicit_layer_visible(e);
    e["SPLITVK_ENABLE"] = "1";
    auto r = run_vkcube(e, "vkcube");
    const std::string err = r.err();
    EXPECT_EQ(grep(err, layer_active_line("vkcube")).size(), 1u) << r.describe();
    EXPECT_EQ(grep(err, std::string("Insert instance layer \"") + kLayerName + "\"").size(), 1u)
        << r.describe();
}

// The manifests are visible to the loader, yet nothing asks for the layer: it stays out. The
// loader's search output must list the build tree's manifest files (explicit and implicit), so the
// absence is the missing request's doing and not a missing or unreadable file.
TEST_F(Loading, NotLoadedWhenNotAsked) {
    Env e = base_;
    make_implicit_layer_visible(e);
    e["VK_ADD_LAYER_PATH"] = explicit_layer_dir().string();
    auto r = run_vkcube(e, "vkcube");
    expect_not_loaded(r);
    const std::string err = r.err();
    for (auto dir : {explicit_layer_dir(), implicit_data_dir() / "vulkan" / "implicit_layer.d"}) {
        auto manifests = manifests_in(dir);
        EXPECT_FALSE(manifests.empty()) << "no layer manifest in " << dir.string();
        for (auto &m : manifests)
            EXPECT_FALSE(grep(err, m.string()).empty()) << "the loader never found " << m.string() << "\n"
                                                        << r.describe();
    }
}

TEST_F(Loading, DisableBeatsImplicitEnable) {
    Env e = base_;
    make_implicit_layer_visible(e);
    e["SPLITVK_ENABLE"] = "1";
    expect_disable_wins(e, implicit_data_dir() / "vulkan" / "implicit_layer.d");
}

// Debian's loader (1.3.239) ignores a manifest's disable_environment for a layer named in
// VK_INSTANCE_LAYERS (checked by hand with a copy of the Mesa overlay manifest given a
// disable_environment: still inserted). The layer therefore declines the loader's interface
// negotiation when SPLITVK_DISABLE=1, and the loader then leaves it out of the chain (it logs an
// error about the layer, but no "Insert instance layer"). Same checks as the implicit case.
TEST_F(Loading, DisableBeatsExplicitEnable) {
    Env e = base_;
    use_explicit_layers(e, {kLayerName});
    expect_disable_wins(e, explicit_layer_dir());
}

TEST_F(Loading, DisableBeatsBothWaysTogether) {
    Env e = base_;
    use_explicit_layers(e, {kLayerName});
    make_implicit_layer_visible(e);
    e["SPLITVK_ENABLE"] = "1";
    e["SPLITVK_DISABLE"] = "1";
    expect_not_loaded(run_vkcube(e, "vkcube"));
    // Control: without SPLITVK_DISABLE it loads (from either manifest; the loader picks one).
    e.erase("SPLITVK_DISABLE");
    auto r = run_vkcube(e, "vkcube-control");
    EXPECT_TRUE(layer_reported_active(r.err(), "vkcube")) << "control run: " << r.describe();
    EXPECT_TRUE(loader_inserted(r.err(), kLayerName)) << "control run: " << r.describe();
}

// Negative control for the explicit path: a wrong manifest folder must make the explicit test's
// checks fail (the loader cannot find the layer; vkCreateInstance fails, so vkcube does too).
TEST_F(Loading, WrongManifestFolderIsNoticed) {
    Env e = base_;
    use_explicit_layers(e, {kLayerName});
    e["VK_ADD_LAYER_PATH"] = (out_ / "no-such-folder").string();
    auto r = run_app({"vkcube", "--c", "5", "--width", "128", "--height", "128"}, e, out_, "vkcube",
                     std::chrono::seconds(60));
    EXPECT_FALSE(r.timed_out) << r.describe();
    EXPECT_FALSE(layer_reported_active(r.err(), "vkcube")) << r.describe();
    EXPECT_FALSE(loader_inserted(r.err(), kLayerName)) << r.describe();
}

} // namespace
} // namespace splitvk::e2e
