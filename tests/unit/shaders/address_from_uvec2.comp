#version 460
// An address built from two 32-bit halves.
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_buffer_reference_uvec2 : require
layout(local_size_x = 1) in;

layout(buffer_reference, std430) buffer Values {
    uint value[];
};

layout(push_constant) uniform Push {
    uvec2 base;
} pc;

void main() {
    Values(pc.base).value[0] = 7u;
}
