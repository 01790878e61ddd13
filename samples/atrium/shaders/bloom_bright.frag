#version 450

// First step of the bloom chain: what is brighter than the threshold, at half size. Four
// bilinear taps average the 4x4 full-size texels around this one.
layout(set = 0, binding = 0) uniform sampler2D source;

layout(push_constant) uniform Push {
    vec2 texel; // one texel of the source, in uv
    float threshold;
} pc;

layout(location = 0) in vec2 in_uv;
layout(location = 0) out vec4 out_color;

void main() {
    vec3 c = 0.25 * (texture(source, in_uv + pc.texel * vec2(-1.0, -1.0)).rgb +
                     texture(source, in_uv + pc.texel * vec2(1.0, -1.0)).rgb +
                     texture(source, in_uv + pc.texel * vec2(-1.0, 1.0)).rgb +
                     texture(source, in_uv + pc.texel * vec2(1.0, 1.0)).rgb);
    float brightness = max(c.r, max(c.g, c.b));
    out_color = vec4(c * max(brightness - pc.threshold, 0.0) / max(brightness, 1e-4), 1.0);
}
