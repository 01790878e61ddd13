// Handshake messages: encoding, hostile input, and the server's and client's decisions.

#include "handshake.h"
#include "wire.h"

#include <gtest/gtest.h>

namespace splitvk::protocol {
namespace {

std::vector<uint8_t> bytes_of(std::string_view text) {
    return std::vector<uint8_t>(text.begin(), text.end());
}

Hello sample_hello() {
    Hello hello;
    hello.capabilities = 0b1011;
    hello.token = bytes_of("s3cret-token");
    hello.client_name = "vkcube";
    hello.client_gpu_name = "llvmpipe (LLVM 15.0.6, 256 bits)";
    hello.codec_fingerprint = 0x0123456789abcdefull;
    return hello;
}

TEST(ProtocolHandshake, HelloRoundTripAndLayout) {
    const Hello hello = sample_hello();
    const auto bytes = encode_hello(hello);
    // Frozen prefix: magic then version, little-endian.
    ASSERT_GE(bytes.size(), 8u);
    EXPECT_EQ(std::string(bytes.begin(), bytes.begin() + 4), "SPVK");
    EXPECT_EQ(load_le32(bytes.data() + 4), kProtocolVersion);
    EXPECT_EQ(kProtocolVersion, 0x00010001u);

    auto back = decode_hello(bytes);
    ASSERT_TRUE(back.ok()) << back.error();
    EXPECT_EQ(back->protocol_version, kProtocolVersion);
    EXPECT_EQ(back->capabilities, 0b1011u);
    EXPECT_EQ(back->token, hello.token);
    EXPECT_EQ(back->client_name, "vkcube");
    EXPECT_EQ(back->client_gpu_name, hello.client_gpu_name);
    EXPECT_EQ(back->codec_fingerprint, hello.codec_fingerprint);
}

TEST(ProtocolHandshake, WelcomeRejectGoodbyeRoundTrip) {
    Welcome welcome{
        kProtocolVersion, capability::kZstdPayloads, 0x1122334455667788ull, "NVIDIA H200", {1, 2, 3}};
    auto w = decode_welcome(encode_welcome(welcome));
    ASSERT_TRUE(w.ok()) << w.error();
    EXPECT_EQ(w->server_device, welcome.server_device);
    EXPECT_EQ(w->protocol_version, welcome.protocol_version);
    EXPECT_EQ(w->capabilities, welcome.capabilities);
    EXPECT_EQ(w->session_id, welcome.session_id);
    EXPECT_EQ(w->server_gpu_name, "NVIDIA H200");

    for (const auto reason :
         {RejectReason::VersionMismatch, RejectReason::BadToken, RejectReason::ServerFull,
          RejectReason::Malformed, RejectReason::NotAuthorised, RejectReason::DeviceMismatch}) {
        auto r = decode_reject(encode_reject(Reject{reason, "why"}));
        ASSERT_TRUE(r.ok()) << r.error();
        EXPECT_EQ(r->reason, reason);
        EXPECT_EQ(r->message, "why");
    }
    auto g = decode_goodbye(encode_goodbye(Goodbye{"app exiting"}));
    ASSERT_TRUE(g.ok());
    EXPECT_EQ(g->message, "app exiting");
}

TEST(ProtocolHandshake, RejectLayoutIsFrozen) {
    // u32 reason, u32 length, text: what every past and future version can read.
    const auto bytes = encode_reject(Reject{RejectReason::ServerFull, "full"});
    const std::vector<uint8_t> expected = {3, 0, 0, 0, 4, 0, 0, 0, 'f', 'u', 'l', 'l'};
    EXPECT_EQ(bytes, expected);
    // A newer server's unknown reason and extra fields still decode.
    std::vector<uint8_t> newer = {99, 0, 0, 0, 2, 0, 0, 0, 'o', 'k', 0xEE, 0xEE};
    auto r = decode_reject(newer);
    ASSERT_TRUE(r.ok()) << r.error();
    EXPECT_EQ(r->reason, RejectReason::Unspecified);
    EXPECT_EQ(r->message, "ok");
}

TEST(ProtocolHandshake, EncodersKeepTextOnOneLineAndCapped) {
    Hello hello = sample_hello();
    hello.client_name = "evil\nname\x1b[31m";
    hello.client_gpu_name = std::string(1000, 'g');
    auto back = decode_hello(encode_hello(hello));
    ASSERT_TRUE(back.ok()) << back.error();
    EXPECT_EQ(back->client_name, "evil?name?[31m");
    EXPECT_EQ(back->client_gpu_name.size(), kMaxNameBytes);
    auto reject =
        decode_reject(encode_reject(Reject{RejectReason::Malformed, std::string(2000, 'r') + "\n"}));
    ASSERT_TRUE(reject.ok());
    EXPECT_EQ(reject->message.size(), kMaxReasonBytes);
}

TEST(ProtocolHandshake, MalformedHellos) {
    const auto good = encode_hello(sample_hello());
    // Every truncation is an error, never a crash or a partial success.
    for (size_t cut = 0; cut < good.size(); ++cut) {
        const std::vector<uint8_t> prefix(good.begin(), good.begin() + static_cast<ptrdiff_t>(cut));
        auto result = decode_hello(prefix);
        ASSERT_FALSE(result.ok()) << "cut " << cut;
        EXPECT_EQ(result.error().rfind("malformed Hello: ", 0), 0u) << result.error();
    }
    {
        auto bad = good;
        bad[0] = 'X';
        auto result = decode_hello(bad);
        ASSERT_FALSE(result.ok());
        EXPECT_EQ(result.error(), "malformed Hello: bad magic (not a splitvk client)");
    }
    {
        auto trailing = good;
        trailing.push_back(0);
        auto result = decode_hello(trailing);
        ASSERT_FALSE(result.ok());
        EXPECT_NE(result.error().find("unexpected bytes after the Hello"), std::string::npos)
            << result.error();
    }
    {
        // Token over the cap (the encoder writes tokens as given).
        Hello hello = sample_hello();
        hello.token.assign(kMaxTokenBytes + 1, 'x');
        auto result = decode_hello(encode_hello(hello));
        ASSERT_FALSE(result.ok());
        EXPECT_NE(result.error().find("token count 257"), std::string::npos) << result.error();
        hello.token.assign(kMaxTokenBytes, 'x');
        EXPECT_TRUE(decode_hello(encode_hello(hello)).ok());
    }
    {
        // A control character written by a hand-made (non-splitvk) encoder.
        WireWriter w;
        w.bytes(kHelloMagic);
        w.u32(kProtocolVersion);
        w.u64(0);
        w.blob({});
        w.string("line\nbreak");
        w.string("gpu");
        auto result = decode_hello(w.data());
        ASSERT_FALSE(result.ok());
        EXPECT_NE(result.error().find("client_name holds control characters"), std::string::npos)
            << result.error();
    }
}

TEST(ProtocolHandshake, NewerMinorMayAppendFields) {
    WireWriter w;
    w.bytes(kHelloMagic);
    w.u32(make_protocol_version(kProtocolMajor, kProtocolMinor + 1));
    w.u64(1);
    w.blob({});
    w.string("app");
    w.string("gpu");
    w.u64(0);                           // codec_fingerprint
    w.blob(std::vector<uint8_t>{7, 7}); // device_envelope (minor 1)
    w.u64(0xFEEDu);                     // a field this version does not know
    auto result = decode_hello(w.data());
    ASSERT_TRUE(result.ok()) << result.error();
    EXPECT_EQ(result->client_gpu_name, "gpu");
    EXPECT_EQ(result->device_envelope, (std::vector<uint8_t>{7, 7}));
    auto decision = evaluate_hello(*result, ServerHandshakeConfig{});
    EXPECT_TRUE(std::holds_alternative<Welcome>(decision));
}

// A client of protocol 1.0 sends no device envelope: its Hello still decodes, unchecked, and a
// Welcome for it decodes without the agent's device.
TEST(ProtocolHandshake, MinorZeroPeersHaveNoEnvelope) {
    WireWriter w;
    w.bytes(kHelloMagic);
    w.u32(make_protocol_version(kProtocolMajor, 0));
    w.u64(1);
    w.blob({});
    w.string("app");
    w.string("gpu");
    w.u64(0);
    auto hello = decode_hello(w.data());
    ASSERT_TRUE(hello.ok()) << hello.error();
    EXPECT_TRUE(hello->device_envelope.empty());
    ServerHandshakeConfig config;
    config.check_envelope = [](std::span<const uint8_t>) { return std::string("never asked"); };
    EXPECT_TRUE(std::holds_alternative<Welcome>(evaluate_hello(*hello, config)));

    WireWriter welcome;
    welcome.u32(make_protocol_version(kProtocolMajor, 0));
    welcome.u64(0);
    welcome.u64(9);
    welcome.string("gpu");
    auto decoded = decode_welcome(welcome.data());
    ASSERT_TRUE(decoded.ok()) << decoded.error();
    EXPECT_TRUE(decoded->server_device.empty());
}

// An agent that cannot honour the envelope refuses with DeviceMismatch and says why.
TEST(ProtocolHandshake, EnvelopeTheServerCannotHonourIsRefused) {
    Hello hello = sample_hello();
    hello.device_envelope = {1, 2, 3};
    ServerHandshakeConfig config;
    config.check_envelope = [](std::span<const uint8_t> blob) {
        return blob.size() == 3 ? std::string("maxImageDimension2D: told 8192, this device 4096")
                                : std::string();
    };
    const auto decision = evaluate_hello(hello, config);
    const Reject *reject = std::get_if<Reject>(&decision);
    ASSERT_NE(reject, nullptr);
    EXPECT_EQ(reject->reason, RejectReason::DeviceMismatch);
    EXPECT_EQ(reject->message, "maxImageDimension2D: told 8192, this device 4096");
    auto back = decode_hello(encode_hello(hello));
    ASSERT_TRUE(back.ok()) << back.error();
    EXPECT_EQ(back->device_envelope, hello.device_envelope);
}

TEST(ProtocolHandshake, VersionMismatchIsRejectedAsSuch) {
    // A major-2 client: whatever follows its version is not ours to parse.
    WireWriter w;
    w.bytes(kHelloMagic);
    w.u32(make_protocol_version(kProtocolMajor + 1, 3));
    w.string("a layout this server cannot know");
    auto hello = decode_hello(w.data());
    ASSERT_TRUE(hello.ok()) << hello.error();
    EXPECT_EQ(protocol_major(hello->protocol_version), kProtocolMajor + 1);
    const auto decision = evaluate_hello(*hello, ServerHandshakeConfig{});
    const Reject *reject = std::get_if<Reject>(&decision);
    ASSERT_NE(reject, nullptr);
    EXPECT_EQ(reject->reason, RejectReason::VersionMismatch);
    EXPECT_EQ(reject->message, "client speaks protocol 2.3, this server 1.1 (the major version must match)");

    // Older major too (0.x).
    Hello old = sample_hello();
    old.protocol_version = make_protocol_version(0, 9);
    EXPECT_EQ(std::get<Reject>(evaluate_hello(old, {})).reason, RejectReason::VersionMismatch);

    // The client refuses a Welcome from another major.
    Welcome welcome;
    welcome.protocol_version = make_protocol_version(kProtocolMajor + 1, 0);
    EXPECT_FALSE(decode_welcome(encode_welcome(welcome)).ok());
    EXPECT_NE(check_welcome(sample_hello(), welcome), "");
    // A different minor is fine.
    welcome.protocol_version = make_protocol_version(kProtocolMajor, kProtocolMinor + 4);
    welcome.capabilities = 0;
    EXPECT_EQ(check_welcome(sample_hello(), welcome), "");
}

TEST(ProtocolHandshake, Tokens) {
    ServerHandshakeConfig config;
    config.token = bytes_of("s3cret-token");
    config.session_id = 77;
    config.server_gpu_name = "gpu0";

    Hello hello = sample_hello();
    const auto accepted = evaluate_hello(hello, config);
    ASSERT_TRUE(std::holds_alternative<Welcome>(accepted));
    EXPECT_EQ(std::get<Welcome>(accepted).session_id, 77u);
    EXPECT_EQ(std::get<Welcome>(accepted).server_gpu_name, "gpu0");

    for (const char *wrong : {"s3cret-tokeN", "S3cret-token", "s3cret-toke", "s3cret-token!", "x"}) {
        hello.token = bytes_of(wrong);
        const auto decision = evaluate_hello(hello, config);
        ASSERT_TRUE(std::holds_alternative<Reject>(decision)) << wrong;
        EXPECT_EQ(std::get<Reject>(decision).reason, RejectReason::BadToken) << wrong;
    }
    hello.token.clear();
    EXPECT_EQ(std::get<Reject>(evaluate_hello(hello, config)).reason, RejectReason::NotAuthorised);

    // A server without a token accepts any client.
    EXPECT_TRUE(std::holds_alternative<Welcome>(evaluate_hello(hello, ServerHandshakeConfig{})));
}

TEST(ProtocolHandshake, ServerFull) {
    ServerHandshakeConfig config;
    config.full = true;
    EXPECT_EQ(std::get<Reject>(evaluate_hello(sample_hello(), config)).reason, RejectReason::ServerFull);
}

TEST(ProtocolHandshake, CodecFingerprintMustMatch) {
    ServerHandshakeConfig config;
    config.codec_fingerprint = sample_hello().codec_fingerprint;
    EXPECT_TRUE(std::holds_alternative<Welcome>(evaluate_hello(sample_hello(), config)));
    config.codec_fingerprint ^= 1;
    const auto verdict = evaluate_hello(sample_hello(), config);
    ASSERT_TRUE(std::holds_alternative<Reject>(verdict));
    EXPECT_EQ(std::get<Reject>(verdict).reason, RejectReason::VersionMismatch);
}

// A peer built before the metadata layout changed sends the codec's fingerprint alone (or mixes in
// an older kMetadataLayout): the server, which compares session_fingerprint, refuses it at the
// handshake rather than misread its SwapchainView or Tiles mid-session.
TEST(ProtocolHandshake, MetadataLayoutIsPartOfTheFingerprint) {
    const uint64_t codec = sample_hello().codec_fingerprint;
    ServerHandshakeConfig config;
    config.codec_fingerprint = session_fingerprint(codec);
    EXPECT_NE(session_fingerprint(codec), codec);
    Hello hello = sample_hello();
    hello.codec_fingerprint = session_fingerprint(codec);
    EXPECT_TRUE(std::holds_alternative<Welcome>(evaluate_hello(hello, config)));
    hello.codec_fingerprint = codec; // a peer that does not mix the layout in
    const auto verdict = evaluate_hello(hello, config);
    ASSERT_TRUE(std::holds_alternative<Reject>(verdict));
    EXPECT_EQ(std::get<Reject>(verdict).reason, RejectReason::VersionMismatch);
    EXPECT_NE(std::get<Reject>(verdict).message.find("message layouts"), std::string::npos)
        << std::get<Reject>(verdict).message;
}

TEST(ProtocolHandshake, CapabilitiesAreTheIntersection) {
    ServerHandshakeConfig config;
    config.capabilities = 0b0110;
    Hello hello = sample_hello(); // 0b1011
    const Welcome welcome = std::get<Welcome>(evaluate_hello(hello, config));
    EXPECT_EQ(welcome.capabilities, 0b0010u);
    EXPECT_EQ(check_welcome(hello, welcome), "");
    Welcome greedy = welcome;
    greedy.capabilities = 0b0100; // not offered by the client
    EXPECT_EQ(check_welcome(hello, greedy), "server granted capabilities 0x4 that were not offered");
}

TEST(ProtocolHandshake, ConstantTimeEqualIsCorrect) {
    EXPECT_TRUE(constant_time_equal(std::string_view(""), std::string_view("")));
    EXPECT_TRUE(constant_time_equal(std::string_view("abc"), std::string_view("abc")));
    EXPECT_FALSE(constant_time_equal(std::string_view(""), std::string_view("a")));
    EXPECT_FALSE(constant_time_equal(std::string_view("a"), std::string_view("")));
    EXPECT_FALSE(constant_time_equal(std::string_view("abc"), std::string_view("abcd"))); // prefix
    EXPECT_FALSE(constant_time_equal(std::string_view("abcd"), std::string_view("abc")));
    // A shorter input must not compare equal by padding with zeros.
    const std::vector<uint8_t> with_zero = {'a', 0};
    const std::vector<uint8_t> without = {'a'};
    EXPECT_FALSE(constant_time_equal(with_zero, without));
    // A difference in any single bit at any position is found.
    const std::vector<uint8_t> base = bytes_of("0123456789abcdef0123456789abcdef");
    for (size_t i = 0; i < base.size(); ++i) {
        for (int bit = 0; bit < 8; ++bit) {
            auto other = base;
            other[i] = static_cast<uint8_t>(other[i] ^ (1 << bit));
            EXPECT_FALSE(constant_time_equal(base, other)) << i << ":" << bit;
        }
    }
    EXPECT_TRUE(constant_time_equal(base, base));
}

TEST(ProtocolHandshake, MalformedWelcomeAndReject) {
    const auto welcome = encode_welcome(Welcome{kProtocolVersion, 1, 2, "gpu", {}});
    for (size_t cut = 0; cut < welcome.size(); ++cut)
        EXPECT_FALSE(decode_welcome(std::span<const uint8_t>(welcome).first(cut)).ok()) << cut;
    const auto reject = encode_reject(Reject{RejectReason::BadToken, "no"});
    for (size_t cut = 0; cut < reject.size(); ++cut)
        EXPECT_FALSE(decode_reject(std::span<const uint8_t>(reject).first(cut)).ok()) << cut;
}

} // namespace
} // namespace splitvk::protocol
