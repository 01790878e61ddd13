#version 450
#extension GL_GOOGLE_include_directive : require

// The deferred path's post-processing: tone mapping and a vignette per eye, into the swapchain.
layout(constant_id = 0) const bool encode_srgb = true; // UNORM swapchain

#include "color.glsl"

layout(set = 0, binding = 0) uniform sampler2D radiance;

layout(push_constant) uniform Push {
    float split; // where eye 1 starts, as a fraction of the width (1: mono)
    float vignette;
} pc;

layout(location = 0) in vec2 in_uv;
layout(location = 0) out vec4 out_color;

void main() {
    vec3 c = tone_map(texture(radiance, in_uv).rgb);
    float x = in_uv.x >= pc.split ? (in_uv.x - pc.split) / (1.0 - pc.split) : in_uv.x / pc.split;
    vec2 d = vec2(x, in_uv.y) * 2.0 - 1.0;
    c *= 1.0 - pc.vignette * dot(d, d);
    out_color = vec4(encode_srgb ? linear_to_srgb(c) : c, 1.0);
}
