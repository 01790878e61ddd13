// splitvk-link's command line: profiles, precedence, and one-line errors for bad flags.

#include "link_options.h"

#include <gtest/gtest.h>

namespace {

using namespace std::chrono_literals;
using splitvk::link::LinkShape;
using splitvk::link::parse_link_options;

std::vector<std::string> with_addresses(std::vector<std::string> extra) {
    std::vector<std::string> args = {"--listen", "127.0.0.1:7448", "--connect", "127.0.0.1:7447"};
    args.insert(args.end(), extra.begin(), extra.end());
    return args;
}

TEST(LinkOptions, ProfilesAreTheDocumentedLinks) {
    const struct {
        const char *name;
        LinkShape shape;
    } expected[] = {
        {"gige", {940'000'000, 200us}},
        {"wifi5", {400'000'000, 2ms}},
        {"wifi6", {800'000'000, 1500us}},
        {"none", {0, 0ns}},
    };
    for (const auto &e : expected) {
        const auto parsed = parse_link_options(with_addresses({"--profile", e.name}));
        ASSERT_EQ(parsed.error, "") << e.name;
        EXPECT_EQ(parsed.options.up, e.shape) << e.name;
        EXPECT_EQ(parsed.options.down, e.shape) << e.name;
        EXPECT_EQ(parsed.options.profile, e.name);
    }
    EXPECT_EQ(splitvk::link::link_profiles().size(), std::size(expected));
}

TEST(LinkOptions, AddressesAndAnyFreePort) {
    const auto parsed =
        parse_link_options({"--connect", "[::1]:7447", "--listen", "127.0.0.1:0", "--profile", "none"});
    ASSERT_EQ(parsed.error, "");
    EXPECT_EQ(parsed.options.listen_host, "127.0.0.1");
    EXPECT_EQ(parsed.options.listen_port, 0);
    EXPECT_EQ(parsed.options.connect_host, "::1");
    EXPECT_EQ(parsed.options.connect_port, 7447);
}

TEST(LinkOptions, SpecificOverridesGeneralInAnyOrder) {
    const auto parsed = parse_link_options(
        with_addresses({"--down-delay", "7ms", "--rate", "100M", "--profile", "wifi5", "--up-rate", "1.5G"}));
    ASSERT_EQ(parsed.error, "");
    EXPECT_EQ(parsed.options.up, (LinkShape{1'500'000'000, 2ms}));
    EXPECT_EQ(parsed.options.down, (LinkShape{100'000'000, 7ms}));
}

TEST(LinkOptions, RatesAndDelays) {
    uint64_t rate = 0;
    EXPECT_TRUE(splitvk::link::parse_rate("400M", rate));
    EXPECT_EQ(rate, 400'000'000u);
    EXPECT_TRUE(splitvk::link::parse_rate("100k", rate));
    EXPECT_EQ(rate, 100'000u);
    EXPECT_TRUE(splitvk::link::parse_rate("2500", rate));
    EXPECT_EQ(rate, 2500u);
    for (const char *bad : {"", "M", "400m", "400 M", "-1M", "0", "0.0000001", "nan", "2T"})
        EXPECT_FALSE(splitvk::link::parse_rate(bad, rate)) << bad;

    std::chrono::nanoseconds delay{};
    EXPECT_TRUE(splitvk::link::parse_delay("0.2ms", delay));
    EXPECT_EQ(delay, 200us);
    EXPECT_TRUE(splitvk::link::parse_delay("150us", delay));
    EXPECT_EQ(delay, 150us);
    EXPECT_TRUE(splitvk::link::parse_delay("0", delay));
    EXPECT_EQ(delay, 0ns);
    for (const char *bad : {"2", "2 ms", "ms", "-1ms", "11s", "2h"})
        EXPECT_FALSE(splitvk::link::parse_delay(bad, delay)) << bad;
}

TEST(LinkOptions, BadCommandLinesGetOneLineThatSaysWhat) {
    const struct {
        std::vector<std::string> args;
        const char *error;
    } cases[] = {
        {with_addresses({"--profile", "lte"}),
         "--profile 'lte' is invalid: expected gige, wifi5, wifi6 or none"},
        {with_addresses({"--rate", "40x"}),
         "--rate '40x' is invalid: expected bits per second such as 400M, 1.5G "
         "or 100k"},
        {with_addresses({"--delay", "2"}),
         "--delay '2' is invalid: expected a one-way delay such as 2ms, 200us, "
         "0.2ms or 0 (at most 10s)"},
        {with_addresses({"--up-delay"}), "--up-delay needs TIME"},
        {with_addresses({"--bandwidth", "1G"}), "unknown option '--bandwidth' (see --help)"},
        {with_addresses({}), "no link given: pass --profile gige|wifi5|wifi6|none, or --rate and --delay"},
        {{"--listen", "127.0.0.1:7448", "--profile", "none"},
         "--connect ADDR:PORT is required (the server to "
         "forward to)"},
        {{"--connect", "127.0.0.1:7447", "--profile", "none"},
         "--listen ADDR:PORT is required (where the client "
         "connects)"},
        {{"--listen", "127.0.0.1", "--connect", "127.0.0.1:7447"},
         "--listen '127.0.0.1' is invalid: expected "
         "HOST:PORT or [IPV6]:PORT"},
        {{"--listen", "127.0.0.1:1", "--connect", "127.0.0.1:0"},
         "--connect '127.0.0.1:0' is invalid: expected "
         "HOST:PORT or [IPV6]:PORT"},
        {{"--listen", "::1:7448", "--connect", "127.0.0.1:1"},
         "--listen '::1:7448' is invalid: expected "
         "HOST:PORT or [IPV6]:PORT"},
    };
    for (const auto &c : cases) {
        const auto parsed = parse_link_options(c.args);
        EXPECT_EQ(parsed.error, c.error);
        EXPECT_EQ(parsed.error.find('\n'), std::string::npos);
    }
}

TEST(LinkOptions, HelpNeedsNothingElseAndListsEveryProfile) {
    const auto parsed = parse_link_options({"--help"});
    EXPECT_EQ(parsed.error, "");
    EXPECT_TRUE(parsed.options.help);
    const std::string usage = splitvk::link::link_usage();
    for (const auto &p : splitvk::link::link_profiles())
        EXPECT_NE(usage.find(std::string("  ") + p.name + " "), std::string::npos) << p.name;
}

TEST(LinkOptions, Describe) {
    EXPECT_EQ(splitvk::link::describe({400'000'000, 2ms}), "400 Mbit/s + 2 ms");
    EXPECT_EQ(splitvk::link::describe({1'000'000'000, 200us}), "1 Gbit/s + 0.2 ms");
    EXPECT_EQ(splitvk::link::describe({0, 1500us}), "unlimited + 1.5 ms");
    EXPECT_EQ(splitvk::link::describe({}), "no shaping");
}

} // namespace
