#include "agent_options.h"

#include <gtest/gtest.h>

namespace splitvk::agent {
namespace {

TEST(AgentOptions, DefaultsListenOnLoopback) {
    const auto parsed = parse_agent_options({});
    ASSERT_TRUE(parsed.error.empty()) << parsed.error;
    EXPECT_EQ(parsed.options.listen_host, "127.0.0.1");
    EXPECT_EQ(parsed.options.listen_port, 7447);
    EXPECT_EQ(parsed.options.device_index, 0u);
}

TEST(AgentOptions, ParsesEveryOption) {
    const auto parsed = parse_agent_options(
        {"--listen", "[::1]:9000", "--device", "2", "--token-file", "/etc/splitvk/token"});
    ASSERT_TRUE(parsed.error.empty()) << parsed.error;
    EXPECT_EQ(parsed.options.listen_host, "::1");
    EXPECT_EQ(parsed.options.listen_port, 9000);
    EXPECT_EQ(parsed.options.device_index, 2u);
    EXPECT_EQ(parsed.options.token_file, "/etc/splitvk/token");
}

TEST(AgentOptions, ValidateAndMaxSessions) {
    const auto defaults = parse_agent_options({});
    EXPECT_FALSE(defaults.options.validate);
    EXPECT_EQ(defaults.options.max_sessions, 16u);
    const auto parsed = parse_agent_options({"--validate", "--max-sessions", "3"});
    ASSERT_TRUE(parsed.error.empty()) << parsed.error;
    EXPECT_TRUE(parsed.options.validate);
    EXPECT_EQ(parsed.options.max_sessions, 3u);
    EXPECT_NE(parse_agent_options({"--max-sessions", "0"}).error.find("--max-sessions"), std::string::npos);
    EXPECT_NE(parse_agent_options({"--max-sessions"}).error.find("--max-sessions"), std::string::npos);
    EXPECT_NE(std::string(agent_usage()).find("--validate"), std::string::npos);
}

TEST(AgentOptions, NonLoopbackNeedsAToken) {
    EXPECT_NE(parse_agent_options({"--listen", "0.0.0.0:7447"}).error.find("--token-file"),
              std::string::npos);
    EXPECT_TRUE(parse_agent_options({"--listen", "0.0.0.0:7447", "--token-file", "t"}).error.empty());
    EXPECT_TRUE(parse_agent_options({"--listen", "localhost:7447"}).error.empty());
}

TEST(AgentOptions, BadInputIsOneLineError) {
    for (const std::vector<std::string> &args :
         std::vector<std::vector<std::string>>{{"--listen"},
                                               {"--listen", "host:99999"},
                                               {"--device", "-1"},
                                               {"--device", "one"},
                                               {"--bogus"}}) {
        const auto parsed = parse_agent_options(args);
        EXPECT_FALSE(parsed.error.empty()) << args.front();
        EXPECT_EQ(parsed.error.find('\n'), std::string::npos);
    }
}

} // namespace
} // namespace splitvk::agent
