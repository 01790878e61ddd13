// The tile codecs are bit-exact on tiles the sample actually renders, not only on synthetic
// patterns: splitvk-atrium runs natively (no splitvk layer), stereo, at 1200x540; frames 3, 4 and 5
// are read from the X server; the fovea of each eye is cut out as production cuts it; and each
// codec streams each eye's three tiles through one encoder and one decoder per eye, the two eyes
// on their own threads at once, as the agent and the layer do. Every decoded tile must equal its
// input byte for byte, all four bytes. Alpha comes in two variants: opaque (255, the usual
// swapchain; the X server's fourth byte is padding, 255 on Xvfb), and a gradient so that the x264
// alpha path carries real data beside real colour.
//
// It prints the compressed/raw ratio of each codec (keyframe and following frames) and the time
// per tile; they are information, not pass/fail (timings belong in benchmarks).
#include "e2e_test.h"
#include "settings.h"
#include "tile_codec.h"

#include <chrono>
#include <cstdio>
#include <cstring>
#include <thread>

namespace splitvk::e2e {
namespace {

using tiles::TileDecoder;
using tiles::TileEncoder;

constexpr uint32_t kWidth = 1200; // two 600x540 eyes
constexpr uint32_t kHeight = 540;
constexpr uint32_t kEyes = 2;
constexpr int kFirstFrame = 3;
constexpr int kFrameCount = 3; // frames 3, 4, 5: a keyframe and two frames coded from their predecessor
constexpr size_t kMinDistinctColours = 500;

enum class Alpha { Opaque, Gradient };
const char *alpha_name(Alpha alpha) {
    switch (alpha) {
    case Alpha::Opaque:
        return "opaque";
    case Alpha::Gradient:
        return "alpha gradient";
    }
    return "?";
}

struct Rect {
    uint32_t x, y, width, height;
};

// The fovea of eye `eye`: the default fovea size for the eye, centred in it (docs/architecture.md §4).
Rect fovea_rect(uint32_t eye) {
    const uint32_t eye_width = kWidth / kEyes;
    const auto [width, height] = FoveaSize{}.pixels_for_eye(eye_width, kHeight);
    return Rect{eye * eye_width + (eye_width - width) / 2, (kHeight - height) / 2, width, height};
}

std::vector<uint8_t> crop(const Image &image, const Rect &rect, Alpha alpha) {
    std::vector<uint8_t> tile(size_t{rect.width} * rect.height * 4);
    for (uint32_t y = 0; y < rect.height; ++y) {
        uint8_t *row = &tile[size_t{y} * rect.width * 4];
        std::memcpy(row, image.pixel(rect.x, rect.y + y), size_t{rect.width} * 4);
        for (uint32_t x = 0; x < rect.width; ++x) {
            row[x * 4 + 3] = alpha == Alpha::Opaque ? 255 : static_cast<uint8_t>((x + 2 * y) / 3);
        }
    }
    return tile;
}

// What one eye's stream did: sizes and times per frame, or the first failure.
struct EyeResult {
    std::string failure;
    std::vector<size_t> encoded_sizes;
    std::vector<bool> keyframes;
    double encode_ms = 0, decode_ms = 0;
};

// One eye's stream, as in production: one encoder and one decoder, the tiles in order.
EyeResult stream_eye(TileCodec codec, const Rect &rect, const std::vector<std::vector<uint8_t>> &tiles) {
    EyeResult result;
    std::string error;
    std::unique_ptr<TileEncoder> encoder =
        tiles::make_tile_encoder(codec, rect.width, rect.height, 4, &error);
    std::unique_ptr<TileDecoder> decoder =
        tiles::make_tile_decoder(codec, rect.width, rect.height, 4, &error);
    if (!encoder || !decoder) {
        result.failure = "cannot create the codec: " + error;
        return result;
    }
    std::vector<uint8_t> encoded;
    std::vector<uint8_t> decoded(tiles.front().size());
    for (size_t i = 0; i < tiles.size(); ++i) {
        const std::string frame = "frame " + std::to_string(kFirstFrame + static_cast<int>(i));
        bool keyframe = false;
        const auto start = std::chrono::steady_clock::now();
        if (!encoder->encode(tiles[i].data(), encoded, &keyframe, &error)) {
            result.failure = frame + ": encode failed: " + error;
            return result;
        }
        const auto encoded_at = std::chrono::steady_clock::now();
        if (!decoder->decode(encoded, decoded.data(), &error)) {
            result.failure = frame + ": decode failed: " + error;
            return result;
        }
        const auto decoded_at = std::chrono::steady_clock::now();
        result.encode_ms += std::chrono::duration<double, std::milli>(encoded_at - start).count();
        result.decode_ms += std::chrono::duration<double, std::milli>(decoded_at - encoded_at).count();
        if (decoded != tiles[i]) {
            size_t at = 0;
            while (decoded[at] == tiles[i][at])
                ++at;
            result.failure = frame + ": decoded tile differs from the input, first at pixel (" +
                             std::to_string(at / 4 % rect.width) + "," + std::to_string(at / 4 / rect.width) +
                             ") byte " + std::to_string(at % 4) + ": " + std::to_string(tiles[i][at]) +
                             " became " + std::to_string(decoded[at]);
            return result;
        }
        result.encoded_sizes.push_back(encoded.size());
        result.keyframes.push_back(keyframe);
    }
    return result;
}

class TileCodecOnAtrium : public XTest, public ::testing::WithParamInterface<TileCodec> {
protected:
    void SetUp() override {
        XTest::SetUp();
        ASSERT_TRUE(built(atrium_path()));
    }

    // Renders frames 0..frame natively, holds the last one and reads it from the X server.
    void render_frame(int frame, Image *image) {
        ProcessSpec spec;
        spec.argv = {atrium_path().string(),    "--width", std::to_string(kWidth), "--height",
                     std::to_string(kHeight),   "--eyes",  std::to_string(kEyes),  "--frames",
                     std::to_string(frame + 1), "--hold"};
        spec.env = env();
        spec.out_dir = out_;
        spec.name = "atrium-frame" + std::to_string(frame);
        Process atrium(spec);
        ASSERT_TRUE(atrium.start()) << atrium.error();
        const std::string holding = "holding frame " + std::to_string(frame);
        if (!atrium.wait_for_line(holding, std::chrono::seconds(60))) {
            auto r = atrium.terminate(std::chrono::seconds(5));
            FAIL() << "atrium never printed '" << holding << "': " << r.describe() << "\n" << r.err();
        }
        std::string error;
        const bool grabbed = grab_stable(display(), 0, 0, kWidth, kHeight,
                                         out_ / ("frame" + std::to_string(frame) + ".raw"), image, &error);
        auto r = atrium.terminate(std::chrono::seconds(10));
        ASSERT_TRUE(grabbed) << error;
        ASSERT_TRUE(r.ok()) << "atrium did not exit 0 on SIGTERM: " << r.describe() << "\n" << r.err();
    }
};

TEST_P(TileCodecOnAtrium, FoveaTilesRoundTripBitExactly) {
    const TileCodec codec = GetParam();
    std::vector<Image> frames(kFrameCount);
    for (int i = 0; i < kFrameCount; ++i)
        ASSERT_NO_FATAL_FAILURE(render_frame(kFirstFrame + i, &frames[static_cast<size_t>(i)]));
    const size_t colours = distinct_colours(frames[0]);
    ASSERT_GT(colours, kMinDistinctColours) << "frame " << kFirstFrame << " looks blank";
    for (int i = 1; i < kFrameCount; ++i)
        ASSERT_NE(frames[static_cast<size_t>(i)].bgr0, frames[static_cast<size_t>(i - 1)].bgr0)
            << "frames " << kFirstFrame + i - 1 << " and " << kFirstFrame + i
            << " are identical: the sequence would not exercise coding from the previous frame";

    for (Alpha alpha : {Alpha::Opaque, Alpha::Gradient}) {
        SCOPED_TRACE(alpha_name(alpha));
        std::vector<Rect> rects;
        std::vector<std::vector<std::vector<uint8_t>>> eye_tiles(kEyes);
        for (uint32_t eye = 0; eye < kEyes; ++eye) {
            rects.push_back(fovea_rect(eye));
            for (const Image &frame : frames)
                eye_tiles[eye].push_back(crop(frame, rects[eye], alpha));
        }

        // The eyes in parallel, one thread each, as in the agent and the layer.
        std::vector<EyeResult> results(kEyes);
        std::vector<std::thread> threads;
        for (uint32_t eye = 0; eye < kEyes; ++eye)
            threads.emplace_back([&, eye] { results[eye] = stream_eye(codec, rects[eye], eye_tiles[eye]); });
        for (auto &thread : threads)
            thread.join();

        size_t raw_bytes_per_frame = 0, keyframe_bytes = 0, later_bytes = 0;
        double encode_ms = 0, decode_ms = 0;
        for (uint32_t eye = 0; eye < kEyes; ++eye) {
            const EyeResult &result = results[eye];
            ASSERT_TRUE(result.failure.empty())
                << to_string(codec) << ", eye " << eye << " (" << rects[eye].width << "x" << rects[eye].height
                << " at " << rects[eye].x << "," << rects[eye].y << "): " << result.failure;
            EXPECT_TRUE(result.keyframes[0]) << "the first tile of a stream must be a keyframe";
            keyframe_bytes += result.encoded_sizes[0];
            for (size_t i = 1; i < result.encoded_sizes.size(); ++i) {
                EXPECT_EQ(result.keyframes[i], codec == TileCodec::Raw) << "frame " << kFirstFrame + i;
                later_bytes += result.encoded_sizes[i];
            }
            raw_bytes_per_frame += eye_tiles[eye][0].size();
            encode_ms += result.encode_ms;
            decode_ms += result.decode_ms;
        }
        const double tile_count = kEyes * kFrameCount;
        const double keyframe_ratio = static_cast<double>(keyframe_bytes) / raw_bytes_per_frame;
        const double later_ratio =
            static_cast<double>(later_bytes) / (raw_bytes_per_frame * (kFrameCount - 1));
        std::printf("  %-4s %-16s %ux%u tiles: compressed/raw %.3f keyframe, %.3f following frames; "
                    "%.2f ms encode, %.2f ms decode per tile\n",
                    to_string(codec), alpha_name(alpha), rects[0].width, rects[0].height, keyframe_ratio,
                    later_ratio, encode_ms / tile_count, decode_ms / tile_count);
        const std::string key = alpha == Alpha::Opaque ? "opaque" : "alpha_gradient";
        RecordProperty(key + "_keyframe_ratio", std::to_string(keyframe_ratio));
        RecordProperty(key + "_following_ratio", std::to_string(later_ratio));
    }
}

INSTANTIATE_TEST_SUITE_P(tile_codec, TileCodecOnAtrium,
                         ::testing::Values(TileCodec::X264, TileCodec::Zstd, TileCodec::Raw),
                         [](const ::testing::TestParamInfo<TileCodec> &p) {
                             return std::string(to_string(p.param));
                         });

} // namespace
} // namespace splitvk::e2e
