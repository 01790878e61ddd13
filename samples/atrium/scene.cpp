#include "scene.h"

#include "textures.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <tuple>

namespace atrium {

uint32_t SceneBuilder::add_material(std::string name, uint32_t texture, float specular, float shininess) {
    materials_.push_back({std::move(name), texture, specular, shininess});
    indices_.emplace_back();
    return uint32_t(materials_.size() - 1);
}

uint32_t SceneBuilder::add_vertex(const Vertex &v) {
    vertices_.push_back(v);
    return uint32_t(vertices_.size() - 1);
}

void SceneBuilder::add_triangle(uint32_t material, uint32_t a, uint32_t b, uint32_t c) {
    auto &list = indices_[material];
    list.insert(list.end(), {a, b, c});
}

Scene SceneBuilder::finish(bool double_sided, bool procedural) {
    Scene scene;
    scene.double_sided = double_sided;
    scene.procedural = procedural;
    size_t total = 0;
    for (const auto &list : indices_)
        total += list.size();
    scene.indices.reserve(total);
    for (uint32_t m = 0; m < materials_.size(); ++m) {
        if (indices_[m].empty()) continue;
        scene.draws.push_back({m, uint32_t(scene.indices.size()), uint32_t(indices_[m].size())});
        scene.indices.insert(scene.indices.end(), indices_[m].begin(), indices_[m].end());
    }
    if (!vertices_.empty()) {
        scene.bounds_min = scene.bounds_max = vertices_.front().position;
        for (const Vertex &v : vertices_) {
            scene.bounds_min = glm::min(scene.bounds_min, v.position);
            scene.bounds_max = glm::max(scene.bounds_max, v.position);
        }
    }
    scene.vertices = std::move(vertices_);
    scene.materials = std::move(materials_);
    *this = SceneBuilder();
    return scene;
}

namespace {

using glm::vec2;
using glm::vec3;

constexpr float pi = std::numbers::pi_v<float>;

// A profile for surfaces of revolution: (radius, height) points. A repeated point marks a crease.
class Profile {
public:
    Profile &to(float r, float h) {
        pts_.emplace_back(r, h);
        return *this;
    }
    Profile &crease() {
        pts_.push_back(pts_.back());
        return *this;
    }
    Profile &line(float r, float h, int steps) {
        const vec2 from = pts_.back();
        for (int i = 1; i <= steps; ++i)
            pts_.push_back(glm::mix(from, vec2(r, h), float(i) / float(steps)));
        return *this;
    }
    // Arc around centre (cr, ch) from angle a0 to a1 (radians, 0 = outward, pi/2 = up); starts with
    // a point if the profile does not already end there.
    Profile &arc(float cr, float ch, float radius, float a0, float a1, int steps) {
        for (int i = pts_.empty() ? 0 : 1; i <= steps; ++i) {
            const float a = a0 + (a1 - a0) * float(i) / float(steps);
            pts_.emplace_back(cr + radius * std::cos(a), ch + radius * std::sin(a));
        }
        return *this;
    }
    template <typename F>
    Profile &curve(int steps, F &&point) { // point(t) for t in (0, 1]
        for (int i = 1; i <= steps; ++i)
            pts_.push_back(point(float(i) / float(steps)));
        return *this;
    }
    Profile scaled(float s) const {
        Profile p;
        for (const vec2 &v : pts_)
            p.pts_.push_back(v * s);
        return p;
    }
    const std::vector<vec2> &points() const { return pts_; }

private:
    std::vector<vec2> pts_;
};

// An orthonormal frame: `axis` is the lathe axis, (x, z) span the plane of its circles.
struct Frame {
    vec3 origin;
    vec3 x{1, 0, 0}, axis{0, 1, 0}, z{0, 0, 1};
};

vec2 planar_uv(const vec3 &p, const vec3 &n, float scale) {
    const vec3 a = glm::abs(n);
    if (a.y >= a.x && a.y >= a.z) return vec2(p.x, p.z) * scale;
    if (a.x >= a.z) return vec2(p.z, -p.y) * scale;
    return vec2(p.x, -p.y) * scale;
}

// Geometry primitives on top of SceneBuilder. Triangles are wound counter-clockwise around the
// vertex normals, so back-face culling works whatever order a primitive emits its corners in.
class Mesher {
public:
    explicit Mesher(SceneBuilder &builder) : b_(builder) {}

    uint32_t vertex(const vec3 &p, const vec3 &n, const vec2 &uv) { return b_.add_vertex({p, n, uv}); }

    void triangle(uint32_t m, uint32_t a, uint32_t b, uint32_t c) {
        const Vertex &va = b_.vertex(a), &vb = b_.vertex(b), &vc = b_.vertex(c);
        const vec3 g = glm::cross(vb.position - va.position, vc.position - va.position);
        if (glm::dot(g, g) < 1e-14f) return; // degenerate (collapsed lathe rings, creases)
        if (glm::dot(g, va.normal + vb.normal + vc.normal) < 0.0f) std::swap(b, c);
        b_.add_triangle(m, a, b, c);
    }

    void quad(uint32_t m, uint32_t a, uint32_t b, uint32_t c, uint32_t d) {
        triangle(m, a, b, c);
        triangle(m, a, c, d);
    }

    // (nu + 1) x (nv + 1) vertices from vertex_at(i, j), joined into quads.
    template <typename F>
    void grid(uint32_t m, int nu, int nv, F &&vertex_at) {
        const uint32_t base = b_.vertex_count();
        for (int j = 0; j <= nv; ++j)
            for (int i = 0; i <= nu; ++i)
                b_.add_vertex(vertex_at(i, j));
        const auto at = [&](int i, int j) { return base + uint32_t(j * (nu + 1) + i); };
        for (int j = 0; j < nv; ++j)
            for (int i = 0; i < nu; ++i)
                quad(m, at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
    }

    // Parametric surface over [0,1]^2 with normals from central differences, turned to face
    // along outward(p).
    template <typename P, typename U, typename O>
    void surface(uint32_t m, int nu, int nv, P &&pos, U &&uv, O &&outward) {
        constexpr float e = 1e-3f;
        grid(m, nu, nv, [&](int i, int j) {
            const float u = float(i) / float(nu), v = float(j) / float(nv);
            const vec3 p = pos(u, v);
            vec3 n = glm::cross(pos(u + e, v) - pos(u - e, v), pos(u, v + e) - pos(u, v - e));
            const float len = glm::length(n);
            n = len > 1e-9f ? n / len : glm::normalize(outward(p));
            if (glm::dot(n, outward(p)) < 0.0f) n = -n;
            return Vertex{p, n, uv(u, v)};
        });
    }

    // Surface of revolution of `profile` around frame.axis; u wraps uv_u times around.
    void lathe(uint32_t m, const Profile &profile, int segments, const Frame &f, float uv_u, float uv_v) {
        const auto &pts = profile.points();
        const int n = int(pts.size());
        std::vector<vec2> normals(pts.size());
        std::vector<float> arc(pts.size(), 0.0f);
        for (int k = 0; k < n; ++k) {
            // One-sided differences at creases keep the two sides of a crease sharp.
            const vec2 prev = k > 0 && pts[k - 1] != pts[k] ? pts[k - 1] : pts[k];
            const vec2 next = k + 1 < n && pts[k + 1] != pts[k] ? pts[k + 1] : pts[k];
            const vec2 t = next - prev;
            normals[k] = glm::length(t) > 0.0f ? glm::normalize(vec2(t.y, -t.x)) : vec2(1, 0);
            if (k > 0) arc[k] = arc[k - 1] + glm::distance(pts[k - 1], pts[k]);
        }
        grid(m, segments, n - 1, [&](int i, int k) {
            const float phi = 2.0f * pi * float(i) / float(segments);
            const vec3 radial = std::cos(phi) * f.x + std::sin(phi) * f.z;
            const vec3 p = f.origin + pts[k].x * radial + pts[k].y * f.axis;
            const vec3 nn = normals[k].x * radial + normals[k].y * f.axis;
            return Vertex{p, nn, vec2(uv_u * float(i) / float(segments), arc[k] * uv_v)};
        });
    }

    // Planar quad p0 + s du + t dv split into nu x nv cells, facing `normal`.
    void plane(uint32_t m, const vec3 &p0, const vec3 &du, const vec3 &dv, const vec3 &normal, float uv_scale,
               int nu = 1, int nv = 1) {
        grid(m, nu, nv, [&](int i, int j) {
            const vec3 p = p0 + du * (float(i) / float(nu)) + dv * (float(j) / float(nv));
            return Vertex{p, normal, planar_uv(p, normal, uv_scale)};
        });
    }

    void box(uint32_t m, const vec3 &lo, const vec3 &hi, float uv_scale) {
        const vec3 d = hi - lo;
        plane(m, lo, vec3(d.x, 0, 0), vec3(0, d.y, 0), vec3(0, 0, -1), uv_scale);
        plane(m, vec3(lo.x, lo.y, hi.z), vec3(d.x, 0, 0), vec3(0, d.y, 0), vec3(0, 0, 1), uv_scale);
        plane(m, lo, vec3(0, 0, d.z), vec3(0, d.y, 0), vec3(-1, 0, 0), uv_scale);
        plane(m, vec3(hi.x, lo.y, lo.z), vec3(0, 0, d.z), vec3(0, d.y, 0), vec3(1, 0, 0), uv_scale);
        plane(m, lo, vec3(d.x, 0, 0), vec3(0, 0, d.z), vec3(0, -1, 0), uv_scale);
        plane(m, vec3(lo.x, hi.y, lo.z), vec3(d.x, 0, 0), vec3(0, 0, d.z), vec3(0, 1, 0), uv_scale);
    }

private:
    SceneBuilder &b_;
};

// The atrium, in metres with y up: a courtyard centred on the origin, long along x, between two
// two-storey arcades (z = +-facade_z) and two end walls (x = +-end_x).
constexpr float bay = 3.0f;
constexpr int bays = 8;
constexpr float first_column_x = -12.0f; // columns at first_column_x + i * bay, i = 0..bays
constexpr float facade_z = 5.0f;
constexpr float back_z = 8.5f;
constexpr float end_x = 13.0f;
constexpr float column_height = 4.35f; // ground storey column, plinth to abacus top
constexpr float abacus_half = 0.42f;
constexpr float ground_wall_top = 6.3f;
constexpr float gallery_y = 6.55f;
constexpr float upper_scale = 0.72f;
constexpr float upper_spring = gallery_y + column_height * upper_scale;
constexpr float upper_wall_top = 11.3f;
constexpr float attic_y = 11.55f;
constexpr float attic_top = 14.0f;

float column_x(int i) {
    return first_column_x + bay * float(i);
}

Profile column_profile() {
    Profile p;
    p.to(0.40f, 0.20f).arc(0.40f, 0.28f, 0.08f, -pi / 2, pi / 2, 8); // lower torus
    p.crease().to(0.35f, 0.36f);
    p.arc(0.35f, 0.40f, 0.04f, -pi / 2, pi / 2, 6); // upper torus
    p.crease().to(0.31f, 0.44f).crease();
    p.curve(16, [](float t) { // shaft with entasis
        return vec2(0.31f - 0.045f * std::pow(t, 1.6f), 0.44f + t * (3.50f - 0.44f));
    });
    p.crease().arc(0.265f, 3.54f, 0.04f, -pi / 2, pi / 2, 6); // astragal
    p.crease().line(0.265f, 3.68f, 1).crease();
    p.curve(10, [](float t) { // bell of the capital
        const float a = t * pi / 2;
        return vec2(0.265f + 0.155f * (1.0f - std::cos(a)), 3.68f + 0.37f * std::sin(a));
    });
    p.crease().line(0.42f, 4.20f, 1);
    return p;
}

Profile baluster_profile() {
    Profile p;
    p.to(0.065f, 0.0f).line(0.065f, 0.05f, 1).crease().to(0.04f, 0.05f).crease();
    p.curve(12, [](float t) {
        return vec2(0.035f + 0.05f * std::sin(pi * std::pow(t, 0.75f)), 0.05f + 0.47f * t);
    });
    p.arc(0.035f, 0.55f, 0.03f, -pi / 2, pi / 2, 4);
    p.crease().to(0.065f, 0.58f).crease().line(0.065f, 0.68f, 1);
    return p;
}

Profile vase_profile() {
    Profile p;
    p.to(0.20f, 0.0f).line(0.20f, 0.06f, 1).crease();
    p.curve(4, [](float t) { return vec2(0.20f - 0.09f * t, 0.06f + 0.12f * t); }); // foot to stem
    p.curve(14, [](float t) {                                                       // bowl
        return vec2(0.11f + 0.33f * std::sin(pi * 0.62f * t), 0.18f + 0.62f * t);
    });
    p.curve(4, [](float t) { return vec2(0.40f + 0.08f * t, 0.80f + 0.10f * t * t); });
    p.crease().to(0.44f, 0.93f);
    return p;
}

class Atrium {
public:
    explicit Atrium(SceneBuilder &builder) : mesh_(builder) {}

    void build() {
        floors();
        for (float s : {-1.0f, 1.0f}) {
            for (int i = 0; i <= bays; ++i) {
                const bool even = i % 2 == 0;
                column(vec3(column_x(i), 0, s * facade_z), 1.0f, even ? "marble_white" : "marble_cream");
                column(vec3(column_x(i), gallery_y, s * facade_z), upper_scale,
                       even ? "marble_grey" : "marble_rose");
            }
            arcade(s);
            balustrade(s);
            attic_and_roof(s);
            end_wall(s);
        }
        drapes();
        planters();
    }

private:
    static uint32_t m(const char *texture) { return texture_index(texture); }

    void floors() {
        const vec3 up(0, 1, 0);
        // Courtyard: terracotta border, stone slabs, and mosaic / basketweave inlays.
        const float ox = end_x, oz = 4.3f, ix = 12.2f, iz = 3.5f;
        for (float s : {-1.0f, 1.0f}) {
            mesh_.plane(m("tiles_terracotta"), vec3(-ox, 0, s * iz), vec3(2 * ox, 0, 0),
                        vec3(0, 0, s * (oz - iz)), up, 0.5f);
            mesh_.plane(m("tiles_terracotta"), vec3(s * ix, 0, -iz), vec3(s * (ox - ix), 0, 0),
                        vec3(0, 0, 2 * iz), up, 0.5f);
        }
        mesh_.plane(m("tiles_slab"), vec3(-ix, 0, -iz), vec3(2 * ix, 0, 0), vec3(0, 0, 2 * iz), up, 0.25f);
        mesh_.plane(m("tiles_mosaic"), vec3(-3.0f, 0.01f, -1.5f), vec3(6, 0, 0), vec3(0, 0, 3), up, 0.25f);
        for (float s : {-1.0f, 1.0f})
            mesh_.plane(m("tiles_basketweave"), vec3(s * 7.5f - 2.0f, 0.01f, -1.5f), vec3(4, 0, 0),
                        vec3(0, 0, 3), up, 0.5f);
        for (float s : {-1.0f, 1.0f}) {
            // Stylobate under the columns, arcade floor, gallery floor.
            mesh_.box(m("tiles_slate"), vec3(-end_x, 0, std::min(s * 4.3f, s * 5.7f)),
                      vec3(end_x, 0.12f, std::max(s * 4.3f, s * 5.7f)), 0.5f);
            mesh_.plane(m("tiles_checker"), vec3(-end_x, 0, s * 5.7f), vec3(2 * end_x, 0, 0),
                        vec3(0, 0, s * (back_z - 5.7f)), up, 0.25f);
            mesh_.plane(m("tiles_diamond"), vec3(-end_x, gallery_y, s * 5.4f), vec3(2 * end_x, 0, 0),
                        vec3(0, 0, s * (back_z - 5.4f)), up, 0.35f);
        }
    }

    void column(const vec3 &base, float scale, const char *shaft) {
        static const Profile profile = column_profile();
        const float k = scale;
        mesh_.box(m("marble_black"), base + k * vec3(-0.45f, 0, -0.45f), base + k * vec3(0.45f, 0.2f, 0.45f),
                  0.5f);
        mesh_.lathe(m(shaft), profile.scaled(k), 28, Frame{base}, 1.0f, 0.5f);
        mesh_.box(m("cornice_stone"), base + k * vec3(-abacus_half, 4.2f, -abacus_half),
                  base + k * vec3(abacus_half, column_height, abacus_half), 1.0f);
    }

    // A wall slab between the planes z = z_front (facing the courtyard) and z = z_back, spanning
    // [x0, x1] x [y0, y1], with a semicircular arch of radius r centred on (cx, y0) cut out of it.
    void arch_wall(uint32_t front, uint32_t back, float x0, float x1, float y0, float y1, float r,
                   float z_front, float z_back) {
        const float cx = 0.5f * (x0 + x1);
        std::vector<float> angles;
        constexpr int steps = 32;
        for (int k = 0; k <= steps; ++k)
            angles.push_back(pi * float(k) / float(steps));
        angles.push_back(std::atan2(y1 - y0, x1 - cx)); // the rectangle's top corners
        angles.push_back(std::atan2(y1 - y0, x0 - cx));
        std::sort(angles.begin(), angles.end());

        const vec3 n_front(0, 0, z_front > z_back ? 1.0f : -1.0f);
        for (const auto &[z, n, mat] :
             {std::tuple{z_front, n_front, front}, std::tuple{z_back, -n_front, back}}) {
            uint32_t prev_in = 0, prev_out = 0;
            for (size_t k = 0; k < angles.size(); ++k) {
                const vec2 d(std::cos(angles[k]), std::sin(angles[k]));
                float t = (y1 - y0) / std::max(d.y, 1e-6f);
                if (d.x > 1e-6f) t = std::min(t, (x1 - cx) / d.x);
                if (d.x < -1e-6f) t = std::min(t, (x0 - cx) / d.x);
                const vec3 pin(cx + r * d.x, y0 + r * d.y, z), pout(cx + t * d.x, y0 + t * d.y, z);
                const uint32_t in = mesh_.vertex(pin, n, planar_uv(pin, n, 0.5f));
                const uint32_t out = mesh_.vertex(pout, n, planar_uv(pout, n, 0.5f));
                if (k > 0) mesh_.quad(mat, prev_in, prev_out, out, in);
                prev_in = in;
                prev_out = out;
            }
        }
        // Intrados: the underside of the arch.
        mesh_.grid(back, steps, 1, [&](int i, int j) {
            const float a = pi * float(i) / float(steps);
            const vec3 p(cx + r * std::cos(a), y0 + r * std::sin(a), j ? z_back : z_front);
            return Vertex{p, -vec3(std::cos(a), std::sin(a), 0), vec2(a * r * 0.5f, p.z * 0.5f)};
        });
    }

    // Half-round moulding of tube radius t following a semicircle of radius r around `centre` in
    // the plane (right, up), standing out along `out`.
    void archivolt(const vec3 &centre, const vec3 &right, const vec3 &up, const vec3 &out, float r, float t) {
        mesh_.grid(m("cornice_stone"), 40, 6, [&](int i, int j) {
            const float a = pi * float(i) / 40.0f, b = pi * float(j) / 6.0f;
            const vec3 radial = std::cos(a) * right + std::sin(a) * up;
            const vec3 n = std::cos(b) * radial + std::sin(b) * out;
            return Vertex{centre + r * radial + t * n, n, vec2(a * r * 0.5f, float(j) / 6.0f)};
        });
    }

    void vault(uint32_t mat, float cx, float spring, float radius, float z0, float z1) {
        mesh_.grid(mat, 20, 3, [&](int i, int j) {
            const float a = pi * float(i) / 20.0f;
            const vec3 p(cx + radius * std::cos(a), spring + radius * std::sin(a),
                         z0 + (z1 - z0) * float(j) / 3.0f);
            return Vertex{p, -vec3(std::cos(a), std::sin(a), 0), vec2(a * radius * 0.4f, p.z * 0.4f)};
        });
    }

    void arcade(float s) {
        const vec3 toward_court(0, 0, -s);
        struct Storey {
            float spring, top, radius, half_thickness;
            const char *front;
            const char *vault;
            float floor, ceiling;
        };
        const Storey storeys[] = {
            {column_height, ground_wall_top, bay / 2 - abacus_half, 0.35f, "ashlar_sand", "plaster_white",
             0.0f, ground_wall_top},
            {upper_spring, upper_wall_top, bay / 2 - abacus_half * upper_scale, 0.25f, "ashlar_warm",
             "plaster_sky", gallery_y, upper_wall_top},
        };
        for (const Storey &st : storeys) {
            const float zf = s * (facade_z - st.half_thickness), zb = s * (facade_z + st.half_thickness);
            for (int i = 0; i < bays; ++i) {
                const float x0 = column_x(i), cx = x0 + bay / 2;
                arch_wall(m(st.front), m("ashlar_grey"), x0, x0 + bay, st.spring, st.top, st.radius, zf, zb);
                archivolt(vec3(cx, st.spring, zf), vec3(1, 0, 0), vec3(0, 1, 0), toward_court,
                          st.radius + 0.09f, 0.07f);
                mesh_.box(m("cornice_stone"), vec3(cx - 0.12f, st.spring + st.radius - 0.05f, zf - s * 0.1f),
                          vec3(cx + 0.12f, st.spring + st.radius + 0.3f, zf), 1.0f);
                vault(m(st.vault), cx, st.spring, bay / 2, zb, s * back_z);
            }
            // Solid piers between the last columns and the end walls.
            for (float e : {-1.0f, 1.0f}) {
                const float column = -e * first_column_x, wall = e * end_x;
                const float pier = column + e * abacus_half * 0.7f;
                mesh_.box(m(st.front), vec3(std::min(pier, wall), st.floor, std::min(zf, zb)),
                          vec3(std::max(pier, wall), st.spring, std::max(zf, zb)), 0.5f);
                mesh_.box(m(st.front), vec3(std::min(column, wall), st.spring, std::min(zf, zb)),
                          vec3(std::max(column, wall), st.top, std::max(zf, zb)), 0.5f);
            }
            // Flat ceiling above the vaults, seen only past their ends.
            mesh_.plane(m("plaster_grey"), vec3(-end_x, st.ceiling, zb), vec3(2 * end_x, 0, 0),
                        vec3(0, 0, s * back_z - zb), vec3(0, -1, 0), 0.5f);
            // Pilasters on the back wall, under the vault springs.
            for (int i = 0; i <= bays; ++i)
                mesh_.box(m("plaster_grey"),
                          vec3(column_x(i) - 0.3f, st.floor, std::min(s * 8.35f, s * back_z)),
                          vec3(column_x(i) + 0.3f, st.spring, std::max(s * 8.35f, s * back_z)), 0.5f);
        }
        // Cornices over each storey.
        mesh_.box(m("cornice_stone"), vec3(-end_x, ground_wall_top, std::min(s * 4.45f, s * 5.4f)),
                  vec3(end_x, gallery_y, std::max(s * 4.45f, s * 5.4f)), 2.0f);
        mesh_.box(m("cornice_stone"), vec3(-end_x, upper_wall_top, std::min(s * 4.5f, s * 5.4f)),
                  vec3(end_x, attic_y, std::max(s * 4.5f, s * 5.4f)), 2.0f);

        // Back walls, with doors.
        const vec3 n(0, 0, -s);
        mesh_.plane(m("plaster_ochre"), vec3(-end_x, 0, s * back_z), vec3(2 * end_x, 0, 0),
                    vec3(0, gallery_y, 0), n, 0.5f);
        mesh_.plane(m("plaster_rose"), vec3(-end_x, gallery_y, s * back_z), vec3(2 * end_x, 0, 0),
                    vec3(0, attic_y - gallery_y, 0), n, 0.5f);
        for (int i = 0; i < bays; ++i) {
            const float cx = column_x(i) + bay / 2, z = s * (back_z - 0.02f);
            const bool ground = i == 0 || i == 2 || i == 5 || i == 7;
            const float w = ground ? 1.4f : 1.2f, h = ground ? 2.6f : 2.2f, y = ground ? 0.0f : gallery_y;
            mesh_.plane(m(ground ? "wood_oak" : "wood_dark"), vec3(cx - w / 2, y, z), vec3(w, 0, 0),
                        vec3(0, h, 0), n, 0.7f);
            mesh_.box(m("cornice_stone"), vec3(cx - w / 2 - 0.15f, y + h, std::min(z, z - s * 0.12f)),
                      vec3(cx + w / 2 + 0.15f, y + h + 0.2f, std::max(z, z - s * 0.12f)), 1.0f);
        }
    }

    void balustrade(float s) {
        static const Profile profile = baluster_profile();
        const float z0 = std::min(s * 4.85f, s * 5.15f), z1 = std::max(s * 4.85f, s * 5.15f);
        for (int i = 0; i < bays; ++i) {
            const float x0 = column_x(i) + 0.32f, x1 = column_x(i + 1) - 0.32f;
            mesh_.box(m("marble_ochre"), vec3(x0, gallery_y, z0), vec3(x1, gallery_y + 0.13f, z1), 1.0f);
            mesh_.box(m("marble_ochre"), vec3(x0, gallery_y + 0.81f, z0 - 0.03f),
                      vec3(x1, gallery_y + 0.93f, z1 + 0.03f), 1.0f);
            constexpr int count = 9;
            for (int k = 0; k < count; ++k) {
                const float x = x0 + 0.18f + (x1 - x0 - 0.36f) * float(k) / float(count - 1);
                mesh_.lathe(m("marble_green"), profile, 10, Frame{vec3(x, gallery_y + 0.13f, s * facade_z)},
                            1.0f, 1.0f);
            }
        }
    }

    void attic_and_roof(float s) {
        const float zf = s * 4.75f;
        const vec3 n(0, 0, -s);
        mesh_.plane(m("brick_red"), vec3(-end_x, attic_y, zf), vec3(2 * end_x, 0, 0),
                    vec3(0, attic_top - attic_y, 0), n, 0.5f);
        for (int i = 0; i <= bays; ++i)
            mesh_.box(m("ashlar_pale"), vec3(column_x(i) - 0.25f, attic_y, std::min(zf, zf - s * 0.12f)),
                      vec3(column_x(i) + 0.25f, attic_top, std::max(zf, zf - s * 0.12f)), 0.5f);
        for (int i = 0; i < bays; ++i)
            mesh_.plane(m("wood_dark"), vec3(column_x(i) + bay / 2 - 0.4f, 12.25f, zf - s * 0.01f),
                        vec3(0.8f, 0, 0), vec3(0, 1.1f, 0), n, 0.7f);
        mesh_.box(m("cornice_stone"), vec3(-end_x, attic_top, std::min(s * 4.4f, s * 5.3f)),
                  vec3(end_x, attic_top + 0.3f, std::max(s * 4.4f, s * 5.3f)), 2.0f);

        // Eaves: a coffered soffit under a tiled roof that rises away from the courtyard.
        const vec3 a(-end_x, 14.3f, s * 4.2f), along(2 * end_x, 0, 0), across(0, 1.0f, s * 4.6f);
        vec3 down = glm::normalize(glm::cross(along, across));
        if (down.y > 0.0f) down = -down;
        mesh_.plane(m("plaster_coffer"), a, along, across, down, 0.5f);
        mesh_.plane(m(s > 0 ? "roof_red" : "roof_brown"), a + vec3(0, 0.12f, 0), along, across, -down, 0.35f);
        mesh_.box(m("wood_oak"), vec3(-end_x, 14.22f, std::min(s * 4.05f, s * 4.25f)),
                  vec3(end_x, 14.42f, std::max(s * 4.05f, s * 4.25f)), 1.0f);
    }

    void end_wall(float e) {
        const float x = e * end_x;
        const vec3 n(-e, 0, 0), right(0, 0, e), up(0, 1, 0);
        // Courtyard face by storey, and the ends of the two arcades.
        const float levels[] = {0.0f, gallery_y, attic_y, attic_top + 0.3f};
        const char *court[] = {"ashlar_ochre", "ashlar_rose", "ashlar_dark"};
        const char *arcade_end[] = {"brick_brown", "brick_yellow"};
        for (int l = 0; l < 3; ++l) {
            const float y = levels[l], h = levels[l + 1] - y;
            mesh_.plane(m(court[l]), vec3(x, y, -facade_z), vec3(0, 0, 2 * facade_z), vec3(0, h, 0), n, 0.5f);
            if (l < 2)
                for (float s : {-1.0f, 1.0f})
                    mesh_.plane(m(arcade_end[l]), vec3(x, y, s * facade_z),
                                vec3(0, 0, s * (back_z - facade_z)), vec3(0, h, 0), n, 0.5f);
        }
        for (float y : {ground_wall_top, upper_wall_top, attic_top})
            mesh_.box(m("cornice_stone"), vec3(std::min(x, x - e * 0.4f), y, -4.45f),
                      vec3(std::max(x, x - e * 0.4f), y + 0.25f, 4.45f), 2.0f);

        // Ground storey: a blind arch framing a bronze medallion over a basin.
        const float face = x - e * 0.02f;
        arch_panel(vec3(face, 0.12f, 0), right, up, n, 2.6f, 3.4f);
        archivolt(vec3(face, 3.52f, 0), right, up, n, 2.7f, 0.09f);
        for (float s : {-1.0f, 1.0f})
            mesh_.box(m("cornice_stone"), vec3(std::min(x, x - e * 0.15f), 0, s * 2.85f - 0.15f),
                      vec3(std::max(x, x - e * 0.15f), 3.52f, s * 2.85f + 0.15f), 1.0f);
        Profile medallion;
        medallion.to(0.85f, 0.0f).arc(0.85f, 0.08f, 0.08f, -pi / 2, pi / 2, 6).crease();
        medallion.curve(10, [](float t) {
            const float a = t * pi / 2;
            return vec2(0.8f * std::cos(a), 0.16f + 0.14f * std::sin(a));
        });
        mesh_.lathe(m("bronze"), medallion, 32, Frame{vec3(x, 3.1f, 0), vec3(0, 1, 0), n, vec3(0, 0, 1)},
                    2.0f, 1.0f);
        Profile basin;
        basin.to(0.25f, 0.0f).curve(8, [](float t) {
            return vec2(0.25f + 0.65f * std::sin(t * pi / 2), 0.5f * t);
        });
        basin.crease().line(0.95f, 0.55f, 1).crease().line(0.8f, 0.55f, 1);
        mesh_.lathe(m("marble_green"), basin, 32, Frame{vec3(x, 0.4f, 0)}, 2.0f, 1.0f);

        // Gallery storey: three blind arches and two banners.
        for (float z : {-3.0f, 0.0f, 3.0f}) {
            arch_panel(vec3(face, gallery_y + 0.2f, z), right, up, n, 0.8f, 2.6f);
            archivolt(vec3(face, gallery_y + 2.8f, z), right, up, n, 0.88f, 0.06f);
        }
        for (float s : {-1.0f, 1.0f})
            drape(m(s * e > 0 ? "fabric_stripes_red" : "fabric_stripes_blue"),
                  vec3(x - e * 0.25f, 11.15f, s * 4.0f), right, n, 1.0f, 3.8f, 3, 16, 40);
    }

    // A flat, round-topped panel: a w/2-wide rectangle of height h from `base` plus a half disc.
    void arch_panel(const vec3 &base, const vec3 &right, const vec3 &up, const vec3 &n, float half_width,
                    float h) {
        const uint32_t mat = m("plaster_green");
        mesh_.plane(mat, base - half_width * right, 2 * half_width * right, h * up, n, 0.5f);
        const vec3 c = base + h * up;
        const uint32_t centre = mesh_.vertex(c, n, planar_uv(c, n, 0.5f));
        uint32_t prev = 0;
        for (int k = 0; k <= 24; ++k) {
            const float a = pi * float(k) / 24.0f;
            const vec3 p = c + half_width * (std::cos(a) * right + std::sin(a) * up);
            const uint32_t v = mesh_.vertex(p, n, planar_uv(p, n, 0.5f));
            if (k > 0) mesh_.triangle(mat, centre, prev, v);
            prev = v;
        }
    }

    // Cloth hanging from a rod: top edge centred on `top`, spread along `right`, falling down,
    // folding and billowing along `out`. Both sides are meshed.
    void drape(uint32_t mat, const vec3 &top, const vec3 &right, const vec3 &out, float width, float length,
               int folds, int nu, int nv) {
        const auto pos = [=](float u, float v) {
            const float fold = 0.5f * std::sin(2 * pi * folds * u) * (0.05f + 0.07f * v);
            const float hem = 0.12f * (1.0f - std::pow(2 * u - 1, 2.0f)) * v * v;
            return top + (u - 0.5f) * width * right + (-length * v + hem) * vec3(0, 1, 0) +
                   (fold * width + 0.12f * v * v) * out;
        };
        const auto uv = [=](float u, float v) { return vec2(u * width / 2.2f, v); }; // hem at the bottom
        mesh_.surface(mat, nu, nv, pos, uv, [&](const vec3 &) { return out; });
        mesh_.surface(mat, nu, nv, pos, uv, [&](const vec3 &) { return -out; });
        Profile rod;
        rod.to(0.03f, -0.5f * width - 0.1f).line(0.03f, 0.5f * width + 0.1f, 1);
        mesh_.lathe(m("iron"), rod, 10, Frame{top, out, right, vec3(0, 1, 0)}, 1.0f, 1.0f);
    }

    void drapes() {
        const char *fabrics[2][4] = {{"fabric_purple", "fabric_red", "fabric_green", "fabric_blue"},
                                     {"fabric_red", "fabric_green", "fabric_blue", "fabric_gold"}};
        const int drape_bays[4] = {1, 3, 4, 6};
        for (int side = 0; side < 2; ++side) {
            const float s = side ? 1.0f : -1.0f;
            for (int k = 0; k < 4; ++k) {
                const float cx = column_x(drape_bays[k]) + bay / 2;
                drape(m(fabrics[side][k]), vec3(cx, 6.15f, s * 4.4f), vec3(1, 0, 0), vec3(0, 0, -s), 2.3f,
                      4.5f, 6, 40, 56);
            }
        }
    }

    void planters() {
        static const Profile vase = vase_profile();
        for (float s : {-1.0f, 1.0f})
            for (int i : {0, 2, 5, 7}) {
                const vec3 base(column_x(i) + bay / 2, 0, s * 3.6f);
                mesh_.box(m("brick_grey"), base + vec3(-0.35f, 0, -0.35f), base + vec3(0.35f, 0.5f, 0.35f),
                          1.0f);
                mesh_.lathe(m("terracotta_pot"), vase, 32, Frame{base + vec3(0, 0.5f, 0)}, 2.0f, 1.0f);
                const vec3 c = base + vec3(0, 1.72f, 0);
                const float phase = float(i) + s;
                const auto pos = [=](float u, float v) {
                    const float a = 2 * pi * u, b = pi * (0.03f + 0.94f * v);
                    const float r = 0.55f * (1.0f + 0.1f * std::sin(7 * a + phase) * std::sin(5 * b) +
                                             0.06f * std::sin(13 * a + 3 * b + phase));
                    return c + r * vec3(std::sin(b) * std::cos(a), -std::cos(b), std::sin(b) * std::sin(a));
                };
                mesh_.surface(
                    m(s > 0 ? "foliage_green" : "foliage_olive"), 36, 20, pos,
                    [](float u, float v) { return vec2(u * 3.0f, v * 1.5f); },
                    [c](const vec3 &p) { return p - c; });
            }
    }

    Mesher mesh_;
};

} // namespace

Scene build_atrium() {
    SceneBuilder builder;
    for (uint32_t t = 0; t < texture_count; ++t) {
        const Shading s = texture_shading(t);
        builder.add_material(texture_name(t), t, s.specular, s.shininess);
    }
    Atrium(builder).build();
    Scene scene = builder.finish(false, true);
    scene.sun_occlusion.enabled = true;
    scene.sun_occlusion.opening = glm::vec4(-end_x, end_x, -4.2f, 4.2f);
    scene.sun_occlusion.roof_height = 14.3f;
    scene.sun_occlusion.facades =
        glm::vec4(facade_z, column_height + 0.9f, gallery_y + 0.9f, upper_spring + 1.0f);
    return scene;
}

} // namespace atrium
