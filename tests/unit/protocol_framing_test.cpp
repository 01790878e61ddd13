// FrameDecoder: the receive side of the framing, fed from byte buffers (the transport feeds it
// whatever the socket returns).

#include "compression.h"
#include "wire.h"

#include <numeric>

#include <gtest/gtest.h>

namespace splitvk::protocol::testing {
void begin_allocation_probe(); // protocol_wire_test.cpp
size_t end_allocation_probe();
} // namespace splitvk::protocol::testing

namespace splitvk::protocol {
namespace {

using testing::begin_allocation_probe;
using testing::end_allocation_probe;

constexpr uint16_t kUnknownType = 0x7777;

std::vector<uint8_t> bytes_of(std::string_view text) {
    return std::vector<uint8_t>(text.begin(), text.end());
}

void append(std::vector<uint8_t> &stream, const std::vector<uint8_t> &frame) {
    stream.insert(stream.end(), frame.begin(), frame.end());
}

std::vector<uint8_t> compressible(size_t size) {
    std::vector<uint8_t> data(size);
    for (size_t i = 0; i < size; ++i)
        data[i] = static_cast<uint8_t>((i / 64) % 7);
    return data;
}

std::vector<uint8_t> compressed_frame(uint16_t type, uint64_t sequence, const std::vector<uint8_t> &raw) {
    std::vector<uint8_t> packed;
    EXPECT_TRUE(compress_if_pays(raw, CompressionPolicy{}, packed));
    return encode_frame(type, sequence, packed, kFlagCompressed);
}

struct Expected {
    uint16_t type;
    uint64_t sequence;
    std::vector<uint8_t> payload;
    bool compressed;
};

std::vector<uint8_t> sample_stream(std::vector<Expected> &expected) {
    std::vector<uint8_t> stream;
    const auto hello = bytes_of("hello payload");
    append(stream, encode_frame(to_wire(MessageType::Hello), 1, hello));
    expected.push_back({to_wire(MessageType::Hello), 1, hello, false});
    append(stream, encode_frame(to_wire(MessageType::Ping), 2, {}));
    expected.push_back({to_wire(MessageType::Ping), 2, {}, false});
    const auto big = compressible(20000);
    append(stream, compressed_frame(to_wire(MessageType::MemoryData), 3, big));
    expected.push_back({to_wire(MessageType::MemoryData), 3, big, true});
    const auto command = bytes_of("vkCmdDraw");
    append(stream, encode_frame(0x0123, 4, command));
    expected.push_back({0x0123, 4, command, false});
    return stream;
}

void expect_messages(const std::vector<Message> &got, const std::vector<Expected> &expected) {
    ASSERT_EQ(got.size(), expected.size());
    for (size_t i = 0; i < got.size(); ++i) {
        EXPECT_EQ(got[i].type, expected[i].type) << i;
        EXPECT_EQ(got[i].sequence, expected[i].sequence) << i;
        EXPECT_EQ(got[i].payload, expected[i].payload) << i;
        EXPECT_EQ(got[i].was_compressed, expected[i].compressed) << i;
    }
}

TEST(ProtocolFraming, WholeStream) {
    std::vector<Expected> expected;
    const auto stream = sample_stream(expected);
    FrameDecoder decoder;
    std::vector<Message> got;
    ASSERT_TRUE(decoder.feed(stream, got)) << decoder.error();
    expect_messages(got, expected);
    EXPECT_EQ(decoder.messages(), 4u);
    EXPECT_TRUE(decoder.at_message_boundary());
    EXPECT_EQ(decoder.stream_offset(), stream.size());
    EXPECT_LT(got[2].wire_payload_bytes, got[2].payload.size());
}

TEST(ProtocolFraming, AnySplitOfTheStream) {
    std::vector<Expected> expected;
    const auto stream = sample_stream(expected);
    const std::span<const uint8_t> all(stream);
    for (size_t cut = 0; cut <= stream.size(); ++cut) {
        FrameDecoder decoder;
        std::vector<Message> got;
        ASSERT_TRUE(decoder.feed(all.first(cut), got)) << cut << ": " << decoder.error();
        ASSERT_TRUE(decoder.feed(all.subspan(cut), got)) << cut << ": " << decoder.error();
        expect_messages(got, expected);
    }
    // And one byte at a time.
    FrameDecoder decoder;
    std::vector<Message> got;
    for (size_t i = 0; i < stream.size(); ++i)
        ASSERT_TRUE(decoder.feed(all.subspan(i, 1), got));
    expect_messages(got, expected);
}

TEST(ProtocolFraming, TruncatedStreamIsNotAtABoundary) {
    std::vector<Expected> expected;
    const auto stream = sample_stream(expected);
    FrameDecoder decoder;
    std::vector<Message> got;
    ASSERT_TRUE(decoder.feed(std::span<const uint8_t>(stream).first(stream.size() - 1), got));
    EXPECT_EQ(got.size(), 3u);
    EXPECT_FALSE(decoder.at_message_boundary());
}

TEST(ProtocolFraming, OversizeLengthRejectedOnTheHeaderAlone) {
    ReceivePolicy policy;
    policy.max_payload = 1000;
    {
        FrameDecoder decoder(policy);
        std::vector<Message> got;
        const auto frame = encode_frame(to_wire(MessageType::Ping), 1, std::vector<uint8_t>(1000));
        EXPECT_TRUE(decoder.feed(frame, got)) << decoder.error(); // exactly the cap is fine
        EXPECT_EQ(got.size(), 1u);
    }
    // Only the 16 header bytes are fed: the verdict must not wait for (or allocate) the payload.
    MessageHeader header{1001, to_wire(MessageType::Ping), 0, 1};
    const auto head = encode_header(header);
    FrameDecoder decoder(policy);
    std::vector<Message> got;
    EXPECT_FALSE(decoder.feed(head, got));
    EXPECT_EQ(decoder.error(),
              "message 1 (type 0x0005): payload length 1001 exceeds the limit 1000 at stream offset 0");

    // The default cap: a header claiming 4 GiB allocates nothing.
    header.payload_length = 0xFFFFFFFFu;
    begin_allocation_probe();
    FrameDecoder defaults;
    const bool fed = defaults.feed(encode_header(header), got);
    const size_t largest = end_allocation_probe();
    EXPECT_FALSE(fed);
    EXPECT_NE(defaults.error().find("exceeds the limit 67108864"), std::string::npos) << defaults.error();
    EXPECT_LT(largest, 64u * 1024);
}

TEST(ProtocolFraming, PayloadMemoryFollowsTheBytesThatArrive) {
    // A legal header claiming 60 MiB followed by 100 bytes: memory grows with the bytes, it is not
    // reserved from the claim.
    MessageHeader header{60u << 20, to_wire(MessageType::MemoryData), 0, 1};
    const auto head = encode_header(header);
    std::vector<uint8_t> stream(head.begin(), head.end());
    stream.resize(stream.size() + 100, 0xAA);
    begin_allocation_probe();
    FrameDecoder decoder;
    std::vector<Message> got;
    const bool fed = decoder.feed(stream, got);
    const size_t largest = end_allocation_probe();
    EXPECT_TRUE(fed);
    EXPECT_TRUE(got.empty());
    EXPECT_LE(largest, (1u << 20) + 4096);
}

TEST(ProtocolFraming, UnknownTypeSkippedWhenThePolicySaysSo) {
    std::vector<uint8_t> stream;
    append(stream, encode_frame(to_wire(MessageType::Hello), 1, bytes_of("a")));
    append(stream, encode_frame(kUnknownType, 2, std::vector<uint8_t>(3u << 20, 0x55))); // 3 MiB
    append(stream, compressed_frame(kUnknownType, 3, compressible(10000))); // compressed: skipped raw
    append(stream, encode_frame(to_wire(MessageType::Ping), 4, bytes_of("b")));

    ReceivePolicy policy;
    policy.unknown_types = UnknownTypePolicy::Skip;
    FrameDecoder decoder(policy);
    std::vector<Message> got;
    begin_allocation_probe();
    bool fed = true;
    for (size_t at = 0; at < stream.size() && fed; at += 64 * 1024) // as a socket would deliver it
        fed = decoder.feed(
            std::span<const uint8_t>(stream).subspan(at, std::min<size_t>(64 * 1024, stream.size() - at)),
            got);
    const size_t largest = end_allocation_probe();
    ASSERT_TRUE(fed) << decoder.error();
    ASSERT_EQ(got.size(), 2u);
    EXPECT_EQ(got[0].sequence, 1u);
    EXPECT_EQ(got[1].type, to_wire(MessageType::Ping));
    EXPECT_EQ(got[1].sequence, 4u); // skipped messages still count in the sequence
    EXPECT_EQ(decoder.skipped(), 2u);
    EXPECT_LT(largest, 1u << 20); // the 3 MiB payload was stepped over, never buffered

    // The default policy rejects it.
    FrameDecoder strict;
    got.clear();
    EXPECT_FALSE(strict.feed(stream, got));
    EXPECT_EQ(got.size(), 1u);
    EXPECT_EQ(strict.error(), "message 2 (type 0x7777): unknown message type at stream offset 17");
}

TEST(ProtocolFraming, ReceiverDefinesWhatItKnows) {
    ReceivePolicy policy;
    policy.is_known_type = [](uint16_t type) { return type != 0x0300; }; // a command this codec lacks
    FrameDecoder decoder(policy);
    std::vector<Message> got;
    EXPECT_TRUE(decoder.feed(encode_frame(0x0200, 1, {}), got));
    EXPECT_FALSE(decoder.feed(encode_frame(0x0300, 2, {}), got));
    EXPECT_NE(decoder.error().find("unknown message type"), std::string::npos);
}

TEST(ProtocolFraming, UnknownFlagsRejected) {
    for (const uint16_t flags : {uint16_t{0x0002}, uint16_t{0x8000}, uint16_t{0x0003}}) {
        FrameDecoder decoder;
        std::vector<Message> got;
        EXPECT_FALSE(decoder.feed(encode_frame(to_wire(MessageType::Ping), 1, bytes_of("x"), flags), got));
        EXPECT_TRUE(got.empty());
        char expected[32];
        std::snprintf(expected, sizeof(expected), "unknown flags 0x%04x", flags);
        EXPECT_NE(decoder.error().find(expected), std::string::npos) << decoder.error();
    }
}

TEST(ProtocolFraming, SequenceMustIncreaseByExactlyOne) {
    struct Case {
        std::vector<uint64_t> sequences;
        size_t delivered;
        const char *error;
    };
    const Case cases[] = {
        {{1, 2, 3}, 3, ""},
        {{0}, 0, "sequence 0 where 1 was expected"},
        {{2}, 0, "sequence 2 where 1 was expected"},
        {{1, 3}, 1, "sequence 3 where 2 was expected"},    // a gap
        {{1, 2, 2}, 2, "sequence 2 where 3 was expected"}, // a repeat
        {{1, 2, 1}, 2, "sequence 1 where 3 was expected"}, // going back
    };
    for (const Case &c : cases) {
        std::vector<uint8_t> stream;
        for (const uint64_t sequence : c.sequences)
            append(stream, encode_frame(to_wire(MessageType::Ping), sequence, {}));
        FrameDecoder decoder;
        std::vector<Message> got;
        const bool fed = decoder.feed(stream, got);
        EXPECT_EQ(got.size(), c.delivered);
        if (*c.error) {
            EXPECT_FALSE(fed);
            EXPECT_NE(decoder.error().find(c.error), std::string::npos) << decoder.error();
        } else {
            EXPECT_TRUE(fed) << decoder.error();
        }
    }
}

TEST(ProtocolFraming, TypeZeroRejected) {
    FrameDecoder decoder;
    std::vector<Message> got;
    EXPECT_FALSE(decoder.feed(encode_frame(0, 1, {}), got));
    EXPECT_NE(decoder.error().find("type 0 is not a valid message type"), std::string::npos);
}

TEST(ProtocolFraming, ErrorsAreSticky) {
    FrameDecoder decoder;
    std::vector<Message> got;
    EXPECT_FALSE(decoder.feed(encode_frame(to_wire(MessageType::Ping), 7, {}), got));
    const std::string first = decoder.error();
    EXPECT_FALSE(decoder.feed(encode_frame(to_wire(MessageType::Ping), 1, {}), got));
    EXPECT_TRUE(got.empty());
    EXPECT_EQ(decoder.error(), first);
}

TEST(ProtocolFraming, CheckHeaderVerdicts) {
    ReceivePolicy policy;
    std::string error;
    EXPECT_EQ(check_header({4, to_wire(MessageType::Ping), 0, 9}, 9, policy, error), HeaderVerdict::Accept);
    EXPECT_EQ(check_header({4, kUnknownType, 0, 9}, 9, policy, error), HeaderVerdict::Reject);
    policy.unknown_types = UnknownTypePolicy::Skip;
    EXPECT_EQ(check_header({4, kUnknownType, 0, 9}, 9, policy, error), HeaderVerdict::Skip);
    // Flags, length and sequence are checked even for a type that would be skipped.
    EXPECT_EQ(check_header({4, kUnknownType, 2, 9}, 9, policy, error), HeaderVerdict::Reject);
    EXPECT_EQ(check_header({policy.max_payload + 1, kUnknownType, 0, 9}, 9, policy, error),
              HeaderVerdict::Reject);
    EXPECT_EQ(check_header({4, kUnknownType, 0, 10}, 9, policy, error), HeaderVerdict::Reject);
}

TEST(ProtocolFraming, CompressedPayloadOverTheCapRejected) {
    // 20000 bytes compress to a few hundred: the wire length passes the cap, the content must not.
    ReceivePolicy policy;
    policy.max_payload = 10000;
    FrameDecoder decoder(policy);
    std::vector<Message> got;
    const auto frame = compressed_frame(to_wire(MessageType::MemoryData), 1, compressible(20000));
    ASSERT_LT(frame.size(), 10000u);
    EXPECT_FALSE(decoder.feed(frame, got));
    EXPECT_TRUE(got.empty());
    EXPECT_NE(decoder.error().find("declared content size 20000 exceeds the limit 10000"), std::string::npos)
        << decoder.error();
}

TEST(ProtocolFraming, CompressedFlagOnGarbageRejected) {
    FrameDecoder decoder;
    std::vector<Message> got;
    EXPECT_FALSE(decoder.feed(
        encode_frame(to_wire(MessageType::MemoryData), 1, bytes_of("not zstd at all"), kFlagCompressed),
        got));
    EXPECT_NE(decoder.error().find("zstd"), std::string::npos) << decoder.error();
    FrameDecoder empty;
    EXPECT_FALSE(empty.feed(encode_frame(to_wire(MessageType::MemoryData), 1, {}, kFlagCompressed), got));
}

} // namespace
} // namespace splitvk::protocol
