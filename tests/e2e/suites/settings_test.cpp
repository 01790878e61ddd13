// A bad setting is one line on stderr, `[splitvk] error: ...`, naming the setting and the values it
// accepts; the application still runs and exits 0 (the layer then runs it unsplit). The parser's
// details are unit-tested elsewhere; this is the end-to-end check through a real app.
#include "e2e_test.h"

#include <fstream>

namespace splitvk::e2e {
namespace {

struct BadSetting {
    const char *name;                        // environment variable
    const char *value;                       // a value it must reject
    std::vector<std::string> accepted_words; // words the error line must contain (the accepted values)
};

class Settings : public XTest {
protected:
    ProcessResult run_vkcube(const Env &extra, const std::string &name) {
        Env e = env();
        use_explicit_layers(e, {kLayerName});
        enable_layer_info_log(e);
        for (auto &[k, v] : extra)
            e[k] = v;
        return run_app({"vkcube", "--c", "5", "--width", "128", "--height", "128"}, e, out_, name,
                       std::chrono::seconds(60));
    }

    void expect_one_error(const BadSetting &bad) {
        auto r = run_vkcube({{bad.name, bad.value}}, std::string("vkcube-") + bad.name);
        EXPECT_TRUE(r.ok()) << "the app must still run: " << r.describe();
        const std::string err = r.err();
        EXPECT_TRUE(layer_reported_active(err, "vkcube")) << r.describe();
        auto errors = lines_starting_with(err, "[splitvk] error: ");
        ASSERT_EQ(errors.size(), 1u) << "expected exactly one error line for " << bad.name << "=" << bad.value
                                     << ":" << joined(errors) << "\n"
                                     << r.describe();
        EXPECT_NE(errors[0].find(bad.name), std::string::npos)
            << "does not name " << bad.name << ": " << errors[0];
        for (auto &word : bad.accepted_words)
            EXPECT_NE(errors[0].find(word), std::string::npos)
                << "does not list '" << word << "': " << errors[0];
        std::cout << "  " << bad.name << "=" << bad.value << " -> " << errors[0] << "\n";
    }
};

TEST_F(Settings, BadScaleIsOneErrorLine) {
    expect_one_error({"SPLITVK_SCALE", "2", {}});
}

TEST_F(Settings, BadEyesIsOneErrorLine) {
    expect_one_error({"SPLITVK_EYES", "3", {"auto", "1", "2"}});
}

// Control: good values of the same settings print no error, so the checks above are not satisfied
// by a layer that complains about everything.
TEST_F(Settings, GoodValuesPrintNoError) {
    auto r = run_vkcube({{"SPLITVK_SCALE", "0.5"}, {"SPLITVK_EYES", "2"}}, "vkcube-good");
    EXPECT_TRUE(r.ok()) << r.describe();
    EXPECT_TRUE(layer_reported_active(r.err(), "vkcube")) << r.describe();
    auto errors = lines_starting_with(r.err(), "[splitvk] error:");
    EXPECT_TRUE(errors.empty()) << joined(errors);
}

// The same through a vk_layer_settings.txt (Khronos convention, found via VK_LAYER_SETTINGS_PATH):
// the error names the file's key.
TEST_F(Settings, BadScaleInSettingsFileIsOneErrorLine) {
    {
        std::ofstream f(out_ / "vk_layer_settings.txt");
        f << "splitvk_split_render.scale = 2\n";
    }
    auto r = run_vkcube({{"VK_LAYER_SETTINGS_PATH", out_.string()}}, "vkcube-file");
    EXPECT_TRUE(r.ok()) << r.describe();
    auto errors = lines_starting_with(r.err(), "[splitvk] error: ");
    ASSERT_EQ(errors.size(), 1u) << joined(errors) << "\n" << r.describe();
    EXPECT_NE(errors[0].find("splitvk_split_render.scale"), std::string::npos) << errors[0];
    std::cout << "  file scale = 2 -> " << errors[0] << "\n";
}

// The environment wins over the file: a good SPLITVK_SCALE hides the file's bad one.
TEST_F(Settings, EnvironmentWinsOverSettingsFile) {
    {
        std::ofstream f(out_ / "vk_layer_settings.txt");
        f << "splitvk_split_render.scale = 2\n";
    }
    auto r =
        run_vkcube({{"VK_LAYER_SETTINGS_PATH", out_.string()}, {"SPLITVK_SCALE", "0.5"}}, "vkcube-env-wins");
    EXPECT_TRUE(r.ok()) << r.describe();
    EXPECT_TRUE(layer_reported_active(r.err(), "vkcube")) << r.describe();
    auto errors = lines_starting_with(r.err(), "[splitvk] error:");
    EXPECT_TRUE(errors.empty()) << joined(errors);
}

} // namespace
} // namespace splitvk::e2e
