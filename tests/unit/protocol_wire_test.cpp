// Wire primitives: the header layout, WireReader / WireWriter round trips, and the reader's
// sticky, bounds-checked behaviour on hostile input.

#include "wire.h"

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <new>

#include <gtest/gtest.h>

// --- allocation probe -------------------------------------------------------------------------
// Replaces the global operator new for this test binary so tests can assert that a hostile
// length is rejected *before* anything of that size is allocated. Declared in the other
// protocol_*_test.cpp files that use it.
// The replacement pairs malloc with free by design; GCC cannot see that through the inlining.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
namespace {
std::atomic<bool> g_probe_active{false};
std::atomic<size_t> g_probe_largest{0};
} // namespace

void *operator new(size_t size) {
    if (g_probe_active.load(std::memory_order_relaxed)) {
        size_t seen = g_probe_largest.load(std::memory_order_relaxed);
        while (size > seen && !g_probe_largest.compare_exchange_weak(seen, size)) {
        }
    }
    if (void *p = std::malloc(size ? size : 1)) return p;
    throw std::bad_alloc();
}
void operator delete(void *p) noexcept {
    std::free(p);
}
void operator delete(void *p, size_t) noexcept {
    std::free(p);
}

namespace splitvk::protocol::testing {
void begin_allocation_probe() {
    g_probe_largest.store(0);
    g_probe_active.store(true);
}
size_t end_allocation_probe() {
    g_probe_active.store(false);
    return g_probe_largest.load();
}
} // namespace splitvk::protocol::testing

namespace splitvk::protocol {
namespace {

using testing::begin_allocation_probe;
using testing::end_allocation_probe;

TEST(ProtocolWire, HeaderIsLittleEndianAndRoundTrips) {
    MessageHeader header;
    header.payload_length = 0x04030201;
    header.type = 0x0605;
    header.flags = kFlagCompressed;
    header.sequence = 0x0F0E0D0C0B0A0908ull;
    const auto bytes = encode_header(header);
    const std::array<uint8_t, kHeaderSize> expected = {0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x01, 0x00,
                                                       0x08, 0x09, 0x0A, 0x0B, 0x0C, 0x0D, 0x0E, 0x0F};
    EXPECT_EQ(bytes, expected);
    EXPECT_EQ(decode_header(bytes), header);
    EXPECT_TRUE(decode_header(bytes).compressed());

    MessageHeader extremes{0xFFFFFFFFu, 0xFFFF, 0xFFFF, ~0ull};
    EXPECT_EQ(decode_header(encode_header(extremes)), extremes);
}

TEST(ProtocolWire, EncodeFrameIsHeaderPlusPayload) {
    const std::vector<uint8_t> payload = {9, 8, 7};
    const auto frame = encode_frame(to_wire(MessageType::Ping), 5, payload);
    ASSERT_EQ(frame.size(), kHeaderSize + 3);
    const auto header = decode_header(std::span<const uint8_t, kHeaderSize>(frame.data(), kHeaderSize));
    EXPECT_EQ(header.payload_length, 3u);
    EXPECT_EQ(header.type, to_wire(MessageType::Ping));
    EXPECT_EQ(header.flags, 0);
    EXPECT_EQ(header.sequence, 5u);
    EXPECT_EQ(bytes_to_skip(header), 3u);
    EXPECT_EQ(std::vector<uint8_t>(frame.begin() + kHeaderSize, frame.end()), payload);
}

TEST(ProtocolWire, TypeRanges) {
    EXPECT_EQ(message_class(0), MessageClass::Invalid);
    EXPECT_EQ(message_class(to_wire(MessageType::Hello)), MessageClass::Control);
    EXPECT_EQ(message_class(0x00FF), MessageClass::Control);
    EXPECT_EQ(message_class(0x0100), MessageClass::Vulkan);
    EXPECT_EQ(message_class(0x0FFF), MessageClass::Vulkan);
    EXPECT_EQ(message_class(0x1000), MessageClass::Metadata);
    EXPECT_EQ(message_class(to_wire(MessageType::Tiles)), MessageClass::Metadata);
    EXPECT_TRUE(is_defined_type(to_wire(MessageType::Welcome)));
    EXPECT_TRUE(is_defined_type(to_wire(MessageType::FramePresent)));
    EXPECT_TRUE(is_defined_type(0x0234)); // the codec's range
    EXPECT_FALSE(is_defined_type(0));
    EXPECT_FALSE(is_defined_type(0x00FE));
    EXPECT_FALSE(is_defined_type(0x7777));
    EXPECT_STREQ(message_type_name(to_wire(MessageType::MemoryData)), "MemoryData");
    EXPECT_TRUE(is_defined_type(to_wire(MessageType::ImageLayouts)));
    EXPECT_TRUE(is_defined_type(to_wire(MessageType::SwapchainView)));
    EXPECT_TRUE(is_defined_type(to_wire(MessageType::BufferAddress)));
    EXPECT_TRUE(is_defined_type(to_wire(MessageType::PeripheryConfig)));
    EXPECT_FALSE(is_defined_type(to_wire(MessageType::PeripheryConfig) + 1));
    EXPECT_STREQ(message_type_name(to_wire(MessageType::BufferAddress)), "BufferAddress");
    EXPECT_STREQ(message_type_name(to_wire(MessageType::ImageLayouts)), "ImageLayouts");
    EXPECT_STREQ(message_type_name(0x0200), "Vulkan command");
    EXPECT_STREQ(message_type_name(0x7777), "unknown");
}

// One of everything, written and read back in the same order.
struct Sample {
    uint8_t a = 0xAB;
    uint16_t b = 0xBEEF;
    uint32_t c = 0xDEADBEEF;
    uint64_t d = 0x0123456789ABCDEFull;
    int32_t e = std::numeric_limits<int32_t>::min();
    int64_t f = -1234567890123ll;
    float g = -0.0f;
    double h = std::numeric_limits<double>::denorm_min();
    float i = std::numeric_limits<float>::infinity();
    std::vector<uint8_t> blob = {0, 1, 2, 255};
    std::string text = "splitvk \xC3\xA9";
    std::vector<uint32_t> words = {1, 0xFFFFFFFFu, 7};
    std::vector<double> doubles = {1.5, -2.25};
    std::vector<int16_t> shorts = {-1, 2};
    std::string empty;
};

std::vector<uint8_t> write_sample(const Sample &s) {
    WireWriter w;
    w.u8(s.a);
    w.u16(s.b);
    w.u32(s.c);
    w.u64(s.d);
    w.i32(s.e);
    w.i64(s.f);
    w.f32(s.g);
    w.f64(s.h);
    w.f32(s.i);
    w.blob(s.blob);
    w.string(s.text);
    w.array<uint32_t>(s.words);
    w.array<double>(s.doubles);
    w.array<int16_t>(s.shorts);
    w.string(s.empty);
    EXPECT_TRUE(w.ok());
    return w.take();
}

Sample read_sample(WireReader &r) {
    Sample s;
    s.a = r.u8("a");
    s.b = r.u16("b");
    s.c = r.u32("c");
    s.d = r.u64("d");
    s.e = r.i32("e");
    s.f = r.i64("f");
    s.g = r.f32("g");
    s.h = r.f64("h");
    s.i = r.f32("i");
    const auto blob = r.blob(16, "blob");
    s.blob.assign(blob.begin(), blob.end());
    s.text = r.string(64, "text");
    s.words = r.array<uint32_t>(8, "words");
    s.doubles = r.array<double>(8, "doubles");
    s.shorts = r.array<int16_t>(8, "shorts");
    s.empty = r.string(8, "empty");
    return s;
}

TEST(ProtocolWire, PrimitivesRoundTrip) {
    const Sample original;
    const auto bytes = write_sample(original);
    WireReader r(bytes);
    const Sample back = read_sample(r);
    ASSERT_TRUE(r.ok()) << r.error();
    EXPECT_TRUE(r.expect_end());
    EXPECT_EQ(back.a, original.a);
    EXPECT_EQ(back.b, original.b);
    EXPECT_EQ(back.c, original.c);
    EXPECT_EQ(back.d, original.d);
    EXPECT_EQ(back.e, original.e);
    EXPECT_EQ(back.f, original.f);
    EXPECT_TRUE(std::signbit(back.g)); // -0.0 keeps its sign bit
    EXPECT_EQ(back.h, original.h);
    EXPECT_TRUE(std::isinf(back.i));
    EXPECT_EQ(back.blob, original.blob);
    EXPECT_EQ(back.text, original.text);
    EXPECT_EQ(back.words, original.words);
    EXPECT_EQ(back.doubles, original.doubles);
    EXPECT_EQ(back.shorts, original.shorts);
    EXPECT_EQ(back.empty, "");
}

TEST(ProtocolWire, ExactEncodings) {
    WireWriter w;
    w.u32(0x11223344);
    w.f32(1.0f);
    w.string("hi");
    const std::vector<uint8_t> expected = {0x44, 0x33, 0x22, 0x11, 0x00, 0x00, 0x80,
                                           0x3F, 0x02, 0x00, 0x00, 0x00, 'h',  'i'};
    EXPECT_EQ(std::vector<uint8_t>(w.data().begin(), w.data().end()), expected);
}

TEST(ProtocolWire, NanBitsSurvive) {
    const uint32_t quiet_nan_with_payload = 0x7FC12345u;
    float nan_in;
    std::memcpy(&nan_in, &quiet_nan_with_payload, 4);
    WireWriter w;
    w.f32(nan_in);
    WireReader r(w.data());
    const float nan_out = r.f32();
    uint32_t bits;
    std::memcpy(&bits, &nan_out, 4);
    EXPECT_EQ(bits, quiet_nan_with_payload);
}

TEST(ProtocolWire, ReadsAtOddOffsetsAreFine) {
    // Every multi-byte read below starts at an odd address in the buffer.
    WireWriter w;
    w.u8(1);
    w.u64(0x8877665544332211ull);
    w.f64(3.5);
    w.u16(0xCAFE);
    WireReader r(w.data());
    EXPECT_EQ(r.u8(), 1);
    EXPECT_EQ(r.u64(), 0x8877665544332211ull);
    EXPECT_EQ(r.f64(), 3.5);
    EXPECT_EQ(r.u16(), 0xCAFE);
    EXPECT_TRUE(r.ok());
}

TEST(ProtocolWire, TruncatedAtEveryCutIsStickyAndSafe) {
    const Sample original;
    const auto bytes = write_sample(original);
    for (size_t cut = 0; cut < bytes.size(); ++cut) {
        // A copy of exactly `cut` bytes, so ASan sees any read past the end.
        const std::vector<uint8_t> prefix(bytes.begin(), bytes.begin() + static_cast<ptrdiff_t>(cut));
        WireReader r(prefix);
        const Sample back = read_sample(r);
        ASSERT_FALSE(r.ok()) << "cut " << cut;
        EXPECT_NE(r.error().find("offset"), std::string::npos) << r.error();
        EXPECT_EQ(r.error().find('\n'), std::string::npos);
        EXPECT_EQ(r.remaining(), 0u);
        // Fields wholly before the cut read back right; everything after the failure is zero /
        // empty. (The last field, an empty string, is the 4 bytes before the end.)
        EXPECT_EQ(back.a, cut == 0 ? 0 : original.a);
        EXPECT_EQ(back.shorts.empty(), cut < bytes.size() - 4);
        EXPECT_TRUE(back.empty.empty());
        // The first failure is what error() keeps describing.
        const std::string first = r.error();
        EXPECT_EQ(r.u32(), 0u);
        EXPECT_EQ(r.string(8), "");
        r.fail("later problem");
        EXPECT_EQ(r.error(), first);
        EXPECT_FALSE(r.expect_end());
    }
}

TEST(ProtocolWire, StickyErrorMessageAndZeroes) {
    const std::vector<uint8_t> bytes = {1, 2, 3, 4, 5, 6};
    WireReader r(bytes);
    EXPECT_EQ(r.u16("first"), 0x0201);
    EXPECT_EQ(r.u64("capabilities"), 0u); // 4 bytes left
    EXPECT_FALSE(r.ok());
    EXPECT_EQ(r.error(), "truncated: u64 'capabilities' at offset 2 needs 8 bytes, 4 left");
    // Bytes are still there, but the stream is dead.
    EXPECT_EQ(r.u8(), 0);
    EXPECT_EQ(r.u16(), 0);
    EXPECT_EQ(r.f32(), 0.0f);
    EXPECT_TRUE(r.bytes(1).empty());
    EXPECT_EQ(r.error(), "truncated: u64 'capabilities' at offset 2 needs 8 bytes, 4 left");
}

TEST(ProtocolWire, LengthCapsAreEnforcedPerRead) {
    WireWriter w;
    w.string("twelve bytes");
    {
        WireReader r(w.data());
        EXPECT_EQ(r.string(11, "name"), "");
        EXPECT_FALSE(r.ok());
        EXPECT_NE(r.error().find("name count 12 at offset 0 exceeds the limit 11"), std::string::npos)
            << r.error();
    }
    {
        WireReader r(w.data());
        EXPECT_EQ(r.string(12, "name"), "twelve bytes");
        EXPECT_TRUE(r.ok());
    }
    WireWriter arrays;
    arrays.array<uint64_t>(std::vector<uint64_t>{1, 2, 3});
    {
        WireReader r(arrays.data());
        EXPECT_TRUE(r.array<uint64_t>(2).empty());
        EXPECT_FALSE(r.ok());
    }
}

TEST(ProtocolWire, HostileCountsAllocateNothing) {
    // A count of 0xFFFFFFFF u64 elements with 8 bytes behind it, under a permissive cap: the reader
    // must refuse from the bytes left, not try to reserve 32 GiB.
    WireWriter w;
    w.u32(0xFFFFFFFFu);
    w.u64(42);
    begin_allocation_probe();
    WireReader r(w.data());
    const auto values = r.array<uint64_t>(0xFFFFFFFFu, "values");
    const size_t largest = end_allocation_probe();
    EXPECT_TRUE(values.empty());
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().find("values of 4294967295 elements"), std::string::npos) << r.error();
    EXPECT_LT(largest, 4096u);

    // Same for blobs and strings.
    WireWriter s;
    s.u32(0x7FFFFFFF);
    s.bytes(std::vector<uint8_t>(10, 'x'));
    begin_allocation_probe();
    WireReader rs(s.data());
    EXPECT_EQ(rs.string(0xFFFFFFFFu), "");
    EXPECT_LT(end_allocation_probe(), 4096u);
    EXPECT_FALSE(rs.ok());

    // count() lets a caller size a container safely.
    WireReader rc(w.data());
    EXPECT_EQ(rc.count(100, 1), 0u);
    EXPECT_FALSE(rc.ok());
}

TEST(ProtocolWire, SemanticFailAndTrailingBytes) {
    const std::vector<uint8_t> bytes = {7, 0, 0, 0, 9};
    {
        WireReader r(bytes);
        EXPECT_EQ(r.u32(), 7u);
        r.fail("enum value 7 is not a VkFormat");
        EXPECT_FALSE(r.ok());
        EXPECT_EQ(r.error(), "enum value 7 is not a VkFormat at offset 4");
        EXPECT_EQ(r.u8(), 0);
    }
    {
        WireReader r(bytes);
        EXPECT_EQ(r.u32(), 7u);
        EXPECT_FALSE(r.expect_end("Hello"));
        EXPECT_EQ(r.error(), "1 unexpected bytes after the Hello at offset 4");
    }
    {
        WireReader r(std::span<const uint8_t>{});
        EXPECT_TRUE(r.at_end());
        EXPECT_TRUE(r.expect_end());
        EXPECT_EQ(r.u8(), 0);
        EXPECT_FALSE(r.ok());
    }
}

TEST(ProtocolWire, WriterPatchesCounts) {
    WireWriter w;
    w.u8(1);
    const size_t at = w.size();
    w.u32(0);
    w.u16(5);
    w.patch_u32(at, 0xA1B2C3D4);
    EXPECT_TRUE(w.ok());
    WireReader r(w.data());
    EXPECT_EQ(r.u8(), 1);
    EXPECT_EQ(r.u32(), 0xA1B2C3D4u);
    EXPECT_EQ(r.u16(), 5);
    w.patch_u32(w.size() - 2, 1); // would run past the end
    EXPECT_FALSE(w.ok());
}

} // namespace
} // namespace splitvk::protocol
