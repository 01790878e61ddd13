#include "png_writer.h"

#include <array>
#include <cerrno>
#include <cstdio>
#include <cstring>

namespace splitvk {
namespace {

constexpr std::array<uint32_t, 256> make_crc_table() {
    std::array<uint32_t, 256> table{};
    for (uint32_t n = 0; n < 256; ++n) {
        uint32_t c = n;
        for (int k = 0; k < 8; ++k)
            c = (c & 1) ? 0xedb88320u ^ (c >> 1) : c >> 1;
        table[n] = c;
    }
    return table;
}

constexpr std::array<uint32_t, 256> crc_table = make_crc_table();

void put_be32(std::vector<uint8_t> &out, uint32_t v) {
    out.push_back(uint8_t(v >> 24));
    out.push_back(uint8_t(v >> 16));
    out.push_back(uint8_t(v >> 8));
    out.push_back(uint8_t(v));
}

void put_chunk(std::vector<uint8_t> &out, const char type[4], const uint8_t *data, size_t size) {
    put_be32(out, uint32_t(size));
    const size_t type_at = out.size();
    out.insert(out.end(), type, type + 4);
    out.insert(out.end(), data, data + size);
    put_be32(out, crc32(out.data() + type_at, size + 4));
}

} // namespace

uint32_t crc32(const uint8_t *data, size_t size, uint32_t crc) {
    crc = ~crc;
    for (size_t i = 0; i < size; ++i)
        crc = crc_table[(crc ^ data[i]) & 0xff] ^ (crc >> 8);
    return ~crc;
}

uint32_t adler32(const uint8_t *data, size_t size, uint32_t adler) {
    // 5552 is the largest n for which 255 n (n + 1) / 2 + (n + 1) (65521 - 1) fits in 32 bits, so
    // the modulo can wait until the end of each run.
    constexpr uint32_t base = 65521, nmax = 5552;
    uint32_t a = adler & 0xffff, b = adler >> 16;
    while (size > 0) {
        const size_t n = size < nmax ? size : nmax;
        for (size_t i = 0; i < n; ++i) {
            a += data[i];
            b += a;
        }
        a %= base;
        b %= base;
        data += n;
        size -= n;
    }
    return (b << 16) | a;
}

std::vector<uint8_t> encode_png(uint32_t w, uint32_t h, const uint8_t *pixels, size_t row_stride, bool bgra) {
    const size_t row_bytes = size_t(w) * 4;
    if (w == 0 || h == 0 || w > 0x7fffffffu || h > 0x7fffffffu || pixels == nullptr || row_stride < row_bytes)
        return {};

    // Filtered scanlines: a filter-type byte (0, None) before each row.
    const size_t raw_size = (row_bytes + 1) * h;
    std::vector<uint8_t> raw(raw_size);
    for (uint32_t y = 0; y < h; ++y) {
        uint8_t *dst = raw.data() + y * (row_bytes + 1);
        const uint8_t *src = pixels + y * row_stride;
        dst[0] = 0;
        if (!bgra) {
            std::memcpy(dst + 1, src, row_bytes);
            continue;
        }
        for (uint32_t x = 0; x < w; ++x) {
            dst[1 + 4 * x + 0] = src[4 * x + 2];
            dst[1 + 4 * x + 1] = src[4 * x + 1];
            dst[1 + 4 * x + 2] = src[4 * x + 0];
            dst[1 + 4 * x + 3] = src[4 * x + 3];
        }
    }

    // zlib stream: CMF/FLG (deflate, 32 KiB window, no dictionary, check bits), stored blocks of at
    // most 65535 bytes each (BFINAL on the last, BTYPE 00, LEN, NLEN), then Adler-32 of the data.
    constexpr size_t max_block = 65535;
    const size_t blocks = (raw_size + max_block - 1) / max_block;
    std::vector<uint8_t> zlib;
    zlib.reserve(2 + raw_size + blocks * 5 + 4);
    zlib.push_back(0x78);
    zlib.push_back(0x01);
    for (size_t offset = 0; offset < raw_size; offset += max_block) {
        const size_t len = raw_size - offset < max_block ? raw_size - offset : max_block;
        zlib.push_back(offset + len == raw_size ? 1 : 0);
        zlib.push_back(uint8_t(len));
        zlib.push_back(uint8_t(len >> 8));
        zlib.push_back(uint8_t(~len));
        zlib.push_back(uint8_t(~len >> 8));
        zlib.insert(zlib.end(), raw.begin() + offset, raw.begin() + offset + len);
    }
    put_be32(zlib, adler32(raw.data(), raw_size));

    std::vector<uint8_t> png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    png.reserve(zlib.size() + 128);
    std::vector<uint8_t> ihdr;
    put_be32(ihdr, w);
    put_be32(ihdr, h);
    ihdr.insert(ihdr.end(), {8, 6, 0, 0, 0}); // 8 bits, RGBA, deflate, adaptive filtering, no interlace
    put_chunk(png, "IHDR", ihdr.data(), ihdr.size());
    // Several IDAT chunks keep each chunk's length far below the 2^31 - 1 limit.
    constexpr size_t max_idat = size_t(1) << 20;
    for (size_t offset = 0; offset < zlib.size(); offset += max_idat) {
        const size_t len = zlib.size() - offset < max_idat ? zlib.size() - offset : max_idat;
        put_chunk(png, "IDAT", zlib.data() + offset, len);
    }
    put_chunk(png, "IEND", nullptr, 0);
    return png;
}

bool write_png(const std::string &path, uint32_t w, uint32_t h, const uint8_t *pixels, size_t row_stride,
               bool bgra, std::string *error) {
    const auto fail = [&](const std::string &why) {
        if (error) *error = path + ": " + why;
        return false;
    };
    const std::vector<uint8_t> png = encode_png(w, h, pixels, row_stride, bgra);
    if (png.empty()) return fail("invalid image (empty, too large or stride shorter than a row)");

    std::FILE *file = std::fopen(path.c_str(), "wb");
    if (!file) return fail(std::strerror(errno));
    const bool written = std::fwrite(png.data(), 1, png.size(), file) == png.size();
    const int write_errno = errno;
    if (std::fclose(file) != 0 || !written) {
        std::remove(path.c_str());
        return fail(std::strerror(written ? errno : write_errno));
    }
    return true;
}

} // namespace splitvk
