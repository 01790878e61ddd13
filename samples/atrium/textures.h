// The 49 procedural textures: square RGBA8 images in sRGB encoding with full mip chains, generated
// deterministically at start-up (no image files, no decoder).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace atrium {

struct Texture {
    std::string name;
    uint32_t size = 0;                // width and height of level 0, a power of two
    uint32_t levels = 0;              // log2(size) + 1
    std::vector<size_t> level_offset; // byte offset of each level in texels
    std::vector<uint8_t> texels;      // all levels back to back, RGBA8, sRGB encoded
};

inline constexpr uint32_t texture_count = 49;

// Index of a texture in the library by name (e.g. "marble_white"); throws if unknown.
uint32_t texture_index(const std::string &name);
const char *texture_name(uint32_t index);

// Blinn-Phong parameters that suit a texture's kind of surface (polished marble, cloth, ...).
struct Shading {
    float specular;
    float shininess;
};
Shading texture_shading(uint32_t index);

// Generates the whole library at size x size, using up to `threads` threads. Same output for
// any thread count.
std::vector<Texture> generate_textures(uint32_t size, unsigned threads);

} // namespace atrium
