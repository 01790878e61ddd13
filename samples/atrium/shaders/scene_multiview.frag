#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_multiview : require

// The forward pass of the multiview path: both eyes at once, each into its layer of an sRGB eye
// texture (which encodes), so the view index names the eye.

#include "shading.glsl"
#include "color.glsl"
#include "scene_inputs.glsl"

layout(location = 0) out vec4 out_color;

void main() {
    vec3 base = texture(albedo, in_uv).rgb;
    vec3 n = normalize(gl_FrontFacing ? in_normal : -in_normal);
    out_color = vec4(tone_map(shade(base, n, in_position, gl_ViewIndex, pc.specular, pc.shininess)), 1.0);
}
