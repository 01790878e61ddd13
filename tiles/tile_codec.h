#pragma once

// Codecs for the tiles the agent streams back to the layer (docs/architecture.md §5): the fovea tiles, always
// lossless, and in the swapped split the parts of the downsampled periphery, which may be
// lossy.
//
// A tile is width*height texels of 4 or 8 bytes (its stream's texel size, tile_format.h's
// tile_texel_bytes of the image's format), rows tightly packed, as the image stores them (B,G,R,A or
// R,G,B,A bytes; four 16-bit channels). The codecs never interpret channel order. A lossless tile
// guarantees that decode(encode(x)) == x byte for byte, every byte including alpha.
//
// Codecs (splitvk::TileCodec):
//  - X264 (4-byte texels only): H.264 (x264, High 4:4:4 Predictive, RGB coded as GBR planes), decoded with
//  FFmpeg's h264
//    decoder. Lossless: CQP qp 0. Lossy (TileQuality::lossless false): constant quality (CRF) on the
//    same GBR planes, so no colour conversion rounds; such tiles carry no checksum, and a decoder
//    accepts them only when made with accept_lossy, so that a fovea tile is never lossy. Alpha
//    travels beside it, losslessly: nothing when every alpha byte is 255, else the alpha plane
//    zstd-compressed (intra only).
//  - H264Yuv420, HevcYuv420 (4-byte texels, the swapped split's periphery only): always lossy, at a CRF,
//    through libavcodec's libx264 (H.264 High) and libx265 (HEVC Main) encoders on Y'CbCr 4:2:0, BT.709,
//    full range (yuv420.h), at the lowest level whose picture size and sample rate fit the stream at
//    90 Hz: what the hardware decoders of headsets take (x264's RGB modes are High 4:4:4 Predictive,
//    which they do not). Decoded with FFmpeg's h264 / hevc decoder, through VA-API or NVDEC (CUDA)
//    where the machine has a device, else in software. Red and blue are the bytes the tile's header
//    names (TileQuality::blue_first); alpha travels beside the planes as for X264. Odd sizes are
//    coded one texel larger, the last column or row repeated, and cut on decoding.
//  - Zstd: zstd level 1 on the byte-wise difference from the stream's previous tile. Always lossless.
//  - Raw: the texels as they are.
//
// Every encoded tile starts with the same 12-byte header (format version, codec, keyframe, alpha,
// lossy and 8-byte-texel flags, width, height, a checksum of the texels), so validation, the keyframe
// rule and the check that decoding gave back exactly the encoder's input are the same for every
// codec. A 4-byte tile's header is what it was before tiles had a texel size.
//
// One encoder and one decoder per eye stream; frames of a stream have a fixed size and texel size (a
// new one takes a new encoder and decoder). Encoders and decoders of different streams may run on
// different threads at once; one object is used by one thread at a time. The X264 encoder and
// decoder each run 2 slice threads of their own.

#include "settings.h"

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace splitvk::tiles {

// Size of the header every encoded tile starts with.
inline constexpr size_t kTileHeaderSize = 12;

class TileEncoder {
public:
    virtual ~TileEncoder();

    // Encodes the next frame of this stream from width*height*texel_bytes bytes at `pixels` into `out`
    // (replacing its contents). *keyframe tells whether the tile can be decoded alone. False with
    // one line in *error when the codec fails (`out` is then not a tile); the next frame is then a
    // keyframe.
    virtual bool encode(const uint8_t *pixels, std::vector<uint8_t> &out, bool *keyframe,
                        std::string *error) = 0;

    // The next encode produces a keyframe (an IDR for x264): after a (re)connect, or when the
    // decoder reported a failure.
    virtual void force_keyframe() = 0;
};

class TileDecoder {
public:
    virtual ~TileDecoder();

    // Decodes one encoded tile into `pixels` (width*height*texel_bytes bytes), writing each byte once, whole
    // rows in order, and never reading them back (the checksum is summed before they are stored):
    // `pixels` may be mapped, uncached device memory (the layer's upload buffer), with no copy of
    // the tile in between. Malformed input of any kind returns false with one line in *error:
    // never a crash, an over-read or an unbounded allocation. On failure `pixels` may have been
    // partly or wholly written: do not use them.
    // A non-keyframe before the first keyframe is an error, and so is a non-keyframe after a
    // failed decode: the stream's reference is lost until the encoder sends a keyframe. A tile of
    // another texel size than the decoder's is an error.
    virtual bool decode(std::span<const uint8_t> data, uint8_t *pixels, std::string *error) = 0;

    // What the stream is and what decodes it, read from the last decoded frame, for one log line:
    // "h264 High 4:2:0, decoded by h264 (software: no VA-API device, no CUDA device)". Empty before
    // the first frame, and for the codecs that are no video streams.
    virtual std::string description() const;
};

// How an encoder codes its stream. Lossy applies to X264 only (CRF `crf`, 0 best .. 51, with x264's
// zerolatency tune: no B-frames, no lookahead, every frame out at once); Zstd and Raw ignore it and
// stay lossless. The 4:2:0 codecs are lossy whatever `lossless` says, and need to know which byte of a
// texel is red (`blue_first`: B,G,R,A); the others never look at channels.
struct TileQuality {
    bool lossless = true;
    uint32_t crf = 23;
    bool blue_first = false;
    bool operator==(const TileQuality &) const = default;
};

// Null with *error when the codec cannot be set up for this size (width and height 1..16384),
// texel size (4 or 8; X264 takes 4 only) or quality (crf above 51).
std::unique_ptr<TileEncoder> make_tile_encoder(TileCodec codec, uint32_t width, uint32_t height,
                                               uint32_t texel_bytes, std::string *error,
                                               const TileQuality &quality = {});
// A decoder without `accept_lossy` refuses a lossy tile as an error; a 4:2:0 codec's cannot be made
// without it.
std::unique_ptr<TileDecoder> make_tile_decoder(TileCodec codec, uint32_t width, uint32_t height,
                                               uint32_t texel_bytes, std::string *error,
                                               bool accept_lossy = false);

// The texel size a tile's header declares (4 or 8), read without decoding it: what to make the
// decoder and size the pixels for before checking them against the image. 0 for a span too short
// for the header, or a header no decoder would take (unknown version, codec or flags, an empty
// size, 8-byte texels in an x264 tile).
uint32_t peek_texel_bytes(std::span<const uint8_t> tile);

} // namespace splitvk::tiles
