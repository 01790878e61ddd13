#include "obj_loader.h"

#include "error.h"
#include "textures.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <fstream>
#include <sstream>
#include <string_view>
#include <unordered_map>

namespace atrium {
namespace {

struct Corner {
    int v = -1, vt = -1, vn = -1; // zero-based, -1 if absent
    bool operator==(const Corner &) const = default;
};

struct CornerHash {
    size_t operator()(const Corner &c) const {
        return (size_t(uint32_t(c.v)) * 0x9e3779b97f4a7c15ull) ^
               (size_t(uint32_t(c.vt)) * 0xc2b2ae3d27d4eb4full) ^ size_t(uint32_t(c.vn));
    }
};

struct Face {
    uint32_t material;
    uint32_t first_corner, corner_count;
    size_t line;
};

class Parser {
public:
    explicit Parser(std::string path) : path_(std::move(path)) {}

    Scene parse() {
        std::ifstream file(path_, std::ios::binary);
        if (!file) throw Error(path_ + ": cannot open");
        std::stringstream buffer;
        buffer << file.rdbuf();
        const std::string text = buffer.str();

        size_t begin = 0;
        while (begin < text.size()) {
            size_t end = text.find('\n', begin);
            if (end == std::string::npos) end = text.size();
            ++line_;
            parse_line(std::string_view(text).substr(begin, end - begin));
            begin = end + 1;
        }
        return build();
    }

private:
    [[noreturn]] void fail(const std::string &why) const {
        throw Error(path_ + ":" + std::to_string(line_) + ": " + why);
    }

    static bool space(char c) { return c == ' ' || c == '\t' || c == '\r'; }

    static std::string_view next_token(std::string_view &s) {
        size_t i = 0;
        while (i < s.size() && space(s[i]))
            ++i;
        size_t j = i;
        while (j < s.size() && !space(s[j]))
            ++j;
        const std::string_view token = s.substr(i, j - i);
        s.remove_prefix(j);
        return token;
    }

    float number(std::string_view &s) {
        const std::string_view token = next_token(s);
        float value = 0.0f;
        const auto [ptr, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
        if (token.empty() || ec != std::errc() || ptr != token.data() + token.size())
            fail("expected a number, got '" + std::string(token) + "'");
        return value;
    }

    // OBJ indices are 1-based; negative ones count back from the latest element.
    int index(std::string_view token, size_t count, const char *what) {
        int value = 0;
        const auto [ptr, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
        if (token.empty() || ec != std::errc() || ptr != token.data() + token.size() || value == 0)
            fail(std::string("bad ") + what + " index '" + std::string(token) + "'");
        const long resolved = value > 0 ? long(value) - 1 : long(count) + value;
        if (resolved < 0 || resolved >= long(count))
            fail(std::string(what) + " index " + std::to_string(value) + " out of range");
        return int(resolved);
    }

    void parse_line(std::string_view s) {
        const std::string_view keyword = next_token(s);
        if (keyword == "v") {
            const float x = number(s), y = number(s), z = number(s);
            positions_.emplace_back(x, y, z);
        } else if (keyword == "vt") {
            const float u = number(s);
            std::string_view peek = s;
            const float v = next_token(peek).empty() ? 0.0f : number(s); // v is optional
            uvs_.emplace_back(u, 1.0f - v); // OBJ's v grows upwards, Vulkan's t downwards
        } else if (keyword == "vn") {
            const float x = number(s), y = number(s), z = number(s);
            normals_.emplace_back(x, y, z);
        } else if (keyword == "f") {
            Face face{current_material(), uint32_t(corners_.size()), 0, line_};
            for (std::string_view token = next_token(s); !token.empty(); token = next_token(s)) {
                Corner c;
                const size_t slash1 = token.find('/');
                c.v = index(token.substr(0, slash1), positions_.size(), "vertex");
                if (slash1 != std::string_view::npos) {
                    const std::string_view rest = token.substr(slash1 + 1);
                    const size_t slash2 = rest.find('/');
                    const std::string_view vt = rest.substr(0, slash2);
                    if (!vt.empty()) c.vt = index(vt, uvs_.size(), "texture coordinate");
                    if (slash2 != std::string_view::npos)
                        c.vn = index(rest.substr(slash2 + 1), normals_.size(), "normal");
                }
                corners_.push_back(c);
                ++face.corner_count;
            }
            if (face.corner_count < 3) fail("face with fewer than three vertices");
            faces_.push_back(face);
        } else if (keyword == "usemtl") {
            const std::string_view name = next_token(s);
            if (name.empty()) fail("usemtl without a name");
            material_ = material(std::string(name));
        }
        // Anything else (comments, o, g, s, mtllib, l, p) carries nothing we draw.
    }

    uint32_t material(const std::string &name) {
        const auto [it, inserted] = material_ids_.try_emplace(name, uint32_t(material_names_.size()));
        if (inserted) material_names_.push_back(name);
        return it->second;
    }

    uint32_t current_material() {
        if (material_ == uint32_t(-1)) material_ = material("default");
        return material_;
    }

    Scene build() {
        if (faces_.empty()) throw Error(path_ + ": no faces");
        SceneBuilder builder;
        for (const std::string &name : material_names_) {
            const uint32_t texture = texture_for_material(name);
            const Shading s = texture_shading(texture);
            builder.add_material(name, texture, s.specular, s.shininess);
        }
        glm::vec3 lo = positions_.front(), hi = positions_.front();
        for (const glm::vec3 &p : positions_) {
            lo = glm::min(lo, p);
            hi = glm::max(hi, p);
        }
        // Planar texture coordinates for corners without any: about two repeats per tenth of the model.
        const float uv_scale = 20.0f / std::max(glm::length(hi - lo), 1e-6f);

        std::unordered_map<Corner, uint32_t, CornerHash> vertex_ids;
        std::vector<uint32_t> ids;
        for (const Face &face : faces_) {
            line_ = face.line;
            const Corner *c = &corners_[face.first_corner];
            // Newell's method: a robust normal for faces (even non-planar polygons) lacking normals.
            glm::vec3 newell(0.0f);
            for (uint32_t k = 0; k < face.corner_count; ++k) {
                const glm::vec3 &a = positions_[c[k].v], &b = positions_[c[(k + 1) % face.corner_count].v];
                newell += glm::vec3((a.y - b.y) * (a.z + b.z), (a.z - b.z) * (a.x + b.x),
                                    (a.x - b.x) * (a.y + b.y));
            }
            const float len = glm::length(newell);
            const glm::vec3 face_normal = len > 0.0f ? newell / len : glm::vec3(0, 1, 0);

            ids.clear();
            for (uint32_t k = 0; k < face.corner_count; ++k) {
                const bool shareable = c[k].vn >= 0;
                if (shareable) {
                    if (const auto it = vertex_ids.find(c[k]); it != vertex_ids.end()) {
                        ids.push_back(it->second);
                        continue;
                    }
                }
                Vertex v;
                v.position = positions_[c[k].v];
                v.normal = shareable ? normals_[c[k].vn] : face_normal;
                if (c[k].vt >= 0) {
                    v.uv = uvs_[c[k].vt];
                } else {
                    const glm::vec3 a = glm::abs(v.normal);
                    v.uv = (a.y >= a.x && a.y >= a.z ? glm::vec2(v.position.x, v.position.z)
                            : a.x >= a.z             ? glm::vec2(v.position.z, -v.position.y)
                                                     : glm::vec2(v.position.x, -v.position.y)) *
                           uv_scale;
                }
                const uint32_t id = builder.add_vertex(v);
                if (shareable) vertex_ids.emplace(c[k], id);
                ids.push_back(id);
            }
            for (uint32_t k = 1; k + 1 < face.corner_count; ++k) // polygons become fans
                builder.add_triangle(face.material, ids[0], ids[k], ids[k + 1]);
        }
        return builder.finish(true, false);
    }

    std::string path_;
    size_t line_ = 0;
    std::vector<glm::vec3> positions_, normals_;
    std::vector<glm::vec2> uvs_;
    std::vector<Corner> corners_;
    std::vector<Face> faces_;
    std::unordered_map<std::string, uint32_t> material_ids_;
    std::vector<std::string> material_names_;
    uint32_t material_ = uint32_t(-1);
};

} // namespace

uint32_t texture_for_material(const std::string &name) {
    struct Rule {
        const char *keyword;
        const char *first_texture;
        uint32_t count; // consecutive textures to choose from
    };
    static constexpr std::array<Rule, 22> rules = {{
        {"fabric", "fabric_red", 7},
        {"curtain", "fabric_red", 7},
        {"cloth", "fabric_red", 7},
        {"leaf", "foliage_green", 2},
        {"plant", "foliage_green", 2},
        {"flower", "foliage_green", 2},
        {"vase", "terracotta_pot", 1},
        {"roof", "roof_red", 2},
        {"brick", "brick_red", 4},
        {"floor", "tiles_checker", 7},
        {"tile", "tiles_checker", 7},
        {"column", "marble_white", 7},
        {"pillar", "marble_white", 7},
        {"marble", "marble_white", 7},
        {"ceiling", "plaster_white", 7},
        {"arch", "ashlar_sand", 7},
        {"wall", "ashlar_sand", 7},
        {"chain", "iron", 1},
        {"pole", "iron", 1},
        {"lion", "bronze", 1},
        {"wood", "wood_oak", 2},
        {"detail", "cornice_stone", 1},
    }};
    std::string lower = name;
    std::transform(lower.begin(), lower.end(), lower.begin(),
                   [](unsigned char c) { return char(std::tolower(c)); });
    uint32_t hash = 2166136261u; // FNV-1a
    for (unsigned char c : lower)
        hash = (hash ^ c) * 16777619u;
    for (const Rule &rule : rules)
        if (lower.find(rule.keyword) != std::string::npos)
            return texture_index(rule.first_texture) + hash % rule.count;
    return hash % texture_count;
}

Scene load_obj(const std::string &path) {
    return Parser(path).parse();
}

} // namespace atrium
