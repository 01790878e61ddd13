#version 450
#extension GL_GOOGLE_include_directive : require

// The hdr path's last pass: scene plus bloom, tone-mapped into the swapchain image.
layout(constant_id = 0) const bool encode_srgb = true; // UNORM swapchain

#include "color.glsl"

layout(set = 0, binding = 0) uniform sampler2D scene;
layout(set = 0, binding = 1) uniform sampler2D bloom;

layout(push_constant) uniform Push {
    float bloom_strength;
} pc;

layout(location = 0) in vec2 in_uv;
layout(location = 0) out vec4 out_color;

void main() {
    vec3 c = tone_map(texture(scene, in_uv).rgb + pc.bloom_strength * texture(bloom, in_uv).rgb);
    out_color = vec4(encode_srgb ? linear_to_srgb(c) : c, 1.0);
}
