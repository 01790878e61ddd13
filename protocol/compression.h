#pragma once

// zstd compression of message payloads (docs/architecture.md §3: large payloads, memory data and shader code,
// are compressed when that pays). A compressed payload is exactly one zstd frame that declares
// its content size; the receiver refuses anything else.

#include "result.h"

#include <cstddef>
#include <cstdint>
#include <mutex>
#include <span>
#include <string>
#include <vector>

struct ZSTD_CCtx_s;
struct ZSTD_DCtx_s;

namespace splitvk::protocol {

struct CompressionPolicy {
    bool enabled = true;
    int level = 1;           // zstd level; 1 is fast enough to sit on the app's thread
    size_t threshold = 4096; // payloads smaller than this are sent raw
    // Compressed output is used only when compressed * ratio_den < raw * ratio_num (< 7/8 of raw).
    unsigned ratio_num = 7;
    unsigned ratio_den = 8;
};

// Compresses payloads per a policy. Thread-safe: it keeps a small pool of zstd contexts so that
// several threads can compress at once without sharing one.
class Compressor {
public:
    explicit Compressor(CompressionPolicy policy = {});
    ~Compressor();
    Compressor(const Compressor &) = delete;
    Compressor &operator=(const Compressor &) = delete;

    // True (and `out` holds one zstd frame) when the policy allows compressing `raw` and the result
    // pays; false otherwise: send `raw` as is. Never fails in a way the caller must handle.
    bool compress_if_pays(std::span<const uint8_t> raw, std::vector<uint8_t> &out);

    const CompressionPolicy &policy() const { return policy_; }

private:
    ZSTD_CCtx_s *acquire();
    void release(ZSTD_CCtx_s *context);

    CompressionPolicy policy_;
    std::mutex mutex_;
    std::vector<ZSTD_CCtx_s *> idle_;
};

// Decompresses untrusted zstd frames. Not thread-safe: one per receiving stream.
class Decompressor {
public:
    Decompressor();
    ~Decompressor();
    Decompressor(const Decompressor &) = delete;
    Decompressor &operator=(const Decompressor &) = delete;

    // Decompresses exactly one frame. Refuses, with a one-line reason, before allocating: a frame
    // that does not declare its content size, a declared size over max_size, anything but exactly
    // one complete frame (truncated, trailing bytes), and output that does not match the declared
    // size.
    Result<std::vector<uint8_t>> decompress(std::span<const uint8_t> frame, size_t max_size);

private:
    ZSTD_DCtx_s *context_;
};

// One-shot helpers over the classes above.
bool compress_if_pays(std::span<const uint8_t> raw, const CompressionPolicy &policy,
                      std::vector<uint8_t> &out);
Result<std::vector<uint8_t>> decompress_bounded(std::span<const uint8_t> frame, size_t max_size);

} // namespace splitvk::protocol
