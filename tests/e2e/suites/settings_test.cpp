// A bad setting is one line on stderr, `[splitvk] error: ...`, naming the setting and the values it
// accepts; the application still runs and exits 0 (the layer then runs it unsplit). The parser's
// details are unit-tested elsewhere; this is the end-to-end check through a real app.
#include "agent.h"
#include "e2e_test.h"
#include "settings.h" // protocol/: splitvk::setting_table(), the one list of settings

#include <algorithm>
#include <fstream>
#include <map>
#include <thread>

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

// Every setting of common/settings.cpp's table, each with a value it must reject, through a real
// Vulkan program (the headless probe creates an instance and a device, which is where the layer
// reads its settings and opens its session). The test iterates the table, not this list: a setting
// added to the table without an invalid value here fails its own test
// (.../IsOneErrorLineAndRunsUnsplit/<NAME>). A bad value must give exactly one error line,
// `<VARIABLE>='<value>' is invalid: expected <accepted>; running unsplit`, quoting the table's `accepted`
// text, and the program must run unsplit: exit 0, and no session at an agent that listens on the address
// SPLITVK_SERVER names.
const std::map<std::string, std::string> &bad_values() {
    static const std::map<std::string, std::string> values = {
        {"SERVER", "127.0.0.1:0"},     // port 0
        {"AGENTS", "3"},               // 1 or 2
        {"SCALE", "2"},                // above 1
        {"FOVEA", "512"},              // no WxH
        {"SPLIT", "never"},            // auto or always
        {"EYES", "3"},                 // auto, 1 or 2
        {"TARGETS", "offscreen"},      // auto or swapchain
        {"AGENT_SCISSOR", "guard:-8"}, // off or guard:N
        {"CLIENT_RENDERS", "both"},    // periphery or fovea
        {"PERIPHERY_QUALITY", "52"},   // CRF 0 to 51
        {"PERIPHERY_CODEC", "h265"},   // h264, hevc or rgb
        {"CLIENT_GUARD", "guard:x"},   // guard:N or full
        {"SEAM", "feather:-1"},        // hard or feather:N
        {"UPSAMPLE", "lanczos"},       // bilinear or bicubic
        {"GAZE", "pipe:/tmp/gaze"},    // not a gaze source
        {"XR_DEADLINE", "late"},       // display or off
        {"CODEC", "h265"},             // not a codec splitvk has
        {"TILE_WAIT", "0"},            // 1 to 60000
        {"PRESENT_DEPTH", "3"},        // 0, 1 or 2
        {"MAX_MBPS", "-1"},
        {"FOVEA_MASK", "stencil"},                        // 0 to 100000
        {"STATS", "/nonexistent-splitvk-dir/stats.csv"},  // directory missing
        {"LOG_LEVEL", "verbose"},                         // not a level
        {"TOKEN", "two words"},                           // whitespace
        {"TOKEN_FILE", "/nonexistent-splitvk-dir/token"}, // unreadable
        {"VERIFY", "partial"},                            // off or full
        {"ENVELOPE", "strict"},                           // auto or client
        {"UNSUPPORTED", "ignore"},                        // fail or passthrough
        {"TLS", "required"},                              // auto, on or off
        {"AGENT_FINGERPRINT", "sha1:0123"},               // sha256: and 64 hex digits
    };
    return values;
}

std::vector<SettingInfo> table() {
    const auto t = setting_table();
    return {t.begin(), t.end()};
}

class BadSettingsTable : public XTest, public ::testing::WithParamInterface<SettingInfo> {
protected:
    // The probe with the layer, SPLITVK_SERVER at `agent` and `extra` on top.
    ProcessResult run_probe(const Agent &agent, const Env &extra, const std::string &name) {
        Env e = env();
        use_explicit_layers(e, {kLayerName});
        enable_layer_info_log(e);
        e["SPLITVK_SERVER"] = agent.address();
        for (auto &[k, v] : extra)
            e[k] = v;
        return run_app({probe_path().string()}, e, out_, name, std::chrono::seconds(60));
    }
    // Whether the agent saw a client (its listener logs "session N (pid P) started" on accept).
    static bool agent_saw_a_client(const Agent &agent) { return !grep(agent.log(), ") started").empty(); }
};

// The control: the same program and agent with good settings does open a session, so the "no
// session" checks below can fail.
TEST_F(BadSettingsTable, GoodSettingsOpenASession) {
    ASSERT_TRUE(built(probe_path()));
    Agent agent;
    ASSERT_TRUE(agent.start(env(), out_)) << agent.error();
    auto r = run_probe(agent, {}, "probe-good");
    ASSERT_TRUE(r.ok()) << r.describe() << "\n" << tail(r.err());
    EXPECT_TRUE(lines_starting_with(r.err(), "[splitvk] error:").empty()) << tail(r.err());
    EXPECT_FALSE(grep(r.err(), "replicating to splitvk-agent").empty()) << tail(r.err());
    const auto deadline = Clock::now() + std::chrono::seconds(10);
    while (!agent_saw_a_client(agent) && Clock::now() < deadline)
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
    EXPECT_TRUE(agent_saw_a_client(agent)) << tail(agent.log());
}

TEST_P(BadSettingsTable, IsOneErrorLineAndRunsUnsplit) {
    const SettingInfo &info = GetParam();
    const std::string variable = std::string("SPLITVK_") + info.name;
    const auto bad = bad_values().find(info.name);
    ASSERT_NE(bad, bad_values().end())
        << variable << " is in protocol::setting_table() but this test has no invalid value for it: add "
        << "one to bad_values() in " << __FILE__;
    ASSERT_TRUE(built(probe_path()));
    Agent agent;
    ASSERT_TRUE(agent.start(env(), out_)) << agent.error();
    auto r = run_probe(agent, {{variable, bad->second}}, "probe-" + std::string(info.name));
    EXPECT_TRUE(r.ok()) << "the program must still run: " << r.describe() << "\n" << tail(r.err());
    const std::string err = r.err();
    // SPLITVK_LOG_LEVEL=verbose leaves the level at its default (warn), which hides the info line.
    if (std::string(info.name) != "LOG_LEVEL") {
        EXPECT_TRUE(layer_reported_active(err, "splitvk-e2e-probe")) << tail(err);
    }
    const auto errors = lines_starting_with(err, "[splitvk] error: ");
    ASSERT_EQ(errors.size(), 1u) << "expected exactly one error line for " << variable << "='" << bad->second
                                 << "':" << joined(errors) << "\n"
                                 << r.describe();
    const std::string expected = "[splitvk] error: " + variable + "='" + bad->second +
                                 "' is invalid: expected " + info.accepted + "; running unsplit";
    EXPECT_EQ(errors[0], expected);
    std::cout << "  " << errors[0] << "\n";
    // Unsplit: the layer never asked the agent, although it listens where SPLITVK_SERVER points.
    EXPECT_TRUE(grep(err, "replicating to splitvk-agent").empty()) << tail(err);
    std::this_thread::sleep_for(std::chrono::milliseconds(200)); // an accept would be logged by now
    EXPECT_FALSE(agent_saw_a_client(agent)) << "the layer opened a session despite the bad setting:\n"
                                            << tail(agent.log());
}

// Every row of the table is a test of its own, named after the setting.
INSTANTIATE_TEST_SUITE_P(Table, BadSettingsTable, ::testing::ValuesIn(table()),
                         [](const ::testing::TestParamInfo<SettingInfo> &p) {
                             return std::string(p.param.name);
                         });

// The reverse direction: a value in bad_values() for a name the table does not have is stale.
TEST(BadSettingsTableCoverage, EveryBadValueBelongsToASetting) {
    for (const auto &[name, value] : bad_values()) {
        const auto t = setting_table();
        EXPECT_TRUE(std::any_of(t.begin(), t.end(), [&](const SettingInfo &i) { return name == i.name; }))
            << name << " is not in protocol::setting_table()";
    }
}

} // namespace
} // namespace splitvk::e2e
