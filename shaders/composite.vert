#version 450
// A full-screen triangle (compositor.cpp draws 3 vertices, no vertex buffer): it covers the
// whole viewport, clipped to the image, so every swapchain pixel gets exactly one fragment.

void main() {
    const vec2 corner = vec2((gl_VertexIndex << 1) & 2, gl_VertexIndex & 2);
    gl_Position = vec4(corner * 2.0 - 1.0, 0.0, 1.0);
}
