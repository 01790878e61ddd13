#version 450
#extension GL_GOOGLE_include_directive : require

// The forward pass: the lit, tone-mapped scene (direct, secondary), or its linear HDR radiance
// (hdr, compute).

// True when the target is UNORM and shows display colours: the shader then encodes to sRGB
// itself, so that UNORM and SRGB swapchains show the same picture.
layout(constant_id = 0) const bool encode_srgb = true;
// False: write linear HDR radiance, for a later tone-mapping pass.
layout(constant_id = 1) const bool display = true;

#include "shading.glsl"
#include "color.glsl"
#include "scene_inputs.glsl"

layout(location = 0) out vec4 out_color;

void main() {
    vec3 base = texture(albedo, in_uv).rgb; // sRGB texture, so already linear
    vec3 n = normalize(gl_FrontFacing ? in_normal : -in_normal);
    vec3 color = shade(base, n, in_position, pc.eye, pc.specular, pc.shininess);
    if (display)
        color = tone_map(color);
    out_color = vec4(display && encode_srgb ? linear_to_srgb(color) : color, 1.0);
}
