// The swapped split's 4:2:0 periphery codecs (tile_codec.h: H264Yuv420, HevcYuv420) and their colour
// conversion (yuv420.h). The streams are read back with FFmpeg's generic decoders, apart from ours,
// and held to what a headset's hardware decoder takes: profile High or Main (never High 4:4:4),
// the level the tile's size needs at 90 Hz, 8-bit 4:2:0, full-range BT.709, read from the decoded
// stream's SPS and the decoder's context rather than from the encoder's settings.
#include "tile_codec.h"
#include "yuv420.h"

#include <cmath>
#include <cstdint>
#include <random>
#include <regex>
#include <span>
#include <string>
#include <vector>

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavutil/pixdesc.h>
}

#include <gtest/gtest.h>

namespace splitvk::tiles {
namespace {

using Pixels = std::vector<uint8_t>;
constexpr size_t kHeader = kTileHeaderSize;

// A smooth picture with a little noise and a hard edge, as a downsampled frame looks; it moves with
// `frame`.
Pixels picture(uint32_t width, uint32_t height, int frame) {
    std::mt19937 noise(11u + static_cast<uint32_t>(frame));
    Pixels pixels(size_t{width} * height * 4);
    for (uint32_t y = 0; y < height; ++y)
        for (uint32_t x = 0; x < width; ++x) {
            uint8_t *p = &pixels[(size_t{y} * width + x) * 4];
            const uint32_t jitter = noise() % 4u;
            const uint32_t shift = static_cast<uint32_t>(frame) * 3;
            p[0] = static_cast<uint8_t>((x + shift) * 180 / width + 20 + jitter);
            p[1] = static_cast<uint8_t>(y * 200 / height + 30 + jitter);
            p[2] = static_cast<uint8_t>(x > width / 3 && x < width / 2 ? 210 : 50 + (x + y) % 24);
            p[3] = 255;
        }
    return pixels;
}

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

std::vector<uint8_t> encode_ok(TileEncoder &encoder, const Pixels &pixels, bool *keyframe = nullptr) {
    std::vector<uint8_t> encoded;
    bool is_keyframe = false;
    std::string error;
    EXPECT_TRUE(encoder.encode(pixels.data(), encoded, &is_keyframe, &error)) << error;
    if (keyframe) *keyframe = is_keyframe;
    return encoded;
}

// The access unit inside a tile: after the header, its u32 size, then the bytes.
std::span<const uint8_t> access_unit(std::span<const uint8_t> tile) {
    if (tile.size() < kHeader + 4) return {};
    const uint32_t size = uint32_t{tile[kHeader]} | uint32_t{tile[kHeader + 1]} << 8 |
                          uint32_t{tile[kHeader + 2]} << 16 | uint32_t{tile[kHeader + 3]} << 24;
    if (size > tile.size() - kHeader - 4) return {};
    return tile.subspan(kHeader + 4, size);
}

// The payload (emulation prevention removed) of the first NAL unit of `type` in an Annex B stream,
// after its header; empty when there is none.
std::vector<uint8_t> nal_payload(std::span<const uint8_t> stream, bool hevc, int type) {
    for (size_t i = 0; i + 3 < stream.size(); ++i) {
        if (!(stream[i] == 0 && stream[i + 1] == 0 && stream[i + 2] == 1)) continue;
        const size_t start = i + 3;
        const int nal_type = hevc ? (stream[start] >> 1) & 0x3f : stream[start] & 0x1f;
        if (nal_type != type) continue;
        std::vector<uint8_t> payload;
        int zeros = 0;
        for (size_t j = start + (hevc ? 2 : 1); j < stream.size(); ++j) {
            if (zeros >= 2 && stream[j] == 1) break; // the next start code
            if (zeros >= 2 && stream[j] == 3) {
                zeros = 0;
                continue;
            }
            zeros = stream[j] == 0 ? zeros + 1 : 0;
            payload.push_back(stream[j]);
        }
        return payload;
    }
    return {};
}

// What the SPS says of profile and level: H.264 profile_idc and level_idc are its first and third
// bytes; HEVC's profile_tier_level follows one byte, general_profile_idc in its first, level_idc in its
// twelfth.
struct SpsFacts {
    int profile = -1;
    int level = -1;
};
SpsFacts sps_facts(std::span<const uint8_t> stream, bool hevc) {
    const std::vector<uint8_t> sps = nal_payload(stream, hevc, hevc ? 33 : 7);
    SpsFacts facts;
    if (!hevc && sps.size() >= 3) facts = {sps[0], sps[2]};
    if (hevc && sps.size() >= 13) facts = {sps[1] & 0x1f, sps[12]};
    return facts;
}

// What FFmpeg's generic software decoder makes of a keyframe's access unit.
struct DecodedFacts {
    bool decoded = false;
    int profile = -1;
    int level = -1;
    AVPixelFormat format = AV_PIX_FMT_NONE;
    int bits = 0;
    AVColorRange range = AVCOL_RANGE_UNSPECIFIED;
    AVColorSpace matrix = AVCOL_SPC_UNSPECIFIED;
    int width = 0, height = 0;
};
DecodedFacts decode_generic(std::span<const uint8_t> stream, AVCodecID id) {
    DecodedFacts facts;
    const AVCodec *codec = avcodec_find_decoder(id);
    if (!codec) return facts;
    AVCodecContext *context = avcodec_alloc_context3(codec);
    AVPacket *packet = av_packet_alloc();
    AVFrame *frame = av_frame_alloc();
    if (context && packet && frame && avcodec_open2(context, codec, nullptr) >= 0 &&
        av_new_packet(packet, static_cast<int>(stream.size())) >= 0) {
        std::copy(stream.begin(), stream.end(), packet->data);
        avcodec_send_packet(context, packet);
        avcodec_send_packet(context, nullptr); // drain: the frame comes out now
        if (avcodec_receive_frame(context, frame) >= 0) {
            facts.decoded = true;
            facts.profile = context->profile;
            facts.level = context->level;
            facts.format = static_cast<AVPixelFormat>(frame->format);
            const AVPixFmtDescriptor *descriptor = av_pix_fmt_desc_get(facts.format);
            facts.bits = descriptor ? descriptor->comp[0].depth : 0;
            facts.range = frame->color_range;
            facts.matrix = frame->colorspace;
            facts.width = frame->width;
            facts.height = frame->height;
        }
    }
    av_frame_free(&frame);
    av_packet_free(&packet);
    avcodec_free_context(&context);
    return facts;
}

struct Yuv420Case {
    TileCodec codec;
    const char *name;
    AVCodecID id;
    bool hevc;
};

class Yuv420TileTest : public ::testing::TestWithParam<Yuv420Case> {
protected:
    std::unique_ptr<TileEncoder> encoder(uint32_t width, uint32_t height, uint32_t crf = 23,
                                         bool blue_first = false) {
        std::string error;
        auto made = make_tile_encoder(GetParam().codec, width, height, 4, &error,
                                      TileQuality{false, crf, blue_first});
        EXPECT_NE(made, nullptr) << error;
        return made;
    }
    std::unique_ptr<TileDecoder> decoder(uint32_t width, uint32_t height) {
        std::string error;
        auto made = make_tile_decoder(GetParam().codec, width, height, 4, &error, true);
        EXPECT_NE(made, nullptr) << error;
        return made;
    }
};

TEST_P(Yuv420TileTest, RoundTripIsCloseSmallerAndNamesItsDecoder) {
    constexpr uint32_t kWidth = 320, kHeight = 180;
    auto enc = encoder(kWidth, kHeight);
    auto dec = decoder(kWidth, kHeight);
    ASSERT_TRUE(enc && dec);
    EXPECT_EQ(dec->description(), "") << "nothing decoded yet";
    Pixels decoded(size_t{kWidth} * kHeight * 4);
    for (int frame = 0; frame < 4; ++frame) {
        const Pixels image = picture(kWidth, kHeight, frame);
        bool keyframe = false;
        const auto encoded = encode_ok(*enc, image, &keyframe);
        EXPECT_EQ(keyframe, frame == 0) << "frame " << frame;
        EXPECT_LT(encoded.size(), image.size() / 8) << "frame " << frame;
        EXPECT_EQ(encoded[8] | encoded[9] | encoded[10] | encoded[11], 0) << "a lossy tile has no checksum";
        std::string error;
        ASSERT_TRUE(dec->decode(encoded, decoded.data(), &error)) << "frame " << frame << ": " << error;
        EXPECT_GT(psnr_rgb(image, decoded), 32.0) << "frame " << frame;
        for (size_t i = 3; i < decoded.size(); i += 4)
            ASSERT_EQ(decoded[i], 255) << "alpha stays exact";
    }
    const std::string profile = GetParam().hevc ? "Main" : "High";
    const std::string decoder_name = GetParam().hevc ? "hevc" : "h264";
    const std::regex line(std::string(GetParam().name) + " " + profile + " 4:2:0, decoded by " +
                          decoder_name + R"( \((VA-API|CUDA|software: .+)\))");
    EXPECT_TRUE(std::regex_match(dec->description(), line)) << dec->description();
}

// The hardware decoders' constraints, read from the stream: at the largest part of a 2400x1080 eye pair
// (the whole periphery at scale 1: 1200x1080) and at the default 0.6 (720x648).
TEST_P(Yuv420TileTest, StreamIsWhatHardwareDecodersTake) {
    const bool hevc = GetParam().hevc;
    struct Size {
        uint32_t width, height;
        int level; // the lowest that fits at 90 Hz
    };
    // H.264: 720x648 is 1845 macroblocks, 166050 a second (3.2: 5120 and 216000); 1200x1080 is 5100,
    // 459000 a second (4.2: 8704 and 522240). HEVC: 466560 samples, 42 M/s (4: 66.8 M/s); 1296000,
    // 116.6 M/s (4.1: 133.7 M/s).
    const Size sizes[] = {{720, 648, hevc ? 120 : 32}, {1200, 1080, hevc ? 123 : 42}};
    for (const Size &size : sizes) {
        SCOPED_TRACE(std::to_string(size.width) + "x" + std::to_string(size.height));
        auto enc = encoder(size.width, size.height);
        ASSERT_TRUE(enc);
        const auto tile = encode_ok(*enc, picture(size.width, size.height, 0));
        const auto stream = access_unit(tile);
        ASSERT_FALSE(stream.empty());

        const SpsFacts sps = sps_facts(stream, hevc);
        if (hevc) {
            EXPECT_EQ(sps.profile, 1) << "general_profile_idc: Main";
        } else {
            EXPECT_TRUE(sps.profile == 100 || sps.profile == 77)
                << "profile_idc " << sps.profile << ": High or Main";
            EXPECT_NE(sps.profile, 244) << "High 4:4:4 Predictive";
        }
        EXPECT_EQ(sps.level, size.level) << "level_idc";

        const DecodedFacts facts = decode_generic(stream, GetParam().id);
        ASSERT_TRUE(facts.decoded);
        if (hevc)
            EXPECT_EQ(facts.profile, FF_PROFILE_HEVC_MAIN);
        else
            EXPECT_TRUE(facts.profile == FF_PROFILE_H264_HIGH || facts.profile == FF_PROFILE_H264_MAIN)
                << avcodec_profile_name(AV_CODEC_ID_H264, facts.profile);
        EXPECT_EQ(facts.level, size.level);
        EXPECT_TRUE(facts.format == AV_PIX_FMT_YUV420P || facts.format == AV_PIX_FMT_YUVJ420P)
            << av_get_pix_fmt_name(facts.format);
        EXPECT_EQ(facts.bits, 8);
        EXPECT_EQ(facts.range, AVCOL_RANGE_JPEG) << "full range, flagged";
        EXPECT_EQ(facts.matrix, AVCOL_SPC_BT709);
        EXPECT_EQ(facts.width, static_cast<int>(size.width));
        EXPECT_EQ(facts.height, static_cast<int>(size.height));
    }
}

// Red stays red in either byte order: the header says which byte is red, and the decoder writes it
// back there.
TEST_P(Yuv420TileTest, ChannelOrderTravelsWithTheTile) {
    constexpr uint32_t kWidth = 64, kHeight = 32;
    for (const bool blue_first : {false, true}) {
        SCOPED_TRACE(blue_first ? "B,G,R,A" : "R,G,B,A");
        Pixels image(size_t{kWidth} * kHeight * 4);
        for (size_t i = 0; i < image.size(); i += 4) {
            image[i + (blue_first ? 2 : 0)] = 230; // red
            image[i + 1] = 40;
            image[i + (blue_first ? 0 : 2)] = 20; // blue
            image[i + 3] = 255;
        }
        auto enc = encoder(kWidth, kHeight, 18, blue_first);
        auto dec = decoder(kWidth, kHeight);
        ASSERT_TRUE(enc && dec);
        Pixels decoded(image.size());
        std::string error;
        ASSERT_TRUE(dec->decode(encode_ok(*enc, image), decoded.data(), &error)) << error;
        EXPECT_GT(psnr_rgb(image, decoded), 38.0);
    }
}

// Odd sizes are coded one texel larger and cut on decoding; alpha travels beside the planes.
TEST_P(Yuv420TileTest, OddSizesAndAlpha) {
    constexpr uint32_t kWidth = 37, kHeight = 19;
    auto enc = encoder(kWidth, kHeight);
    auto dec = decoder(kWidth, kHeight);
    ASSERT_TRUE(enc && dec);
    Pixels image = picture(kWidth, kHeight, 0);
    for (size_t i = 3; i < image.size(); i += 4)
        image[i] = static_cast<uint8_t>(i * 7);
    Pixels decoded(image.size());
    std::string error;
    ASSERT_TRUE(dec->decode(encode_ok(*enc, image), decoded.data(), &error)) << error;
    EXPECT_GT(psnr_rgb(image, decoded), 28.0);
    for (size_t i = 3; i < image.size(); i += 4)
        ASSERT_EQ(decoded[i], image[i]) << "alpha is lossless";
}

// Malformed input fails with one line, never crashes: every truncation, a flipped bit in every
// byte of a small tile, and a non-keyframe without its keyframe.
TEST_P(Yuv420TileTest, MalformedTilesFailCleanly) {
    constexpr uint32_t kWidth = 48, kHeight = 32;
    auto enc = encoder(kWidth, kHeight);
    ASSERT_TRUE(enc);
    const auto keyframe = encode_ok(*enc, picture(kWidth, kHeight, 0));
    const auto next = encode_ok(*enc, picture(kWidth, kHeight, 1));
    Pixels decoded(size_t{kWidth} * kHeight * 4);
    for (size_t length = 0; length < keyframe.size(); ++length) {
        auto dec = decoder(kWidth, kHeight);
        std::string error;
        EXPECT_FALSE(dec->decode(std::span(keyframe).first(length), decoded.data(), &error)) << length;
        EXPECT_FALSE(error.empty());
    }
    for (size_t i = 0; i < keyframe.size(); ++i) {
        auto damaged = keyframe;
        damaged[i] ^= static_cast<uint8_t>(1u << (i % 8));
        auto dec = decoder(kWidth, kHeight);
        std::string error;
        if (!dec->decode(damaged, decoded.data(), &error)) {
            EXPECT_FALSE(error.empty()) << i;
        }
    }
    auto dec = decoder(kWidth, kHeight);
    std::string error;
    EXPECT_FALSE(dec->decode(next, decoded.data(), &error));
    EXPECT_NE(error.find("non-keyframe"), std::string::npos) << error;
    EXPECT_TRUE(dec->decode(keyframe, decoded.data(), &error)) << error;
    EXPECT_TRUE(dec->decode(next, decoded.data(), &error)) << error;
}

// A 4:2:0 tile is never a fovea's: no lossless decoder is made for the codec, an x264 decoder refuses
// the tile as another codec's, and the tile's texel size reads as 4.
TEST_P(Yuv420TileTest, NeverAFoveaTile) {
    constexpr uint32_t kWidth = 32, kHeight = 16;
    std::string error;
    EXPECT_EQ(make_tile_decoder(GetParam().codec, kWidth, kHeight, 4, &error, false), nullptr);
    EXPECT_NE(error.find("lossy"), std::string::npos) << error;
    EXPECT_EQ(make_tile_encoder(GetParam().codec, kWidth, kHeight, 8, &error, TileQuality{false, 23}),
              nullptr);
    auto enc = encoder(kWidth, kHeight);
    ASSERT_TRUE(enc);
    const auto tile = encode_ok(*enc, picture(kWidth, kHeight, 0));
    EXPECT_EQ(peek_texel_bytes(tile), 4u);
    auto x264 = make_tile_decoder(TileCodec::X264, kWidth, kHeight, 4, &error, true);
    ASSERT_NE(x264, nullptr) << error;
    Pixels decoded(size_t{kWidth} * kHeight * 4);
    EXPECT_FALSE(x264->decode(tile, decoded.data(), &error));
    EXPECT_NE(error.find("codec id"), std::string::npos) << error;
}

INSTANTIATE_TEST_SUITE_P(Codecs, Yuv420TileTest,
                         ::testing::Values(Yuv420Case{TileCodec::H264Yuv420, "h264", AV_CODEC_ID_H264, false},
                                           Yuv420Case{TileCodec::HevcYuv420, "hevc", AV_CODEC_ID_HEVC, true}),
                         [](const ::testing::TestParamInfo<Yuv420Case> &p) {
                             return std::string(p.param.name);
                         });

// The conversion alone: grey stays exactly grey (each matrix row sums to one, chroma to zero), and
// flat colours come back within a step of rounding.
TEST(Yuv420Conversion, GreyIsExactAndFlatColoursClose) {
    constexpr uint32_t kWidth = 6, kHeight = 4;
    const uint8_t colours[][3] = {{0, 0, 0},   {255, 255, 255}, {128, 128, 128}, {17, 17, 17},
                                  {255, 0, 0}, {0, 255, 0},     {0, 0, 255},     {200, 120, 30}};
    for (const auto &colour : colours) {
        Pixels rgb(size_t{kWidth} * kHeight * 4);
        for (size_t i = 0; i < rgb.size(); i += 4) {
            rgb[i] = colour[0];
            rgb[i + 1] = colour[1];
            rgb[i + 2] = colour[2];
            rgb[i + 3] = 255;
        }
        std::vector<uint8_t> y(kWidth * kHeight), u(kWidth * kHeight / 4), v(u.size());
        const Yuv420Planes planes{y.data(), u.data(), v.data(), kWidth, kWidth / 2, 1};
        rgb_to_yuv420(rgb.data(), kWidth * 4, kWidth, kHeight, ChannelOrder{}, planes, kWidth, kHeight);
        std::vector<int32_t> scratch(kWidth);
        Pixels row(kWidth * 4);
        const bool grey = colour[0] == colour[1] && colour[1] == colour[2];
        for (uint32_t r = 0; r < kHeight; ++r) {
            yuv420_row_to_rgb(planes, kWidth, kHeight, r, ChannelOrder{}, scratch.data(), row.data());
            for (uint32_t x = 0; x < kWidth; ++x)
                for (int c = 0; c < 3; ++c) {
                    const int got = row[x * 4 + c], want = colour[c];
                    if (grey)
                        ASSERT_EQ(got, want) << "grey " << want;
                    else
                        ASSERT_LE(std::abs(got - want), 2)
                            << "colour " << int(colour[0]) << "," << int(colour[1]) << "," << int(colour[2])
                            << " channel " << c;
                }
        }
    }
}

} // namespace
} // namespace splitvk::tiles
