#version 450

// Must match atrium::FrameUniforms (renderer.h), std140.
layout(set = 0, binding = 0) uniform Frame {
    mat4 view_proj[2];
    vec4 eye_position[2];
    vec4 sun_direction;
    vec4 sun_color;
    vec4 sky_color;
    vec4 ground_color;
    vec4 sun_opening;
    vec4 sun_facades;
    vec4 sun_params;
} frame;

layout(push_constant) uniform Push {
    uint eye;
    float specular;
    float shininess;
} pc;

layout(location = 0) in vec3 in_position;
layout(location = 1) in vec3 in_normal;
layout(location = 2) in vec2 in_uv;

layout(location = 0) out vec3 out_position;
layout(location = 1) out vec3 out_normal;
layout(location = 2) out vec2 out_uv;

void main() {
    // The scene is static and in world space: no model matrix.
    out_position = in_position;
    out_normal = in_normal;
    out_uv = in_uv;
    gl_Position = frame.view_proj[pc.eye] * vec4(in_position, 1.0);
}
