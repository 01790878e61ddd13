#version 450
// scene.vert with the view-projection matrices read through a buffer device address passed in push
// constants (--buffer-address) instead of the frame's uniform-buffer descriptor.
#extension GL_EXT_buffer_reference : require

// The start of atrium::FrameUniforms (renderer.h), std140, as the uniform block has it.
layout(buffer_reference, std140, buffer_reference_align = 16) readonly buffer FrameRef {
    mat4 view_proj[2];
};

layout(push_constant) uniform Push {
    uint eye;
    float specular;
    float shininess;
    FrameRef frame; // offset 16: atrium::PushConstants::frame
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
    gl_Position = pc.frame.view_proj[pc.eye] * vec4(in_position, 1.0);
}
