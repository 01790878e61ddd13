#version 450
#extension GL_GOOGLE_include_directive : require

// The multiview path's composition: layer 0 of the eye texture on the left half, layer 1 on the
// right (mono: layer 0 over the whole image). The eye texture is sRGB, so sampling decodes.
layout(constant_id = 0) const bool encode_srgb = true; // UNORM swapchain

#include "color.glsl"

layout(set = 0, binding = 0) uniform sampler2DArray eyes;

layout(push_constant) uniform Push {
    float split; // where eye 1 starts, as a fraction of the width (1: mono)
} pc;

layout(location = 0) in vec2 in_uv;
layout(location = 0) out vec4 out_color;

void main() {
    float eye = in_uv.x >= pc.split ? 1.0 : 0.0;
    float x = eye == 0.0 ? in_uv.x / pc.split : (in_uv.x - pc.split) / (1.0 - pc.split);
    vec3 c = texture(eyes, vec3(x, in_uv.y, eye)).rgb;
    out_color = vec4(encode_srgb ? linear_to_srgb(c) : c, 1.0);
}
