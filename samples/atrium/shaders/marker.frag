#version 450
// --engine-extensions: the marker's colour, pushed per draw.
layout(push_constant) uniform Marker {
    vec4 colour;
} marker;

layout(location = 0) out vec4 out_colour;

void main() {
    out_colour = marker.colour;
}
