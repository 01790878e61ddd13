#include "textures.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <thread>

#include <glm/glm.hpp>

namespace atrium {
namespace {

using glm::vec3;

enum class Family { marble, ashlar, tiles, fabric, plaster, brick, organic };

struct Spec {
    const char *name;
    Family family;
    int variant;
    uint32_t a, b, c; // palette, 0xRRGGBB in sRGB
};

// Seven families of seven: the variant picks the layout within a family, the palette the colours.
constexpr std::array<Spec, texture_count> specs = {{
    {"marble_white", Family::marble, 0, 0xe6e2da, 0x84848c, 0},
    {"marble_cream", Family::marble, 1, 0xe4d6b6, 0x9c845c, 0},
    {"marble_grey", Family::marble, 2, 0xa6a6a8, 0x4c4c54, 0},
    {"marble_rose", Family::marble, 3, 0xd4a49c, 0xf2e2da, 0},
    {"marble_green", Family::marble, 4, 0x3a6250, 0xc6d6c6, 0},
    {"marble_black", Family::marble, 5, 0x28282c, 0xaeaeae, 0},
    {"marble_ochre", Family::marble, 6, 0xc69656, 0x684826, 0},

    {"ashlar_sand", Family::ashlar, 0, 0xc8b48c, 0xa49478, 0},
    {"ashlar_grey", Family::ashlar, 1, 0xa09c94, 0x7c7870, 0},
    {"ashlar_warm", Family::ashlar, 2, 0xc69e76, 0xa68868, 0},
    {"ashlar_pale", Family::ashlar, 3, 0xdcd2bc, 0xb4aa96, 0},
    {"ashlar_ochre", Family::ashlar, 4, 0xb88e50, 0x94784e, 0},
    {"ashlar_dark", Family::ashlar, 5, 0x7c746a, 0x5c564e, 0},
    {"ashlar_rose", Family::ashlar, 6, 0xc09888, 0x9c8074, 0},

    {"tiles_checker", Family::tiles, 0, 0xd8d4cc, 0x5a5650, 0x8a8680},
    {"tiles_diamond", Family::tiles, 1, 0xd8c8a8, 0x9a4a38, 0x7a6a5a},
    {"tiles_terracotta", Family::tiles, 2, 0xb0603c, 0xb0603c, 0x8a7a6a},
    {"tiles_slab", Family::tiles, 3, 0xc8bca8, 0x8a7a68, 0x6a6258},
    {"tiles_mosaic", Family::tiles, 4, 0xc8b890, 0x4a6a8a, 0xa04a3a},
    {"tiles_basketweave", Family::tiles, 5, 0xa86a48, 0x8c5a3e, 0x6a5a4a},
    {"tiles_slate", Family::tiles, 6, 0x5a5e62, 0x4a4e52, 0x34363a},

    {"fabric_red", Family::fabric, 0, 0x8a1c1c, 0xc8a040, 0},
    {"fabric_green", Family::fabric, 1, 0x1e5a32, 0xa8b870, 0},
    {"fabric_blue", Family::fabric, 2, 0x1c3270, 0xc0b080, 0},
    {"fabric_gold", Family::fabric, 3, 0xb08a2c, 0x6a3a18, 0},
    {"fabric_purple", Family::fabric, 4, 0x4a1e5a, 0xc8a8d0, 0},
    {"fabric_stripes_red", Family::fabric, 5, 0xa02020, 0xe0d0b0, 0x303030},
    {"fabric_stripes_blue", Family::fabric, 6, 0x203a80, 0xe0d8c0, 0xa08030},

    {"plaster_white", Family::plaster, 0, 0xe0dad0, 0, 0},
    {"plaster_ochre", Family::plaster, 1, 0xd0b080, 0, 0},
    {"plaster_rose", Family::plaster, 2, 0xd8b0a0, 0, 0},
    {"plaster_grey", Family::plaster, 3, 0xa8a49c, 0, 0},
    {"plaster_sky", Family::plaster, 4, 0x5a74a0, 0xd8b860, 0},
    {"plaster_green", Family::plaster, 5, 0xa8b898, 0, 0},
    {"plaster_coffer", Family::plaster, 6, 0xc8bca8, 0x9a8c76, 0xb08a40},

    {"brick_red", Family::brick, 0, 0x9a4a34, 0xb8a890, 0},
    {"brick_brown", Family::brick, 1, 0x6e4a34, 0xa89880, 0},
    {"brick_yellow", Family::brick, 2, 0xc8a060, 0x9c9080, 0},
    {"brick_grey", Family::brick, 3, 0x7a7470, 0xb0aaa0, 0},
    {"roof_red", Family::brick, 4, 0xa8502c, 0, 0},
    {"roof_brown", Family::brick, 5, 0x7a4a30, 0, 0},
    {"cornice_stone", Family::brick, 6, 0xccc0a8, 0, 0},

    {"wood_oak", Family::organic, 0, 0x9a6a3a, 0x6a4222, 0},
    {"wood_dark", Family::organic, 1, 0x5a3a22, 0x3a2414, 0},
    {"bronze", Family::organic, 2, 0x8a6a3a, 0x4a8a70, 0},
    {"iron", Family::organic, 3, 0x4a4a4e, 0x8a4a2a, 0},
    {"foliage_green", Family::organic, 4, 0x4a7a30, 0x1a3a14, 0},
    {"foliage_olive", Family::organic, 5, 0x7a8a44, 0x2a3a1a, 0},
    {"terracotta_pot", Family::organic, 6, 0xb8683c, 0x7a3c24, 0},
}};

vec3 colour(uint32_t hex) {
    return vec3(float((hex >> 16) & 0xff), float((hex >> 8) & 0xff), float(hex & 0xff)) / 255.0f;
}

uint32_t hash(uint32_t x) {
    x ^= x >> 16;
    x *= 0x7feb352du;
    x ^= x >> 15;
    x *= 0x846ca68bu;
    x ^= x >> 16;
    return x;
}

uint32_t hash(int a, int b, uint32_t seed) {
    return hash(uint32_t(a) ^ hash(uint32_t(b) ^ hash(seed)));
}

float unit(uint32_t h) {
    return float(h >> 8) * (1.0f / 16777216.0f);
}

float fract(float x) {
    return x - std::floor(x);
}

float smoothstep(float e0, float e1, float x) {
    const float t = std::clamp((x - e0) / (e1 - e0), 0.0f, 1.0f);
    return t * t * (3.0f - 2.0f * t);
}

constexpr float pi = std::numbers::pi_v<float>;

// Tileable fractal value noise, roughly in [-1, 1]. Octave o interpolates a (period << o)^2 lattice of
// random values; because every lattice period divides the image, the result wraps seamlessly.
class Noise {
public:
    Noise(uint32_t size, uint32_t period, int octaves, uint32_t seed) : size_(size), values_(size * size) {
        float amplitude = 1.0f, total = 0.0f;
        std::vector<uint32_t> i0(size), i1(size);
        std::vector<float> w(size);
        for (int o = 0; o < octaves && (period << o) <= size; ++o) {
            const uint32_t p = period << o;
            std::vector<float> lattice(p * p);
            for (uint32_t i = 0; i < p * p; ++i)
                lattice[i] = unit(hash(int(i), o, seed)) * 2.0f - 1.0f;
            for (uint32_t x = 0; x < size; ++x) {
                const float f = (float(x) + 0.5f) * float(p) / float(size);
                const float fl = std::floor(f);
                i0[x] = uint32_t(fl) % p;
                i1[x] = (i0[x] + 1) % p;
                w[x] = smoothstep(0.0f, 1.0f, f - fl);
            }
            for (uint32_t y = 0; y < size; ++y) {
                const float *row0 = &lattice[i0[y] * p];
                const float *row1 = &lattice[i1[y] * p];
                float *out = &values_[y * size];
                for (uint32_t x = 0; x < size; ++x) {
                    const float top = row0[i0[x]] + (row0[i1[x]] - row0[i0[x]]) * w[x];
                    const float bottom = row1[i0[x]] + (row1[i1[x]] - row1[i0[x]]) * w[x];
                    out[x] += amplitude * (top + (bottom - top) * w[y]);
                }
            }
            total += amplitude;
            amplitude *= 0.5f;
        }
        for (float &v : values_)
            v /= total;
    }

    float at(uint32_t x, uint32_t y) const { return values_[(y % size_) * size_ + x % size_]; }

private:
    uint32_t size_;
    std::vector<float> values_;
};

// Distance from (fu, fv), a position within a cell of cw x ch in uv units, to the cell's edge.
float edge_distance(float fu, float fv, float cw, float ch) {
    return std::min(std::min(fu, 1.0f - fu) * cw, std::min(fv, 1.0f - fv) * ch);
}

struct Texel {
    uint32_t x, y; // texel coordinates
    float u, v;    // texel centre in [0, 1)
    float n1, n2;  // low- and high-frequency noise
    float px;      // one texel in uv units, for antialiased edges
};

vec3 marble(const Spec &s, const Texel &t) {
    static constexpr int dirs[7][4] = {{2, 1, 3, -2}, {1, 2, 2, -3}, {3, 1, 1, -2}, {2, 2, 3, -1},
                                       {1, 1, 2, -3}, {2, -1, 1, 3}, {1, 3, 3, -1}};
    const int *d = dirs[s.variant];
    const float t1 = float(d[0]) * t.u + float(d[1]) * t.v + 1.7f * t.n1;
    const float t2 = float(d[2]) * t.u + float(d[3]) * t.v + 2.3f * t.n2;
    const float vein = std::pow(1.0f - std::abs(std::sin(pi * t1)), 7.0f + float(s.variant % 3) * 4.0f);
    const float fine = std::pow(1.0f - std::abs(std::sin(pi * t2)), 24.0f) * 0.45f;
    const vec3 base = colour(s.a) * (0.93f + 0.07f * t.n2) + 0.05f * std::max(t.n1, 0.0f);
    return glm::mix(base, colour(s.b), std::min(vein * 0.8f + fine, 1.0f));
}

vec3 ashlar(const Spec &s, const Texel &t) {
    const int rows = 4 + s.variant % 2, cols = 2 + s.variant % 3 / 2;
    const int r = int(t.v * float(rows));
    const float uu = t.u * float(cols) + (r % 2 ? 0.5f : 0.0f);
    const int c = int(uu) % cols;
    const float d =
        edge_distance(fract(uu), fract(t.v * float(rows)), 1.0f / float(cols), 1.0f / float(rows));
    const float mortar = 0.007f;
    const float inside = smoothstep(mortar, mortar + 1.5f * t.px, d);
    const float tint = 0.88f + 0.22f * unit(hash(r, c, 7u + uint32_t(s.variant)));
    const float bevel = 0.8f + 0.2f * smoothstep(0.0f, 0.025f, d - mortar);
    const vec3 stone = colour(s.a) * tint * bevel * (0.9f + 0.1f * t.n1 + 0.05f * t.n2);
    return glm::mix(colour(s.b) * (0.85f + 0.1f * t.n2), stone, inside);
}

vec3 tiles(const Spec &s, const Texel &t) {
    const vec3 a = colour(s.a), b = colour(s.b), grout = colour(s.c) * (0.9f + 0.1f * t.n2);
    const float vein = 0.06f * t.n1 + 0.04f * t.n2;
    switch (s.variant) {
    case 0: { // checkerboard
        const int n = 8, i = int(t.u * n), j = int(t.v * n);
        const float d = edge_distance(fract(t.u * n), fract(t.v * n), 1.0f / n, 1.0f / n);
        const vec3 tile = ((i + j) % 2 ? b : a) * (0.95f + vein);
        return glm::mix(grout, tile, smoothstep(0.003f, 0.003f + t.px, d));
    }
    case 1: { // diamonds: a checkerboard rotated by 45 degrees, still periodic in u and v
        const float p = (t.u + t.v) * 4.0f, q = (t.u - t.v) * 4.0f + 8.0f;
        const int i = int(p), j = int(q);
        const float d = edge_distance(fract(p), fract(q), 0.177f, 0.177f);
        const vec3 tile = ((i + j) % 2 ? b : a) * (0.95f + vein);
        return glm::mix(grout, tile, smoothstep(0.003f, 0.003f + t.px, d));
    }
    case 2:   // square terracotta
    case 6: { // slate, irregular rows
        const int n = s.variant == 2 ? 6 : 5, j = int(t.v * n);
        const float uu = t.u * n + (s.variant == 6 ? float(hash(j, 0, 3u) % 5) * 0.2f : 0.0f);
        const int i = int(uu) % n;
        const float d = edge_distance(fract(uu), fract(t.v * n), 1.0f / n, 1.0f / n);
        const float tint = 0.82f + 0.3f * unit(hash(i, j, 11u + uint32_t(s.variant)));
        const vec3 tile = a * tint * (0.92f + 0.1f * t.n1 + 0.06f * t.n2);
        return glm::mix(grout, tile, smoothstep(0.004f, 0.004f + t.px, d));
    }
    case 3: { // large slabs with an inlaid border band
        const float fu = fract(t.u * 2.0f), fv = fract(t.v * 2.0f);
        const float d = edge_distance(fu, fv, 0.5f, 0.5f);
        const float band = smoothstep(0.035f, 0.035f + t.px, d) * (1.0f - smoothstep(0.06f, 0.06f + t.px, d));
        const vec3 slab = glm::mix(a * (0.94f + vein), b, band);
        return glm::mix(grout, slab, smoothstep(0.004f, 0.004f + t.px, d));
    }
    case 4: { // mosaic
        const int n = 32, i = int(t.u * n), j = int(t.v * n);
        const float d = edge_distance(fract(t.u * n), fract(t.v * n), 1.0f / n, 1.0f / n);
        const uint32_t h = hash(i, j, 19u);
        const vec3 tile = (h % 7 == 0 ? b : h % 11 == 0 ? colour(s.c) : a) * (0.85f + 0.25f * unit(h >> 3));
        return glm::mix(colour(0x3a3630), tile, smoothstep(0.002f, 0.002f + t.px, d));
    }
    default: { // basketweave: pairs of bricks alternating direction
        const int n = 4, i = int(t.u * n), j = int(t.v * n);
        float fu = fract(t.u * n), fv = fract(t.v * n);
        if ((i + j) % 2) std::swap(fu, fv);
        const int half = fv < 0.5f;
        const float d = edge_distance(fu, fract(fv * 2.0f), 1.0f / n, 0.5f / n);
        const vec3 brick = (half ? a : b) * (0.9f + 0.2f * unit(hash(i * 2 + half, j, 23u)) + vein);
        return glm::mix(grout, brick, smoothstep(0.004f, 0.004f + t.px, d));
    }
    }
}

vec3 fabric(const Spec &s, const Texel &t, uint32_t size) {
    // Woven threads: over/under alternates on a checkerboard of thread crossings.
    const float threads = float(size / 4);
    const float fu = fract(t.u * threads), fv = fract(t.v * threads);
    const bool over = (int(t.u * threads) + int(t.v * threads)) % 2;
    const float weave = 0.9f + 0.1f * (over ? std::sin(pi * fu) : std::sin(pi * fv));
    vec3 c;
    if (s.variant < 5) { // damask: a two-tone motif plus a hem band
        static constexpr float freq[5][2] = {{2, 3}, {3, 2}, {4, 4}, {2, 2}, {3, 5}};
        const float m =
            std::sin(2 * pi * freq[s.variant][0] * t.u) * std::sin(2 * pi * freq[s.variant][1] * t.v) +
            0.6f * std::sin(2 * pi * (4 * t.u + 2 * t.v) + 1.5f * t.n1);
        const float hem = t.v > 0.92f ? 1.0f : 0.0f;
        c = glm::mix(colour(s.a), colour(s.b), std::max(smoothstep(0.4f, 0.6f, m) * 0.75f, hem * 0.9f));
    } else { // stripes
        const float f = fract(t.u * 6.0f);
        c = f < 0.12f ? colour(s.c) : f < 0.5f ? colour(s.a) : f < 0.56f ? colour(s.b) : colour(s.a) * 0.82f;
    }
    return c * weave * (0.95f + 0.05f * t.n2);
}

vec3 plaster(const Spec &s, const Texel &t) {
    const vec3 a = colour(s.a);
    if (s.variant == 4) { // painted vault: blue with a grid of gilded stars
        const int n = 8, i = int(t.u * n), j = int(t.v * n);
        const uint32_t h = hash(i, j, 29u);
        const float cx = 0.3f + 0.4f * unit(h), cy = 0.3f + 0.4f * unit(hash(h));
        const float dx = fract(t.u * n) - cx, dy = fract(t.v * n) - cy;
        const float star = 1.0f - smoothstep(0.05f, 0.08f, std::sqrt(dx * dx + dy * dy));
        return glm::mix(a * (0.9f + 0.1f * t.n1), colour(s.b), star);
    }
    if (s.variant == 6) { // coffers: framed recessed panels with a rosette, lit from the top left
        const int n = 4;
        const float fu = fract(t.u * n), fv = fract(t.v * n);
        const float d = edge_distance(fu, fv, 1.0f, 1.0f);
        const float frame = 1.0f - smoothstep(0.12f, 0.12f + t.px * n, d);
        // The recess's sloping sides: lit where they face up-left, shaded where they face down-right.
        const bool top_left = std::min(fu, fv) < std::min(1.0f - fu, 1.0f - fv);
        const float bevel = d < 0.2f ? (top_left ? 1.1f : 0.8f) : 1.0f;
        const float r = std::sqrt((fu - 0.5f) * (fu - 0.5f) + (fv - 0.5f) * (fv - 0.5f));
        const float rosette = 1.0f - smoothstep(0.09f, 0.1f, r);
        vec3 c = glm::mix(colour(s.b) * bevel, a, frame);
        c = glm::mix(c, colour(s.c) * (0.8f + 0.4f * std::cos(r * 120.0f)), rosette);
        return c * (0.95f + 0.05f * t.n2);
    }
    const float stain = smoothstep(0.3f, 0.8f, t.n1) * 0.12f;
    return a * (0.93f + 0.06f * t.n1 + 0.03f * t.n2 - stain);
}

vec3 brick(const Spec &s, const Texel &t) {
    const vec3 a = colour(s.a);
    if (s.variant == 6) { // cornice: horizontal moulding bands and a row of dentils
        static constexpr float shade[8] = {1.0f, 0.75f, 1.05f, 0.9f, 0.7f, 1.0f, 0.85f, 1.05f};
        const float fv = fract(t.v * 2.0f);
        const int band = std::min(int(fv * 8.0f), 7);
        float k = shade[band];
        if (band == 4 && fract(t.u * 16.0f) < 0.55f) k = 1.0f;
        return a * k * (0.92f + 0.08f * t.n1 + 0.03f * t.n2);
    }
    if (s.variant >= 4) { // roof tiles: overlapping rows, each tile rounded and shadowed at its foot
        const int rows = 8, cols = 8, r = int(t.v * rows);
        const float uu = t.u * cols + (r % 2 ? 0.5f : 0.0f);
        const float fu = fract(uu), fv = fract(t.v * rows);
        const float round = 1.0f - std::pow(2.0f * fu - 1.0f, 2.0f);
        const float shade = (0.65f + 0.35f * round) * (1.0f - 0.45f * smoothstep(0.75f, 1.0f, fv));
        const float tint = 0.85f + 0.25f * unit(hash(int(uu) % cols, r, 31u + uint32_t(s.variant)));
        return a * shade * tint * (0.92f + 0.08f * t.n2);
    }
    const int rows = 16, cols = 8, r = int(t.v * rows);
    const float uu = t.u * cols + (r % 2 ? 0.5f : 0.0f);
    const float d = edge_distance(fract(uu), fract(t.v * rows), 1.0f / cols, 1.0f / rows);
    const float tint = 0.82f + 0.3f * unit(hash(int(uu) % cols, r, 37u + uint32_t(s.variant)));
    const vec3 b = a * tint * (0.9f + 0.08f * t.n1 + 0.08f * t.n2);
    return glm::mix(colour(s.b) * (0.9f + 0.1f * t.n2), b, smoothstep(0.004f, 0.004f + t.px, d));
}

vec3 organic(const Spec &s, const Texel &t) {
    const vec3 a = colour(s.a), b = colour(s.b);
    switch (s.variant) {
    case 0:
    case 1: { // planks with grain; the end joints are staggered per plank
        const int planks = 4, i = int(t.u * planks);
        const float fu = fract(t.u * planks);
        const float joint = fract(t.v + unit(hash(i, 0, 41u)));
        const float grain = 0.5f + 0.5f * std::sin(2 * pi * (t.u * 24.0f + 2.5f * t.n1 + 0.3f * t.n2));
        const float gap = smoothstep(0.0f, 2.0f * t.px * planks, std::min(fu, 1.0f - fu)) *
                          smoothstep(0.0f, 2.0f * t.px, std::min(joint, 1.0f - joint));
        return glm::mix(b, a, grain * grain) * (0.9f + 0.2f * unit(hash(i, 1, 43u))) * (0.35f + 0.65f * gap);
    }
    case 2: { // bronze with verdigris
        const float patina = smoothstep(0.05f, 0.45f, t.n1 + 0.3f * t.n2);
        return glm::mix(a * (0.85f + 0.3f * t.n2), b, patina * 0.85f);
    }
    case 3: { // wrought iron with rust
        const float rust = smoothstep(0.3f, 0.6f, t.n1 + 0.4f * t.n2);
        return glm::mix(a * (0.85f + 0.15f * t.n2), b, rust * 0.7f);
    }
    case 4:
    case 5: { // foliage: leaf clusters with dark gaps
        const float leaves = smoothstep(-0.15f, 0.35f, t.n2 + 0.3f * t.n1);
        return glm::mix(b, a * (0.8f + 0.4f * std::max(t.n1, 0.0f)), leaves);
    }
    default: { // terracotta pot with a painted band
        const float fv = fract(t.v * 3.0f);
        const float wave = 0.5f + 0.04f * std::sin(2 * pi * t.u * 12.0f);
        const float band = smoothstep(0.02f, 0.02f + t.px * 3, 0.06f - std::abs(fv - wave));
        return glm::mix(a * (0.9f + 0.1f * t.n1 + 0.05f * t.n2), b, band);
    }
    }
}

vec3 shade(const Spec &s, const Texel &t, uint32_t size) {
    switch (s.family) {
    case Family::marble:
        return marble(s, t);
    case Family::ashlar:
        return ashlar(s, t);
    case Family::tiles:
        return tiles(s, t);
    case Family::fabric:
        return fabric(s, t, size);
    case Family::plaster:
        return plaster(s, t);
    case Family::brick:
        return brick(s, t);
    case Family::organic:
        return organic(s, t);
    }
    return vec3(1.0f, 0.0f, 1.0f);
}

struct SrgbTables {
    std::array<float, 256> to_linear;
    std::array<uint8_t, 4096> to_srgb; // indexed by linear * 4095

    SrgbTables() {
        for (int i = 0; i < 256; ++i) {
            const float c = float(i) / 255.0f;
            to_linear[i] = c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
        }
        for (int i = 0; i < 4096; ++i) {
            const float l = float(i) / 4095.0f;
            const float c = l <= 0.0031308f ? l * 12.92f : 1.055f * std::pow(l, 1.0f / 2.4f) - 0.055f;
            to_srgb[i] = uint8_t(std::lround(std::clamp(c, 0.0f, 1.0f) * 255.0f));
        }
    }
};

// Each mip level is the 2x2 box filter of the previous one, averaged in linear light.
void build_mips(Texture &tex, const SrgbTables &srgb) {
    for (uint32_t level = 1; level < tex.levels; ++level) {
        const uint32_t src_size = tex.size >> (level - 1), dst_size = tex.size >> level;
        const uint8_t *src = tex.texels.data() + tex.level_offset[level - 1];
        uint8_t *dst = tex.texels.data() + tex.level_offset[level];
        for (uint32_t y = 0; y < dst_size; ++y) {
            for (uint32_t x = 0; x < dst_size; ++x) {
                const uint8_t *p00 = src + ((2 * y) * src_size + 2 * x) * 4;
                const uint8_t *p10 = p00 + src_size * 4;
                uint8_t *out = dst + (y * dst_size + x) * 4;
                for (int c = 0; c < 3; ++c) {
                    const float sum = srgb.to_linear[p00[c]] + srgb.to_linear[p00[4 + c]] +
                                      srgb.to_linear[p10[c]] + srgb.to_linear[p10[4 + c]];
                    out[c] = srgb.to_srgb[size_t(sum * (0.25f * 4095.0f) + 0.5f)];
                }
                out[3] = 255;
            }
        }
    }
}

Texture generate(uint32_t index, uint32_t size, const SrgbTables &srgb) {
    const Spec &s = specs[index];
    Texture tex;
    tex.name = s.name;
    tex.size = size;
    tex.levels = uint32_t(std::bit_width(size));
    size_t bytes = 0;
    for (uint32_t level = 0; level < tex.levels; ++level) {
        tex.level_offset.push_back(bytes);
        bytes += size_t(size >> level) * (size >> level) * 4;
    }
    tex.texels.resize(bytes);

    const Noise low(size, 4, 5, hash(index * 2 + 1));
    const Noise high(size, 16, 4, hash(index * 2 + 2));
    Texel t{};
    t.px = 1.0f / float(size);
    for (t.y = 0; t.y < size; ++t.y) {
        t.v = (float(t.y) + 0.5f) * t.px;
        for (t.x = 0; t.x < size; ++t.x) {
            t.u = (float(t.x) + 0.5f) * t.px;
            t.n1 = low.at(t.x, t.y);
            t.n2 = high.at(t.x, t.y);
            const vec3 c = glm::clamp(shade(s, t, size), 0.0f, 1.0f) * 255.0f + 0.5f;
            uint8_t *out = &tex.texels[(size_t(t.y) * size + t.x) * 4];
            out[0] = uint8_t(c.r);
            out[1] = uint8_t(c.g);
            out[2] = uint8_t(c.b);
            out[3] = 255;
        }
    }
    build_mips(tex, srgb);
    return tex;
}

} // namespace

uint32_t texture_index(const std::string &name) {
    for (uint32_t i = 0; i < texture_count; ++i)
        if (name == specs[i].name) return i;
    throw std::logic_error("unknown texture " + name);
}

const char *texture_name(uint32_t index) {
    return specs.at(index).name;
}

Shading texture_shading(uint32_t index) {
    const Spec &s = specs.at(index);
    switch (s.family) {
    case Family::marble:
        return {0.45f, 60.0f};
    case Family::tiles:
        return {0.25f, 40.0f};
    case Family::fabric:
        return {0.04f, 6.0f};
    case Family::plaster:
        return {0.04f, 8.0f};
    case Family::ashlar:
    case Family::brick:
        return {0.07f, 12.0f};
    case Family::organic:
        return s.variant == 2 || s.variant == 3 ? Shading{0.6f, 40.0f} : Shading{0.12f, 16.0f};
    }
    return {0.0f, 1.0f};
}

std::vector<Texture> generate_textures(uint32_t size, unsigned threads) {
    if (size < 16 || !std::has_single_bit(size))
        throw std::invalid_argument("texture size must be a power of two >= 16");
    const SrgbTables srgb;
    std::vector<Texture> textures(texture_count);
    std::atomic<uint32_t> next{0};
    const auto work = [&] {
        for (uint32_t i = next++; i < texture_count; i = next++)
            textures[i] = generate(i, size, srgb);
    };
    std::vector<std::jthread> pool;
    for (unsigned i = 1; i < std::clamp(threads, 1u, texture_count); ++i)
        pool.emplace_back(work);
    work();
    return textures;
}

} // namespace atrium
