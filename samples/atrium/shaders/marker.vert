#version 450
// --engine-extensions: the positions transform feedback captured (marker_capture.vert).
layout(location = 0) in vec4 captured;

void main() {
    gl_Position = captured;
}
