// Device extensions splitvk does not forward: an application that enables one without
// asking gets one warning line naming it, and then (SPLITVK_UNSUPPORTED=fail, the default)
// VK_ERROR_EXTENSION_NOT_PRESENT, or (passthrough) a device that runs unsplit with splitvk out of
// its way. The headless probe enables VK_EXT_external_memory_host, which lavapipe offers and
// splitvk does not forward; the first test proves both halves of that premise, prints how many of
// lavapipe's device extensions splitvk forwards and why each of the others is withheld, and holds
// the floor of 80 %.
#include "agent.h"
#include "e2e_test.h"
#include "vk_withheld_extensions.h"

#include <algorithm>
#include <set>
#include <thread>

namespace splitvk::e2e {
namespace {

constexpr const char *kWithheld = "VK_EXT_external_memory_host";
// At least this share of the driver's device extensions is forwarded.
constexpr size_t kCoverageFloorPercent = 80;
constexpr const char *kLinePrefix =
    "[splitvk] warning: 'splitvk-e2e-probe' enables device extensions splitvk "
    "does not forward: ";

class UnsupportedExtensions : public XTest {
protected:
    Env probe_env(bool with_layer) const {
        Env e = env();
        if (with_layer) {
            use_explicit_layers(e, {kLayerName});
            enable_layer_info_log(e); // "replicating to splitvk-agent" is an info line
        }
        return e;
    }

    ProcessResult run_probe(const Env &e, const std::vector<std::string> &args, const std::string &name) {
        std::vector<std::string> argv = {probe_path().string()};
        argv.insert(argv.end(), args.begin(), args.end());
        return run_app(argv, e, out_, name, std::chrono::seconds(60));
    }

    // The device extensions the probe is told, with or without splitvk.
    std::set<std::string> listed(bool with_layer, const std::string &name) {
        auto r = run_probe(probe_env(with_layer), {"--list-device-extensions"}, name);
        EXPECT_TRUE(r.ok()) << r.describe() << "\n" << tail(r.err());
        std::set<std::string> names;
        for (const auto &line : lines_starting_with(r.out(), "device extension: "))
            names.insert(line.substr(std::string("device extension: ").size()));
        return names;
    }

    std::vector<std::string> warning_lines(const std::string &err) {
        return lines_starting_with(err, "[splitvk] warning: ");
    }
};

// Coverage as a number: lavapipe's device extensions against those splitvk lets the application
// see. Also the premise of the tests below: lavapipe offers kWithheld, splitvk hides it, and the
// probe enabling it runs without splitvk.
TEST_F(UnsupportedExtensions, Coverage) {
    ASSERT_TRUE(built(probe_path()));
    const auto offered = listed(false, "list-offered");
    const auto forwarded = listed(true, "list-forwarded");
    ASSERT_FALSE(offered.empty());
    ASSERT_FALSE(forwarded.empty());
    std::vector<std::string> withheld;
    std::set_difference(offered.begin(), offered.end(), forwarded.begin(), forwarded.end(),
                        std::back_inserter(withheld));
    for (const auto &name : forwarded)
        EXPECT_TRUE(offered.count(name)) << name << " is forwarded but the driver does not offer it";
    std::cout << "  " << forwarded.size() << " of " << offered.size() << " device extensions forwarded ("
              << forwarded.size() * 100 / offered.size() << " %)\n"
              << "  withheld (" << withheld.size() << "):\n";
    for (const auto &name : withheld) {
        const auto *known = std::find_if(std::begin(kWithheldExtensions), std::end(kWithheldExtensions),
                                         [&](const WithheldExtension &w) { return name == w.name; });
        const bool has_reason = known != std::end(kWithheldExtensions);
        std::cout << "    " << name << ": " << (has_reason ? known->reason : "(no reason given)") << "\n";
        EXPECT_TRUE(has_reason) << name
                                << " is withheld without a reason in codegen/allowlist.py WITHHELD_REASONS";
    }
    EXPECT_GE(forwarded.size() * 100, offered.size() * kCoverageFloorPercent)
        << "splitvk forwards fewer than " << kCoverageFloorPercent << " % of the driver's device extensions";
    ASSERT_TRUE(offered.count(kWithheld)) << "lavapipe no longer offers " << kWithheld << ": pick another";
    ASSERT_FALSE(forwarded.count(kWithheld)) << "splitvk now forwards " << kWithheld << ": pick another";
    auto r = run_probe(probe_env(false), {"--device-extension", kWithheld}, "probe-without-splitvk");
    EXPECT_TRUE(r.ok()) << r.describe() << "\n" << tail(r.err());
}

// The default: one line naming every withheld extension of the request (and none of the forwarded
// ones), saying what to do, and vkCreateDevice fails with VK_ERROR_EXTENSION_NOT_PRESENT.
TEST_F(UnsupportedExtensions, DefaultIsOneLineAndFails) {
    ASSERT_TRUE(built(probe_path()));
    auto r = run_probe(probe_env(true),
                       {"--device-extension", kWithheld, "--device-extension", "VK_KHR_swapchain",
                        "--device-extension", "VK_EXT_multi_draw"},
                       "probe-fail");
    EXPECT_FALSE(r.ok()) << r.describe();
    const std::string err = r.err();
    EXPECT_FALSE(grep(err, "vkCreateDevice(gpu, &dci, nullptr, &device) failed: -7").empty()) << tail(err);
    const auto lines = warning_lines(err);
    ASSERT_EQ(lines.size(), 1u) << joined(lines) << "\n" << tail(err);
    std::cout << "  " << lines[0] << "\n";
    EXPECT_EQ(lines[0], std::string(kLinePrefix) + kWithheld +
                            ", VK_EXT_multi_draw; vkCreateDevice fails with VK_ERROR_EXTENSION_NOT_PRESENT. "
                            "To run it unsplit, set SPLITVK_UNSUPPORTED=passthrough, or SPLITVK_DISABLE=1 to "
                            "keep splitvk out");
}

// passthrough: the device is created as asked and the probe runs to the end, with no session at the
// agent SPLITVK_SERVER names; the control run, without the extension and the same settings, does
// replicate, so the absence means something.
TEST_F(UnsupportedExtensions, PassthroughRunsUnsplit) {
    ASSERT_TRUE(built(probe_path()));
    Agent agent;
    ASSERT_TRUE(agent.start(env(), out_)) << agent.error();
    Env e = probe_env(true);
    e["SPLITVK_SERVER"] = agent.address();
    e["SPLITVK_UNSUPPORTED"] = "passthrough";
    {
        SCOPED_TRACE("control: no withheld extension, split as usual");
        auto r = run_probe(e, {}, "probe-control");
        ASSERT_TRUE(r.ok()) << r.describe() << "\n" << tail(r.err());
        EXPECT_TRUE(warning_lines(r.err()).empty()) << tail(r.err());
        EXPECT_FALSE(grep(r.err(), "replicating to splitvk-agent").empty()) << tail(r.err());
    }
    auto r = run_probe(e, {"--device-extension", kWithheld}, "probe-passthrough");
    ASSERT_TRUE(r.ok()) << r.describe() << "\n" << tail(r.err());
    EXPECT_FALSE(grep(r.out(), "probe ok").empty()) << r.describe();
    const std::string err = r.err();
    const auto lines = warning_lines(err);
    ASSERT_EQ(lines.size(), 1u) << joined(lines) << "\n" << tail(err);
    std::cout << "  " << lines[0] << "\n";
    EXPECT_EQ(lines[0], std::string(kLinePrefix) + kWithheld +
                            "; SPLITVK_UNSUPPORTED=passthrough: splitvk passes this device through to the "
                            "driver, unsplit");
    EXPECT_TRUE(grep(err, "replicating to splitvk-agent").empty()) << tail(err);
    EXPECT_TRUE(lines_starting_with(err, "[splitvk] error:").empty()) << tail(err);
    // The instance still greets the agent at vkCreateInstance (for the device envelope), before any
    // device exists, so the agent sees a second connection; but no device of it is created there.
    const auto deadline = Clock::now() + std::chrono::seconds(10);
    while (grep(agent.log(), ") ended").size() < 2 && Clock::now() < deadline)
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
    EXPECT_EQ(grep(agent.log(), ": device created on ").size(), 1u)
        << "only the control run's device replicates:\n"
        << tail(agent.log());
}

} // namespace
} // namespace splitvk::e2e
