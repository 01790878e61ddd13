#version 460
// A linked list: the next address is read from buffer memory (written by a shader or the host).
#extension GL_EXT_buffer_reference : require
layout(local_size_x = 1) in;

layout(buffer_reference) buffer Node;
layout(buffer_reference, std430) buffer Node {
    Node next;
    uint value;
};

layout(push_constant) uniform Push {
    Node head;
} pc;

void main() {
    pc.head.next.value = 1u;
}
