#version 460
// An address as a 64-bit integer member at offset 8, plus an offset in the shader.
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
layout(local_size_x = 1) in;

layout(buffer_reference, std430) buffer Values {
    uint value[];
};

layout(push_constant) uniform Push {
    uint count;
    uint pad;
    uint64_t base;
} pc;

void main() {
    Values values = Values(pc.base + 16ul);
    values.value[gl_GlobalInvocationID.x] = pc.count;
}
