#include "agent_options.h"
#include "handshake.h"

#include <variant>

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

TEST(AgentOptions, AdvertiseTakesAnOptionalName) {
    const auto bare = parse_agent_options({"--advertise", "--validate"});
    ASSERT_TRUE(bare.error.empty()) << bare.error;
    EXPECT_TRUE(bare.options.advertise);
    EXPECT_TRUE(bare.options.advertise_name.empty());
    EXPECT_TRUE(bare.options.validate);
    const auto named = parse_agent_options({"--advertise", "lab GPU 1"});
    ASSERT_TRUE(named.error.empty()) << named.error;
    EXPECT_EQ(named.options.advertise_name, "lab GPU 1");
    EXPECT_FALSE(parse_agent_options({"--advertise", std::string(64, 'x')}).error.empty());
    EXPECT_FALSE(parse_agent_options({}).options.advertise);
}

TEST(AgentOptions, DeviceIsAnIndexOrAUuid) {
    const auto uuid = parse_agent_options({"--device", "6B39A0F2-1C1D-4E55-8A8E-0123456789AB"});
    ASSERT_TRUE(uuid.error.empty()) << uuid.error;
    EXPECT_EQ(uuid.options.device_uuid, "6b39a0f21c1d4e558a8e0123456789ab");
    EXPECT_EQ(parse_agent_options({"--device", "3"}).options.device_uuid, "");
    const auto bad = parse_agent_options({"--device", "6b39a0f2"});
    EXPECT_NE(bad.error.find("--device '6b39a0f2' is invalid"), std::string::npos) << bad.error;
    // --listen names one address: a list or dnssd is the layer's.
    EXPECT_FALSE(parse_agent_options({"--listen", "127.0.0.1:1,127.0.0.1:2"}).error.empty());
    EXPECT_FALSE(parse_agent_options({"--listen", "dnssd"}).error.empty());
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

TEST(AgentOptions, UserAndNoConfine) {
    const auto defaults = parse_agent_options({});
    EXPECT_EQ(defaults.options.user, "nobody");
    EXPECT_FALSE(defaults.options.user_given);
    EXPECT_TRUE(defaults.options.confine);
    const auto parsed = parse_agent_options({"--user", "splitvk", "--no-confine"});
    ASSERT_TRUE(parsed.error.empty()) << parsed.error;
    EXPECT_EQ(parsed.options.user, "splitvk");
    EXPECT_TRUE(parsed.options.user_given);
    EXPECT_FALSE(parsed.options.confine);
    for (const char *user : {"root", "0", ""})
        EXPECT_NE(parse_agent_options({"--user", user}).error.find("unprivileged"), std::string::npos)
            << user;
    EXPECT_NE(parse_agent_options({"--user"}).error.find("--user needs"), std::string::npos);
    EXPECT_NE(std::string(agent_usage()).find("--no-confine"), std::string::npos);
}

TEST(AgentOptions, NonLoopbackNeedsAToken) {
    EXPECT_NE(parse_agent_options({"--listen", "0.0.0.0:7447"}).error.find("--token-file"),
              std::string::npos);
    EXPECT_TRUE(parse_agent_options({"--listen", "0.0.0.0:7447", "--token-file", "t"}).error.empty());
    EXPECT_TRUE(parse_agent_options({"--listen", "localhost:7447"}).error.empty());
    EXPECT_TRUE(parse_agent_options({"--listen", "127.0.0.2:7447"}).error.empty());
    EXPECT_TRUE(parse_agent_options({"--listen", "[::1]:7447"}).error.empty());
    // Anything that is not a numeric loopback address needs the token, names included: a name
    // that starts like one resolves wherever its DNS says.
    for (const char *listen : {"192.168.1.20:7447", "[::]:7447", "127.example.com:7447", "gpu-box:7447"}) {
        const auto parsed = parse_agent_options({"--listen", listen});
        EXPECT_NE(parsed.error.find("without --token-file"), std::string::npos) << listen;
        EXPECT_EQ(parsed.error.find('\n'), std::string::npos);
    }
    EXPECT_FALSE(is_loopback_host("127.0.0.1.nip.io"));
    EXPECT_TRUE(is_loopback_host("127.255.0.9"));
}

TEST(AgentOptions, TlsIdentityOptions) {
    const auto parsed = parse_agent_options({"--tls-cert", "/etc/a.crt", "--tls-key", "/etc/a.key",
                                             "--state-dir", "/var/lib/x", "--print-fingerprint"});
    ASSERT_TRUE(parsed.error.empty()) << parsed.error;
    EXPECT_EQ(parsed.options.tls_cert, "/etc/a.crt");
    EXPECT_EQ(parsed.options.tls_key, "/etc/a.key");
    EXPECT_EQ(parsed.options.state_dir, "/var/lib/x");
    EXPECT_TRUE(parsed.options.print_fingerprint);
    EXPECT_NE(parse_agent_options({"--tls-cert", "/etc/a.crt"}).error.find("needs --tls-key"),
              std::string::npos);
    EXPECT_NE(parse_agent_options({"--tls-key", "/etc/a.key"}).error.find("needs --tls-cert"),
              std::string::npos);
    EXPECT_NE(parse_agent_options({"--state-dir"}).error.find("--state-dir"), std::string::npos);
    // Printing the fingerprint serves nobody: a LAN --listen needs no token for it.
    EXPECT_TRUE(parse_agent_options({"--listen", "10.0.0.2:7447", "--print-fingerprint"}).error.empty());
    EXPECT_NE(std::string(agent_usage()).find("--print-fingerprint"), std::string::npos);
}

TEST(AgentOptions, ByteSizes) {
    EXPECT_EQ(parse_byte_size("4096"), 4096u);
    EXPECT_EQ(parse_byte_size("512K"), 512u << 10);
    EXPECT_EQ(parse_byte_size("512M"), 512u << 20);
    EXPECT_EQ(parse_byte_size("4G"), uint64_t{4} << 30);
    EXPECT_EQ(parse_byte_size("4GiB"), uint64_t{4} << 30);
    EXPECT_EQ(parse_byte_size("2t"), uint64_t{2} << 40);
    for (const char *bad : {"", "M", "-1", "4X", "4GG", "1 G", "99999999999T", "0x10"})
        EXPECT_FALSE(parse_byte_size(bad)) << bad;
}

TEST(AgentOptions, Limits) {
    const auto defaults = parse_agent_options({});
    EXPECT_EQ(defaults.options.max_message_bytes, 64u << 20);
    EXPECT_EQ(defaults.options.max_host_memory, uint64_t{4} << 30);
    EXPECT_EQ(defaults.options.max_gpu_memory, uint64_t{8} << 30);
    const auto parsed = parse_agent_options(
        {"--max-message-bytes", "1M", "--max-host-memory", "512M", "--max-gpu-memory", "2G"});
    ASSERT_TRUE(parsed.error.empty()) << parsed.error;
    EXPECT_EQ(parsed.options.max_message_bytes, 1u << 20);
    EXPECT_EQ(parsed.options.max_host_memory, 512u << 20);
    EXPECT_EQ(parsed.options.max_gpu_memory, uint64_t{2} << 30);
    for (const std::vector<std::string> &args :
         std::vector<std::vector<std::string>>{{"--max-message-bytes", "1K"},
                                               {"--max-message-bytes", "3G"},
                                               {"--max-host-memory", "0"},
                                               {"--max-gpu-memory", "lots"},
                                               {"--max-gpu-memory"}}) {
        const auto bad = parse_agent_options(args);
        EXPECT_NE(bad.error.find(args.front()), std::string::npos) << args.front();
        EXPECT_EQ(bad.error.find('\n'), std::string::npos);
    }
    for (const char *flag : {"--max-message-bytes", "--max-host-memory", "--max-gpu-memory",
                             "--record-corpus", "--emulate-limits"})
        EXPECT_NE(std::string(agent_usage()).find(flag), std::string::npos) << flag;
}

TEST(AgentOptions, EmulateLimitsTakesAProfile) {
    const auto parsed = parse_agent_options({"--emulate-limits", "strict.json"});
    ASSERT_TRUE(parsed.error.empty()) << parsed.error;
    EXPECT_EQ(parsed.options.emulate_limits, "strict.json");
    const auto missing = parse_agent_options({"--emulate-limits"});
    EXPECT_NE(missing.error.find("--emulate-limits"), std::string::npos) << missing.error;
}

// --no-periphery drops the swapped split from what sessions offer; a client gets it only when both
// sides have it.
TEST(AgentOptions, NoPeripheryDropsTheSwappedSplit) {
    const auto defaults = parse_agent_options({});
    EXPECT_TRUE(defaults.options.periphery);
    EXPECT_EQ(agent_capabilities(defaults.options), protocol::kSupportedCapabilities);
    EXPECT_TRUE(agent_capabilities(defaults.options) & protocol::capability::kSwappedSplit);
    const auto parsed = parse_agent_options({"--no-periphery"});
    ASSERT_TRUE(parsed.error.empty()) << parsed.error;
    EXPECT_FALSE(parsed.options.periphery);
    EXPECT_EQ(agent_capabilities(parsed.options),
              protocol::kSupportedCapabilities & ~protocol::capability::kSwappedSplit);
    EXPECT_NE(std::string(agent_usage()).find("--no-periphery"), std::string::npos);

    protocol::Hello hello;
    hello.capabilities = protocol::capability::kZstdPayloads | protocol::capability::kFoveaTiles |
                         protocol::capability::kSwappedSplit;
    const auto granted = [&](const AgentOptions &options, const protocol::Hello &h) {
        protocol::ServerHandshakeConfig config;
        config.capabilities = agent_capabilities(options);
        const auto answer = protocol::evaluate_hello(h, config);
        EXPECT_TRUE(std::holds_alternative<protocol::Welcome>(answer));
        return std::get<protocol::Welcome>(answer).capabilities;
    };
    EXPECT_EQ(granted(defaults.options, hello), hello.capabilities);
    EXPECT_EQ(granted(parsed.options, hello),
              protocol::capability::kZstdPayloads | protocol::capability::kFoveaTiles);
    protocol::Hello periphery_client = hello;
    periphery_client.capabilities &= ~protocol::capability::kSwappedSplit;
    EXPECT_FALSE(granted(defaults.options, periphery_client) & protocol::capability::kSwappedSplit)
        << "granted only to a client that offers it";
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
