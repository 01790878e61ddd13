// TLS 1.3 on the link: identities, the transport over TLS on real loopback sockets, the
// client's refusals (a pin that does not match, an expired certificate) as one line on each side,
// the agent's sniffing of plaintext, and the known_agents file.

#include "handshake.h"
#include "known_agents.h"
#include "settings.h"
#include "tls.h"
#include "transport.h"

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <future>
#include <thread>

#include <gtest/gtest.h>
#include <sys/socket.h>
#include <unistd.h>

namespace splitvk::protocol {
namespace {

using namespace std::chrono_literals;

TlsIdentity make_identity(std::chrono::seconds from = -1h, std::chrono::seconds until = 24h) {
    auto identity = generate_tls_identity("splitvk-agent test", from, until);
    EXPECT_TRUE(identity.ok()) << identity.error();
    return identity ? std::move(identity).value() : TlsIdentity{};
}

struct TlsOutcome {
    Result<std::unique_ptr<Connection>> client = Error{"not run"};
    Result<std::unique_ptr<Connection>> server = Error{"not run"};
};

// A client connect() and a server adopt() running at once, as they must for a handshake.
TlsOutcome connect_pair(const TlsIdentity &identity, TlsContext::Verifier verify) {
    TlsOutcome outcome;
    auto acceptor = Acceptor::listen("127.0.0.1", 0);
    EXPECT_TRUE(acceptor.ok()) << acceptor.error();
    if (!acceptor) return outcome;
    auto server_context = TlsContext::server(identity);
    EXPECT_TRUE(server_context.ok()) << server_context.error();
    if (!server_context) return outcome;
    auto server = std::async(std::launch::async, [&]() -> Result<std::unique_ptr<Connection>> {
        auto fd = (*acceptor)->accept(5s);
        if (!fd || !*fd) return Error{"no connection"};
        ConnectionOptions options;
        options.name = "server";
        options.tls = server_context.value();
        options.tls_handshake_timeout = 3s;
        return Connection::adopt(std::move(fd).value(), options);
    });
    ConnectionOptions options;
    options.name = "client";
    auto context = TlsContext::client(std::move(verify));
    EXPECT_TRUE(context.ok()) << context.error();
    if (!context) return outcome;
    options.tls = context.value();
    options.tls_handshake_timeout = 3s;
    outcome.client = Connection::connect("127.0.0.1", (*acceptor)->port(), 2s, options);
    outcome.server = server.get();
    return outcome;
}

TEST(Tls, GeneratedIdentityHasASha256FingerprintAndMatchingKey) {
    const TlsIdentity identity = make_identity();
    auto info = check_identity(identity);
    ASSERT_TRUE(info.ok()) << info.error();
    EXPECT_EQ(info->fingerprint.size(), 7u + 64u);
    EXPECT_EQ(normalize_fingerprint(info->fingerprint), info->fingerprint);
    EXPECT_NE(info->subject.find("splitvk-agent test"), std::string::npos);
    EXPECT_TRUE(validity_problem(*info, static_cast<int64_t>(std::time(nullptr))).empty());
    // Another key's certificate is not this key's.
    TlsIdentity mixed = make_identity();
    mixed.private_key_pem = identity.private_key_pem;
    EXPECT_FALSE(check_identity(mixed).ok());
    EXPECT_FALSE(TlsContext::server(mixed).ok());
}

TEST(Tls, FingerprintsAreNormalised) {
    const std::string hex(64, 'a');
    EXPECT_EQ(normalize_fingerprint("sha256:" + hex), "sha256:" + hex);
    EXPECT_EQ(normalize_fingerprint("SHA256:" + std::string(64, 'A')), "sha256:" + hex);
    std::string colons;
    for (int i = 0; i < 32; ++i)
        colons += std::string(i ? ":" : "") + "AA";
    EXPECT_EQ(normalize_fingerprint(colons), "sha256:" + hex);
    EXPECT_FALSE(normalize_fingerprint("sha256:" + std::string(63, 'a')));
    EXPECT_FALSE(normalize_fingerprint("sha256:" + std::string(63, 'a') + "g"));
    EXPECT_FALSE(normalize_fingerprint(""));
}

TEST(Tls, SessionIsTls13BothWaysWithLargeMessages) {
    const TlsIdentity identity = make_identity();
    const std::string expected = check_identity(identity)->fingerprint;
    std::string seen;
    auto pair = connect_pair(identity, [&](const CertificateInfo &cert) {
        seen = cert.fingerprint;
        return std::string();
    });
    ASSERT_TRUE(pair.client.ok()) << pair.client.error();
    ASSERT_TRUE(pair.server.ok()) << pair.server.error();
    EXPECT_EQ(seen, expected);
    auto &client = *pair.client.value();
    auto &server = *pair.server.value();
    EXPECT_TRUE(client.security().starts_with("TLS 1.3 (")) << client.security();
    EXPECT_TRUE(server.security().starts_with("TLS 1.3 (")) << server.security();
    client.start([](const std::string &) {});
    server.start([](const std::string &) {});
    // Many small messages (gathered into one staged write) and ones over the staging size.
    std::vector<uint8_t> big(3u << 20);
    for (size_t i = 0; i < big.size(); ++i)
        big[i] = static_cast<uint8_t>(i * 7 + (i >> 13));
    for (int i = 0; i < 200; ++i)
        ASSERT_EQ(client.send(MessageType::Ping, std::vector<uint8_t>{static_cast<uint8_t>(i)}),
                  SendResult::Queued);
    ASSERT_EQ(client.send(MessageType::MemoryData, big), SendResult::Queued);
    ASSERT_EQ(server.send(MessageType::Tiles, big), SendResult::Queued);
    for (int i = 0; i < 200; ++i) {
        auto m = server.receive(5s);
        ASSERT_TRUE(m) << server.close_reason();
        ASSERT_EQ(m->payload, std::vector<uint8_t>{static_cast<uint8_t>(i)});
    }
    auto m = server.receive(5s);
    ASSERT_TRUE(m) << server.close_reason();
    EXPECT_EQ(m->payload, big);
    auto t = client.receive(5s);
    ASSERT_TRUE(t) << client.close_reason();
    EXPECT_EQ(t->payload, big);
    // A TLS peer that closes its socket is "peer closed the connection", as in plaintext.
    client.close();
    const auto deadline = std::chrono::steady_clock::now() + 5s;
    while (server.is_open() && std::chrono::steady_clock::now() < deadline)
        std::this_thread::sleep_for(10ms);
    EXPECT_EQ(server.close_reason(), "peer closed the connection");
}

TEST(Tls, ARefusedCertificateIsOneLineOnEachSide) {
    auto pair = connect_pair(make_identity(), [](const CertificateInfo &cert) {
        return "the agent's certificate changed: it is now " + cert.fingerprint;
    });
    ASSERT_FALSE(pair.client.ok());
    EXPECT_TRUE(pair.client.error().starts_with("the agent's certificate changed: it is now sha256:"))
        << pair.client.error();
    ASSERT_FALSE(pair.server.ok());
    EXPECT_NE(pair.server.error().find("the client refused this agent's certificate"), std::string::npos)
        << pair.server.error();
    EXPECT_EQ(pair.server.error().find('\n'), std::string::npos);
}

TEST(Tls, AnExpiredCertificateIsRefusedEvenWhenAccepted) {
    bool asked = false;
    auto pair = connect_pair(make_identity(-48h, -24h), [&](const CertificateInfo &) {
        asked = true;
        return std::string();
    });
    EXPECT_FALSE(asked) << "an expired certificate must be refused before any pin is consulted";
    ASSERT_FALSE(pair.client.ok());
    EXPECT_TRUE(pair.client.error().starts_with("the agent's certificate expired on "))
        << pair.client.error();
    ASSERT_FALSE(pair.server.ok());
    EXPECT_NE(pair.server.error().find("refused this agent's certificate: it has expired"), std::string::npos)
        << pair.server.error();
}

TEST(Tls, FirstBytesTellTlsFromAPlaintextHello) {
    // A plaintext Hello header: payload length 22 (0x16, as a TLS handshake record starts), type 1.
    const uint8_t hello[6] = {0x16, 0x03, 0x00, 0x00, 0x01, 0x00};
    EXPECT_EQ(classify_first_bytes(hello), FirstBytes::Plain);
    const uint8_t client_hello[6] = {0x16, 0x03, 0x01, 0x02, 0x00, 0x01};
    EXPECT_EQ(classify_first_bytes(client_hello), FirstBytes::Tls);

    int fds[2];
    ASSERT_EQ(::socketpair(AF_UNIX, SOCK_STREAM, 0, fds), 0);
    ASSERT_EQ(::write(fds[0], client_hello, 3), 3);
    auto partial = sniff_first_bytes(fds[1], 100ms);
    EXPECT_FALSE(partial.ok()); // three bytes are not a greeting
    ASSERT_EQ(::write(fds[0], client_hello + 3, 3), 3);
    auto full = sniff_first_bytes(fds[1], 1s);
    ASSERT_TRUE(full.ok()) << full.error();
    EXPECT_EQ(*full, FirstBytes::Tls);
    uint8_t still[6];
    EXPECT_EQ(::read(fds[1], still, 6), 6) << "sniffing must not consume the bytes";
    ::close(fds[0]);
    auto closed = sniff_first_bytes(fds[1], 1s);
    EXPECT_FALSE(closed.ok());
    ::close(fds[1]);
}

TEST(Tls, RequireTlsRefusesEveryHelloBeforeItsToken) {
    ServerHandshakeConfig config;
    config.token = {'t'};
    config.require_tls = "use TLS";
    Hello hello;
    hello.token = {'t'};
    auto decision = evaluate_hello(hello, config);
    ASSERT_TRUE(std::holds_alternative<Reject>(decision));
    EXPECT_EQ(std::get<Reject>(decision).reason, RejectReason::TlsRequired);
    auto round = decode_reject(encode_reject(std::get<Reject>(decision)));
    ASSERT_TRUE(round.ok());
    EXPECT_EQ(round->reason, RejectReason::TlsRequired);
    EXPECT_STREQ(to_string(RejectReason::TlsRequired), "TLS required");
}

TEST(KnownAgents, ParsesEntriesAndReportsBadLines) {
    const std::string a(64, 'a');
    const std::string text = "# agents\n\n10.0.0.2:7447 sha256:" + a +
                             "\n[fe80::1]:7447   SHA256:" + std::string(64, 'B') +
                             "  \nbroken\n10.0.0.3:0 sha256:" + a +
                             "\n10.0.0.4:1 sha256:xyz\n10.0.0.2:7447 sha256:" + std::string(64, 'c');
    const KnownAgents known = parse_known_agents(text, "KA");
    ASSERT_EQ(known.entries.size(), 3u);
    EXPECT_EQ(known.entries[0].address, "10.0.0.2:7447");
    EXPECT_EQ(known.entries[0].line, 3);
    EXPECT_EQ(known.entries[1].fingerprint, "sha256:" + std::string(64, 'b'));
    ASSERT_EQ(known.problems.size(), 3u);
    EXPECT_TRUE(known.problems[0].starts_with("KA:5: ")) << known.problems[0];
    const KnownAgent *found = find_known_agent(known, "10.0.0.2:7447");
    ASSERT_NE(found, nullptr);
    EXPECT_EQ(found->line, 3) << "the first entry for an address decides";
    EXPECT_EQ(find_known_agent(known, "10.0.0.9:7447"), nullptr);
}

TEST(KnownAgents, PathFollowsXdgAndAppendCreatesThePrivateFile) {
    EXPECT_EQ(known_agents_path("/x", "/h"), "/x/splitvk/known_agents");
    EXPECT_EQ(known_agents_path("relative", "/h"), "/h/.config/splitvk/known_agents");
    EXPECT_EQ(known_agents_path(nullptr, nullptr), "");
    const auto dir = std::filesystem::temp_directory_path() / ("splitvk-known-" + std::to_string(::getpid()));
    std::filesystem::remove_all(dir);
    const std::string path = (dir / "splitvk" / "known_agents").string();
    EXPECT_EQ(append_known_agent(path, "10.0.0.2:7447", "sha256:" + std::string(64, 'a')), "");
    EXPECT_EQ(append_known_agent(path, "10.0.0.3:7447", "sha256:" + std::string(64, 'b')), "");
    std::ifstream in(path);
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const KnownAgents known = parse_known_agents(text, path);
    EXPECT_EQ(known.entries.size(), 2u);
    EXPECT_TRUE(known.problems.empty());
    EXPECT_EQ(std::filesystem::status(path).permissions() & std::filesystem::perms::all,
              std::filesystem::perms::owner_read | std::filesystem::perms::owner_write);
    std::filesystem::remove_all(dir);
}

TEST(TlsSettings, AutoIsOnForEveryAddressButLoopback) {
    Settings s;
    for (const char *host : {"127.0.0.1", "127.9.9.9", "::1", "localhost", "::ffff:127.0.0.1"}) {
        s.server.host = host;
        EXPECT_FALSE(s.use_tls()) << host;
    }
    for (const char *host : {"10.0.0.2", "192.168.1.1", "fe80::1", "agent.lan", "127.0.0.1.nip.io"}) {
        s.server.host = host;
        EXPECT_TRUE(s.use_tls()) << host;
    }
    s.tls = TlsMode::Off;
    EXPECT_FALSE(s.use_tls());
    s.server.host = "127.0.0.1";
    s.tls = TlsMode::On;
    EXPECT_TRUE(s.use_tls());
}

} // namespace
} // namespace splitvk::protocol
