// zstd payload compression: when it is used, round trips, and refusal of hostile frames.

#include "compression.h"

#include <algorithm>
#include <atomic>
#include <random>
#include <thread>

#include <gtest/gtest.h>
#include <zstd.h>

namespace splitvk::protocol::testing {
void begin_allocation_probe(); // protocol_wire_test.cpp
size_t end_allocation_probe();
} // namespace splitvk::protocol::testing

namespace splitvk::protocol {
namespace {

using testing::begin_allocation_probe;
using testing::end_allocation_probe;

std::vector<uint8_t> compressible(size_t size) {
    std::vector<uint8_t> data(size);
    for (size_t i = 0; i < size; ++i)
        data[i] = static_cast<uint8_t>((i * 7 / 100) % 13);
    return data;
}

std::vector<uint8_t> random_bytes(size_t size, uint32_t seed = 1) {
    std::mt19937 engine(seed);
    std::vector<uint8_t> data(size);
    for (auto &b : data)
        b = static_cast<uint8_t>(engine());
    return data;
}

TEST(ProtocolCompression, RoundTrip) {
    const auto raw = compressible(256 * 1024);
    std::vector<uint8_t> packed;
    ASSERT_TRUE(compress_if_pays(raw, CompressionPolicy{}, packed));
    EXPECT_LT(packed.size(), raw.size() / 10);
    EXPECT_EQ(ZSTD_getFrameContentSize(packed.data(), packed.size()), raw.size()); // declared
    auto back = decompress_bounded(packed, raw.size());
    ASSERT_TRUE(back.ok()) << back.error();
    EXPECT_EQ(*back, raw);
}

TEST(ProtocolCompression, OnlyAtOrAboveTheThreshold) {
    CompressionPolicy policy; // 4096
    std::vector<uint8_t> packed;
    EXPECT_FALSE(compress_if_pays(std::vector<uint8_t>(4095, 0), policy, packed));
    EXPECT_TRUE(packed.empty());
    EXPECT_TRUE(compress_if_pays(std::vector<uint8_t>(4096, 0), policy, packed));
    policy.threshold = 100;
    EXPECT_TRUE(compress_if_pays(std::vector<uint8_t>(200, 0), policy, packed));
    policy.enabled = false;
    EXPECT_FALSE(compress_if_pays(std::vector<uint8_t>(1 << 20, 0), policy, packed));
    EXPECT_FALSE(compress_if_pays({}, CompressionPolicy{.threshold = 0}, packed));
}

TEST(ProtocolCompression, IncompressibleIsSentRaw) {
    std::vector<uint8_t> packed = {1, 2, 3};
    EXPECT_FALSE(compress_if_pays(random_bytes(64 * 1024), CompressionPolicy{}, packed));
    EXPECT_TRUE(packed.empty());
}

TEST(ProtocolCompression, MustPayByTheConfiguredRatio) {
    // Half random, half zeros: compresses to a little over 50 %.
    auto raw = random_bytes(64 * 1024);
    std::fill(raw.begin() + 32 * 1024, raw.end(), 0);
    std::vector<uint8_t> packed;
    EXPECT_TRUE(compress_if_pays(raw, CompressionPolicy{}, packed)); // < 7/8
    EXPECT_FALSE(
        compress_if_pays(raw, CompressionPolicy{.ratio_num = 1, .ratio_den = 2}, packed)); // not < 1/2
    EXPECT_TRUE(packed.empty());
}

TEST(ProtocolCompression, LevelIsConfigurable) {
    std::string text;
    for (int i = 0; i < 4000; ++i)
        text += "frame " + std::to_string(i * 7919 % 1000) + " draws mesh " + std::to_string(i % 37) + "; ";
    const std::vector<uint8_t> raw(text.begin(), text.end());
    std::vector<uint8_t> fast;
    std::vector<uint8_t> strong;
    ASSERT_TRUE(compress_if_pays(raw, CompressionPolicy{.level = 1}, fast));
    ASSERT_TRUE(compress_if_pays(raw, CompressionPolicy{.level = 19}, strong));
    EXPECT_LT(strong.size(), fast.size());
    EXPECT_EQ(*decompress_bounded(strong, raw.size()), raw);
}

TEST(ProtocolCompression, CompressorIsUsableFromManyThreads) {
    Compressor compressor;
    const auto raw = compressible(64 * 1024);
    std::vector<std::thread> threads;
    std::atomic<int> good{0};
    for (int t = 0; t < 4; ++t)
        threads.emplace_back([&] {
            Decompressor decompressor;
            for (int i = 0; i < 20; ++i) {
                std::vector<uint8_t> packed;
                if (compressor.compress_if_pays(raw, packed) &&
                    *decompressor.decompress(packed, raw.size()) == raw)
                    ++good;
            }
        });
    for (auto &thread : threads)
        thread.join();
    EXPECT_EQ(good.load(), 80);
}

TEST(ProtocolCompression, DeclaredSizeOverTheCapRejectedBeforeAllocating) {
    const auto raw = compressible(10000);
    std::vector<uint8_t> packed;
    ASSERT_TRUE(compress_if_pays(raw, CompressionPolicy{}, packed));
    auto refused = decompress_bounded(packed, 9999);
    ASSERT_FALSE(refused.ok());
    EXPECT_EQ(refused.error(), "zstd: declared content size 10000 exceeds the limit 9999");

    // A hand-made frame header declaring 1 TiB: magic, descriptor (8-byte content size, single
    // segment), the size, then an empty last raw block.
    std::vector<uint8_t> liar = {0x28, 0xB5, 0x2F, 0xFD, 0xE0};
    for (int i = 0; i < 8; ++i)
        liar.push_back(static_cast<uint8_t>((1ull << 40) >> (8 * i)));
    liar.insert(liar.end(), {0x01, 0x00, 0x00});
    ASSERT_EQ(ZSTD_getFrameContentSize(liar.data(), liar.size()), 1ull << 40);
    begin_allocation_probe();
    auto hostile = decompress_bounded(liar, 64u << 20);
    const size_t largest = end_allocation_probe();
    ASSERT_FALSE(hostile.ok());
    EXPECT_NE(hostile.error().find("exceeds the limit"), std::string::npos) << hostile.error();
    EXPECT_LT(largest, 1u << 20);
}

TEST(ProtocolCompression, FrameWithoutContentSizeRejected) {
    const auto raw = compressible(10000);
    // A valid frame whose header leaves the content size out (as a streaming writer would).
    ZSTD_CCtx *context = ZSTD_createCCtx();
    ZSTD_CCtx_setParameter(context, ZSTD_c_contentSizeFlag, 0);
    std::vector<uint8_t> packed(ZSTD_compressBound(raw.size()));
    const size_t written = ZSTD_compress2(context, packed.data(), packed.size(), raw.data(), raw.size());
    ZSTD_freeCCtx(context);
    ASSERT_FALSE(ZSTD_isError(written));
    packed.resize(written);
    ASSERT_EQ(ZSTD_getFrameContentSize(packed.data(), packed.size()), ZSTD_CONTENTSIZE_UNKNOWN);
    auto refused = decompress_bounded(packed, 1u << 20);
    ASSERT_FALSE(refused.ok());
    EXPECT_EQ(refused.error(), "zstd: frame does not declare its content size");
}

TEST(ProtocolCompression, TruncatedFrameRejectedAtEveryCut) {
    const auto raw = compressible(50000);
    std::vector<uint8_t> packed;
    ASSERT_TRUE(compress_if_pays(raw, CompressionPolicy{}, packed));
    Decompressor decompressor;
    for (size_t cut = 0; cut < packed.size(); ++cut) {
        const std::vector<uint8_t> prefix(packed.begin(), packed.begin() + static_cast<ptrdiff_t>(cut));
        auto result = decompressor.decompress(prefix, raw.size());
        EXPECT_FALSE(result.ok()) << "cut " << cut;
        EXPECT_EQ(result.error().find('\n'), std::string::npos);
    }
    // The decompressor is still good after all that.
    EXPECT_EQ(*decompressor.decompress(packed, raw.size()), raw);
}

TEST(ProtocolCompression, TrailingBytesRejected) {
    const auto raw = compressible(10000);
    std::vector<uint8_t> packed;
    ASSERT_TRUE(compress_if_pays(raw, CompressionPolicy{}, packed));
    packed.push_back(0);
    auto refused = decompress_bounded(packed, raw.size());
    ASSERT_FALSE(refused.ok());
    EXPECT_EQ(refused.error(), "zstd: 1 bytes after the frame");
}

// Finds the content-size field of a frame written by ZSTD_compress, to forge it.
size_t content_size_offset(const std::vector<uint8_t> &frame, size_t &field_size) {
    const uint8_t descriptor = frame[4];
    const int fcs_flag = descriptor >> 6;
    const bool single_segment = (descriptor >> 5) & 1;
    const size_t dict_id_sizes[] = {0, 1, 2, 4};
    const size_t fcs_sizes[] = {single_segment ? 1u : 0u, 2, 4, 8};
    field_size = fcs_sizes[fcs_flag];
    return 5 + (single_segment ? 0 : 1) + dict_id_sizes[descriptor & 3];
}

TEST(ProtocolCompression, ContentThatDoesNotMatchTheDeclaredSizeRejected) {
    const auto raw = compressible(10000);
    std::vector<uint8_t> packed;
    ASSERT_TRUE(compress_if_pays(raw, CompressionPolicy{}, packed));
    size_t field_size = 0;
    const size_t at = content_size_offset(packed, field_size);
    ASSERT_EQ(field_size, 2u); // 10000 needs the 2-byte form (stored as size - 256)
    for (const int delta : {-1, +1}) {
        auto forged = packed;
        const unsigned stored = forged[at] | (forged[at + 1] << 8);
        forged[at] = static_cast<uint8_t>(stored + delta);
        forged[at + 1] = static_cast<uint8_t>((stored + delta) >> 8);
        ASSERT_EQ(ZSTD_getFrameContentSize(forged.data(), forged.size()), 10000u + delta);
        auto result = decompress_bounded(forged, 1u << 20);
        EXPECT_FALSE(result.ok()) << "delta " << delta;
    }
}

} // namespace
} // namespace splitvk::protocol
