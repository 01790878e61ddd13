// Self-tests of the e2e harness: each check the other suites rely on is shown to fail when it
// should, so a broken harness cannot make them pass.
#include "agent.h"
#include "e2e_test.h"

#include <csignal>

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
    ::setenv("SPLITVK_SPLIT", "auto", 1);
    ::setenv("VK_LOADER_DEBUG", "all", 1);
    Env env = clean_env();
    ::unsetenv("VK_INSTANCE_LAYERS");
    ::unsetenv("VK_LAYER_PATH");
    ::unsetenv("SPLITVK_ENABLE");
    ::unsetenv("SPLITVK_SPLIT");
    ::unsetenv("VK_LOADER_DEBUG");
    auto r = run_app({"env"}, env, out, "env", std::chrono::seconds(10));
    ASSERT_TRUE(r.ok()) << r.describe();
    const std::string text = r.out();
    EXPECT_TRUE(grep(text, "leaked").empty()) << text;
    // Only the harness's own: the suites test the split wherever it would not pay.
    EXPECT_EQ(lines_starting_with(text, "SPLITVK_"), std::vector<std::string>{"SPLITVK_SPLIT=always"})
        << text;
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

// splitvk-harness: this harness on the command line, which scripts/common.sh and scripts/bench_lib
// start Xvfb and the agent and hold apps with.
std::filesystem::path harness_cli() {
    return bin_dir() / "splitvk-harness";
}

// The value of `key` in a splitvk-harness report ("key=value" lines).
std::string report_value(const std::string &report, const std::string &key) {
    const auto lines = lines_starting_with(report, key + "=");
    return lines.size() == 1 ? lines[0].substr(key.size() + 1) : std::string();
}

// A service reports, then says "ready"; SIGTERM to it stops what it started.
TEST(HarnessCli, AgentServiceReportsItsAddressAndStopsTheAgentOnSigterm) {
    using namespace std::chrono_literals;
    const auto out = test_output_dir();
    ASSERT_TRUE(built(harness_cli()));
    ASSERT_TRUE(built(agent_path()));
    ProcessSpec spec;
    spec.argv = {harness_cli().string(), "agent", "--out-dir", out.string(), "--name", "agent", "--",
                 agent_path().string()};
    spec.env = clean_env();
    spec.out_dir = out;
    spec.name = "harness";
    Process service(spec);
    ASSERT_TRUE(service.start()) << service.error();
    ASSERT_TRUE(service.wait_for_line("ready", 60s)) << service.result().describe() << "\n"
                                                     << read_file(service.result().stderr_path);
    const std::string report = read_file(service.result().stdout_path);
    const std::string address = report_value(report, "address");
    const int pid = std::atoi(report_value(report, "pid").c_str());
    ASSERT_EQ(address.rfind("127.0.0.1:", 0), 0u) << report;
    ASSERT_GT(pid, 0) << report;
    EXPECT_EQ(report_value(report, "log"), (out / "agent.stderr").string()) << report;
    EXPECT_FALSE(grep(read_file(out / "agent.stderr"), "listening on " + address).empty());
    EXPECT_EQ(::kill(pid, 0), 0) << "the agent is not running";

    const ProcessResult r = service.terminate(40s);
    EXPECT_TRUE(r.ok()) << r.describe() << "\n" << r.err();
    // Its own process group, which the service's SIGTERM did not reach: the service stopped it.
    EXPECT_NE(::kill(pid, 0), 0) << "the agent outlived its service";
    EXPECT_FALSE(grep(read_file(out / "agent.stderr"), "] info: stopped").empty())
        << tail(read_file(out / "agent.stderr"));
}

// An app that ends before its hold: one error line and exit status 1, and no grab.
TEST(HarnessCli, HoldSaysInOneLineThatTheAppEndedFirst) {
    const auto out = test_output_dir();
    ASSERT_TRUE(built(harness_cli()));
    Env env = clean_env();
    env["DISPLAY"] = ":0"; // never reached: the app ends first
    const auto r = run_app({harness_cli().string(), "hold", "--out-dir", out.string(), "--name", "app",
                            "--frame", "3", "--grab", (out / "never.png").string(), "--size", "8x8", "--",
                            "sh", "-c", "echo 'holding frame 2'"},
                           env, out, "harness", std::chrono::seconds(30));
    ASSERT_TRUE(r.exited) << r.describe();
    EXPECT_EQ(r.exit_code, 1) << r.describe();
    const auto lines = split_lines(r.err());
    ASSERT_EQ(lines.size(), 1u) << r.err();
    EXPECT_EQ(lines[0].rfind("splitvk-harness: error: the app ended before 'holding frame 3'", 0), 0u)
        << r.err();
    EXPECT_FALSE(std::filesystem::exists(out / "never.png"));
}

// hold: the app runs to its "holding frame N", the screen is grabbed with the frame on it, the app
// ends on SIGTERM.
TEST_F(HarnessX, CliHoldGrabsTheHeldFrameThenEndsTheApp) {
    ASSERT_TRUE(built(harness_cli()));
    ASSERT_TRUE(built(atrium_path()));
    const auto grab = out_ / "held.bgr0";
    const auto r = run_app({harness_cli().string(),
                            "hold",
                            "--out-dir",
                            out_.string(),
                            "--name",
                            "atrium",
                            "--frame",
                            "1",
                            "--grab",
                            grab.string(),
                            "--size",
                            "160x100",
                            "--pix-fmt",
                            "bgr0",
                            "--",
                            atrium_path().string(),
                            "--width",
                            "160",
                            "--height",
                            "100",
                            "--frames",
                            "2",
                            "--hold"},
                           env(), out_, "harness", std::chrono::seconds(180));
    ASSERT_TRUE(r.ok()) << r.describe() << "\n" << r.err();
    EXPECT_EQ(report_value(r.out(), "grab"), grab.string()) << r.out();
    EXPECT_FALSE(grep(read_file(out_ / "atrium.stdout"), "holding frame 1").empty());
    const std::string pixels = read_file(grab);
    ASSERT_EQ(pixels.size(), 160u * 100u * 4u);
    Image img;
    img.width = 160;
    img.height = 100;
    img.bgr0.assign(pixels.begin(), pixels.end());
    // The atrium, not an empty screen (BlankScreenGrabIsOneColour).
    EXPECT_GT(distinct_colours(img), 16u);
}

} // namespace
} // namespace splitvk::e2e
