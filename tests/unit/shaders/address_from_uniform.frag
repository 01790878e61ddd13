#version 460
// An address the host wrote into a uniform buffer: untyped bytes on the wire.
#extension GL_EXT_buffer_reference : require

layout(buffer_reference, std430) readonly buffer Colors {
    vec4 color[];
};

layout(set = 0, binding = 0) uniform Frame {
    Colors colors;
} frame;

layout(location = 0) out vec4 out_color;

void main() {
    out_color = frame.colors.color[0];
}
