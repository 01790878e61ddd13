// What the OpenXR suites judge: the eye images VK_LAYER_SPLITVK_test_xr_readback
// (xr_readback_layer/) wrote as the runtime received them, compared texel by texel (4-byte and
// 8-byte texels alike), SPLITVK_STATS summed up, and validation logs by message ID.
#pragma once

#include "e2e_test.h"
#include "fovea.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iostream>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

namespace splitvk::e2e {

inline constexpr const char *kReadbackLayerName = "VK_LAYER_SPLITVK_test_xr_readback";
inline constexpr const char *kXrLayerName = "XR_APILAYER_SPLITVK_split_render";

// An eye image as the readback layer wrote it: texels of `bytes` bytes, rows packed, as the image
// held them. `format` is the file's TUPLTYPE: RGB_ALPHA (8-bit RGBA or BGRA), or the name of a
// 16-bit format (R16G16B16A16_UNORM, R16G16B16A16_SFLOAT).
struct EyeImage {
    uint32_t width = 0, height = 0;
    uint32_t bytes = 4;
    std::string format;
    std::vector<uint8_t> rgba;

    const uint8_t *at(uint32_t x, uint32_t y) const { return rgba.data() + (size_t{y} * width + x) * bytes; }
    // A 4-byte texel as one number (hello_xr's palette).
    uint32_t texel(uint32_t x, uint32_t y) const {
        uint32_t v = 0;
        std::memcpy(&v, at(x, y), 4);
        return v;
    }
    bool same_texel(const EyeImage &other, uint32_t x, uint32_t y) const {
        return std::memcmp(at(x, y), other.at(x, y), bytes) == 0;
    }
};

// A PAM of 4-byte or 8-byte texels (DEPTH 4 or 8, MAXVAL 255), read whole and unconverted.
inline bool load_pam(const std::filesystem::path &path, EyeImage *image) {
    std::ifstream in(path, std::ios::binary);
    std::string line;
    if (!std::getline(in, line) || line != "P7") return false;
    uint32_t depth = 0;
    *image = EyeImage{};
    while (std::getline(in, line) && line != "ENDHDR") {
        std::istringstream fields(line);
        std::string name;
        fields >> name;
        if (name == "WIDTH") fields >> image->width;
        if (name == "HEIGHT") fields >> image->height;
        if (name == "DEPTH") fields >> depth;
        if (name == "TUPLTYPE") fields >> image->format;
    }
    if ((depth != 4 && depth != 8) || image->width == 0 || image->height == 0) return false;
    image->bytes = depth;
    image->rgba.resize(size_t{image->width} * image->height * depth);
    in.read(reinterpret_cast<char *>(image->rgba.data()), static_cast<std::streamsize>(image->rgba.size()));
    return in.gcount() == static_cast<std::streamsize>(image->rgba.size());
}

// The native and split readbacks of one released image, both `width` x `height`.
inline void load_pair(const std::filesystem::path &native, const std::filesystem::path &split, uint32_t width,
                      uint32_t height, EyeImage *a, EyeImage *b) {
    ASSERT_TRUE(load_pam(native, a) && load_pam(split, b));
    ASSERT_EQ(a->width, width);
    ASSERT_EQ(a->height, height);
    ASSERT_EQ(b->width, width);
    ASSERT_EQ(b->height, height);
    ASSERT_EQ(a->format, b->format);
}

// IEEE 754 binary16, little-endian, as a float.
inline float half_to_float(const uint8_t *p) {
    const uint16_t h = static_cast<uint16_t>(p[0] | p[1] << 8);
    const int exponent = (h >> 10) & 0x1f, mantissa = h & 0x3ff;
    const float magnitude = exponent == 0    ? std::ldexp(float(mantissa), -24)
                            : exponent == 31 ? (mantissa ? NAN : INFINITY)
                                             : std::ldexp(float(mantissa | 0x400), exponent - 25);
    return (h & 0x8000) ? -magnitude : magnitude;
}

// The bgr0 Image of the harness (for its PNG artefacts and SSIM), alpha in the fourth byte. The
// 16-bit formats hold linear colours: they are encoded to sRGB, as a display would show them.
inline Image to_image(const EyeImage &e) {
    Image image;
    image.width = e.width;
    image.height = e.height;
    image.bgr0.resize(size_t{e.width} * e.height * 4);
    const auto encode = [](float linear) {
        const float c = std::isnan(linear) ? 0.0f : std::clamp(linear, 0.0f, 1.0f);
        const float srgb = c <= 0.0031308f ? c * 12.92f : 1.055f * std::pow(c, 1.0f / 2.4f) - 0.055f;
        return static_cast<uint8_t>(std::lround(srgb * 255.0f));
    };
    for (size_t i = 0, n = size_t{e.width} * e.height; i < n; ++i) {
        const uint8_t *t = e.rgba.data() + i * e.bytes;
        uint8_t rgba[4];
        for (int c = 0; c < 4; ++c) {
            if (e.bytes == 4) {
                rgba[c] = t[c];
                continue;
            }
            const float v = e.format == "R16G16B16A16_SFLOAT"
                                ? half_to_float(t + 2 * c)
                                : float(t[2 * c] | t[2 * c + 1] << 8) / 65535.0f;
            rgba[c] =
                c < 3 ? encode(v) : static_cast<uint8_t>(std::lround(std::clamp(v, 0.0f, 1.0f) * 255.0f));
        }
        image.bgr0[i * 4] = rgba[2];
        image.bgr0[i * 4 + 1] = rgba[1];
        image.bgr0[i * 4 + 2] = rgba[0];
        image.bgr0[i * 4 + 3] = rgba[3];
    }
    return image;
}

// Every readback in `dir` (image<K>-<N>.pam): (K, N) -> path.
inline std::map<std::pair<int, int>, std::filesystem::path> readbacks(const std::filesystem::path &dir) {
    std::map<std::pair<int, int>, std::filesystem::path> all;
    for (const auto &[numbers, path] : numbered_files(dir, std::regex(R"(image(\d+)-(\d+)\.pam)")))
        all[{numbers[0], numbers[1]}] = path;
    return all;
}

struct Mismatch {
    uint64_t pixels = 0, mismatched = 0;
};

// Texels (all their bytes) that differ within `r`.
inline Mismatch compare_rect(const EyeImage &a, const EyeImage &b, const Rect &r) {
    Mismatch m;
    for (uint32_t y = r.y; y < r.y + r.h; ++y)
        for (uint32_t x = r.x; x < r.x + r.w; ++x) {
            ++m.pixels;
            if (!a.same_texel(b, x, y)) ++m.mismatched;
        }
    return m;
}

inline bool inside(const Rect &r, uint32_t x, uint32_t y) {
    return x >= r.x && x < r.x + r.w && y >= r.y && y < r.y + r.h;
}

// Validation log messages by ID ("VUID-...", "SYNC-...", or the message's first words).
inline std::map<std::string, int> message_ids(const std::filesystem::path &log) {
    std::map<std::string, int> ids;
    const std::regex id(R"((VUID-[A-Za-z0-9_-]+|SYNC-[A-Z-]+|UNASSIGNED-[A-Za-z0-9_.-]+))");
    for (const std::string &l : split_lines(read_file(log))) {
        if (l.empty() || l[0] == ' ' || l[0] == '\t') continue;
        std::smatch m;
        ++ids[std::regex_search(l, m, id) ? m[1].str() : l.substr(0, 60)];
    }
    return ids;
}

inline std::string describe(const std::map<std::string, int> &ids) {
    std::string s;
    for (const auto &[id, n] : ids)
        s += "\n  " + id + " x" + std::to_string(n);
    return s.empty() ? " none" : s;
}

struct StatsSummary {
    int frames = 0, late = 0, with_tiles = 0;
    bool last_with_tiles = false;
};

inline StatsSummary read_stats(const std::filesystem::path &csv) {
    StatsSummary s;
    for (auto &row : stats_rows(read_file(csv))) {
        ++s.frames;
        s.late += row["late"] != 0;
        s.last_with_tiles = row["tile_bytes"] > 0;
        s.with_tiles += s.last_with_tiles;
    }
    return s;
}

// A native run's environment made a split one: splitvk's Vulkan layer on top of the chain, its
// OpenXR API layer on, the agent at `agent`, per-frame stats into `stats`.
inline void add_split_layers(Env &e, const std::string &agent, const std::filesystem::path &stats) {
    e["VK_LAYER_PATH"] = explicit_layer_dir().string() + ":" + e["VK_LAYER_PATH"];
    e["VK_INSTANCE_LAYERS"] = std::string(kLayerName) + ":" + e["VK_INSTANCE_LAYERS"];
    e["XR_API_LAYER_PATH"] = (build_dir() / "manifest" / "openxr").string();
    e["XR_ENABLE_API_LAYERS"] = kXrLayerName;
    e["SPLITVK_SERVER"] = agent;
    e["SPLITVK_STATS"] = stats.string();
    e["SPLITVK_LOG_LEVEL"] = "info";
    e["SPLITVK_TILE_WAIT"] = "60000"; // a busy machine must not turn the compared frames late
    // Nor their display times, which lavapipe's agent misses on a busy machine: every frame waits
    // for its fovea, to be compared with native (XrDeadline judges the deadline itself).
    e["SPLITVK_XR_DEADLINE"] = "off";
}

// Every row of the run's SPLITVK_STATS (at `csv`) split with tiles, none late, at least `min_frames`.
inline void expect_split_stats(const std::filesystem::path &csv, int min_frames) {
    const StatsSummary s = read_stats(csv);
    std::cout << "  " << csv.parent_path().filename().string() << ": " << s.frames << " frames split, "
              << s.with_tiles << " with tiles, " << s.late << " late\n";
    EXPECT_GE(s.frames, min_frames) << "SPLITVK_STATS: too few split frames";
    EXPECT_EQ(s.late, 0) << "SPLITVK_STATS: late frames";
    EXPECT_EQ(s.with_tiles, s.frames) << "SPLITVK_STATS: frames without tiles";
}

// No Khronos validation message ID in the split run's log that the native run's lacks.
inline void expect_no_new_validation(const std::filesystem::path &native_log,
                                     const std::filesystem::path &split_log) {
    const auto native = message_ids(native_log);
    const auto split = message_ids(split_log);
    int native_n = 0, split_n = 0;
    for (const auto &[id, n] : native)
        native_n += n;
    for (const auto &[id, n] : split)
        split_n += n;
    std::cout << "  Khronos validation: " << native_n << " message(s) native, " << split_n << " split\n";
    for (const auto &[id, n] : split)
        EXPECT_TRUE(native.count(id))
            << "validation message " << id << " (x" << n << ") only with splitvk; native:" << describe(native)
            << "\nsplit:" << describe(split) << "\nfirst: " << first_message(read_file(split_log));
}

} // namespace splitvk::e2e
