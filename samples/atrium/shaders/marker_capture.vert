#version 450
// --engine-extensions: a small triangle at the centre of the viewport, whose positions transform
// feedback captures into a buffer (engine_markers.h); marker.vert draws them back.
out gl_PerVertex {
    layout(xfb_buffer = 0, xfb_offset = 0, xfb_stride = 16) vec4 gl_Position;
};

void main() {
    const vec2 corners[3] = vec2[](vec2(-0.1, 0.12), vec2(0.1, 0.12), vec2(0.0, -0.12));
    gl_Position = vec4(corners[gl_VertexIndex], 0.0, 1.0);
}
