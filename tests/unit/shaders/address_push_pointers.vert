#version 460
// Addresses as push-constant members of pointer type: one, and an array of two (offsets 16, 24, 32).
#extension GL_EXT_buffer_reference : require

layout(buffer_reference, std430) readonly buffer Positions {
    vec4 position[];
};

layout(push_constant) uniform Push {
    uint index;
    float scale;
    float unused;
    Positions positions;
    Positions more[2];
} pc;

void main() {
    gl_Position = pc.scale * (pc.positions.position[pc.index] + pc.more[1].position[gl_VertexIndex]);
}
