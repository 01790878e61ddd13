#pragma once

// The fuzz targets' entry functions (docs/architecture.md §7: the agent must survive every input). They are
// plain functions so that two builds share them: the libFuzzer executables (clang,
// -DSPLITVK_BUILD_FUZZERS=ON, see scripts/fuzz) and splitvk_fuzz_regression_tests (the normal GCC
// build), which replays every file under tests/fuzz/regressions/<target>/ so that a crash found
// once stays fixed without clang in CI.

#include <cstddef>
#include <cstdint>

namespace splitvk::fuzz {

// Bytes as a client's socket delivers them to the agent: framed messages (wire.h), validated by a
// FrameDecoder, then each payload through the decoder of its type; Commands through the generated
// codec into a visitor that registers created objects, so later commands of the same input
// resolve their ids as they would in a session. Recorded seeds are such streams (--record-corpus).
void agent_messages(const uint8_t *data, size_t size);

// One tile stream: byte 0 picks the codec (modulo 3: x264, zstd, raw), whether lossy tiles are
// accepted (the next bit, base 3) and the texel size (the one after: 4 or 8), byte 1 the tile size,
// then up to 8
// tiles, each a u32 little-endian length and that many bytes (the last one takes what is left
// when its length runs past the end). Every tile goes through one TileDecoder, in order.
void tile_decoder(const uint8_t *data, size_t size);

// The TLS and handshake paths a client (or a man in the middle) reaches before any session exists
//. Byte 0 picks the side: even, the agent's TLS server reading a client's bytes; odd,
// the layer's TLS client (with its certificate verifier) reading an agent's. The rest is that
// peer's byte stream, run through OpenSSL with splitvk's own contexts over memory (tls.h), and,
// as the agent's plaintext path sees it, through the first-bytes check and the Hello decoder with
// the plaintext refusal. Seeds: splitvk-fuzz-tls-seeds.
void tls_handshake(const uint8_t *data, size_t size);

// A known_agents file (known_agents.h): parsed, every entry looked up, fingerprints normalised.
void known_agents(const uint8_t *data, size_t size);

// The tile sizes byte 1 chooses from (modulo the count), so seed writers agree with the target.
struct TileSize {
    uint32_t width, height;
};
inline constexpr TileSize kFuzzTileSizes[] = {{16, 16}, {64, 48}, {130, 66}, {512, 360}};
inline constexpr size_t kFuzzTileSizeCount = sizeof(kFuzzTileSizes) / sizeof(kFuzzTileSizes[0]);
inline constexpr size_t kFuzzMaxTiles = 8;

} // namespace splitvk::fuzz
