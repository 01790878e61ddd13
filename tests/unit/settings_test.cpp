#include "settings.h"

#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>

#include <gtest/gtest.h>
#include <unistd.h>

namespace splitvk {
namespace {

namespace fs = std::filesystem;

class SettingsTest : public ::testing::Test {
protected:
    void SetUp() override {
        dir_ = fs::temp_directory_path() / ("splitvk-settings-" + std::to_string(::getpid()) + "-" +
                                            ::testing::UnitTest::GetInstance()->current_test_info()->name());
        fs::create_directories(dir_);
    }
    void TearDown() override { fs::remove_all(dir_); }

    LoadedSettings load(Environment env) { return load_settings(env, dir_.string()); }

    std::string write_file(const std::string &name, const std::string &text) {
        const auto path = dir_ / name;
        std::ofstream(path) << text;
        return path.string();
    }

    fs::path dir_;
};

TEST_F(SettingsTest, DefaultsAreThePapersConfiguration) {
    const auto loaded = load({});
    ASSERT_TRUE(loaded.valid());
    EXPECT_TRUE(loaded.warnings.empty());
    const Settings &s = loaded.settings;
    EXPECT_EQ(s.server.host, "127.0.0.1");
    EXPECT_EQ(s.server.port, 7447);
    EXPECT_DOUBLE_EQ(s.scale, 0.6);
    EXPECT_EQ(s.eyes, EyeMode::Auto);
    EXPECT_EQ(s.split, SplitMode::Auto) << "the split must pay for itself unless forced";
    EXPECT_EQ(s.codec, TileCodec::X264);
    EXPECT_EQ(s.log_level, LogLevel::Warn);
    EXPECT_TRUE(s.stats_path.empty());
    EXPECT_TRUE(s.token.empty());
    // No frame waits in the layer behind an earlier one: the least latency (docs/BENCHMARKS.md).
    EXPECT_EQ(s.present_depth, 0u);
    // 512x360 for a 1200x1080 eye, the same fractions elsewhere.
    EXPECT_EQ(s.fovea.pixels_for_eye(1200, 1080), std::make_pair(512u, 360u));
    EXPECT_EQ(s.fovea.pixels_for_eye(600, 540), std::make_pair(256u, 180u));
}

// SPLITVK_FOVEA=auto grows to the whole eye, auto:WxH to that (fractions); SPLITVK_MAX_MBPS bounds it.
TEST_F(SettingsTest, AutomaticFovea) {
    const auto loaded = load({{"SPLITVK_FOVEA", " Auto "}, {"SPLITVK_MAX_MBPS", "250.5"}});
    ASSERT_TRUE(loaded.valid()) << loaded.errors.front();
    EXPECT_TRUE(loaded.settings.fovea.automatic);
    EXPECT_DOUBLE_EQ(loaded.settings.max_mbps, 250.5);
    EXPECT_EQ(loaded.settings.fovea.pixels_for_eye(1200, 1080), std::make_pair(1200u, 1080u))
        << "it grows to the whole eye";
    const auto largest = load({{"SPLITVK_FOVEA", "auto:0.6x0.5"}});
    ASSERT_TRUE(largest.valid()) << largest.errors.front();
    EXPECT_TRUE(largest.settings.fovea.automatic);
    EXPECT_EQ(largest.settings.fovea.pixels_for_eye(1200, 1080), std::make_pair(720u, 540u));
    EXPECT_FALSE(load({}).settings.fovea.automatic);
    EXPECT_EQ(load({}).settings.max_mbps, 0.0);
}

TEST_F(SettingsTest, ValidEnvironmentValues) {
    const std::string token_file = write_file("token", "  s3cret\n");
    const auto loaded = load({{"SPLITVK_SERVER", "gpu-box:9000"},
                              {"SPLITVK_SCALE", "0.5"},
                              {"SPLITVK_FOVEA", "640x480"},
                              {"SPLITVK_EYES", "2"},
                              {"SPLITVK_SPLIT", "Always"},
                              {"SPLITVK_CODEC", "zstd"},
                              {"SPLITVK_TILE_WAIT", "40"},
                              {"SPLITVK_PRESENT_DEPTH", "2"},
                              {"SPLITVK_STATS", (dir_ / "stats.csv").string()},
                              {"SPLITVK_LOG_LEVEL", "DEBUG"},
                              {"SPLITVK_TOKEN_FILE", token_file}});
    ASSERT_TRUE(loaded.valid()) << loaded.errors.front();
    const Settings &s = loaded.settings;
    EXPECT_EQ(s.server.host, "gpu-box");
    EXPECT_EQ(s.server.port, 9000);
    EXPECT_DOUBLE_EQ(s.scale, 0.5);
    EXPECT_FALSE(s.fovea.fractional);
    EXPECT_EQ(s.fovea.pixels_for_eye(1200, 1080), std::make_pair(640u, 480u));
    EXPECT_EQ(s.fovea.pixels_for_eye(320, 240), std::make_pair(320u, 240u)) << "clamped to the eye";
    EXPECT_EQ(s.eyes, EyeMode::Two);
    EXPECT_EQ(s.split, SplitMode::Forced);
    EXPECT_EQ(s.codec, TileCodec::Zstd);
    EXPECT_EQ(s.tile_wait_ms, 40u);
    EXPECT_EQ(s.present_depth, 2u);
    EXPECT_EQ(s.log_level, LogLevel::Debug);
    EXPECT_EQ(s.token, "s3cret");
}

TEST_F(SettingsTest, ServerForms) {
    struct Case {
        const char *value;
        const char *host;
        uint16_t port;
    };
    for (const Case &c : {Case{"10.0.0.2", "10.0.0.2", 7447}, Case{"[::1]:8000", "::1", 8000},
                          Case{"[fe80::1]", "fe80::1", 7447}, Case{"localhost:1", "localhost", 1},
                          Case{"host:65535", "host", 65535}}) {
        const auto loaded = load({{"SPLITVK_SERVER", c.value}});
        ASSERT_TRUE(loaded.valid()) << c.value;
        EXPECT_EQ(loaded.settings.server.host, c.host) << c.value;
        EXPECT_EQ(loaded.settings.server.port, c.port) << c.value;
    }
}

TEST_F(SettingsTest, AgentScissorGuard) {
    EXPECT_FALSE(load({}).settings.agent_scissor.guard) << "off by default";
    const auto loaded = load({{"SPLITVK_AGENT_SCISSOR", "Guard:64"}});
    ASSERT_TRUE(loaded.valid());
    EXPECT_TRUE(loaded.settings.agent_scissor.guard);
    EXPECT_EQ(loaded.settings.agent_scissor.pixels, 64u);
    EXPECT_EQ(to_string(loaded.settings.agent_scissor), "guard:64");
    EXPECT_EQ(load({{"SPLITVK_AGENT_SCISSOR", "guard:0"}}).settings.agent_scissor.pixels, 0u);
}

// The swapped split's settings: which side renders what, the periphery's quality and the
// client's guard, with their defaults and bounds.
TEST_F(SettingsTest, SwappedSplit) {
    const Settings defaults = load({}).settings;
    EXPECT_EQ(defaults.client_renders, ClientRenders::Periphery);
    EXPECT_EQ(defaults.periphery_quality, (PeripheryQuality{false, 20}));
    EXPECT_EQ(defaults.periphery_codec, PeripheryCodec::H264);
    EXPECT_EQ(load({{"SPLITVK_PERIPHERY_CODEC", "HEVC"}}).settings.periphery_codec, PeripheryCodec::Hevc);
    EXPECT_EQ(load({{"SPLITVK_PERIPHERY_CODEC", "rgb"}}).settings.periphery_codec, PeripheryCodec::Rgb);
    EXPECT_FALSE(defaults.client_guard.full);
    EXPECT_EQ(defaults.client_guard.pixels, 64u);
    const auto loaded = load({{"SPLITVK_CLIENT_RENDERS", "Fovea"},
                              {"SPLITVK_PERIPHERY_QUALITY", "18"},
                              {"SPLITVK_CLIENT_GUARD", "guard:16"}});
    ASSERT_TRUE(loaded.valid());
    EXPECT_EQ(loaded.settings.client_renders, ClientRenders::Fovea);
    EXPECT_EQ(loaded.settings.periphery_quality, (PeripheryQuality{false, 18}));
    EXPECT_EQ(loaded.settings.client_guard.pixels, 16u);
    EXPECT_TRUE(load({{"SPLITVK_PERIPHERY_QUALITY", "lossless"}}).settings.periphery_quality.lossless);
    EXPECT_EQ(load({{"SPLITVK_PERIPHERY_QUALITY", "51"}}).settings.periphery_quality.crf, 51u);
    EXPECT_TRUE(load({{"SPLITVK_CLIENT_GUARD", "full"}}).settings.client_guard.full);
    EXPECT_FALSE(load({{"SPLITVK_PERIPHERY_QUALITY", "52"}}).valid());
    EXPECT_FALSE(load({{"SPLITVK_CLIENT_RENDERS", "agent"}}).valid());
    EXPECT_FALSE(load({{"SPLITVK_CLIENT_GUARD", "guard:4097"}}).valid());
}

// SPLITVK_SEAM: a feathered seam of 16 pixels by default; hard is a feather of none.
TEST_F(SettingsTest, Seam) {
    EXPECT_EQ(load({}).settings.seam.feather, 16u);
    EXPECT_EQ(load({{"SPLITVK_SEAM", "feather:32"}}).settings.seam.feather, 32u);
    EXPECT_EQ(load({{"SPLITVK_SEAM", "feather:0"}}).settings.seam.feather, 0u);
    EXPECT_EQ(load({{"SPLITVK_SEAM", "feather:256"}}).settings.seam.feather, 256u);
    EXPECT_EQ(load({{"SPLITVK_SEAM", "Hard"}}).settings.seam.feather, 0u);
    const auto bad = load({{"SPLITVK_SEAM", "feather:257"}});
    EXPECT_FALSE(bad.valid());
    EXPECT_EQ(bad.settings.seam.feather, 16u) << "a bad value leaves the default";
}

// SPLITVK_UPSAMPLE: bilinear by default, bicubic on request, in any case.
TEST_F(SettingsTest, Upsample) {
    EXPECT_EQ(load({}).settings.upsample, UpsampleMode::Bilinear);
    EXPECT_EQ(load({{"SPLITVK_UPSAMPLE", "bicubic"}}).settings.upsample, UpsampleMode::Bicubic);
    EXPECT_EQ(load({{"SPLITVK_UPSAMPLE", "Bilinear"}}).settings.upsample, UpsampleMode::Bilinear);
    const auto bad = load({{"SPLITVK_UPSAMPLE", "lanczos"}});
    EXPECT_FALSE(bad.valid());
    EXPECT_EQ(bad.settings.upsample, UpsampleMode::Bilinear) << "a bad value leaves the default";
}

// SPLITVK_UNSUPPORTED: fail (the default) or passthrough, in any case, from the file too.
TEST_F(SettingsTest, UnsupportedExtensions) {
    EXPECT_EQ(load({}).settings.unsupported, UnsupportedMode::Fail);
    EXPECT_EQ(load({{"SPLITVK_UNSUPPORTED", "passthrough"}}).settings.unsupported,
              UnsupportedMode::Passthrough);
    EXPECT_EQ(load({{"SPLITVK_UNSUPPORTED", "Passthrough"}}).settings.unsupported,
              UnsupportedMode::Passthrough);
    EXPECT_EQ(load({{"SPLITVK_UNSUPPORTED", "fail"}}).settings.unsupported, UnsupportedMode::Fail);
    write_file("vk_layer_settings.txt", "splitvk_split_render.unsupported = passthrough\n");
    EXPECT_EQ(load({}).settings.unsupported, UnsupportedMode::Passthrough);
    EXPECT_STREQ(to_string(UnsupportedMode::Passthrough), "passthrough");
}

// SPLITVK_GAZE: fixed (the default), openxr, fifo:PATH with the path as written.
TEST_F(SettingsTest, GazeSources) {
    EXPECT_EQ(load({}).settings.gaze, GazeMode::Fixed);
    auto loaded = load({{"SPLITVK_GAZE", "fifo:/run/User/Gaze"}});
    ASSERT_TRUE(loaded.valid());
    EXPECT_EQ(loaded.settings.gaze, GazeMode::Fifo);
    EXPECT_EQ(loaded.settings.gaze_fifo, "/run/User/Gaze");
    EXPECT_EQ(to_string(loaded.settings.gaze, loaded.settings.gaze_fifo), "fifo:/run/User/Gaze");
    EXPECT_EQ(load({{"SPLITVK_GAZE", "Fixed"}}).settings.gaze, GazeMode::Fixed);
    write_file("vk_layer_settings.txt", "splitvk_split_render.gaze = fifo:/tmp/g\n");
    EXPECT_EQ(load({}).settings.gaze_fifo, "/tmp/g");

    loaded = load({{"SPLITVK_GAZE", "OpenXR"}});
    ASSERT_TRUE(loaded.valid());
    EXPECT_TRUE(loaded.warnings.empty());
    EXPECT_EQ(loaded.settings.gaze, GazeMode::OpenXR);
    EXPECT_EQ(to_string(loaded.settings.gaze, loaded.settings.gaze_fifo), "openxr");
    EXPECT_FALSE(load({{"SPLITVK_GAZE", "openxr:left"}}).valid());
}

TEST_F(SettingsTest, FractionalFovea) {
    const auto loaded = load({{"SPLITVK_FOVEA", "0.5x0.25"}});
    ASSERT_TRUE(loaded.valid());
    EXPECT_TRUE(loaded.settings.fovea.fractional);
    EXPECT_EQ(loaded.settings.fovea.pixels_for_eye(1000, 800), std::make_pair(500u, 200u));
}

// Every setting with values it must refuse. Each refusal is one line that names the setting and
// what it accepts, and leaves the default in place.
TEST_F(SettingsTest, InvalidValuesAreOneLineErrorsNamingTheSetting) {
    const std::vector<std::pair<std::string, std::vector<std::string>>> table = {
        {"SERVER", {"", ":7447", "host:", "host:0", "host:65536", "host:port", "::1:80", "[::1", "a b:1"}},
        {"AGENTS", {"", "0", "3", "-1", "1.5", "two", "both"}},
        {"SCALE", {"", "0", "0.05", "1.5", "2", "-0.6", "abc", "0.6x", "nan", "inf"}},
        {"FOVEA",
         {"", "512", "512x", "x360", "0x360", "512x0", "0.5x360", "1.5x0.5", "-1x-1", "axb", "99999x1",
          "automatic"}},
        {"FOVEA_MASK", {"", "on", "stencil", "1"}},
        {"SPLIT", {"", "on", "never", "forced", "1"}},
        {"MAX_MBPS", {"", "-1", "100001", "fast", "nan", "50M"}},
        {"EYES", {"", "0", "3", "both", "two"}},
        {"TARGETS", {"", "all", "offscreen", "1"}},
        {"AGENT_SCISSOR", {"", "on", "guard", "guard:", "guard:-1", "guard:4097", "guard:1.5", "64"}},
        {"CLIENT_RENDERS", {"", "both", "agent", "1", "foveae"}},
        {"PERIPHERY_QUALITY", {"", "-1", "52", "23.5", "best", "lossy"}},
        {"PERIPHERY_CODEC", {"", "x264", "h265", "yuv", "444", "h264:high"}},
        {"CLIENT_GUARD", {"", "off", "guard", "guard:", "guard:-1", "guard:4097", "64"}},
        {"SEAM", {"", "soft", "feather", "feather:", "feather:-1", "feather:257", "feather:1.5", "16"}},
        {"UPSAMPLE", {"", "lanczos", "cubic", "edge", "1"}},
        {"GAZE", {"", "fifo:", "fifo", "pipe:/tmp/gaze", "eyes", "1"}},
        {"XR_DEADLINE", {"", "on", "1", "vsync"}},
        {"CODEC", {"", "h264", "x265", "lz4"}},
        {"TILE_WAIT", {"", "0", "-5", "60001", "1.5", "soon"}},
        {"PRESENT_DEPTH", {"", "3", "-1", "1.5", "two"}},
        {"STATS", {"", "/nonexistent-dir/stats.csv", "/tmp/"}},
        {"LOG_LEVEL", {"", "verbose", "5", "trace"}},
        {"TOKEN", {"", "two words", "tab\there"}},
        {"TOKEN_FILE", {"", "/nonexistent/token", "/"}},
        {"VERIFY", {"", "on", "1", "partial"}},
        {"ENVELOPE", {"", "on", "agent", "strict"}},
        {"UNSUPPORTED", {"", "ignore", "pass", "disable", "1"}},
        {"TLS", {"", "yes", "1", "tls13", "required"}},
        {"AGENT_FINGERPRINT",
         {"", "sha256:", "sha1:" + std::string(40, 'a'), "sha256:" + std::string(63, 'a'),
          "sha256:" + std::string(63, 'a') + "z", std::string(66, 'a')}},
    };
    ASSERT_EQ(table.size(), setting_table().size()) << "every setting in the table has invalid cases";
    for (const auto &[name, values] : table) {
        const SettingInfo *info = nullptr;
        for (const auto &row : setting_table()) {
            if (name == row.name) info = &row;
        }
        ASSERT_NE(info, nullptr) << name;
        for (const auto &value : values) {
            const std::string variable = "SPLITVK_" + name;
            const auto loaded = load({{variable, value}});
            ASSERT_EQ(loaded.errors.size(), 1u) << variable << "=" << value;
            const std::string &error = loaded.errors.front();
            EXPECT_EQ(error.find('\n'), std::string::npos) << error;
            EXPECT_NE(error.find(variable), std::string::npos) << error;
            EXPECT_NE(error.find(info->accepted), std::string::npos) << error;
            // The refused value leaves the default in place.
            const Settings defaults;
            EXPECT_DOUBLE_EQ(loaded.settings.scale, defaults.scale);
            EXPECT_EQ(loaded.settings.server.port, defaults.server.port);
            EXPECT_EQ(loaded.settings.eyes, defaults.eyes);
        }
    }
}

TEST_F(SettingsTest, TokenAndTokenFileTogetherAreRefused) {
    const std::string token_file = write_file("token", "abc");
    const auto loaded = load({{"SPLITVK_TOKEN", "abc"}, {"SPLITVK_TOKEN_FILE", token_file}});
    ASSERT_EQ(loaded.errors.size(), 1u);
    EXPECT_NE(loaded.errors.front().find("SPLITVK_TOKEN_FILE"), std::string::npos);
}

// An agent per eye needs two agents to dial and the paper's split; each refusal is one line naming
// SPLITVK_AGENTS.
TEST_F(SettingsTest, AnAgentPerEye) {
    EXPECT_EQ(load({}).settings.agents, 1u);
    const auto two = load({{"SPLITVK_AGENTS", "2"}, {"SPLITVK_SERVER", "a:1,b:2"}});
    EXPECT_TRUE(two.valid()) << (two.errors.empty() ? "" : two.errors.front());
    EXPECT_EQ(two.settings.agents, 2u);
    EXPECT_TRUE(load({{"SPLITVK_AGENTS", "2"}, {"SPLITVK_SERVER", "dnssd"}}).valid());
    for (const Environment &bad : {
             Environment{{"SPLITVK_AGENTS", "2"}},
             Environment{{"SPLITVK_AGENTS", "2"}, {"SPLITVK_SERVER", "a:1"}},
             Environment{
                 {"SPLITVK_AGENTS", "2"}, {"SPLITVK_SERVER", "a:1,b:2"}, {"SPLITVK_CLIENT_RENDERS", "fovea"}},
             Environment{{"SPLITVK_AGENTS", "2"}, {"SPLITVK_SERVER", "a:1,b:2"}, {"SPLITVK_VERIFY", "full"}},
         }) {
        const auto loaded = load(bad);
        ASSERT_EQ(loaded.errors.size(), 1u) << bad.back().first;
        EXPECT_NE(loaded.errors.front().find("SPLITVK_AGENTS=2"), std::string::npos) << loaded.errors.front();
        EXPECT_EQ(loaded.errors.front().find('\n'), std::string::npos);
    }
}

TEST_F(SettingsTest, UnknownVariablesWarnButManifestVariablesAreKnown) {
    const auto loaded = load({{"SPLITVK_SCLAE", "0.5"}, {"SPLITVK_ENABLE", "1"}, {"SPLITVK_DISABLE", "0"}});
    EXPECT_TRUE(loaded.valid());
    ASSERT_EQ(loaded.warnings.size(), 1u);
    EXPECT_NE(loaded.warnings.front().find("SPLITVK_SCLAE"), std::string::npos);
    EXPECT_NE(loaded.warnings.front().find("SPLITVK_SCALE"), std::string::npos) << "lists the known names";
}

// The scripts' own variables are neither settings nor unknown: a user who exports one for the
// scripts (SPLITVK_CACHE) must not get a warning from every application. Near misses still warn.
TEST_F(SettingsTest, ScriptVariablesAreNotWarnedAbout) {
    Environment env;
    for (const ScriptVariable &v : script_variable_table())
        env.emplace_back(v.name, "/somewhere");
    ASSERT_FALSE(env.empty());
    const auto loaded = load(env);
    EXPECT_TRUE(loaded.valid()) << loaded.errors.front();
    EXPECT_TRUE(loaded.warnings.empty()) << loaded.warnings.front();
    EXPECT_EQ(loaded.settings.server.host, "127.0.0.1");
    EXPECT_DOUBLE_EQ(loaded.settings.scale, 0.6);

    const auto near_miss = load({{"SPLITVK_CACHE_DIR", "/somewhere"}});
    ASSERT_EQ(near_miss.warnings.size(), 1u);
    EXPECT_NE(near_miss.warnings.front().find("unknown setting SPLITVK_CACHE_DIR"), std::string::npos);
    // Only the environment: the settings file holds the layer's keys alone.
    write_file("vk_layer_settings.txt", "splitvk_split_render.cache = /somewhere\n");
    EXPECT_EQ(load({}).warnings.size(), 1u);
}

TEST(Settings, ServerIsAnAddressAListOrDnssd) {
    const auto list = load_settings({{"SPLITVK_SERVER", "10.0.0.2:7447, gpu2.lab:7448"}}, "/nonexistent");
    ASSERT_TRUE(list.valid()) << list.errors[0];
    ASSERT_EQ(list.settings.servers.size(), 2u);
    EXPECT_EQ(list.settings.server, (ServerAddress{"10.0.0.2", 7447}));
    EXPECT_EQ(list.settings.servers[1], (ServerAddress{"gpu2.lab", 7448}));
    EXPECT_FALSE(list.settings.dnssd);

    const auto browse = load_settings({{"SPLITVK_SERVER", "dnssd"}}, "/nonexistent");
    ASSERT_TRUE(browse.valid());
    EXPECT_TRUE(browse.settings.dnssd);
    EXPECT_TRUE(browse.settings.dnssd_name.empty());
    EXPECT_TRUE(browse.settings.servers.empty());
    const auto one = load_settings({{"SPLITVK_SERVER", "dnssd:lab GPU 1"}}, "/nonexistent");
    ASSERT_TRUE(one.valid());
    EXPECT_EQ(one.settings.dnssd_name, "lab GPU 1");

    for (const char *bad : {"dnssd:", "10.0.0.2:7447,", ",10.0.0.2", "10.0.0.2:0,10.0.0.3"})
        EXPECT_FALSE(load_settings({{"SPLITVK_SERVER", bad}}, "/nonexistent").valid()) << bad;
}

TEST(ScriptVariables, AreNoSettingsNorManifestVariables) {
    std::set<std::string> seen;
    for (const ScriptVariable &v : script_variable_table()) {
        const std::string name = v.name;
        EXPECT_TRUE(name.starts_with("SPLITVK_")) << name;
        EXPECT_TRUE(seen.insert(name).second) << name << " is in the table twice";
        EXPECT_NE(name, "SPLITVK_ENABLE");
        EXPECT_NE(name, "SPLITVK_DISABLE");
        for (const SettingInfo &info : setting_table())
            EXPECT_NE(name, std::string("SPLITVK_") + info.name) << "a setting of the layer";
        EXPECT_NE(std::string(v.read_by), "");
        EXPECT_NE(std::string(v.description), "");
    }
}

TEST_F(SettingsTest, SettingsFileInWorkingDirectory) {
    write_file("vk_layer_settings.txt",
               "# splitvk\n"
               "khronos_validation.enables = VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT\n"
               "splitvk_split_render.scale = 0.75\n"
               "  splitvk_split_render.eyes=1  \n"
               "splitvk_split_render.codec = raw\n");
    const auto loaded = load({});
    ASSERT_TRUE(loaded.valid());
    EXPECT_EQ(loaded.file_path, (dir_ / "vk_layer_settings.txt").string());
    EXPECT_DOUBLE_EQ(loaded.settings.scale, 0.75);
    EXPECT_EQ(loaded.settings.eyes, EyeMode::One);
    EXPECT_EQ(loaded.settings.codec, TileCodec::Raw);
    EXPECT_TRUE(loaded.warnings.empty()) << "other layers' keys are not ours to judge";
}

TEST_F(SettingsTest, SettingsPathMayNameAFileOrADirectory) {
    const auto sub = dir_ / "conf";
    fs::create_directories(sub);
    std::ofstream(sub / "vk_layer_settings.txt") << "splitvk_split_render.scale = 0.8\n";
    std::ofstream(dir_ / "custom.txt") << "splitvk_split_render.scale = 0.9\n";

    EXPECT_DOUBLE_EQ(load({{"VK_LAYER_SETTINGS_PATH", sub.string()}}).settings.scale, 0.8);
    EXPECT_DOUBLE_EQ(load({{"VK_LAYER_SETTINGS_PATH", (dir_ / "custom.txt").string()}}).settings.scale, 0.9);
}

TEST_F(SettingsTest, EnvironmentWinsOverTheFile) {
    write_file("vk_layer_settings.txt", "splitvk_split_render.scale = 0.75\nsplitvk_split_render.eyes = 3\n");
    const auto loaded = load({{"SPLITVK_SCALE", "0.5"}, {"SPLITVK_EYES", "2"}});
    EXPECT_TRUE(loaded.valid()) << "the environment's valid EYES replaces the file's invalid one";
    EXPECT_DOUBLE_EQ(loaded.settings.scale, 0.5);
    EXPECT_EQ(loaded.settings.eyes, EyeMode::Two);
}

TEST_F(SettingsTest, FileErrorsNameTheKeyAndLine) {
    write_file("vk_layer_settings.txt",
               "\nsplitvk_split_render.codec = mpeg2\nsplitvk_split_render.sclae = 1\n");
    const auto loaded = load({});
    ASSERT_EQ(loaded.errors.size(), 1u);
    EXPECT_NE(loaded.errors.front().find("splitvk_split_render.codec"), std::string::npos);
    EXPECT_NE(loaded.errors.front().find("vk_layer_settings.txt:2"), std::string::npos);
    ASSERT_EQ(loaded.warnings.size(), 1u);
    EXPECT_NE(loaded.warnings.front().find("splitvk_split_render.sclae"), std::string::npos);
}

} // namespace
} // namespace splitvk

namespace splitvk {
namespace {

std::string read_text(const std::string &path) {
    std::ifstream file(path);
    std::stringstream text;
    text << file.rdbuf();
    return text.str();
}

// The settings table in docs/ and the list in the README are the user's reference: a setting
// the parser knows but the docs do not is a setting nobody can find.
TEST(SettingsDocs, EverySettingIsDocumented) {
    const std::string reference = read_text(SPLITVK_SOURCE_DIR "/docs/settings.md");
    const std::string readme = read_text(SPLITVK_SOURCE_DIR "/README.md");
    ASSERT_FALSE(reference.empty());
    ASSERT_FALSE(readme.empty());
    for (const SettingInfo &info : setting_table()) {
        const std::string variable = std::string("`SPLITVK_") + info.name + "`";
        EXPECT_NE(reference.find(variable), std::string::npos)
            << variable << " missing from docs/settings.md";
        EXPECT_NE(reference.find(info.accepted), std::string::npos)
            << "docs/settings.md does not state what " << variable << " accepts: " << info.accepted;
        EXPECT_NE(readme.find(variable), std::string::npos) << variable << " missing from README.md";
    }
}

// docs/settings.md lists the scripts' variables too, apart from the layer's settings.
TEST(SettingsDocs, EveryScriptVariableIsDocumented) {
    const std::string reference = read_text(SPLITVK_SOURCE_DIR "/docs/settings.md");
    const auto section = reference.find("## Variables of the scripts");
    ASSERT_NE(section, std::string::npos) << "docs/settings.md has no section for the scripts' variables";
    for (const ScriptVariable &v : script_variable_table()) {
        const std::string variable = std::string("`") + v.name + "`";
        EXPECT_NE(reference.find(variable, section), std::string::npos)
            << variable << " missing from docs/settings.md's section of the scripts' variables";
    }
}

// Every SPLITVK_* variable that a script or test program takes from the environment is a setting,
// a manifest variable, or in script_variable_table(); otherwise whoever sets it for the script gets
// the layer's "unknown setting" warning in every application.
TEST(ScriptVariables, EveryVariableTheScriptsAndTestsReadIsKnown) {
    // scripts/common.sh's own shell variables, set for the scripts that source it, never exported.
    const std::set<std::string> shell_variables = {"SPLITVK_PHASE_RUNNING", "SPLITVK_XVFB_PID"};
    std::set<std::string> known = {"SPLITVK_ENABLE", "SPLITVK_DISABLE"};
    for (const SettingInfo &info : setting_table())
        known.insert(std::string("SPLITVK_") + info.name);
    for (const ScriptVariable &v : script_variable_table())
        known.insert(v.name);
    // Reads from the environment: getenv("X") and env_or("X", ...) in C++, ${X:-...} and ${X-...}
    // in shell, os.environ.get("X") and os.environ["X"] in Python.
    const std::regex reads(
        R"re((?:getenv|env_or)\("(SPLITVK_[A-Z0-9_]+)"|\$\{(SPLITVK_[A-Z0-9_]+):?-|environ(?:\.get\(|\[)["'](SPLITVK_[A-Z0-9_]+))re");
    const fs::path root = SPLITVK_SOURCE_DIR;
    size_t files = 0;
    std::set<std::string> found;
    for (const char *folder : {"scripts", "tests", ".ci"}) {
        for (const auto &entry : fs::recursive_directory_iterator(root / folder)) {
            if (!entry.is_regular_file()) continue;
            const std::string ext = entry.path().extension().string();
            // Extensionless files are scripts under scripts/ and .ci/, but fuzz inputs under tests/.
            const bool script = ext.empty() && std::string(folder) != "tests";
            if (!script && ext != ".sh" && ext != ".py" && ext != ".cpp" && ext != ".h") continue;
            ++files;
            const std::string text = read_text(entry.path().string());
            for (std::sregex_iterator it(text.begin(), text.end(), reads), end; it != end; ++it) {
                const std::string name = (*it)[1].matched ? (*it)[1] : (*it)[2].matched ? (*it)[2] : (*it)[3];
                found.insert(name);
                if (!known.count(name) && !shell_variables.count(name))
                    ADD_FAILURE() << fs::relative(entry.path(), root).string() << " reads " << name
                                  << ", which the layer would warn about: add it to kScriptVariables "
                                     "(common/settings.cpp) and docs/settings.md";
            }
        }
    }
    EXPECT_GT(files, 50u) << "the scan found too few files under " << root;
    // The scan sees the reads it must see, so that a pattern gone stale cannot pass silently.
    for (const char *name : {"SPLITVK_CACHE", "SPLITVK_FUZZ_SECONDS", "SPLITVK_E2E_BUILD_DIR"})
        EXPECT_TRUE(found.count(name)) << "the scan did not find " << name << " read";
}

} // namespace
} // namespace splitvk
