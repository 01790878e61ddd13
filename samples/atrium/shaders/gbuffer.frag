#version 450
#extension GL_GOOGLE_include_directive : require

// The deferred path's G-buffer: albedo and specular strength, normal (facing the viewer) and
// shininess; the position comes back from the depth buffer.

#include "scene_inputs.glsl"

layout(location = 0) out vec4 out_albedo; // rgb: linear albedo, a: specular strength
layout(location = 1) out vec4 out_normal; // xyz: unit normal, w: shininess

void main() {
    out_albedo = vec4(texture(albedo, in_uv).rgb, pc.specular);
    out_normal = vec4(normalize(gl_FrontFacing ? in_normal : -in_normal), pc.shininess);
}
