#include "tile_codec.h"

#include "yuv420.h"

#include <algorithm>
#include <climits>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <mutex>

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavutil/frame.h>
#include <libavutil/hwcontext.h>
#include <libavutil/log.h>
#include <libavutil/pixdesc.h>
#include <libavutil/pixfmt.h>
#include <x264.h>
}
#include <dlfcn.h>
#include <unistd.h>
#include <zstd.h>

namespace splitvk::tiles {

TileEncoder::~TileEncoder() = default;
TileDecoder::~TileDecoder() = default;
std::string TileDecoder::description() const {
    return {};
}

namespace {

// Encoded tile layout, version 1 (integers little-endian):
//
//   header   u8 format version (1), u8 codec (1 x264, 2 zstd, 3 raw), u8 flags, u8 zero,
//            u16 width, u16 height, u32 tile_checksum() of the width*height*T texel bytes (0 for
//            a lossy tile, whose decoded pixels are not the encoder's input); T is 8 with
//            kWideTexels, else 4
//   x264     u32 size of the H.264 access unit, the access unit (Annex B), then with kAlphaPlane
//            exactly one zstd frame holding the width*height alpha bytes, else nothing
//   h264, hevc (4 and 5): as x264, the access unit H.264 or HEVC of Y'CbCr 4:2:0; always kLossy
//   zstd     exactly one zstd frame holding the width*height*T byte differences
//   raw      the width*height*T bytes
//
// 8-byte texels are a flag rather than a new version: a 4-byte tile stays byte for byte what it
// was, and a decoder from before them refuses an 8-byte tile as one of unknown flags.
constexpr uint8_t kFormatVersion = 1;
constexpr uint8_t kKeyframe = 1u << 0;
constexpr uint8_t kAlphaPlane = 1u << 1; // x264 only; without it every alpha byte is 255
constexpr uint8_t kLossy = 1u << 2;      // x264 only: coded at a CRF, no checksum
constexpr uint8_t kWideTexels = 1u << 3; // 8-byte texels; zstd and raw only
constexpr uint8_t kBlueFirst = 1u << 4;  // 4:2:0 only: byte 0 of a texel is blue (B,G,R,A)
constexpr uint8_t kKnownFlags = kKeyframe | kAlphaPlane | kLossy | kWideTexels | kBlueFirst;

constexpr uint32_t kMaxTileSide = 16384;
constexpr int kZstdLevel = 1;

uint8_t wire_id(TileCodec codec) {
    switch (codec) {
    case TileCodec::X264:
        return 1;
    case TileCodec::Zstd:
        return 2;
    case TileCodec::Raw:
        return 3;
    case TileCodec::H264Yuv420:
        return 4;
    case TileCodec::HevcYuv420:
        return 5;
    }
    return 0;
}

void put_u16(std::vector<uint8_t> &out, uint32_t value) {
    out.push_back(static_cast<uint8_t>(value));
    out.push_back(static_cast<uint8_t>(value >> 8));
}

void put_u32(std::vector<uint8_t> &out, uint32_t value) {
    put_u16(out, value & 0xffffu);
    put_u16(out, value >> 16);
}

uint32_t get_u16(const uint8_t *p) {
    return uint32_t{p[0]} | uint32_t{p[1]} << 8;
}

uint32_t get_u32(const uint8_t *p) {
    return get_u16(p) | get_u16(p + 2) << 16;
}

uint64_t get_u64(const uint8_t *p) {
    return uint64_t{get_u32(p)} | uint64_t{get_u32(p + 4)} << 32;
}

// A checksum of the tile's pixels, carried in the header and checked after decoding. Neither H.264
// nor zstd frames without a checksum notice most damage (a flipped bit usually decodes to other
// pixels), and an encoder/decoder pair that disagreed (library versions on two machines) would
// composite wrong pixels silently. Four independent multiply lanes keep it at memory speed; it
// is not cryptographic.
//
// TileChecksum takes the bytes in pieces (a decoder's rows as it packs them, so that it never reads
// back the upload memory it writes, which may be uncached); tile_checksum() is it over one piece.
class TileChecksum {
public:
    void update(const uint8_t *bytes, size_t size) {
        total_ += size;
        if (pending_ > 0) {
            const size_t take = std::min(kBlock - pending_, size);
            std::memcpy(block_ + pending_, bytes, take);
            pending_ += take;
            bytes += take;
            size -= take;
            if (pending_ < kBlock) return;
            mix(block_);
            pending_ = 0;
        }
        for (; size >= kBlock; bytes += kBlock, size -= kBlock)
            mix(bytes);
        std::memcpy(block_, bytes, size);
        pending_ = size;
    }

    uint32_t finish() const {
        uint64_t hash = total_;
        for (uint64_t lane : lanes_)
            hash = (hash ^ lane) * kOdd;
        for (size_t i = 0; i < pending_; ++i)
            hash = (hash ^ block_[i]) * kOdd;
        hash ^= hash >> 29;
        hash *= kOdd;
        return static_cast<uint32_t>(hash ^ hash >> 32);
    }

private:
    static constexpr uint64_t kOdd = 0x9e3779b97f4a7c15ull; // odd: each step is a bijection of the lane
    static constexpr size_t kBlock = 32;                    // four lanes of eight bytes

    void mix(const uint8_t *block) {
        for (size_t lane = 0; lane < 4; ++lane)
            lanes_[lane] = (lanes_[lane] ^ get_u64(block + lane * 8)) * kOdd;
    }

    uint64_t lanes_[4] = {1, 2, 3, 4};
    uint64_t total_ = 0;
    uint8_t block_[kBlock] = {};
    size_t pending_ = 0;
};

uint32_t tile_checksum(const uint8_t *bytes, size_t size) {
    TileChecksum checksum;
    checksum.update(bytes, size);
    return checksum.finish();
}

// The geometry of one stream's tiles.
struct TileShape {
    uint32_t width = 0;
    uint32_t height = 0;
    uint32_t texel_bytes = 4;

    size_t bytes() const { return size_t{width} * height * texel_bytes; }
};

// Starts `out` with the header of a tile of `pixels`; a lossy one carries no checksum.
void put_header(std::vector<uint8_t> &out, TileCodec codec, uint8_t flags, const TileShape &shape,
                const uint8_t *pixels) {
    if (shape.texel_bytes == 8) flags |= kWideTexels;
    out.clear();
    out.push_back(kFormatVersion);
    out.push_back(wire_id(codec));
    out.push_back(flags);
    out.push_back(0);
    put_u16(out, shape.width);
    put_u16(out, shape.height);
    put_u32(out, (flags & kLossy) ? 0 : tile_checksum(pixels, shape.bytes()));
}

bool fail(std::string *error, std::string message) {
    if (error) *error = std::move(message);
    return false;
}

std::string size_text(uint32_t width, uint32_t height) {
    return std::to_string(width) + "x" + std::to_string(height);
}

struct TileHeader {
    uint8_t flags;
    uint32_t checksum;
};

// Checks the header against the decoder's codec, tile size and texel size. What follows the header
// is the codec's body.
bool read_header(std::span<const uint8_t> data, TileCodec codec, const TileShape &shape, TileHeader *header,
                 std::string *error) {
    const char *name = splitvk::to_string(codec);
    if (data.size() < kTileHeaderSize)
        return fail(error, std::string(name) + " tile: " + std::to_string(data.size()) +
                               " bytes, shorter than the " + std::to_string(kTileHeaderSize) +
                               "-byte header");
    if (data[0] != kFormatVersion)
        return fail(error, std::string(name) + " tile: format version " + std::to_string(data[0]) +
                               ", expected " + std::to_string(kFormatVersion));
    if (data[1] != wire_id(codec))
        return fail(error, std::string(name) + " tile: codec id " + std::to_string(data[1]) + ", expected " +
                               std::to_string(wire_id(codec)));
    if ((data[2] & ~kKnownFlags) != 0 || data[3] != 0)
        return fail(error, std::string(name) + " tile: unknown flags " + std::to_string(data[2]) + "/" +
                               std::to_string(data[3]));
    const uint32_t tile_width = get_u16(&data[4]);
    const uint32_t tile_height = get_u16(&data[6]);
    if (tile_width != shape.width || tile_height != shape.height)
        return fail(error, std::string(name) + " tile: " + size_text(tile_width, tile_height) +
                               ", the stream's tiles are " + size_text(shape.width, shape.height));
    const uint32_t texel_bytes = (data[2] & kWideTexels) ? 8 : 4;
    if (texel_bytes != shape.texel_bytes)
        return fail(error, std::string(name) + " tile: " + std::to_string(texel_bytes) +
                               "-byte texels, the stream's are " + std::to_string(shape.texel_bytes) +
                               "-byte");
    header->flags = static_cast<uint8_t>(data[2] & ~kWideTexels);
    header->checksum = get_u32(&data[8]);
    return true;
}

bool check_checksum(TileCodec codec, const TileHeader &header, uint32_t checksum, std::string *error) {
    if (checksum == header.checksum) return true;
    return fail(error,
                std::string(splitvk::to_string(codec)) + " tile: decoded pixels do not match the checksum");
}

bool check_pixels(TileCodec codec, const TileHeader &header, std::span<const uint8_t> pixels,
                  std::string *error) {
    return check_checksum(codec, header, tile_checksum(pixels.data(), pixels.size()), error);
}

// The body of a video tile (x264, h264, hevc): the u32 size, the access unit, and what follows it
// (the alpha plane's zstd frame, or nothing).
bool split_video_body(std::span<const uint8_t> body, const std::string &name,
                      std::span<const uint8_t> *stream, std::span<const uint8_t> *rest, std::string *error) {
    if (body.size() < 4)
        return fail(error, name + " tile: " + std::to_string(body.size()) +
                               " bytes after the header, too short for the access unit's size");
    const uint32_t size = get_u32(body.data());
    body = body.subspan(4);
    if (size == 0 || size > body.size())
        return fail(error, name + " tile: access unit size " + std::to_string(size) + " but " +
                               std::to_string(body.size()) + " bytes follow");
    // libavcodec packets are int-sized, padding included.
    if (size > static_cast<uint32_t>(INT_MAX - AV_INPUT_BUFFER_PADDING_SIZE))
        return fail(error, name + " tile: access unit size " + std::to_string(size) + " is too large");
    *stream = body.first(size);
    *rest = body.subspan(size);
    return true;
}

struct ZstdCCtxDeleter {
    void operator()(ZSTD_CCtx *context) const { ZSTD_freeCCtx(context); }
};
struct ZstdDCtxDeleter {
    void operator()(ZSTD_DCtx *context) const { ZSTD_freeDCtx(context); }
};
using ZstdCompressor = std::unique_ptr<ZSTD_CCtx, ZstdCCtxDeleter>;
using ZstdDecompressor = std::unique_ptr<ZSTD_DCtx, ZstdDCtxDeleter>;

// Appends one zstd frame (declaring its content size) of `input` to `out`.
bool zstd_append(ZSTD_CCtx *context, std::span<const uint8_t> input, std::vector<uint8_t> &out,
                 const char *what, std::string *error) {
    const size_t start = out.size();
    out.resize(start + ZSTD_compressBound(input.size()));
    const size_t written = ZSTD_compressCCtx(context, out.data() + start, out.size() - start, input.data(),
                                             input.size(), kZstdLevel);
    if (ZSTD_isError(written)) {
        out.resize(start);
        return fail(error, std::string(what) + ": zstd compression failed: " + ZSTD_getErrorName(written));
    }
    out.resize(start + written);
    return true;
}

// Decompresses `frame`, which must be exactly one complete zstd frame declaring exactly
// output.size() bytes, into `output`. Sizes are checked before anything is decompressed.
bool zstd_decompress_exact(ZSTD_DCtx *context, std::span<const uint8_t> frame, std::span<uint8_t> output,
                           const char *what, std::string *error) {
    const unsigned long long declared = ZSTD_getFrameContentSize(frame.data(), frame.size());
    if (declared == ZSTD_CONTENTSIZE_ERROR)
        return fail(error,
                    std::string(what) + ": not a zstd frame (" + std::to_string(frame.size()) + " bytes)");
    if (declared == ZSTD_CONTENTSIZE_UNKNOWN)
        return fail(error, std::string(what) + ": zstd frame does not declare its content size");
    if (declared != output.size())
        return fail(error, std::string(what) + ": zstd frame declares " + std::to_string(declared) +
                               " bytes, expected " + std::to_string(output.size()));
    const size_t frame_size = ZSTD_findFrameCompressedSize(frame.data(), frame.size());
    if (ZSTD_isError(frame_size))
        return fail(error, std::string(what) + ": incomplete zstd frame: " + ZSTD_getErrorName(frame_size));
    if (frame_size != frame.size())
        return fail(error, std::string(what) + ": " + std::to_string(frame.size() - frame_size) +
                               " bytes after the zstd frame");
    const size_t produced =
        ZSTD_decompressDCtx(context, output.data(), output.size(), frame.data(), frame.size());
    if (ZSTD_isError(produced))
        return fail(error, std::string(what) + ": zstd: " + ZSTD_getErrorName(produced));
    if (produced != output.size())
        return fail(error, std::string(what) + ": zstd frame produced " + std::to_string(produced) +
                               " bytes, expected " + std::to_string(output.size()));
    return true;
}

// ---------------------------------------------------------------------------------------------
// x264

// x264's log lines go to the encoder's error message instead of the application's stderr.
struct X264Log {
    std::mutex mutex; // sliced threads may log from x264's worker threads
    std::string last_error;

    // format(printf, 3, 0): the format is x264's own, checked where x264 calls its logger.
    [[gnu::format(printf, 3, 0)]] static void callback(void *self, int level, const char *format,
                                                       va_list args) {
        if (level > X264_LOG_ERROR) return;
        char line[256];
        std::vsnprintf(line, sizeof line, format, args);
        std::string text(line);
        while (!text.empty() && (text.back() == '\n' || text.back() == '\r'))
            text.pop_back();
        auto *log = static_cast<X264Log *>(self);
        std::lock_guard lock(log->mutex);
        log->last_error = std::move(text);
    }

    std::string take() {
        std::lock_guard lock(mutex);
        std::string text = std::move(last_error);
        last_error.clear();
        return text.empty() ? text : " (" + text + ")";
    }
};

// True when byte 3 of every pixel is 255; otherwise extracts those bytes into `alpha`.
bool opaque_or_extract_alpha(const uint8_t *pixels, size_t pixel_count, std::vector<uint8_t> &alpha) {
    size_t i = 0;
    while (i < pixel_count && pixels[i * 4 + 3] == 255)
        ++i;
    if (i == pixel_count) return true;
    alpha.resize(pixel_count);
    for (size_t j = 0; j < pixel_count; ++j)
        alpha[j] = pixels[j * 4 + 3];
    return false;
}

class X264TileEncoder final : public TileEncoder {
public:
    X264TileEncoder(uint32_t width, uint32_t height, const TileQuality &quality)
        : width_(width), height_(height), quality_(quality) {}
    ~X264TileEncoder() override {
        if (encoder_) x264_encoder_close(encoder_);
    }
    X264TileEncoder(const X264TileEncoder &) = delete;
    X264TileEncoder &operator=(const X264TileEncoder &) = delete;

    bool open(std::string *error) {
        x264_param_t param;
        if (x264_param_default_preset(&param, "ultrafast", "zerolatency") < 0)
            return fail(error, "x264: preset ultrafast/zerolatency is unknown");
        param.pf_log = &X264Log::callback;
        param.p_log_private = &log_;
        param.i_log_level = X264_LOG_ERROR;
        param.i_width = static_cast<int>(width_);
        param.i_height = static_cast<int>(height_);
        param.i_bitdepth = 8;
        // RGB in, RGB coded: x264 deinterleaves packed input straight into G, B, R planes and signals
        // matrix_coefficients 0 (GBR), so no colour conversion touches the samples. With qp 0 in
        // High 4:4:4 Predictive it codes them with transform bypass: lossless. (yuv444p would not be:
        // RGB->YUV rounds.) Lossy keeps the GBR planes and codes them at a constant quality.
        param.i_csp = X264_CSP_RGB;
        if (quality_.lossless) {
            param.rc.i_rc_method = X264_RC_CQP;
            param.rc.i_qp_constant = 0;
        } else {
            param.rc.i_rc_method = X264_RC_CRF;
            param.rc.f_rf_constant = static_cast<float>(quality_.crf);
        }
        // Slices halve decode time at no cost in size; slice threads (not frame threads) add no
        // latency.
        param.b_sliced_threads = 1;
        param.i_threads = 2;
        param.i_slice_count = 4;
        param.i_keyint_max = X264_KEYINT_MAX_INFINITE;
        param.b_repeat_headers = 1; // SPS/PPS with every IDR: an IDR can be decoded alone
        param.b_annexb = 1;
        if (x264_param_apply_profile(&param, "high444") < 0)
            return fail(error, "x264: cannot apply profile high444" + log_.take());
        encoder_ = x264_encoder_open(&param);
        if (!encoder_)
            return fail(error,
                        "x264: cannot open an encoder for " + size_text(width_, height_) + log_.take());
        return true;
    }

    bool encode(const uint8_t *pixels, std::vector<uint8_t> &out, bool *keyframe,
                std::string *error) override {
        const bool ok = encode_frame(pixels, out, keyframe, error);
        // A frame that is not sent leaves the decoder without the reference the encoder now has.
        keyframe_pending_ = !ok;
        return ok;
    }

    void force_keyframe() override { keyframe_pending_ = true; }

private:
    bool encode_frame(const uint8_t *pixels, std::vector<uint8_t> &out, bool *keyframe, std::string *error) {
        x264_picture_t input;
        x264_picture_init(&input);
        input.img.i_csp = X264_CSP_BGRA;
        input.img.i_plane = 1;
        // x264 only reads the input picture; its API is not const-qualified.
        input.img.plane[0] = const_cast<uint8_t *>(pixels);
        input.img.i_stride[0] = static_cast<int>(width_ * 4);
        input.i_type = keyframe_pending_ ? X264_TYPE_IDR : X264_TYPE_AUTO;
        input.i_pts = next_pts_++;

        x264_nal_t *nals = nullptr;
        int nal_count = 0;
        x264_picture_t output;
        const int size = x264_encoder_encode(encoder_, &nals, &nal_count, &input, &output);
        if (size < 0) return fail(error, "x264: encoding failed" + log_.take());
        // tune zerolatency has no lookahead, B-frames or frame threads: every call returns its frame.
        if (size == 0 || nal_count <= 0 || x264_encoder_delayed_frames(encoder_) != 0)
            return fail(error, "x264: the encoder delayed a frame (expected none with tune zerolatency)");
        if (keyframe_pending_ && !output.b_keyframe)
            return fail(error, "x264: an IDR was requested but the encoder produced a non-keyframe");

        const bool opaque = opaque_or_extract_alpha(pixels, size_t{width_} * height_, alpha_);
        put_header(out, TileCodec::X264,
                   static_cast<uint8_t>((output.b_keyframe ? kKeyframe : 0) | (opaque ? 0 : kAlphaPlane) |
                                        (quality_.lossless ? 0 : kLossy)),
                   TileShape{width_, height_, 4}, pixels);
        put_u32(out, static_cast<uint32_t>(size));
        // x264 guarantees the payloads of one call's NAL units are contiguous, in order.
        out.insert(out.end(), nals[0].p_payload, nals[0].p_payload + size);
        if (!opaque) {
            if (!alpha_compressor_) alpha_compressor_.reset(ZSTD_createCCtx());
            if (!alpha_compressor_) return fail(error, "x264 tile alpha: cannot create a zstd context");
            if (!zstd_append(alpha_compressor_.get(), alpha_, out, "x264 tile alpha", error)) return false;
        }
        *keyframe = output.b_keyframe != 0;
        return true;
    }

    uint32_t width_;
    uint32_t height_;
    TileQuality quality_;
    X264Log log_;
    x264_t *encoder_ = nullptr;
    bool keyframe_pending_ = true;
    int64_t next_pts_ = 0;
    std::vector<uint8_t> alpha_;
    ZstdCompressor alpha_compressor_;
};

struct AvCodecContextDeleter {
    void operator()(AVCodecContext *context) const { avcodec_free_context(&context); }
};
struct AvPacketDeleter {
    void operator()(AVPacket *packet) const { av_packet_free(&packet); }
};
struct AvFrameDeleter {
    void operator()(AVFrame *frame) const { av_frame_free(&frame); }
};

std::string av_error_text(int code) {
    char text[AV_ERROR_MAX_STRING_SIZE] = {};
    av_strerror(code, text, sizeof text);
    return text;
}

class X264TileDecoder final : public TileDecoder {
public:
    X264TileDecoder(uint32_t width, uint32_t height, bool accept_lossy)
        : width_(width), height_(height), accept_lossy_(accept_lossy), alpha_(size_t{width} * height) {}

    bool open(std::string *error) {
        const AVCodec *codec = avcodec_find_decoder(AV_CODEC_ID_H264);
        if (!codec) return fail(error, "libavcodec has no H.264 decoder");
        context_.reset(avcodec_alloc_context3(codec));
        packet_.reset(av_packet_alloc());
        frame_.reset(av_frame_alloc());
        extra_frame_.reset(av_frame_alloc());
        alpha_decompressor_.reset(ZSTD_createDCtx());
        if (!context_ || !packet_ || !frame_ || !extra_frame_ || !alpha_decompressor_)
            return fail(error, "x264 tile decoder: out of memory");
        context_->flags |= AV_CODEC_FLAG_LOW_DELAY;
        // Slice threads decode the slices of one frame at once; frame threads would add a frame
        // of latency per thread.
        context_->thread_type = FF_THREAD_SLICE;
        context_->thread_count = 2;
        // Report damage instead of concealing it: a concealed tile is not the tile that was sent.
        context_->err_recognition = AV_EF_EXPLODE | AV_EF_BITSTREAM | AV_EF_BUFFER;
        // Bounds what a forged SPS can make the decoder allocate: the tile rounded up to whole
        // macroblocks, plus the stride alignment libavcodec adds before checking.
        context_->max_pixels = int64_t{(width_ + 15) / 16 * 16 + 64} * ((height_ + 15) / 16 * 16);
        // Damaged input is reported through *error; keep libavcodec's own complaints out of the
        // application's stderr unless its log level asks for debug output.
        context_->log_level_offset = AV_LOG_DEBUG - AV_LOG_ERROR;
        const int opened = avcodec_open2(context_.get(), codec, nullptr);
        if (opened < 0)
            return fail(error, "cannot open libavcodec's H.264 decoder: " + av_error_text(opened));
        return true;
    }

    bool decode(std::span<const uint8_t> data, uint8_t *pixels, std::string *error) override {
        const bool ok = decode_tile(data, pixels, error);
        if (!ok && have_reference_) {
            avcodec_flush_buffers(context_.get());
            have_reference_ = false;
        }
        return ok;
    }

    std::string description() const override { return description_; }

private:
    bool decode_tile(std::span<const uint8_t> data, uint8_t *pixels, std::string *error) {
        TileHeader header{};
        if (!read_header(data, TileCodec::X264, TileShape{width_, height_, 4}, &header, error)) return false;
        const bool keyframe = (header.flags & kKeyframe) != 0;
        const bool has_alpha = (header.flags & kAlphaPlane) != 0;
        const bool lossy = (header.flags & kLossy) != 0;
        if (lossy && !accept_lossy_)
            return fail(error, "x264 tile: a lossy tile where only lossless ones are accepted");
        if (lossy && header.checksum != 0) return fail(error, "x264 tile: a lossy tile with a checksum");
        if (!keyframe && !have_reference_)
            return fail(
                error, "x264 tile: a non-keyframe with no keyframe before it (since the start or a failure)");
        if (header.flags & kBlueFirst)
            return fail(error, "x264 tile: the blue-first flag is for 4:2:0 tiles only");
        std::span<const uint8_t> h264, alpha_frame;
        if (!split_video_body(data.subspan(kTileHeaderSize), "x264", &h264, &alpha_frame, error))
            return false;
        if (has_alpha) {
            if (!zstd_decompress_exact(alpha_decompressor_.get(), alpha_frame, alpha_, "x264 tile alpha",
                                       error))
                return false;
        } else if (!alpha_frame.empty()) {
            return fail(error, "x264 tile: " + std::to_string(alpha_frame.size()) +
                                   " bytes after the H.264 access unit");
        }

        if (!decode_h264(h264, keyframe, error)) return false;
        if (description_.empty()) {
            const char *profile = avcodec_profile_name(AV_CODEC_ID_H264, context_->profile);
            description_ = std::string("rgb ") + (profile ? profile : "(unknown profile)") +
                           " (GBR), decoded by h264 (software: hardware decoders do not take 4:4:4)";
        }
        // The one conversion there is (the decoder's GBR planes are its reference frames, and
        // planar): straight into the caller's memory, which is the layer's upload buffer.
        const uint32_t checksum = pack_pixels(has_alpha, pixels);
        av_frame_unref(frame_.get());
        // A lossy tile's pixels are not the encoder's input; damage to it still shows as a decoding
        // error (AV_EF_EXPLODE, decode_error_flags).
        if (!lossy && !check_checksum(TileCodec::X264, header, checksum, error)) return false;
        have_reference_ = true;
        return true;
    }

    bool decode_h264(std::span<const uint8_t> h264, bool keyframe, std::string *error) {
        // libavcodec may read up to AV_INPUT_BUFFER_PADDING_SIZE bytes past the data; av_new_packet
        // allocates and zeroes that padding.
        const int allocated = av_new_packet(packet_.get(), static_cast<int>(h264.size()));
        if (allocated < 0)
            return fail(error, "x264 tile: cannot allocate a packet: " + av_error_text(allocated));
        std::memcpy(packet_->data, h264.data(), h264.size());
        const int sent = avcodec_send_packet(context_.get(), packet_.get());
        av_packet_unref(packet_.get());
        if (sent < 0) return fail(error, "x264 tile: H.264 decoding failed: " + av_error_text(sent));
        const int received = avcodec_receive_frame(context_.get(), frame_.get());
        if (received == AVERROR(EAGAIN))
            return fail(error, "x264 tile: the H.264 decoder returned no frame for the access unit");
        if (received < 0) return fail(error, "x264 tile: H.264 decoding failed: " + av_error_text(received));
        const bool ok = check_frame(keyframe, error);
        // One access unit is one frame; a second one means the data held more than one.
        const bool more = avcodec_receive_frame(context_.get(), extra_frame_.get()) >= 0;
        av_frame_unref(extra_frame_.get());
        if (!ok) {
            av_frame_unref(frame_.get());
            return false;
        }
        if (more) {
            av_frame_unref(frame_.get());
            return fail(error, "x264 tile: the H.264 data decoded to more than one frame");
        }
        return true;
    }

    bool check_frame(bool keyframe, std::string *error) const {
        const AVFrame &frame = *frame_;
        if (frame.format != AV_PIX_FMT_GBRP) {
            const char *name = av_get_pix_fmt_name(static_cast<AVPixelFormat>(frame.format));
            return fail(error, std::string("x264 tile: decoded pixel format ") + (name ? name : "unknown") +
                                   ", expected gbrp (RGB)");
        }
        if (frame.width != static_cast<int>(width_) || frame.height != static_cast<int>(height_))
            return fail(error, "x264 tile: decoded " +
                                   size_text(static_cast<uint32_t>(frame.width),
                                             static_cast<uint32_t>(frame.height)) +
                                   ", the stream's tiles are " + size_text(width_, height_));
        if (frame.decode_error_flags != 0 || (frame.flags & AV_FRAME_FLAG_CORRUPT))
            return fail(error, "x264 tile: the H.264 decoder reported a damaged frame");
        if ((frame.key_frame != 0) != keyframe)
            return fail(error, std::string("x264 tile: the header says ") +
                                   (keyframe ? "keyframe" : "non-keyframe") + " but the H.264 frame is " +
                                   (frame.key_frame ? "one" : "not"));
        return true;
    }

    // The exact inverse of x264's packed-RGB input path: for X264_CSP_BGRA it stores byte 0 of each
    // pixel in plane 1, byte 1 in plane 0 and byte 2 in plane 2, and H.264 with matrix GBR codes
    // plane 0 as G (luma), plane 1 as B, plane 2 as R. libavcodec's GBRP has data[0] = G,
    // data[1] = B, data[2] = R, so byte 0 comes from data[1], byte 1 from data[0], byte 2 from data[2].
    // Each row is packed in cache, summed there and written out whole: `pixels` may be uncached
    // (write-combined) upload memory, which wants full sequential writes and no reads. Returns the
    // pixels' tile_checksum().
    uint32_t pack_pixels(bool has_alpha, uint8_t *pixels) {
        const AVFrame &frame = *frame_;
        const size_t row_bytes = size_t{width_} * 4;
        row_.resize(row_bytes);
        TileChecksum checksum;
        for (uint32_t y = 0; y < height_; ++y) {
            const uint8_t *byte0 = frame.data[1] + ptrdiff_t{frame.linesize[1]} * y;
            const uint8_t *byte1 = frame.data[0] + ptrdiff_t{frame.linesize[0]} * y;
            const uint8_t *byte2 = frame.data[2] + ptrdiff_t{frame.linesize[2]} * y;
            const uint8_t *alpha = alpha_.data() + size_t{width_} * y;
            uint8_t *row = row_.data();
            for (uint32_t x = 0; x < width_; ++x) {
                row[x * 4 + 0] = byte0[x];
                row[x * 4 + 1] = byte1[x];
                row[x * 4 + 2] = byte2[x];
                row[x * 4 + 3] = has_alpha ? alpha[x] : 255;
            }
            checksum.update(row, row_bytes);
            std::memcpy(pixels + row_bytes * y, row, row_bytes);
        }
        return checksum.finish();
    }

    uint32_t width_;
    uint32_t height_;
    bool accept_lossy_;
    std::string description_; // from the first frame
    std::unique_ptr<AVCodecContext, AvCodecContextDeleter> context_;
    std::unique_ptr<AVPacket, AvPacketDeleter> packet_;
    std::unique_ptr<AVFrame, AvFrameDeleter> frame_;
    std::unique_ptr<AVFrame, AvFrameDeleter> extra_frame_;
    ZstdDecompressor alpha_decompressor_;
    std::vector<uint8_t> alpha_;
    std::vector<uint8_t> row_; // one packed row, in cache
    bool have_reference_ = false;
};

// ---------------------------------------------------------------------------------------------
// 4:2:0 H.264 and HEVC through libavcodec (the swapped split's periphery)

// The frame rate a stream's level is chosen for: headsets' 90 Hz.
constexpr uint64_t kLevelFrameRate = 90;

// A level's limits in luma samples: H.264's MaxFS and MaxMBPS times 256 (a macroblock's samples),
// HEVC's MaxLumaPs and MaxLumaSr (ITU-T H.264 table A-1, H.265 table A.8). Levels of the same limits
// and a higher bit rate only are left out: the first that fits is the lowest.
struct CodecLevel {
    int idc;        // H.264 level_idc (10 x level), HEVC general_level_idc (30 x level)
    uint64_t frame; // samples of a picture
    uint64_t rate;  // samples a second
};
constexpr uint64_t kMb = 256;
constexpr CodecLevel kH264Levels[] = {
    {10, 99 * kMb, 1485 * kMb},        {11, 396 * kMb, 3000 * kMb},        {12, 396 * kMb, 6000 * kMb},
    {13, 396 * kMb, 11880 * kMb},      {21, 792 * kMb, 19800 * kMb},       {22, 1620 * kMb, 20250 * kMb},
    {30, 1620 * kMb, 40500 * kMb},     {31, 3600 * kMb, 108000 * kMb},     {32, 5120 * kMb, 216000 * kMb},
    {40, 8192 * kMb, 245760 * kMb},    {42, 8704 * kMb, 522240 * kMb},     {50, 22080 * kMb, 589824 * kMb},
    {51, 36864 * kMb, 983040 * kMb},   {52, 36864 * kMb, 2073600 * kMb},   {60, 139264 * kMb, 4177920 * kMb},
    {61, 139264 * kMb, 8355840 * kMb}, {62, 139264 * kMb, 16711680 * kMb},
};
constexpr CodecLevel kHevcLevels[] = {
    {30, 36864, 552960},         {60, 122880, 3686400},       {63, 245760, 7372800},
    {90, 552960, 16588800},      {93, 983040, 33177600},      {120, 2228224, 66846720},
    {123, 2228224, 133693440},   {150, 8912896, 267386880},   {153, 8912896, 534773760},
    {156, 8912896, 1069547520},  {180, 35651584, 1069547520}, {183, 35651584, 2139095040},
    {186, 35651584, 4278190080},
};

// One row per 4:2:0 codec: the one place its encoder, decoder and stream shape are chosen.
struct Yuv420Codec {
    TileCodec codec;
    AVCodecID id;
    const char *encoder;    // libavcodec's wrapper of the encoding library
    const char *profile;    // its profile option: High and Main are what hardware decoders take
    const char *params_key; // the wrapper's option that passes the library's own parameters
    // Infinite GOP (an IDR only when asked for), headers with every IDR so that one decodes alone,
    // the library's log quiet; the level is appended.
    const char *params;
    std::span<const CodecLevel> levels;
    uint32_t block; // the coded size is rounded up to this for the level check
};
const Yuv420Codec kYuv420Codecs[] = {
    {TileCodec::H264Yuv420, AV_CODEC_ID_H264, "libx264", "high", "x264-params",
     // ultrafast alone would code Constrained Baseline: CABAC and the 8x8 transform make it High.
     "keyint=infinite:repeat-headers=1:annexb=1:cabac=1:8x8dct=1:deblock=1", kH264Levels, 16},
    {TileCodec::HevcYuv420, AV_CODEC_ID_HEVC, "libx265", "main", "x265-params",
     "keyint=-1:repeat-headers=1:annexb=1:log-level=error:frame-threads=1:pools=2", kHevcLevels, 8},
};

const Yuv420Codec *yuv420_codec(TileCodec codec) {
    for (const Yuv420Codec &row : kYuv420Codecs)
        if (row.codec == codec) return &row;
    return nullptr;
}

// The lowest level whose picture size (and the side that bounds, sqrt(8 x MaxFS)) and sample rate
// at kLevelFrameRate fit `width` x `height`; 0 when none does.
int lowest_level(const Yuv420Codec &codec, uint32_t width, uint32_t height) {
    const uint64_t w = (uint64_t{width} + codec.block - 1) / codec.block * codec.block;
    const uint64_t h = (uint64_t{height} + codec.block - 1) / codec.block * codec.block;
    for (const CodecLevel &level : codec.levels)
        if (w * h <= level.frame && w * h * kLevelFrameRate <= level.rate && w * w <= 8 * level.frame &&
            h * h <= 8 * level.frame)
            return level.idc;
    return 0;
}

std::string level_text(const Yuv420Codec &codec, int idc) {
    const int tenths = codec.id == AV_CODEC_ID_HEVC ? idc / 3 : idc;
    return std::to_string(tenths / 10) + "." + std::to_string(tenths % 10);
}

uint32_t even(uint32_t size) {
    return (size + 1) & ~1u;
}

// libavcodec's logs about our own contexts become debug lines: failures reach *error instead.
constexpr int kQuietLogOffset = AV_LOG_DEBUG - AV_LOG_ERROR;

class Yuv420TileEncoder final : public TileEncoder {
public:
    Yuv420TileEncoder(const Yuv420Codec &codec, uint32_t width, uint32_t height, const TileQuality &quality)
        : codec_(codec), width_(width), height_(height), quality_(quality) {}

    bool open(std::string *error) {
        const char *name = splitvk::to_string(codec_.codec);
        const AVCodec *encoder = avcodec_find_encoder_by_name(codec_.encoder);
        if (!encoder)
            return fail(error,
                        std::string(name) + " tiles: this FFmpeg has no " + codec_.encoder + " encoder");
        const int level = lowest_level(codec_, width_, height_);
        if (level == 0)
            return fail(error, std::string(name) + " tiles: " + size_text(width_, height_) +
                                   " at 90 Hz fits no level");
        context_.reset(avcodec_alloc_context3(encoder));
        frame_.reset(av_frame_alloc());
        packet_.reset(av_packet_alloc());
        if (!context_ || !frame_ || !packet_) return fail(error, std::string(name) + " tiles: out of memory");
        AVCodecContext &c = *context_;
        c.width = static_cast<int>(even(width_));
        c.height = static_cast<int>(even(height_));
        c.pix_fmt = AV_PIX_FMT_YUV420P;
        c.time_base = {1, static_cast<int>(kLevelFrameRate)};
        c.framerate = {static_cast<int>(kLevelFrameRate), 1};
        c.level = level; // libx264 takes it from here; libx265 from its parameters below
        // What the VUI says, and what yuv420.h does: BT.709 throughout, full range, the bytes' own
        // transfer (sRGB), chroma centred in its luma block.
        c.color_range = AVCOL_RANGE_JPEG;
        c.colorspace = AVCOL_SPC_BT709;
        c.color_primaries = AVCOL_PRI_BT709;
        c.color_trc = AVCOL_TRC_IEC61966_2_1;
        c.chroma_sample_location = AVCHROMA_LOC_CENTER;
        // Slice threads, as the RGB tiles' x264: no frame of latency.
        c.thread_count = 2;
        c.thread_type = FF_THREAD_SLICE;
        c.slices = 4;
        c.log_level_offset = kQuietLogOffset;
        AVDictionary *options = nullptr;
        av_dict_set(&options, "preset", "ultrafast", 0);
        av_dict_set(&options, "tune", "zerolatency", 0);
        av_dict_set(&options, "profile", codec_.profile, 0);
        av_dict_set(&options, "crf", std::to_string(quality_.crf).c_str(), 0);
        av_dict_set(&options, "forced-idr", "1", 0); // an I frame asked for is an IDR
        const std::string params =
            std::string(codec_.params) +
            (codec_.id == AV_CODEC_ID_HEVC ? ":level-idc=" + level_text(codec_, level) : std::string());
        av_dict_set(&options, codec_.params_key, params.c_str(), 0);
        const int opened = avcodec_open2(context_.get(), encoder, &options);
        // avcodec_open2 leaves in `options` what the encoder did not take.
        const AVDictionaryEntry *unused = av_dict_get(options, "", nullptr, AV_DICT_IGNORE_SUFFIX);
        const std::string unused_key = unused ? unused->key : "";
        av_dict_free(&options);
        if (opened < 0)
            return fail(error, std::string(name) + " tiles: cannot open " + codec_.encoder + " for " +
                                   size_text(width_, height_) + ": " + av_error_text(opened));
        if (!unused_key.empty())
            return fail(error, std::string(name) + " tiles: " + codec_.encoder +
                                   " does not take the option " + unused_key);
        frame_->format = AV_PIX_FMT_YUV420P;
        frame_->width = c.width;
        frame_->height = c.height;
        const int allocated = av_frame_get_buffer(frame_.get(), 0);
        if (allocated < 0) return fail(error, std::string(name) + " tiles: " + av_error_text(allocated));
        return true;
    }

    bool encode(const uint8_t *pixels, std::vector<uint8_t> &out, bool *keyframe,
                std::string *error) override {
        const bool ok = encode_frame(pixels, out, keyframe, error);
        keyframe_pending_ = !ok; // as X264TileEncoder: an unsent frame loses the decoder's reference
        return ok;
    }

    void force_keyframe() override { keyframe_pending_ = true; }

private:
    bool encode_frame(const uint8_t *pixels, std::vector<uint8_t> &out, bool *keyframe, std::string *error) {
        const std::string name = splitvk::to_string(codec_.codec);
        // The encoder may still hold the previous frame's buffers.
        const int writable = av_frame_make_writable(frame_.get());
        if (writable < 0) return fail(error, name + " tiles: " + av_error_text(writable));
        const Yuv420Planes planes{frame_->data[0],     frame_->data[1],     frame_->data[2],
                                  frame_->linesize[0], frame_->linesize[1], 1};
        rgb_to_yuv420(pixels, size_t{width_} * 4, width_, height_, ChannelOrder{quality_.blue_first}, planes,
                      even(width_), even(height_));
        frame_->pict_type = keyframe_pending_ ? AV_PICTURE_TYPE_I : AV_PICTURE_TYPE_NONE;
        frame_->pts = next_pts_++;
        const int sent = avcodec_send_frame(context_.get(), frame_.get());
        if (sent < 0) return fail(error, name + " tiles: encoding failed: " + av_error_text(sent));
        const int received = avcodec_receive_packet(context_.get(), packet_.get());
        // tune zerolatency: no lookahead, B-frames or frame threads, every frame comes out at once.
        if (received == AVERROR(EAGAIN))
            return fail(error,
                        name + " tiles: the encoder delayed a frame (expected none with tune zerolatency)");
        if (received < 0) return fail(error, name + " tiles: encoding failed: " + av_error_text(received));
        const bool key = (packet_->flags & AV_PKT_FLAG_KEY) != 0;
        if (keyframe_pending_ && !key) {
            av_packet_unref(packet_.get());
            return fail(error, name + " tiles: an IDR was requested but the encoder produced a non-keyframe");
        }
        const bool opaque = opaque_or_extract_alpha(pixels, size_t{width_} * height_, alpha_);
        put_header(out, codec_.codec,
                   static_cast<uint8_t>((key ? kKeyframe : 0) | (opaque ? 0 : kAlphaPlane) | kLossy |
                                        (quality_.blue_first ? kBlueFirst : 0)),
                   TileShape{width_, height_, 4}, pixels);
        put_u32(out, static_cast<uint32_t>(packet_->size));
        out.insert(out.end(), packet_->data, packet_->data + packet_->size);
        av_packet_unref(packet_.get());
        if (!opaque) {
            if (!alpha_compressor_) alpha_compressor_.reset(ZSTD_createCCtx());
            if (!alpha_compressor_) return fail(error, name + " tile alpha: cannot create a zstd context");
            if (!zstd_append(alpha_compressor_.get(), alpha_, out, (name + " tile alpha").c_str(), error))
                return false;
        }
        *keyframe = key;
        return true;
    }

    const Yuv420Codec &codec_;
    uint32_t width_;
    uint32_t height_;
    TileQuality quality_;
    std::unique_ptr<AVCodecContext, AvCodecContextDeleter> context_;
    std::unique_ptr<AVFrame, AvFrameDeleter> frame_;
    std::unique_ptr<AVPacket, AvPacketDeleter> packet_;
    bool keyframe_pending_ = true;
    int64_t next_pts_ = 0;
    std::vector<uint8_t> alpha_;
    ZstdCompressor alpha_compressor_;
};

// The hardware the decoder tries, in order, each through libavcodec's hwaccel of the same decoder.
// `device` finds the device to open, or says why there is none: libavcodec's own probing (every
// DRM node, then the X display; dlopen of the CUDA driver) logs its failures to the application's
// stderr, which a machine without the hardware must not see.
struct HardwareDecoder {
    AVHWDeviceType type;
    const char *name;
    bool (*device)(std::string *path, std::string *why);
};

bool vaapi_device(std::string *path, std::string *why) {
    // The first DRM render node: VA-API drivers are opened on render nodes.
    for (int node = 128; node < 136; ++node) {
        const std::string candidate = "/dev/dri/renderD" + std::to_string(node);
        if (::access(candidate.c_str(), R_OK | W_OK) == 0) {
            *path = candidate;
            return true;
        }
    }
    *why = "no VA-API device";
    return false;
}

bool cuda_device(std::string *path, std::string *why) {
    // libavutil loads the CUDA driver itself; see first whether there is one to load.
    void *driver = ::dlopen("libcuda.so.1", RTLD_LAZY | RTLD_LOCAL);
    if (!driver) {
        *why = "no CUDA device";
        return false;
    }
    ::dlclose(driver);
    path->clear(); // the first CUDA device
    return true;
}

constexpr HardwareDecoder kHardwareDecoders[] = {{AV_HWDEVICE_TYPE_VAAPI, "VA-API", &vaapi_device},
                                                 {AV_HWDEVICE_TYPE_CUDA, "CUDA", &cuda_device}};

class Yuv420TileDecoder final : public TileDecoder {
public:
    Yuv420TileDecoder(const Yuv420Codec &codec, uint32_t width, uint32_t height)
        : codec_(codec), width_(width), height_(height), alpha_(size_t{width} * height) {}

    bool open(std::string *error) {
        const char *name = splitvk::to_string(codec_.codec);
        decoder_ = avcodec_find_decoder(codec_.id);
        if (!decoder_) return fail(error, std::string("libavcodec has no decoder for ") + name + " tiles");
        context_.reset(avcodec_alloc_context3(decoder_));
        packet_.reset(av_packet_alloc());
        frame_.reset(av_frame_alloc());
        software_frame_.reset(av_frame_alloc());
        extra_frame_.reset(av_frame_alloc());
        alpha_decompressor_.reset(ZSTD_createDCtx());
        if (!context_ || !packet_ || !frame_ || !software_frame_ || !extra_frame_ || !alpha_decompressor_)
            return fail(error, std::string(name) + " tile decoder: out of memory");
        open_hardware();
        context_->opaque = this;
        context_->get_format = &Yuv420TileDecoder::choose_format;
        context_->flags |= AV_CODEC_FLAG_LOW_DELAY;
        context_->thread_type = FF_THREAD_SLICE;
        context_->thread_count = 2;
        context_->err_recognition = AV_EF_EXPLODE | AV_EF_BITSTREAM | AV_EF_BUFFER;
        // As the RGB tiles' decoder: what a forged SPS can make it allocate is bounded by the tile.
        context_->max_pixels = int64_t{(even(width_) + 63) / 64 * 64 + 64} * ((even(height_) + 63) / 64 * 64);
        context_->log_level_offset = kQuietLogOffset;
        const int opened = avcodec_open2(context_.get(), decoder_, nullptr);
        if (opened < 0)
            return fail(error, std::string("cannot open libavcodec's ") + decoder_->name +
                                   " decoder: " + av_error_text(opened));
        return true;
    }

    bool decode(std::span<const uint8_t> data, uint8_t *pixels, std::string *error) override {
        const bool ok = decode_tile(data, pixels, error);
        if (!ok && have_reference_) {
            avcodec_flush_buffers(context_.get());
            have_reference_ = false;
        }
        return ok;
    }

    std::string description() const override {
        if (stream_.empty()) return {};
        return stream_ + ", decoded by " + decoder_->name + " (" + decoded_by_ + ")";
    }

private:
    // A device of the first kind of kHardwareDecoders this decoder has a hwaccel for and the machine
    // has; none: software, and why, for description().
    void open_hardware() {
        std::string why;
        for (const HardwareDecoder &hardware : kHardwareDecoders) {
            AVPixelFormat format = AV_PIX_FMT_NONE;
            for (int i = 0;; ++i) {
                const AVCodecHWConfig *config = avcodec_get_hw_config(decoder_, i);
                if (!config) break;
                if ((config->methods & AV_CODEC_HW_CONFIG_METHOD_HW_DEVICE_CTX) &&
                    config->device_type == hardware.type) {
                    format = config->pix_fmt;
                    break;
                }
            }
            if (format == AV_PIX_FMT_NONE) {
                why += (why.empty() ? "" : ", ") + std::string("no ") + hardware.name + " in this FFmpeg";
                continue;
            }
            std::string path, missing;
            if (!hardware.device(&path, &missing)) {
                why += (why.empty() ? "" : ", ") + missing;
                continue;
            }
            AVBufferRef *device = nullptr;
            const int created = av_hwdevice_ctx_create(&device, hardware.type,
                                                       path.empty() ? nullptr : path.c_str(), nullptr, 0);
            if (created < 0) {
                why += (why.empty() ? "" : ", ") + std::string("no ") + hardware.name + " (" +
                       (path.empty() ? std::string() : path + ": ") + av_error_text(created) + ")";
                continue;
            }
            context_->hw_device_ctx = device; // the context owns it now
            hardware_format_ = format;
            hardware_name_ = hardware.name;
            return;
        }
        software_reason_ = "software: " + why;
    }

    // libavcodec's choice of output format: the device's where the decoder offers it (it does not for
    // a stream the hardware cannot decode), else the software one.
    static AVPixelFormat choose_format(AVCodecContext *context, const AVPixelFormat *formats) {
        const auto *self = static_cast<const Yuv420TileDecoder *>(context->opaque);
        AVPixelFormat software = AV_PIX_FMT_NONE;
        for (const AVPixelFormat *f = formats; *f != AV_PIX_FMT_NONE; ++f) {
            if (*f == self->hardware_format_ && self->hardware_format_ != AV_PIX_FMT_NONE) return *f;
            const AVPixFmtDescriptor *descriptor = av_pix_fmt_desc_get(*f);
            if (software == AV_PIX_FMT_NONE && descriptor && !(descriptor->flags & AV_PIX_FMT_FLAG_HWACCEL))
                software = *f;
        }
        return software;
    }

    bool decode_tile(std::span<const uint8_t> data, uint8_t *pixels, std::string *error) {
        const std::string name = splitvk::to_string(codec_.codec);
        TileHeader header{};
        if (!read_header(data, codec_.codec, TileShape{width_, height_, 4}, &header, error)) return false;
        const bool keyframe = (header.flags & kKeyframe) != 0;
        const bool has_alpha = (header.flags & kAlphaPlane) != 0;
        if (!(header.flags & kLossy) || header.checksum != 0)
            return fail(error, name + " tile: not flagged lossy without a checksum, as every 4:2:0 tile is");
        if (!keyframe && !have_reference_)
            return fail(
                error,
                name + " tile: a non-keyframe with no keyframe before it (since the start or a failure)");
        std::span<const uint8_t> stream, alpha_frame;
        if (!split_video_body(data.subspan(kTileHeaderSize), name, &stream, &alpha_frame, error))
            return false;
        if (has_alpha) {
            if (!zstd_decompress_exact(alpha_decompressor_.get(), alpha_frame, alpha_,
                                       (name + " tile alpha").c_str(), error))
                return false;
        } else if (!alpha_frame.empty()) {
            return fail(error, name + " tile: " + std::to_string(alpha_frame.size()) +
                                   " bytes after the access unit");
        }
        if (!decode_access_unit(stream, keyframe, error)) return false;
        pack_pixels(has_alpha, ChannelOrder{(header.flags & kBlueFirst) != 0}, pixels);
        av_frame_unref(frame_.get());
        av_frame_unref(software_frame_.get());
        have_reference_ = true;
        return true;
    }

    bool decode_access_unit(std::span<const uint8_t> stream, bool keyframe, std::string *error) {
        const std::string name = splitvk::to_string(codec_.codec);
        const int allocated = av_new_packet(packet_.get(), static_cast<int>(stream.size()));
        if (allocated < 0)
            return fail(error, name + " tile: cannot allocate a packet: " + av_error_text(allocated));
        std::memcpy(packet_->data, stream.data(), stream.size());
        const int sent = avcodec_send_packet(context_.get(), packet_.get());
        av_packet_unref(packet_.get());
        if (sent < 0) return fail(error, name + " tile: decoding failed: " + av_error_text(sent));
        const int received = avcodec_receive_frame(context_.get(), frame_.get());
        if (received == AVERROR(EAGAIN))
            return fail(error, name + " tile: the decoder returned no frame for the access unit");
        if (received < 0) return fail(error, name + " tile: decoding failed: " + av_error_text(received));
        const bool more = avcodec_receive_frame(context_.get(), extra_frame_.get()) >= 0;
        av_frame_unref(extra_frame_.get());
        bool ok = !more || fail(error, name + " tile: the data decoded to more than one frame");
        ok = ok && check_frame(keyframe, error);
        if (ok && frame_->format == hardware_format_) {
            // The device's surface, read back as NV12 (or what the driver gives; checked below).
            const int transferred = av_hwframe_transfer_data(software_frame_.get(), frame_.get(), 0);
            ok = transferred >= 0 || fail(error, name + " tile: cannot read the " + hardware_name_ +
                                                     " frame back: " + av_error_text(transferred));
        }
        const AVFrame &planes = frame_->format == hardware_format_ ? *software_frame_ : *frame_;
        ok = ok && check_planes(planes, error);
        if (!ok) {
            av_frame_unref(frame_.get());
            av_frame_unref(software_frame_.get());
            return false;
        }
        if (stream_.empty()) {
            const char *profile = avcodec_profile_name(codec_.id, context_->profile);
            stream_ = name + " " + (profile ? profile : "(unknown profile)") + " 4:2:0";
            decoded_by_ = frame_->format == hardware_format_ ? hardware_name_
                          : software_reason_.empty()
                              ? "software: the " + hardware_name_ + " decoder does not take this stream"
                              : software_reason_;
        }
        return true;
    }

    // The decoded frame is what our encoder makes and nothing else: its size, full-range BT.709,
    // undamaged, keyframe as the header says.
    bool check_frame(bool keyframe, std::string *error) const {
        const std::string name = splitvk::to_string(codec_.codec);
        const AVFrame &frame = *frame_;
        if (frame.width != static_cast<int>(even(width_)) || frame.height != static_cast<int>(even(height_)))
            return fail(error, name + " tile: decoded " +
                                   size_text(static_cast<uint32_t>(frame.width),
                                             static_cast<uint32_t>(frame.height)) +
                                   ", the stream codes " + size_text(even(width_), even(height_)));
        if (frame.decode_error_flags != 0 || (frame.flags & AV_FRAME_FLAG_CORRUPT))
            return fail(error, name + " tile: the decoder reported a damaged frame");
        if (frame.color_range != AVCOL_RANGE_JPEG || frame.colorspace != AVCOL_SPC_BT709)
            return fail(error, name + " tile: the stream is not full-range BT.709");
        if ((frame.key_frame != 0) != keyframe)
            return fail(error, name + " tile: the header says " + (keyframe ? "keyframe" : "non-keyframe") +
                                   " but the frame is " + (frame.key_frame ? "one" : "not"));
        return true;
    }

    bool check_planes(const AVFrame &planes, std::string *error) const {
        const auto format = static_cast<AVPixelFormat>(planes.format);
        if (format == AV_PIX_FMT_YUV420P || format == AV_PIX_FMT_YUVJ420P || format == AV_PIX_FMT_NV12) {
            if (planes.width >= static_cast<int>(width_) && planes.height >= static_cast<int>(height_))
                return true;
            return fail(error, std::string(splitvk::to_string(codec_.codec)) +
                                   " tile: planes smaller than the tile");
        }
        const char *format_name = av_get_pix_fmt_name(format);
        return fail(error, std::string(splitvk::to_string(codec_.codec)) + " tile: decoded pixel format " +
                               (format_name ? format_name : "unknown") + ", expected 8-bit 4:2:0");
    }

    // Converted row by row in cache and written out whole, as X264TileDecoder packs its rows: `pixels`
    // may be write-combined upload memory.
    void pack_pixels(bool has_alpha, ChannelOrder order, uint8_t *pixels) {
        const AVFrame &frame = frame_->format == hardware_format_ ? *software_frame_ : *frame_;
        const bool interleaved = frame.format == AV_PIX_FMT_NV12;
        const Yuv420Planes planes{
            frame.data[0],     frame.data[1],     interleaved ? frame.data[1] + 1 : frame.data[2],
            frame.linesize[0], frame.linesize[1], interleaved ? 2 : 1};
        const size_t row_bytes = size_t{width_} * 4;
        row_.resize(row_bytes);
        scratch_.resize(2 * size_t{(width_ + 1) / 2});
        for (uint32_t y = 0; y < height_; ++y) {
            yuv420_row_to_rgb(planes, width_, height_, y, order, scratch_.data(), row_.data());
            if (has_alpha) {
                const uint8_t *alpha = alpha_.data() + size_t{width_} * y;
                for (uint32_t x = 0; x < width_; ++x)
                    row_[x * 4 + 3] = alpha[x];
            }
            std::memcpy(pixels + row_bytes * y, row_.data(), row_bytes);
        }
    }

    const Yuv420Codec &codec_;
    uint32_t width_;
    uint32_t height_;
    const AVCodec *decoder_ = nullptr;
    AVPixelFormat hardware_format_ = AV_PIX_FMT_NONE;
    std::string hardware_name_ = "hardware";
    std::string software_reason_; // empty with a device
    std::string stream_;          // "h264 High 4:2:0", from the first frame
    std::string decoded_by_;      // "VA-API", "software: no VA-API device, ..."
    std::unique_ptr<AVCodecContext, AvCodecContextDeleter> context_;
    std::unique_ptr<AVPacket, AvPacketDeleter> packet_;
    std::unique_ptr<AVFrame, AvFrameDeleter> frame_;
    std::unique_ptr<AVFrame, AvFrameDeleter> software_frame_;
    std::unique_ptr<AVFrame, AvFrameDeleter> extra_frame_;
    ZstdDecompressor alpha_decompressor_;
    std::vector<uint8_t> alpha_;
    std::vector<uint8_t> row_;
    std::vector<int32_t> scratch_;
    bool have_reference_ = false;
};

// ---------------------------------------------------------------------------------------------
// zstd on the difference from the previous tile

// Byte-wise difference mod 256; decoding adds it back. Subtraction rather than XOR: a small change
// either way (dark -> light by a few codes) is a small number near 0 or 255 after subtraction but
// can flip many bits under XOR. Measured on splitvk-atrium's fovea tiles (frames 3-5, both eyes,
// zstd level 1): subtraction 0.397 of raw, XOR 0.446 at 512x360; 0.398 and 0.451 at 256x180.
// (On that walk, whose camera moves every frame, the tile without any difference is smaller still,
// 0.339 at 512x360: the difference pays where the picture holds still.)
inline uint8_t difference(uint8_t current, uint8_t previous) {
    return static_cast<uint8_t>(current - previous);
}
inline uint8_t undo_difference(uint8_t difference_byte, uint8_t previous) {
    return static_cast<uint8_t>(difference_byte + previous);
}

class ZstdTileEncoder final : public TileEncoder {
public:
    explicit ZstdTileEncoder(const TileShape &shape)
        : shape_(shape), previous_(shape.bytes()), difference_(previous_.size()),
          compressor_(ZSTD_createCCtx()) {}

    bool ready() const { return compressor_ != nullptr; }

    bool encode(const uint8_t *pixels, std::vector<uint8_t> &out, bool *keyframe,
                std::string *error) override {
        // A keyframe is the difference from an all-zero tile, i.e. the tile itself.
        if (keyframe_pending_) std::fill(previous_.begin(), previous_.end(), uint8_t{0});
        for (size_t i = 0; i < previous_.size(); ++i)
            difference_[i] = difference(pixels[i], previous_[i]);
        std::memcpy(previous_.data(), pixels, previous_.size());
        put_header(out, TileCodec::Zstd, keyframe_pending_ ? kKeyframe : 0, shape_, pixels);
        if (!zstd_append(compressor_.get(), difference_, out, "zstd tile", error)) {
            keyframe_pending_ = true;
            return false;
        }
        *keyframe = keyframe_pending_;
        keyframe_pending_ = false;
        return true;
    }

    void force_keyframe() override { keyframe_pending_ = true; }

private:
    TileShape shape_;
    std::vector<uint8_t> previous_;
    std::vector<uint8_t> difference_;
    ZstdCompressor compressor_;
    bool keyframe_pending_ = true;
};

class ZstdTileDecoder final : public TileDecoder {
public:
    explicit ZstdTileDecoder(const TileShape &shape)
        : shape_(shape), previous_(shape.bytes()), difference_(previous_.size()),
          decompressor_(ZSTD_createDCtx()) {}

    bool ready() const { return decompressor_ != nullptr; }

    bool decode(std::span<const uint8_t> data, uint8_t *pixels, std::string *error) override {
        const bool ok = decode_tile(data, pixels, error);
        if (!ok) have_reference_ = false;
        return ok;
    }

private:
    bool decode_tile(std::span<const uint8_t> data, uint8_t *pixels, std::string *error) {
        TileHeader header{};
        if (!read_header(data, TileCodec::Zstd, shape_, &header, error)) return false;
        if (header.flags & (kAlphaPlane | kLossy | kBlueFirst))
            return fail(error,
                        "zstd tile: the alpha-plane, lossy and blue-first flags are for video tiles only");
        const bool keyframe = (header.flags & kKeyframe) != 0;
        if (!keyframe && !have_reference_)
            return fail(
                error, "zstd tile: a non-keyframe with no keyframe before it (since the start or a failure)");
        if (!zstd_decompress_exact(decompressor_.get(), data.subspan(kTileHeaderSize), difference_,
                                   "zstd tile", error))
            return false;
        if (keyframe) std::fill(previous_.begin(), previous_.end(), uint8_t{0});
        for (size_t i = 0; i < previous_.size(); ++i)
            previous_[i] = undo_difference(difference_[i], previous_[i]);
        // On a mismatch previous_ is no reference any more; decode() then waits for a keyframe.
        if (!check_pixels(TileCodec::Zstd, header, previous_, error)) return false;
        std::memcpy(pixels, previous_.data(), previous_.size());
        have_reference_ = true;
        return true;
    }

    TileShape shape_;
    std::vector<uint8_t> previous_;
    std::vector<uint8_t> difference_;
    ZstdDecompressor decompressor_;
    bool have_reference_ = false;
};

// ---------------------------------------------------------------------------------------------
// raw

class RawTileEncoder final : public TileEncoder {
public:
    explicit RawTileEncoder(const TileShape &shape) : shape_(shape) {}

    bool encode(const uint8_t *pixels, std::vector<uint8_t> &out, bool *keyframe, std::string *) override {
        put_header(out, TileCodec::Raw, kKeyframe, shape_, pixels);
        out.insert(out.end(), pixels, pixels + shape_.bytes());
        *keyframe = true;
        return true;
    }

    void force_keyframe() override {} // every raw tile is one

private:
    TileShape shape_;
};

class RawTileDecoder final : public TileDecoder {
public:
    explicit RawTileDecoder(const TileShape &shape) : shape_(shape) {}

    bool decode(std::span<const uint8_t> data, uint8_t *pixels, std::string *error) override {
        TileHeader header{};
        if (!read_header(data, TileCodec::Raw, shape_, &header, error)) return false;
        if (header.flags != kKeyframe)
            return fail(error,
                        "raw tile: flags " + std::to_string(header.flags) + ", expected keyframe only");
        const std::span<const uint8_t> body = data.subspan(kTileHeaderSize);
        const size_t expected = shape_.bytes();
        if (body.size() != expected)
            return fail(error, "raw tile: " + std::to_string(body.size()) + " pixel bytes, expected " +
                                   std::to_string(expected));
        if (!check_pixels(TileCodec::Raw, header, body, error)) return false;
        std::memcpy(pixels, body.data(), expected);
        return true;
    }

private:
    TileShape shape_;
};

bool valid_shape(TileCodec codec, const TileShape &shape, std::string *error) {
    if (shape.width < 1 || shape.width > kMaxTileSide || shape.height < 1 || shape.height > kMaxTileSide)
        return fail(error,
                    "tile size " + size_text(shape.width, shape.height) + " is outside 1x1..16384x16384");
    if (shape.texel_bytes != 4 && shape.texel_bytes != 8)
        return fail(error, "tile texels of " + std::to_string(shape.texel_bytes) + " bytes (4 or 8 are)");
    // The video codecs code 8-bit samples of 4-byte RGB texels.
    if (codec != TileCodec::Zstd && codec != TileCodec::Raw && shape.texel_bytes != 4)
        return fail(error, std::string(splitvk::to_string(codec)) + " tiles have 4-byte texels, not " +
                               std::to_string(shape.texel_bytes) + " (zstd and raw carry 8)");
    return true;
}

} // namespace

std::unique_ptr<TileEncoder> make_tile_encoder(TileCodec codec, uint32_t width, uint32_t height,
                                               uint32_t texel_bytes, std::string *error,
                                               const TileQuality &quality) {
    const TileShape shape{width, height, texel_bytes};
    if (!valid_shape(codec, shape, error)) return nullptr;
    if (!quality.lossless && quality.crf > kMaxPeripheryCrf) {
        fail(error, "tile quality: crf " + std::to_string(quality.crf) + " above " +
                        std::to_string(kMaxPeripheryCrf));
        return nullptr;
    }
    switch (codec) {
    case TileCodec::X264: {
        auto encoder = std::make_unique<X264TileEncoder>(width, height, quality);
        if (!encoder->open(error)) return nullptr;
        return encoder;
    }
    case TileCodec::Zstd: {
        auto encoder = std::make_unique<ZstdTileEncoder>(shape);
        if (!encoder->ready()) {
            fail(error, "zstd tile encoder: cannot create a zstd context");
            return nullptr;
        }
        return encoder;
    }
    case TileCodec::Raw:
        return std::make_unique<RawTileEncoder>(shape);
    case TileCodec::H264Yuv420:
    case TileCodec::HevcYuv420: {
        auto encoder = std::make_unique<Yuv420TileEncoder>(*yuv420_codec(codec), width, height, quality);
        if (!encoder->open(error)) return nullptr;
        return encoder;
    }
    }
    fail(error, "unknown tile codec " + std::to_string(static_cast<int>(codec)));
    return nullptr;
}

std::unique_ptr<TileDecoder> make_tile_decoder(TileCodec codec, uint32_t width, uint32_t height,
                                               uint32_t texel_bytes, std::string *error, bool accept_lossy) {
    const TileShape shape{width, height, texel_bytes};
    if (!valid_shape(codec, shape, error)) return nullptr;
    switch (codec) {
    case TileCodec::X264: {
        auto decoder = std::make_unique<X264TileDecoder>(width, height, accept_lossy);
        if (!decoder->open(error)) return nullptr;
        return decoder;
    }
    case TileCodec::Zstd: {
        auto decoder = std::make_unique<ZstdTileDecoder>(shape);
        if (!decoder->ready()) {
            fail(error, "zstd tile decoder: cannot create a zstd context");
            return nullptr;
        }
        return decoder;
    }
    case TileCodec::Raw:
        return std::make_unique<RawTileDecoder>(shape);
    case TileCodec::H264Yuv420:
    case TileCodec::HevcYuv420: {
        // Every 4:2:0 tile is lossy: a fovea's decoder (no accept_lossy) has no use for this codec.
        if (!accept_lossy) {
            fail(error,
                 std::string(splitvk::to_string(codec)) +
                     " tiles are lossy 4:2:0, for the periphery only: not a decoder of lossless tiles");
            return nullptr;
        }
        auto decoder = std::make_unique<Yuv420TileDecoder>(*yuv420_codec(codec), width, height);
        if (!decoder->open(error)) return nullptr;
        return decoder;
    }
    }
    fail(error, "unknown tile codec " + std::to_string(static_cast<int>(codec)));
    return nullptr;
}

uint32_t peek_texel_bytes(std::span<const uint8_t> tile) {
    if (tile.size() < kTileHeaderSize || tile[0] != kFormatVersion || (tile[2] & ~kKnownFlags) != 0 ||
        tile[3] != 0 || get_u16(&tile[4]) == 0 || get_u16(&tile[6]) == 0)
        return 0;
    const bool wide = (tile[2] & kWideTexels) != 0;
    if (tile[1] == wire_id(TileCodec::X264) || tile[1] == wire_id(TileCodec::H264Yuv420) ||
        tile[1] == wire_id(TileCodec::HevcYuv420))
        return wide ? 0 : 4;
    if (tile[1] == wire_id(TileCodec::Zstd) || tile[1] == wire_id(TileCodec::Raw)) return wide ? 8 : 4;
    return 0;
}

} // namespace splitvk::tiles
