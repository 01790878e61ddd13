// splitvk-fuzz-tile-seeds RAW WIDTH HEIGHT OUTDIR
//
// Seeds for fuzz_tile_decoder from real frames: RAW holds consecutive WIDTHxHEIGHT BGRA frames (as
// `ffmpeg -f x11grab ... -f rawvideo -pix_fmt bgra` writes them while splitvk-atrium runs). For
// each codec and each fuzz tile size it cuts the centre of up to kFuzzMaxTiles frames, encodes them
// as one stream (a keyframe, then differences) and writes the input format fuzz_targets.h
// describes. Scripts/fuzz runs it; the seeds go to the build tree, never into the repository.

#include "fuzz_targets.h"
#include "tile_codec.h"
#include "wire.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

int main(int argc, char **argv) {
    using namespace splitvk;
    if (argc != 5) {
        std::fprintf(stderr, "usage: %s RAW WIDTH HEIGHT OUTDIR\n", argv[0]);
        return 2;
    }
    const uint32_t width = static_cast<uint32_t>(std::strtoul(argv[2], nullptr, 10));
    const uint32_t height = static_cast<uint32_t>(std::strtoul(argv[3], nullptr, 10));
    std::ifstream in(argv[1], std::ios::binary);
    const std::vector<uint8_t> raw((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const size_t frame_bytes = size_t{width} * height * 4;
    const size_t frames = frame_bytes ? raw.size() / frame_bytes : 0;
    if (frames == 0) {
        std::fprintf(stderr, "%s: no whole %ux%u BGRA frame in it\n", argv[1], width, height);
        return 1;
    }
    const struct {
        TileCodec codec;
        const char *name;
    } codecs[] = {{TileCodec::X264, "x264"}, {TileCodec::Zstd, "zstd"}, {TileCodec::Raw, "raw"}};
    int written = 0;
    for (uint8_t c = 0; c < 3; ++c) {
        for (uint8_t s = 0; s < fuzz::kFuzzTileSizeCount; ++s) {
            const auto tile = fuzz::kFuzzTileSizes[s];
            if (tile.width > width || tile.height > height) continue;
            std::string error;
            auto encoder = tiles::make_tile_encoder(codecs[c].codec, tile.width, tile.height, 4, &error);
            if (!encoder) {
                std::fprintf(stderr, "%s %ux%u: %s\n", codecs[c].name, tile.width, tile.height,
                             error.c_str());
                return 1;
            }
            std::vector<uint8_t> seed = {c, s};
            std::vector<uint8_t> pixels(size_t{tile.width} * tile.height * 4);
            const uint32_t x0 = (width - tile.width) / 2, y0 = (height - tile.height) / 2;
            for (size_t f = 0; f < std::min(frames, fuzz::kFuzzMaxTiles); ++f) {
                for (uint32_t y = 0; y < tile.height; ++y) {
                    const uint8_t *row = raw.data() + f * frame_bytes + (size_t{y0 + y} * width + x0) * 4;
                    std::copy(row, row + size_t{tile.width} * 4, pixels.begin() + size_t{y} * tile.width * 4);
                }
                std::vector<uint8_t> encoded;
                bool keyframe = false;
                if (!encoder->encode(pixels.data(), encoded, &keyframe, &error)) {
                    std::fprintf(stderr, "%s: %s\n", codecs[c].name, error.c_str());
                    return 1;
                }
                uint8_t length[4];
                protocol::store_le32(length, static_cast<uint32_t>(encoded.size()));
                seed.insert(seed.end(), length, length + 4);
                seed.insert(seed.end(), encoded.begin(), encoded.end());
            }
            const std::string path = std::string(argv[4]) + "/" + codecs[c].name + "-" +
                                     std::to_string(tile.width) + "x" + std::to_string(tile.height);
            std::ofstream out(path, std::ios::binary);
            out.write(reinterpret_cast<const char *>(seed.data()), static_cast<std::streamsize>(seed.size()));
            if (!out) {
                std::fprintf(stderr, "%s: cannot write it\n", path.c_str());
                return 1;
            }
            ++written;
            if (codecs[c].codec == TileCodec::X264) continue;
            // The same frames as an RGBA16 image holds them (each byte widened to 16 bits), for the
            // 8-byte decoders (byte 0 + 6: fuzz_targets.h).
            auto wide = tiles::make_tile_encoder(codecs[c].codec, tile.width, tile.height, 8, &error);
            if (!wide) {
                std::fprintf(stderr, "%s %ux%u, 8-byte texels: %s\n", codecs[c].name, tile.width, tile.height,
                             error.c_str());
                return 1;
            }
            std::vector<uint8_t> wide_seed = {static_cast<uint8_t>(c + 6), s};
            std::vector<uint8_t> wide_pixels(pixels.size() * 2);
            for (size_t f = 0; f < std::min(frames, fuzz::kFuzzMaxTiles); ++f) {
                for (uint32_t y = 0; y < tile.height; ++y)
                    for (uint32_t x = 0; x < tile.width * 4; ++x) {
                        const uint8_t byte = raw[f * frame_bytes + (size_t{y0 + y} * width + x0) * 4 + x];
                        wide_pixels[(size_t{y} * tile.width * 4 + x) * 2] = byte;
                        wide_pixels[(size_t{y} * tile.width * 4 + x) * 2 + 1] = byte;
                    }
                std::vector<uint8_t> encoded;
                bool keyframe = false;
                if (!wide->encode(wide_pixels.data(), encoded, &keyframe, &error)) {
                    std::fprintf(stderr, "%s: %s\n", codecs[c].name, error.c_str());
                    return 1;
                }
                uint8_t length[4];
                protocol::store_le32(length, static_cast<uint32_t>(encoded.size()));
                wide_seed.insert(wide_seed.end(), length, length + 4);
                wide_seed.insert(wide_seed.end(), encoded.begin(), encoded.end());
            }
            std::ofstream wide_out(path + "-rgba16", std::ios::binary);
            wide_out.write(reinterpret_cast<const char *>(wide_seed.data()),
                           static_cast<std::streamsize>(wide_seed.size()));
            if (!wide_out) {
                std::fprintf(stderr, "%s-rgba16: cannot write it\n", path.c_str());
                return 1;
            }
            ++written;
        }
    }
    std::printf("wrote %d tile seeds from %zu frames to %s\n", written, frames, argv[4]);
    return 0;
}
