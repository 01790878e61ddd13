#include "tile_codec.h"

#include <algorithm>
#include <climits>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <mutex>

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavutil/frame.h>
#include <libavutil/log.h>
#include <libavutil/pixdesc.h>
#include <libavutil/pixfmt.h>
#include <x264.h>
}
#include <zstd.h>

namespace splitvk::tiles {

TileEncoder::~TileEncoder() = default;
TileDecoder::~TileDecoder() = default;

namespace {

// Encoded tile layout, version 1 (integers little-endian):
//
//   header   u8 format version (1), u8 codec (1 x264, 2 zstd, 3 raw), u8 flags, u8 zero,
//            u16 width, u16 height, u32 tile_checksum() of the width*height*T texel bytes (0 for
//            a lossy tile, whose decoded pixels are not the encoder's input); T is 8 with
//            kWideTexels, else 4
//   x264     u32 size of the H.264 access unit, the access unit (Annex B), then with kAlphaPlane
//            exactly one zstd frame holding the width*height alpha bytes, else nothing
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
constexpr uint8_t kKnownFlags = kKeyframe | kAlphaPlane | kLossy | kWideTexels;

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
        std::span<const uint8_t> body = data.subspan(kTileHeaderSize);
        if (body.size() < 4)
            return fail(error, "x264 tile: " + std::to_string(body.size()) +
                                   " bytes after the header, too short for the H.264 size");
        const uint32_t h264_size = get_u32(body.data());
        body = body.subspan(4);
        if (h264_size == 0 || h264_size > body.size())
            return fail(error, "x264 tile: H.264 size " + std::to_string(h264_size) + " but " +
                                   std::to_string(body.size()) + " bytes follow");
        // libavcodec packets are int-sized, padding included.
        if (h264_size > static_cast<uint32_t>(INT_MAX - AV_INPUT_BUFFER_PADDING_SIZE))
            return fail(error, "x264 tile: H.264 size " + std::to_string(h264_size) + " is too large");
        const std::span<const uint8_t> h264 = body.first(h264_size);
        const std::span<const uint8_t> alpha_frame = body.subspan(h264_size);
        if (has_alpha) {
            if (!zstd_decompress_exact(alpha_decompressor_.get(), alpha_frame, alpha_, "x264 tile alpha",
                                       error))
                return false;
        } else if (!alpha_frame.empty()) {
            return fail(error, "x264 tile: " + std::to_string(alpha_frame.size()) +
                                   " bytes after the H.264 access unit");
        }

        if (!decode_h264(h264, keyframe, error)) return false;
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
        if (header.flags & (kAlphaPlane | kLossy))
            return fail(error, "zstd tile: the alpha-plane and lossy flags are for x264 tiles only");
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
    // x264 codes 8-bit samples, and its RGB input is 4 bytes a pixel.
    if (codec == TileCodec::X264 && shape.texel_bytes != 4)
        return fail(error, "x264 tiles have 4-byte texels, not " + std::to_string(shape.texel_bytes) +
                               " (zstd and raw carry 8)");
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
    }
    fail(error, "unknown tile codec " + std::to_string(static_cast<int>(codec)));
    return nullptr;
}

uint32_t peek_texel_bytes(std::span<const uint8_t> tile) {
    if (tile.size() < kTileHeaderSize || tile[0] != kFormatVersion || (tile[2] & ~kKnownFlags) != 0 ||
        tile[3] != 0 || get_u16(&tile[4]) == 0 || get_u16(&tile[6]) == 0)
        return 0;
    const bool wide = (tile[2] & kWideTexels) != 0;
    if (tile[1] == wire_id(TileCodec::X264)) return wide ? 0 : 4;
    if (tile[1] == wire_id(TileCodec::Zstd) || tile[1] == wire_id(TileCodec::Raw)) return wide ? 8 : 4;
    return 0;
}

} // namespace splitvk::tiles
