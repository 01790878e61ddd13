#include "compression.h"

#include <new>

#include <zstd.h>

namespace splitvk::protocol {
namespace {

// More idle contexts than this are freed rather than kept: a burst of senders should not pin
// memory for ever (a level-1 context is a few hundred KiB).
constexpr size_t kMaxIdleContexts = 4;

} // namespace

Compressor::Compressor(CompressionPolicy policy) : policy_(policy) {}

Compressor::~Compressor() {
    for (ZSTD_CCtx *context : idle_)
        ZSTD_freeCCtx(context);
}

ZSTD_CCtx *Compressor::acquire() {
    {
        std::lock_guard lock(mutex_);
        if (!idle_.empty()) {
            ZSTD_CCtx *context = idle_.back();
            idle_.pop_back();
            return context;
        }
    }
    return ZSTD_createCCtx();
}

void Compressor::release(ZSTD_CCtx *context) {
    std::lock_guard lock(mutex_);
    if (idle_.size() < kMaxIdleContexts) {
        idle_.push_back(context);
        return;
    }
    ZSTD_freeCCtx(context);
}

bool Compressor::compress_if_pays(std::span<const uint8_t> raw, std::vector<uint8_t> &out) {
    if (!policy_.enabled || raw.size() < policy_.threshold || raw.empty()) return false;
    ZSTD_CCtx *context = acquire();
    if (!context) return false;
    // Only output smaller than the break-even size is worth having; give zstd a buffer of that
    // size and let it fail (dstSize_tooSmall) when the data does not compress, which also stops it
    // early on incompressible input.
    const size_t limit = (raw.size() * policy_.ratio_num + policy_.ratio_den - 1) / policy_.ratio_den;
    bool pays = false;
    try {
        out.resize(limit);
        const size_t written =
            ZSTD_compressCCtx(context, out.data(), out.size(), raw.data(), raw.size(), policy_.level);
        // compressed * den < raw * num, i.e. strictly below the ratio.
        if (!ZSTD_isError(written) && written * policy_.ratio_den < raw.size() * policy_.ratio_num) {
            out.resize(written);
            pays = true;
        }
    } catch (const std::bad_alloc &) {
        pays = false;
    }
    release(context);
    if (!pays) out.clear();
    return pays;
}

Decompressor::Decompressor() : context_(ZSTD_createDCtx()) {}

Decompressor::~Decompressor() {
    ZSTD_freeDCtx(context_);
}

Result<std::vector<uint8_t>> Decompressor::decompress(std::span<const uint8_t> frame, size_t max_size) {
    if (!context_) return Error{"zstd: cannot create a decompression context"};
    const unsigned long long declared = ZSTD_getFrameContentSize(frame.data(), frame.size());
    if (declared == ZSTD_CONTENTSIZE_ERROR)
        return Error{"zstd: not a valid frame header (" + std::to_string(frame.size()) + " bytes)"};
    if (declared == ZSTD_CONTENTSIZE_UNKNOWN) return Error{"zstd: frame does not declare its content size"};
    if (declared > max_size)
        return Error{"zstd: declared content size " + std::to_string(declared) + " exceeds the limit " +
                     std::to_string(max_size)};
    // Exactly one complete frame: this catches truncation and trailing bytes before allocating.
    const size_t frame_size = ZSTD_findFrameCompressedSize(frame.data(), frame.size());
    if (ZSTD_isError(frame_size))
        return Error{std::string("zstd: incomplete frame: ") + ZSTD_getErrorName(frame_size)};
    if (frame_size != frame.size())
        return Error{"zstd: " + std::to_string(frame.size() - frame_size) + " bytes after the frame"};

    std::vector<uint8_t> out;
    try {
        out.resize(static_cast<size_t>(declared));
    } catch (const std::bad_alloc &) {
        return Error{"zstd: cannot allocate " + std::to_string(declared) + " bytes"};
    }
    const size_t produced = ZSTD_decompressDCtx(context_, out.data(), out.size(), frame.data(), frame.size());
    if (ZSTD_isError(produced)) return Error{std::string("zstd: ") + ZSTD_getErrorName(produced)};
    if (produced != declared)
        return Error{"zstd: frame declared " + std::to_string(declared) + " bytes but produced " +
                     std::to_string(produced)};
    return out;
}

bool compress_if_pays(std::span<const uint8_t> raw, const CompressionPolicy &policy,
                      std::vector<uint8_t> &out) {
    Compressor compressor(policy);
    return compressor.compress_if_pays(raw, out);
}

Result<std::vector<uint8_t>> decompress_bounded(std::span<const uint8_t> frame, size_t max_size) {
    Decompressor decompressor;
    return decompressor.decompress(frame, max_size);
}

} // namespace splitvk::protocol
