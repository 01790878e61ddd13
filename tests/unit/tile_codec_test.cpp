// The tile codecs on synthetic tiles: round trips (opaque, with alpha, noise, odd sizes), the
// keyframe rules, and malformed input of every kind (truncation at every byte, random bit flips,
// wrong sizes, trailing bytes, the wrong codec). Malformed input must fail with one line, never
// crash or over-read (the sanitize build runs this under ASan+UBSan). Real rendered tiles are in
// the e2e suite tile_codec_test.
#include "tile_codec.h"

#include <cmath>
#include <cstdint>
#include <random>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

namespace splitvk::tiles {
namespace {

using Pixels = std::vector<uint8_t>;

enum class AlphaKind { Opaque, Gradient, Noise };

// A smooth pattern that moves with `frame`, with a little noise, so differences between frames are
// neither zero nor everything. Byte 0..2 differ so a swapped plane cannot go unnoticed.
Pixels synthetic_tile(uint32_t width, uint32_t height, int frame, AlphaKind alpha, uint32_t seed = 1) {
    std::mt19937 noise(seed * 1000u + static_cast<uint32_t>(frame));
    Pixels pixels(size_t{width} * height * 4);
    for (uint32_t y = 0; y < height; ++y) {
        for (uint32_t x = 0; x < width; ++x) {
            uint8_t *p = &pixels[(size_t{y} * width + x) * 4];
            const uint32_t jitter = noise() & 3u;
            p[0] = static_cast<uint8_t>(x * 3 + static_cast<uint32_t>(frame) * 2 + jitter);
            p[1] = static_cast<uint8_t>(y * 5 + 40);
            p[2] = static_cast<uint8_t>((x ^ y) + static_cast<uint32_t>(frame) * 7);
            switch (alpha) {
            case AlphaKind::Opaque:
                p[3] = 255;
                break;
            case AlphaKind::Gradient:
                p[3] = static_cast<uint8_t>(x + y);
                break;
            case AlphaKind::Noise:
                p[3] = static_cast<uint8_t>(noise());
                break;
            }
        }
    }
    return pixels;
}

Pixels noise_tile(uint32_t width, uint32_t height, uint32_t seed) {
    std::mt19937 noise(seed);
    Pixels pixels(size_t{width} * height * 4);
    for (auto &byte : pixels)
        byte = static_cast<uint8_t>(noise());
    return pixels;
}

// The first index at which two tiles differ, for failure messages.
std::string first_difference(const Pixels &expected, const Pixels &actual) {
    if (expected.size() != actual.size()) return "sizes differ";
    for (size_t i = 0; i < expected.size(); ++i)
        if (expected[i] != actual[i])
            return "byte " + std::to_string(i) + " (pixel " + std::to_string(i / 4) + ", byte " +
                   std::to_string(i % 4) + "): expected " + std::to_string(expected[i]) + ", got " +
                   std::to_string(actual[i]);
    return "equal";
}

struct Stream {
    std::unique_ptr<TileEncoder> encoder;
    std::unique_ptr<TileDecoder> decoder;
};

Stream open_stream(TileCodec codec, uint32_t width, uint32_t height) {
    Stream stream;
    std::string error;
    stream.encoder = make_tile_encoder(codec, width, height, 4, &error);
    EXPECT_NE(stream.encoder, nullptr) << error;
    stream.decoder = make_tile_decoder(codec, width, height, 4, &error);
    EXPECT_NE(stream.decoder, nullptr) << error;
    return stream;
}

std::vector<uint8_t> encode_ok(TileEncoder &encoder, const Pixels &pixels, bool *keyframe = nullptr) {
    std::vector<uint8_t> encoded;
    bool is_keyframe = false;
    std::string error;
    EXPECT_TRUE(encoder.encode(pixels.data(), encoded, &is_keyframe, &error)) << error;
    if (keyframe) *keyframe = is_keyframe;
    return encoded;
}

class TileCodecTest : public ::testing::TestWithParam<TileCodec> {
protected:
    TileCodec codec() const { return GetParam(); }
    bool has_inter_frames() const { return codec() != TileCodec::Raw; }

    // Encodes and decodes `frames` tiles of one stream, expecting every one back byte for byte.
    void round_trip(uint32_t width, uint32_t height, int frames, AlphaKind alpha) {
        Stream stream = open_stream(codec(), width, height);
        ASSERT_TRUE(stream.encoder && stream.decoder);
        Pixels decoded(size_t{width} * height * 4);
        for (int frame = 0; frame < frames; ++frame) {
            const Pixels tile = synthetic_tile(width, height, frame, alpha);
            bool keyframe = false;
            const auto encoded = encode_ok(*stream.encoder, tile, &keyframe);
            EXPECT_EQ(keyframe, frame == 0 || !has_inter_frames()) << "frame " << frame;
            std::string error;
            ASSERT_TRUE(stream.decoder->decode(encoded, decoded.data(), &error))
                << "frame " << frame << ": " << error;
            ASSERT_EQ(decoded, tile) << "frame " << frame << ": " << first_difference(tile, decoded);
        }
    }
};

TEST_P(TileCodecTest, OpaqueTilesRoundTrip) {
    round_trip(64, 48, 5, AlphaKind::Opaque);
}

TEST_P(TileCodecTest, AlphaGradientRoundTrips) {
    round_trip(64, 48, 4, AlphaKind::Gradient);
}

TEST_P(TileCodecTest, AlphaNoiseRoundTrips) {
    round_trip(64, 48, 3, AlphaKind::Noise);
}

// Sizes that are not whole macroblocks, and tiles smaller than one.
TEST_P(TileCodecTest, OddSizesRoundTrip) {
    round_trip(37, 21, 3, AlphaKind::Gradient);
    round_trip(16, 16, 2, AlphaKind::Opaque);
    round_trip(5, 3, 2, AlphaKind::Opaque);
}

// Incompressible content must still come back exactly (lossless is not "lossless when it fits").
TEST_P(TileCodecTest, NoiseRoundTrips) {
    Stream stream = open_stream(codec(), 64, 48);
    ASSERT_TRUE(stream.encoder && stream.decoder);
    Pixels decoded(64 * 48 * 4);
    for (uint32_t frame = 0; frame < 3; ++frame) {
        const Pixels tile = noise_tile(64, 48, frame + 7);
        const auto encoded = encode_ok(*stream.encoder, tile);
        std::string error;
        ASSERT_TRUE(stream.decoder->decode(encoded, decoded.data(), &error)) << error;
        ASSERT_EQ(decoded, tile) << "frame " << frame << ": " << first_difference(tile, decoded);
    }
}

// After force_keyframe the next tile decodes alone, in a fresh decoder.
TEST_P(TileCodecTest, ForcedKeyframeDecodesAlone) {
    Stream stream = open_stream(codec(), 64, 48);
    ASSERT_TRUE(stream.encoder && stream.decoder);
    for (int frame = 0; frame < 3; ++frame)
        encode_ok(*stream.encoder, synthetic_tile(64, 48, frame, AlphaKind::Opaque));
    stream.encoder->force_keyframe();
    const Pixels tile = synthetic_tile(64, 48, 3, AlphaKind::Gradient);
    bool keyframe = false;
    const auto encoded = encode_ok(*stream.encoder, tile, &keyframe);
    EXPECT_TRUE(keyframe);
    Pixels decoded(tile.size());
    std::string error;
    ASSERT_TRUE(stream.decoder->decode(encoded, decoded.data(), &error)) << error;
    EXPECT_EQ(decoded, tile) << first_difference(tile, decoded);

    // And only that one: the tile after it is a non-keyframe again.
    encode_ok(*stream.encoder, synthetic_tile(64, 48, 4, AlphaKind::Opaque), &keyframe);
    EXPECT_EQ(keyframe, !has_inter_frames());
}

TEST_P(TileCodecTest, NonKeyframeFirstIsAnError) {
    if (!has_inter_frames()) GTEST_SKIP() << "every raw tile is a keyframe";
    Stream stream = open_stream(codec(), 64, 48);
    ASSERT_TRUE(stream.encoder && stream.decoder);
    encode_ok(*stream.encoder, synthetic_tile(64, 48, 0, AlphaKind::Opaque));
    bool keyframe = true;
    const auto second = encode_ok(*stream.encoder, synthetic_tile(64, 48, 1, AlphaKind::Opaque), &keyframe);
    ASSERT_FALSE(keyframe);
    Pixels decoded(64 * 48 * 4, 0xab);
    const Pixels untouched = decoded;
    std::string error;
    EXPECT_FALSE(stream.decoder->decode(second, decoded.data(), &error));
    EXPECT_NE(error.find("keyframe"), std::string::npos) << error;
    EXPECT_EQ(decoded, untouched) << "a failed decode wrote pixels";
}

// A failed decode loses the stream's reference: non-keyframes are refused until a keyframe.
TEST_P(TileCodecTest, FailureRequiresAKeyframe) {
    if (!has_inter_frames()) GTEST_SKIP() << "every raw tile is a keyframe";
    Stream stream = open_stream(codec(), 64, 48);
    ASSERT_TRUE(stream.encoder && stream.decoder);
    Pixels decoded(64 * 48 * 4);
    std::string error;
    ASSERT_TRUE(stream.decoder->decode(
        encode_ok(*stream.encoder, synthetic_tile(64, 48, 0, AlphaKind::Opaque)), decoded.data(), &error))
        << error;
    auto lost = encode_ok(*stream.encoder, synthetic_tile(64, 48, 1, AlphaKind::Opaque));
    ASSERT_FALSE(lost.empty());
    lost.pop_back(); // truncated: this tile never arrives whole
    EXPECT_FALSE(stream.decoder->decode(lost, decoded.data(), &error));
    EXPECT_FALSE(stream.decoder->decode(
        encode_ok(*stream.encoder, synthetic_tile(64, 48, 2, AlphaKind::Opaque)), decoded.data(), &error));
    stream.encoder->force_keyframe();
    const Pixels tile = synthetic_tile(64, 48, 3, AlphaKind::Opaque);
    ASSERT_TRUE(stream.decoder->decode(encode_ok(*stream.encoder, tile), decoded.data(), &error)) << error;
    EXPECT_EQ(decoded, tile) << first_difference(tile, decoded);
    const Pixels next = synthetic_tile(64, 48, 4, AlphaKind::Opaque);
    ASSERT_TRUE(stream.decoder->decode(encode_ok(*stream.encoder, next), decoded.data(), &error)) << error;
    EXPECT_EQ(decoded, next) << first_difference(next, decoded);
}

// Every proper prefix of a tile (keyframe and non-keyframe, with an alpha plane) is refused.
TEST_P(TileCodecTest, EveryTruncationIsRefused) {
    Stream stream = open_stream(codec(), 40, 24);
    ASSERT_TRUE(stream.encoder && stream.decoder);
    const Pixels first = synthetic_tile(40, 24, 0, AlphaKind::Gradient);
    const auto keyframe = encode_ok(*stream.encoder, first);
    const auto next = encode_ok(*stream.encoder, synthetic_tile(40, 24, 1, AlphaKind::Gradient));
    Pixels decoded(40 * 24 * 4);
    std::string error;
    for (const auto *encoded : {&keyframe, &next}) {
        for (size_t size = 0; size < encoded->size(); ++size) {
            // Restore the reference each time, so the non-keyframe's truncations reach its body.
            ASSERT_TRUE(stream.decoder->decode(keyframe, decoded.data(), &error)) << error;
            error.clear();
            EXPECT_FALSE(stream.decoder->decode(std::span(encoded->data(), size), decoded.data(), &error))
                << "a " << size << "-byte prefix of " << encoded->size() << " bytes was accepted";
            EXPECT_FALSE(error.empty());
            EXPECT_EQ(error.find('\n'), std::string::npos) << error;
        }
    }
}

TEST_P(TileCodecTest, TrailingBytesAreRefused) {
    Stream stream = open_stream(codec(), 40, 24);
    ASSERT_TRUE(stream.encoder && stream.decoder);
    for (AlphaKind alpha : {AlphaKind::Opaque, AlphaKind::Gradient}) {
        stream.encoder->force_keyframe();
        auto encoded = encode_ok(*stream.encoder, synthetic_tile(40, 24, 0, alpha));
        encoded.push_back(0);
        Pixels decoded(40 * 24 * 4);
        std::string error;
        EXPECT_FALSE(stream.decoder->decode(encoded, decoded.data(), &error));
        EXPECT_FALSE(error.empty());
    }
}

TEST_P(TileCodecTest, WrongSizeIsRefused) {
    Stream small = open_stream(codec(), 32, 32);
    std::string error;
    auto decoder = make_tile_decoder(codec(), 48, 32, 4, &error);
    ASSERT_TRUE(small.encoder && decoder) << error;
    const auto encoded = encode_ok(*small.encoder, synthetic_tile(32, 32, 0, AlphaKind::Opaque));
    Pixels decoded(48 * 32 * 4);
    EXPECT_FALSE(decoder->decode(encoded, decoded.data(), &error));
    EXPECT_NE(error.find("32x32"), std::string::npos) << error;
}

// A tile of another codec is refused, whatever its body.
TEST_P(TileCodecTest, OtherCodecsTilesAreRefused) {
    std::string error;
    auto decoder = make_tile_decoder(codec(), 32, 32, 4, &error);
    ASSERT_TRUE(decoder) << error;
    Pixels decoded(32 * 32 * 4);
    for (TileCodec other : {TileCodec::X264, TileCodec::Zstd, TileCodec::Raw}) {
        if (other == codec()) continue;
        auto encoder = make_tile_encoder(other, 32, 32, 4, &error);
        ASSERT_TRUE(encoder) << error;
        const auto encoded = encode_ok(*encoder, synthetic_tile(32, 32, 0, AlphaKind::Opaque));
        EXPECT_FALSE(decoder->decode(encoded, decoded.data(), &error)) << to_string(other);
        EXPECT_NE(error.find("codec"), std::string::npos) << error;
    }
}

// Random bit flips anywhere (header, lengths, checksum, H.264 or zstd data): the decoder refuses
// the tile or, for a flip in a bit it ignores, decodes the original; never other pixels, never a
// crash or an over-read. A good keyframe before each attempt keeps it on a reference.
TEST_P(TileCodecTest, BitFlipsAreRefusedOrHarmless) {
    Stream stream = open_stream(codec(), 48, 32);
    ASSERT_TRUE(stream.encoder && stream.decoder);
    const Pixels first = synthetic_tile(48, 32, 0, AlphaKind::Gradient);
    const Pixels second = synthetic_tile(48, 32, 1, AlphaKind::Gradient);
    const auto keyframe = encode_ok(*stream.encoder, first);
    const auto next = encode_ok(*stream.encoder, second);
    std::mt19937 random(42);
    Pixels decoded(48 * 32 * 4);
    std::string error;
    int refused = 0;
    constexpr int kAttempts = 400;
    for (int attempt = 0; attempt < kAttempts; ++attempt) {
        ASSERT_TRUE(stream.decoder->decode(keyframe, decoded.data(), &error)) << error;
        auto damaged = (attempt % 2 == 0) ? keyframe : next;
        const int flips = 1 + static_cast<int>(random() % 4);
        for (int i = 0; i < flips; ++i) {
            const size_t bit = random() % (damaged.size() * 8);
            damaged[bit / 8] ^= static_cast<uint8_t>(1u << (bit % 8));
        }
        error.clear();
        if (!stream.decoder->decode(damaged, decoded.data(), &error)) {
            ++refused;
            EXPECT_FALSE(error.empty());
            EXPECT_EQ(error.find('\n'), std::string::npos) << error;
        } else {
            // Accepted damage (a bit the decoder ignores) must still give back the original tile.
            const Pixels &original = (attempt % 2 == 0) ? first : second;
            EXPECT_EQ(decoded, original) << "attempt " << attempt << ": damaged tile decoded to other pixels";
        }
    }
    std::printf("  %s: %d of %d damaged tiles refused\n", to_string(codec()), refused, kAttempts);
}

INSTANTIATE_TEST_SUITE_P(Codecs, TileCodecTest,
                         ::testing::Values(TileCodec::X264, TileCodec::Zstd, TileCodec::Raw),
                         [](const ::testing::TestParamInfo<TileCodec> &p) {
                             return std::string(to_string(p.param));
                         });

TEST(TileCodecFactory, RefusesEmptyAndHugeTiles) {
    std::string error;
    EXPECT_EQ(make_tile_encoder(TileCodec::X264, 0, 16, 4, &error), nullptr);
    EXPECT_NE(error.find("0x16"), std::string::npos) << error;
    EXPECT_EQ(make_tile_decoder(TileCodec::Zstd, 16, 20000, 4, &error), nullptr);
    EXPECT_NE(error.find("16x20000"), std::string::npos) << error;
}

// --- 8-byte texels (RGBA16 images: zstd and raw) ---------------------------------------------

// Four 16-bit channels that move with `frame`, with low bytes that are noise, so that a codec that
// dropped or reordered half of each texel could not give the tile back.
Pixels wide_tile(uint32_t width, uint32_t height, int frame, uint32_t seed = 7) {
    std::mt19937 noise(seed * 1000u + static_cast<uint32_t>(frame));
    Pixels pixels(size_t{width} * height * 8);
    for (uint32_t y = 0; y < height; ++y)
        for (uint32_t x = 0; x < width; ++x) {
            uint8_t *p = &pixels[(size_t{y} * width + x) * 8];
            const uint32_t channels[4] = {x * 517 + static_cast<uint32_t>(frame) * 97, y * 263 + 4000,
                                          (x ^ y) * 1031, 65535 - x};
            for (int c = 0; c < 4; ++c) {
                const uint32_t value = channels[c] + (noise() & 7u);
                p[c * 2] = static_cast<uint8_t>(value);
                p[c * 2 + 1] = static_cast<uint8_t>(value >> 8);
            }
        }
    return pixels;
}

class WideTexelTest : public ::testing::TestWithParam<TileCodec> {};

TEST_P(WideTexelTest, TilesRoundTripBitExact) {
    for (const auto &[width, height] : {std::pair<uint32_t, uint32_t>{64, 48}, {37, 21}, {1, 1}}) {
        std::string error;
        auto encoder = make_tile_encoder(GetParam(), width, height, 8, &error);
        ASSERT_NE(encoder, nullptr) << error;
        auto decoder = make_tile_decoder(GetParam(), width, height, 8, &error);
        ASSERT_NE(decoder, nullptr) << error;
        Pixels decoded(size_t{width} * height * 8);
        for (int frame = 0; frame < 4; ++frame) {
            const Pixels tile =
                frame == 3 ? noise_tile(width * 2, height, 9) : wide_tile(width, height, frame);
            bool keyframe = false;
            const auto encoded = encode_ok(*encoder, tile, &keyframe);
            EXPECT_EQ(keyframe, frame == 0 || GetParam() == TileCodec::Raw) << "frame " << frame;
            EXPECT_EQ(peek_texel_bytes(encoded), 8u);
            ASSERT_TRUE(decoder->decode(encoded, decoded.data(), &error))
                << "frame " << frame << ": " << error;
            ASSERT_EQ(decoded, tile) << width << "x" << height << ", frame " << frame << ": "
                                     << first_difference(tile, decoded);
        }
    }
}

// A decoder takes only tiles of its own texel size: a 4-byte tile is not half of an 8-byte one, nor
// an 8-byte tile two 4-byte ones, whatever the sizes say.
TEST_P(WideTexelTest, TilesOfTheOtherTexelSizeAreRefused) {
    std::string error;
    for (const auto &[encoded_bytes, decoder_bytes] : {std::pair<uint32_t, uint32_t>{4, 8}, {8, 4}}) {
        auto encoder = make_tile_encoder(GetParam(), 32, 16, encoded_bytes, &error);
        auto decoder = make_tile_decoder(GetParam(), 32, 16, decoder_bytes, &error);
        ASSERT_TRUE(encoder && decoder) << error;
        const Pixels tile =
            encoded_bytes == 8 ? wide_tile(32, 16, 0) : synthetic_tile(32, 16, 0, AlphaKind::Noise);
        const auto encoded = encode_ok(*encoder, tile);
        EXPECT_EQ(peek_texel_bytes(encoded), encoded_bytes);
        Pixels decoded(size_t{32} * 16 * decoder_bytes);
        error.clear();
        EXPECT_FALSE(decoder->decode(encoded, decoded.data(), &error));
        EXPECT_NE(error.find(std::to_string(encoded_bytes) + "-byte texels, the stream's are " +
                             std::to_string(decoder_bytes)),
                  std::string::npos)
            << error;
        EXPECT_EQ(error.find('\n'), std::string::npos) << error;
    }
}

// Damage to an 8-byte tile is refused or harmless, as to a 4-byte one.
TEST_P(WideTexelTest, BitFlipsAreRefusedOrHarmless) {
    std::string error;
    auto encoder = make_tile_encoder(GetParam(), 24, 16, 8, &error);
    auto decoder = make_tile_decoder(GetParam(), 24, 16, 8, &error);
    ASSERT_TRUE(encoder && decoder) << error;
    const Pixels tile = wide_tile(24, 16, 0);
    const auto keyframe = encode_ok(*encoder, tile);
    std::mt19937 random(11);
    Pixels decoded(tile.size());
    for (int attempt = 0; attempt < 200; ++attempt) {
        auto damaged = keyframe;
        const size_t bit = random() % (damaged.size() * 8);
        damaged[bit / 8] ^= static_cast<uint8_t>(1u << (bit % 8));
        if (decoder->decode(damaged, decoded.data(), &error)) {
            EXPECT_EQ(decoded, tile) << "attempt " << attempt << ": damaged tile decoded to other pixels";
        }
    }
}

INSTANTIATE_TEST_SUITE_P(Codecs, WideTexelTest, ::testing::Values(TileCodec::Zstd, TileCodec::Raw),
                         [](const ::testing::TestParamInfo<TileCodec> &p) {
                             return std::string(to_string(p.param));
                         });

TEST(TileCodecFactory, X264RefusesEightByteTexels) {
    std::string error;
    EXPECT_EQ(make_tile_encoder(TileCodec::X264, 32, 16, 8, &error), nullptr);
    EXPECT_NE(error.find("x264 tiles have 4-byte texels, not 8"), std::string::npos) << error;
    error.clear();
    EXPECT_EQ(make_tile_decoder(TileCodec::X264, 32, 16, 8, &error), nullptr);
    EXPECT_NE(error.find("x264 tiles have 4-byte texels, not 8"), std::string::npos) << error;
}

TEST(TileCodecFactory, RefusesTexelSizesOtherThanFourAndEight) {
    for (const TileCodec codec : {TileCodec::X264, TileCodec::Zstd, TileCodec::Raw})
        for (const uint32_t bytes : {0u, 1u, 3u, 6u, 16u}) {
            std::string error;
            EXPECT_EQ(make_tile_encoder(codec, 32, 16, bytes, &error), nullptr)
                << to_string(codec) << " " << bytes;
            EXPECT_NE(error.find("tile texels of " + std::to_string(bytes) + " bytes"), std::string::npos)
                << error;
            error.clear();
            EXPECT_EQ(make_tile_decoder(codec, 32, 16, bytes, &error), nullptr)
                << to_string(codec) << " " << bytes;
            EXPECT_FALSE(error.empty());
        }
}

// A 4-byte tile is what it was before tiles had a texel size: no new flag in its header, so a
// layer that predates 8-byte texels decodes it as before (and refuses an 8-byte one).
TEST(TileHeader, FourByteTilesCarryNoTexelFlag) {
    std::string error;
    auto raw = make_tile_encoder(TileCodec::Raw, 2, 1, 4, &error);
    ASSERT_NE(raw, nullptr) << error;
    const Pixels pixels = {1, 2, 3, 4, 5, 6, 7, 8};
    const auto encoded = encode_ok(*raw, pixels);
    ASSERT_EQ(encoded.size(), kTileHeaderSize + pixels.size());
    const std::vector<uint8_t> header(encoded.begin(), encoded.begin() + 8);
    EXPECT_EQ(header, (std::vector<uint8_t>{1, 3, 1, 0, 2, 0, 1, 0})) << "version 1, raw, keyframe only, 2x1";
    auto wide = make_tile_encoder(TileCodec::Raw, 1, 1, 8, &error);
    ASSERT_NE(wide, nullptr) << error;
    const auto wide_encoded = encode_ok(*wide, pixels);
    EXPECT_EQ(wide_encoded[2], 1u | 8u) << "keyframe and 8-byte texels";
}

TEST(TileHeader, PeekTexelBytes) {
    std::string error;
    for (const TileCodec codec : {TileCodec::X264, TileCodec::Zstd, TileCodec::Raw}) {
        auto encoder = make_tile_encoder(codec, 16, 16, 4, &error);
        ASSERT_NE(encoder, nullptr) << error;
        EXPECT_EQ(peek_texel_bytes(encode_ok(*encoder, synthetic_tile(16, 16, 0, AlphaKind::Opaque))), 4u)
            << to_string(codec);
    }
    auto zstd = make_tile_encoder(TileCodec::Zstd, 16, 16, 8, &error);
    ASSERT_NE(zstd, nullptr) << error;
    const auto good = encode_ok(*zstd, wide_tile(16, 16, 0));
    ASSERT_EQ(peek_texel_bytes(good), 8u);
    // Only the header is read: a tile whose body is cut off still says its texel size.
    EXPECT_EQ(peek_texel_bytes(std::span(good).first(kTileHeaderSize)), 8u);

    EXPECT_EQ(peek_texel_bytes({}), 0u);
    EXPECT_EQ(peek_texel_bytes(std::span(good).first(kTileHeaderSize - 1)), 0u) << "shorter than the header";
    const auto damaged = [&](size_t at, uint8_t value) {
        auto copy = good;
        copy[at] = value;
        return peek_texel_bytes(copy);
    };
    EXPECT_EQ(damaged(0, 2), 0u) << "format version 2";
    EXPECT_EQ(damaged(0, 0), 0u) << "format version 0";
    EXPECT_EQ(damaged(1, 0), 0u) << "codec id 0";
    EXPECT_EQ(damaged(1, 6), 0u) << "codec id 6";
    EXPECT_EQ(damaged(1, 4), 0u) << "8-byte texels in an h264 tile";
    EXPECT_EQ(damaged(1, 1), 0u) << "8-byte texels in an x264 tile";
    EXPECT_EQ(damaged(2, 0x20 | 0x08), 0u) << "an unknown flag";
    EXPECT_EQ(damaged(3, 1), 0u) << "the zero byte";
    auto empty = good;
    empty[4] = empty[5] = 0;
    EXPECT_EQ(peek_texel_bytes(empty), 0u) << "zero width";
    empty = good;
    empty[6] = empty[7] = 0;
    EXPECT_EQ(peek_texel_bytes(empty), 0u) << "zero height";
    EXPECT_EQ(damaged(2, 0x01), 4u) << "the flag off: a 4-byte header";
}

// The alpha plane is carried only when some alpha byte is not 255: opaque x264 tiles are the
// H.264 access unit alone.
TEST(X264Tiles, OpaqueTilesCarryNoAlphaPlane) {
    Stream stream = open_stream(TileCodec::X264, 64, 48);
    ASSERT_TRUE(stream.encoder);
    const auto h264_end = [](const std::vector<uint8_t> &tile) {
        const uint8_t *size = &tile[kTileHeaderSize];
        return kTileHeaderSize + 4 + (size[0] | size[1] << 8 | size[2] << 16 | size_t{size[3]} << 24);
    };
    const auto opaque = encode_ok(*stream.encoder, synthetic_tile(64, 48, 0, AlphaKind::Opaque));
    ASSERT_GT(opaque.size(), kTileHeaderSize + 4);
    EXPECT_EQ(opaque[2] & 2, 0) << "alpha-plane flag set on an opaque tile";
    EXPECT_EQ(opaque.size(), h264_end(opaque));
    const auto translucent = encode_ok(*stream.encoder, synthetic_tile(64, 48, 1, AlphaKind::Gradient));
    ASSERT_GT(translucent.size(), kTileHeaderSize + 4);
    EXPECT_NE(translucent[2] & 2, 0) << "alpha-plane flag missing";
    EXPECT_GT(translucent.size(), h264_end(translucent));
}

// The header's checksum covers the pixels: a raw tile with one pixel byte changed is well formed in
// every other way and must still be refused.
TEST(RawTiles, ChangedPixelFailsTheChecksum) {
    Stream stream = open_stream(TileCodec::Raw, 16, 8);
    ASSERT_TRUE(stream.encoder && stream.decoder);
    auto encoded = encode_ok(*stream.encoder, synthetic_tile(16, 8, 0, AlphaKind::Opaque));
    encoded[kTileHeaderSize + 100] ^= 0x10;
    Pixels decoded(16 * 8 * 4);
    std::string error;
    EXPECT_FALSE(stream.decoder->decode(encoded, decoded.data(), &error));
    EXPECT_NE(error.find("checksum"), std::string::npos) << error;
}

// Each byte of a pixel comes back in its own place: distinct constant values per byte, so a swap
// of any two of x264's G/B/R planes would show.
TEST(X264Tiles, ByteOrderIsKept) {
    Stream stream = open_stream(TileCodec::X264, 32, 16);
    ASSERT_TRUE(stream.encoder && stream.decoder);
    Pixels tile(32 * 16 * 4);
    for (size_t i = 0; i < tile.size(); i += 4) {
        tile[i + 0] = 10;
        tile[i + 1] = 120;
        tile[i + 2] = 230;
        tile[i + 3] = 255;
    }
    Pixels decoded(tile.size());
    std::string error;
    ASSERT_TRUE(stream.decoder->decode(encode_ok(*stream.encoder, tile), decoded.data(), &error)) << error;
    EXPECT_EQ(decoded, tile) << first_difference(tile, decoded);
}

// An H.264 stream of a larger picture, relabelled as a small tile, is refused (the decoder's
// picture-size bound and the decoded-size check), not decoded into a 64x64 buffer.
TEST(X264Tiles, LargerPictureIsRefused) {
    Stream large = open_stream(TileCodec::X264, 1024, 512);
    ASSERT_TRUE(large.encoder);
    auto encoded = encode_ok(*large.encoder, synthetic_tile(1024, 512, 0, AlphaKind::Opaque));
    encoded[4] = 64;
    encoded[5] = 0;
    encoded[6] = 64;
    encoded[7] = 0;
    std::string error;
    auto decoder = make_tile_decoder(TileCodec::X264, 64, 64, 4, &error);
    ASSERT_TRUE(decoder) << error;
    Pixels decoded(64 * 64 * 4);
    EXPECT_FALSE(decoder->decode(encoded, decoded.data(), &error));
    EXPECT_FALSE(error.empty());
}

// The other way round: a smaller picture relabelled as a larger tile decodes, but to the wrong size.
TEST(X264Tiles, SmallerPictureIsRefused) {
    Stream small = open_stream(TileCodec::X264, 32, 32);
    ASSERT_TRUE(small.encoder);
    auto encoded = encode_ok(*small.encoder, synthetic_tile(32, 32, 0, AlphaKind::Opaque));
    encoded[4] = 48;
    std::string error;
    auto decoder = make_tile_decoder(TileCodec::X264, 48, 32, 4, &error);
    ASSERT_TRUE(decoder) << error;
    Pixels decoded(48 * 32 * 4);
    EXPECT_FALSE(decoder->decode(encoded, decoded.data(), &error));
    EXPECT_NE(error.find("decoded 32x32"), std::string::npos) << error;
}

// ---------------------------------------------------------------------------------------------
// Lossy x264 (the swapped split's periphery)

// Peak signal-to-noise ratio over the colour bytes (alpha is lossless and left out), in dB.
double psnr_rgb(const Pixels &expected, const Pixels &actual) {
    double squared = 0;
    size_t count = 0;
    for (size_t i = 0; i < expected.size(); ++i) {
        if (i % 4 == 3) continue;
        const double d = static_cast<double>(expected[i]) - static_cast<double>(actual[i]);
        squared += d * d;
        ++count;
    }
    if (squared == 0) return 99;
    return 10 * std::log10(255.0 * 255.0 * static_cast<double>(count) / squared);
}

// A smooth picture with a little noise and a hard edge, as a downsampled frame looks.
Pixels gradient_noise_image(uint32_t width, uint32_t height, int frame) {
    std::mt19937 noise(77u + static_cast<uint32_t>(frame));
    Pixels pixels(size_t{width} * height * 4);
    for (uint32_t y = 0; y < height; ++y)
        for (uint32_t x = 0; x < width; ++x) {
            uint8_t *p = &pixels[(size_t{y} * width + x) * 4];
            const uint32_t jitter = noise() % 5u;
            const uint32_t shift = static_cast<uint32_t>(frame) * 3;
            p[0] = static_cast<uint8_t>((x + shift) * 200 / width + jitter);
            p[1] = static_cast<uint8_t>(y * 220 / height + jitter);
            p[2] = static_cast<uint8_t>(x > width / 3 && x < width / 2 ? 230 : 40 + (x + y) % 32);
            p[3] = 255;
        }
    return pixels;
}

Stream open_lossy_stream(uint32_t width, uint32_t height, uint32_t crf, bool accept_lossy) {
    Stream stream;
    std::string error;
    stream.encoder = make_tile_encoder(TileCodec::X264, width, height, 4, &error, TileQuality{false, crf});
    EXPECT_NE(stream.encoder, nullptr) << error;
    stream.decoder = make_tile_decoder(TileCodec::X264, width, height, 4, &error, accept_lossy);
    EXPECT_NE(stream.decoder, nullptr) << error;
    return stream;
}

TEST(X264LossyTiles, RoundTripIsCloseAndSmaller) {
    constexpr uint32_t kWidth = 200, kHeight = 120;
    Stream stream = open_lossy_stream(kWidth, kHeight, 23, true);
    ASSERT_TRUE(stream.encoder && stream.decoder);
    Pixels decoded(size_t{kWidth} * kHeight * 4);
    for (int frame = 0; frame < 4; ++frame) {
        const Pixels image = gradient_noise_image(kWidth, kHeight, frame);
        bool keyframe = false;
        const auto encoded = encode_ok(*stream.encoder, image, &keyframe);
        EXPECT_EQ(keyframe, frame == 0) << "frame " << frame;
        EXPECT_LT(encoded.size(), image.size() / 4) << "frame " << frame;
        std::string error;
        ASSERT_TRUE(stream.decoder->decode(encoded, decoded.data(), &error))
            << "frame " << frame << ": " << error;
        EXPECT_GT(psnr_rgb(image, decoded), 35.0) << "frame " << frame;
        for (size_t i = 3; i < decoded.size(); i += 4)
            ASSERT_EQ(decoded[i], 255) << "alpha stays exact";
    }
}

TEST(X264LossyTiles, HigherCrfIsSmaller) {
    constexpr uint32_t kWidth = 128, kHeight = 96;
    const Pixels image = gradient_noise_image(kWidth, kHeight, 0);
    Stream fine = open_lossy_stream(kWidth, kHeight, 10, true);
    Stream coarse = open_lossy_stream(kWidth, kHeight, 40, true);
    ASSERT_TRUE(fine.encoder && coarse.encoder);
    EXPECT_LT(encode_ok(*coarse.encoder, image).size(), encode_ok(*fine.encoder, image).size());
}

// A decoder made for foveae never takes a lossy tile, and a lossy tile carries no checksum.
TEST(X264LossyTiles, RefusedWithoutAcceptLossy) {
    constexpr uint32_t kWidth = 64, kHeight = 48;
    Stream stream = open_lossy_stream(kWidth, kHeight, 23, false);
    ASSERT_TRUE(stream.encoder && stream.decoder);
    const auto encoded = encode_ok(*stream.encoder, gradient_noise_image(kWidth, kHeight, 0));
    EXPECT_EQ(encoded[8] | encoded[9] | encoded[10] | encoded[11], 0) << "no checksum";
    Pixels decoded(size_t{kWidth} * kHeight * 4);
    std::string error;
    EXPECT_FALSE(stream.decoder->decode(encoded, decoded.data(), &error));
    EXPECT_NE(error.find("lossy"), std::string::npos) << error;

    auto with_checksum = encoded;
    with_checksum[8] = 1;
    std::string lossy_error;
    auto accepting = make_tile_decoder(TileCodec::X264, kWidth, kHeight, 4, &lossy_error, true);
    ASSERT_NE(accepting, nullptr) << lossy_error;
    EXPECT_FALSE(accepting->decode(with_checksum, decoded.data(), &lossy_error));
    EXPECT_TRUE(accepting->decode(encoded, decoded.data(), &lossy_error)) << lossy_error;
}

// A decoder that accepts lossy tiles still checks lossless ones byte for byte.
TEST(X264LossyTiles, AcceptingDecoderStillChecksLosslessTiles) {
    constexpr uint32_t kWidth = 64, kHeight = 48;
    std::string error;
    auto encoder = make_tile_encoder(TileCodec::X264, kWidth, kHeight, 4, &error);
    auto decoder = make_tile_decoder(TileCodec::X264, kWidth, kHeight, 4, &error, true);
    ASSERT_TRUE(encoder && decoder) << error;
    const Pixels tile = synthetic_tile(kWidth, kHeight, 0, AlphaKind::Opaque);
    auto encoded = encode_ok(*encoder, tile);
    Pixels decoded(tile.size());
    ASSERT_TRUE(decoder->decode(encoded, decoded.data(), &error)) << error;
    EXPECT_EQ(decoded, tile);
    encoder->force_keyframe();
    encoded = encode_ok(*encoder, tile);
    encoded[8] ^= 1; // the checksum
    EXPECT_FALSE(decoder->decode(encoded, decoded.data(), &error));
    EXPECT_NE(error.find("checksum"), std::string::npos) << error;
}

// Zstd and Raw have no lossy form: the quality is ignored and they stay exact. A crf over 51 is refused.
TEST(TileCodecFactory, LossyQualityOnlyForX264AndWithinRange) {
    for (TileCodec codec : {TileCodec::Zstd, TileCodec::Raw}) {
        std::string error;
        auto encoder = make_tile_encoder(codec, 32, 16, 4, &error, TileQuality{false, 30});
        auto decoder = make_tile_decoder(codec, 32, 16, 4, &error, true);
        ASSERT_TRUE(encoder && decoder) << error;
        const Pixels tile = synthetic_tile(32, 16, 0, AlphaKind::Noise);
        Pixels decoded(tile.size());
        ASSERT_TRUE(decoder->decode(encode_ok(*encoder, tile), decoded.data(), &error)) << error;
        EXPECT_EQ(decoded, tile) << to_string(codec);
    }
    std::string error;
    EXPECT_EQ(make_tile_encoder(TileCodec::X264, 32, 16, 4, &error, TileQuality{false, 52}), nullptr);
    EXPECT_NE(error.find("crf"), std::string::npos) << error;
}

} // namespace
} // namespace splitvk::tiles
