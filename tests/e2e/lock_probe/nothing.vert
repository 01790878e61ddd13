#version 450
// The vertex stage of a pipeline that rasterizes nothing: the lock probe only times its creation.

void main() {
    gl_Position = vec4(0.0, 0.0, 0.0, 1.0);
}
