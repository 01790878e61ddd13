// CPU-side scene: one vertex buffer, one index buffer sorted by material, and one draw per material.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <glm/glm.hpp>

namespace atrium {

struct Vertex {
    glm::vec3 position;
    glm::vec3 normal;
    glm::vec2 uv;
};
static_assert(sizeof(Vertex) == 32, "Vertex must match the pipeline's vertex input layout");

struct Material {
    std::string name;
    uint32_t texture = 0; // index into the texture library
    float specular = 0.0f;
    float shininess = 1.0f;
};

struct DrawRange {
    uint32_t material = 0;
    uint32_t first_index = 0;
    uint32_t index_count = 0;
};

// A cheap analytic stand-in for shadow maps, for scenes shaped like the atrium: the sun reaches a
// point only if the ray towards it leaves through the open roof of the courtyard and, from behind
// the facades, passes through the arcade openings. Columns and drapes cast no shadows.
struct SunOcclusion {
    bool enabled = false;
    glm::vec4 opening{0.0f};  // x0, x1, z0, z1 of the roof opening
    float roof_height = 0.0f; // y of the roof opening
    glm::vec4 facades{0.0f};  // |z| of the facade planes, top of the ground openings, bottom and top of the
                              // gallery openings
};

struct Scene {
    std::vector<Vertex> vertices;
    std::vector<uint32_t> indices;
    std::vector<Material> materials;
    std::vector<DrawRange> draws; // one per material that has triangles, in material order
    glm::vec3 bounds_min{0.0f};
    glm::vec3 bounds_max{0.0f};
    bool double_sided = false; // disable back-face culling (models of unknown winding)
    bool procedural = false;   // the built-in atrium (its camera path and sun are tuned for it)
    SunOcclusion sun_occlusion;

    size_t triangle_count() const { return indices.size() / 3; }
};

// Accumulates vertices and per-material triangle lists, then lays the indices out material by
// material so that each material is a single indexed draw.
class SceneBuilder {
public:
    uint32_t add_material(std::string name, uint32_t texture, float specular, float shininess);
    uint32_t add_vertex(const Vertex &v);
    void add_triangle(uint32_t material, uint32_t a, uint32_t b, uint32_t c);

    const Vertex &vertex(uint32_t index) const { return vertices_[index]; }
    uint32_t vertex_count() const { return uint32_t(vertices_.size()); }
    size_t material_count() const { return materials_.size(); }

    Scene finish(bool double_sided, bool procedural);

private:
    std::vector<Vertex> vertices_;
    std::vector<Material> materials_;
    std::vector<std::vector<uint32_t>> indices_; // per material
};

// The procedural atrium: two-storey arcades around a courtyard, drapes, balustrades and planters.
Scene build_atrium();

} // namespace atrium
