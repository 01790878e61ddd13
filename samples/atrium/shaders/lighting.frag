#version 450
#extension GL_GOOGLE_include_directive : require

// The deferred path's lighting: reads the G-buffer texel under this fragment (texelFetch at
// gl_FragCoord: the G-buffer has the size of this pass's target), rebuilds the position from
// depth and writes linear HDR radiance.

#include "shading.glsl"

layout(set = 1, binding = 0) uniform sampler2D gbuffer_albedo;
layout(set = 1, binding = 1) uniform sampler2D gbuffer_normal;
layout(set = 1, binding = 2) uniform sampler2D gbuffer_depth;

layout(push_constant) uniform Push {
    vec4 sky;    // rgb: radiance where nothing was drawn
    float split; // where eye 1 starts, as a fraction of the width (1: mono)
} pc;

layout(location = 0) in vec2 in_uv;
layout(location = 0) out vec4 out_color;

void main() {
    ivec2 texel = ivec2(gl_FragCoord.xy);
    float depth = texelFetch(gbuffer_depth, texel, 0).r;
    if (depth == 1.0) {
        out_color = vec4(pc.sky.rgb, 1.0);
        return;
    }
    // The eye and the position within it come from uv, not from pixel numbers, so that the pass
    // reads the same under any scaling of its targets.
    uint eye = in_uv.x >= pc.split ? 1u : 0u;
    float x = eye == 0u ? in_uv.x / pc.split : (in_uv.x - pc.split) / (1.0 - pc.split);
    vec4 p = frame.inv_view_proj[eye] * vec4(x * 2.0 - 1.0, in_uv.y * 2.0 - 1.0, depth, 1.0);
    vec4 albedo = texelFetch(gbuffer_albedo, texel, 0);
    vec4 normal = texelFetch(gbuffer_normal, texel, 0);
    out_color = vec4(shade(albedo.rgb, normal.xyz, p.xyz / p.w, eye, albedo.a, normal.w), 1.0);
}
