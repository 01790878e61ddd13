#version 450
// scene_address.vert with the address of the matrices written by the host into the frame's uniform
// block (--buffer-address uniform): an address in memory, which no type on the wire marks. splitvk's
// agent cannot translate it and must not draw with it (docs/user-guide.md, "Buffer device addresses").
#extension GL_EXT_buffer_reference : require

layout(buffer_reference, std140, buffer_reference_align = 16) readonly buffer FrameRef {
    mat4 view_proj[2];
};

// atrium::FrameUniforms (scene_gpu.h), std140, up to its frame_address.
layout(set = 0, binding = 0) uniform Frame {
    mat4 view_proj[2];
    vec4 eye_position[2];
    vec4 sun[7];
    mat4 inv_view_proj[2];
    FrameRef self; // this very block, through its buffer device address
} frame;

layout(push_constant) uniform Push {
    uint eye;
} pc;

layout(location = 0) in vec3 in_position;
layout(location = 1) in vec3 in_normal;
layout(location = 2) in vec2 in_uv;

layout(location = 0) out vec3 out_position;
layout(location = 1) out vec3 out_normal;
layout(location = 2) out vec2 out_uv;

void main() {
    out_position = in_position;
    out_normal = in_normal;
    out_uv = in_uv;
    gl_Position = frame.self.view_proj[pc.eye] * vec4(in_position, 1.0);
}
