#version 450

// The bloom chain's downsample: half the size of its source, a 4x4 box in four bilinear taps.
layout(set = 0, binding = 0) uniform sampler2D source;

layout(push_constant) uniform Push {
    vec2 texel; // one texel of the source, in uv
} pc;

layout(location = 0) in vec2 in_uv;
layout(location = 0) out vec4 out_color;

void main() {
    out_color = 0.25 * (texture(source, in_uv + pc.texel * vec2(-1.0, -1.0)) +
                        texture(source, in_uv + pc.texel * vec2(1.0, -1.0)) +
                        texture(source, in_uv + pc.texel * vec2(-1.0, 1.0)) +
                        texture(source, in_uv + pc.texel * vec2(1.0, 1.0)));
}
