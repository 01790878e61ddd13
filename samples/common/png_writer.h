// Minimal PNG encoder: 8-bit RGBA, no filtering, zlib stream made of stored (uncompressed) deflate
// blocks. Output is larger than a real encoder's, but it needs no zlib and any decoder reads it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace splitvk {

// CRC-32 (ISO 3309 / PNG) and Adler-32 (RFC 1950), exposed for the tests.
uint32_t crc32(const uint8_t *data, size_t size, uint32_t crc = 0);
uint32_t adler32(const uint8_t *data, size_t size, uint32_t adler = 1);

// Encodes a w x h image whose rows start row_stride bytes apart and hold 4 bytes per pixel, in
// RGBA order, or BGRA order when bgra is set (a B8G8R8A8 swapchain image). The PNG is RGBA.
// Returns an empty vector if the arguments are invalid (zero size, stride shorter than a row).
std::vector<uint8_t> encode_png(uint32_t w, uint32_t h, const uint8_t *rgba_or_bgra, size_t row_stride,
                                bool bgra);

// encode_png() and write the result to path. On failure returns false and, if error is not null,
// stores a one-line reason.
bool write_png(const std::string &path, uint32_t w, uint32_t h, const uint8_t *rgba_or_bgra,
               size_t row_stride, bool bgra, std::string *error);

} // namespace splitvk
