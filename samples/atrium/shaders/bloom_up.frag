#version 450

// The bloom chain's upsample: a 3x3 tent over the smaller level, added (by blending) to the
// level twice its size.
layout(set = 0, binding = 0) uniform sampler2D source;

layout(push_constant) uniform Push {
    vec2 texel; // one texel of the source, in uv
} pc;

layout(location = 0) in vec2 in_uv;
layout(location = 0) out vec4 out_color;

void main() {
    vec4 sum = vec4(0.0);
    for (int y = -1; y <= 1; ++y)
        for (int x = -1; x <= 1; ++x)
            sum += texture(source, in_uv + pc.texel * vec2(x, y)) * float((2 - abs(x)) * (2 - abs(y)));
    out_color = vec4(sum.rgb / 16.0, 1.0);
}
