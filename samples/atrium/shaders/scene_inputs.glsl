// What the scene's vertex shaders hand to its fragment shaders, and the per-draw state.
layout(set = 1, binding = 0) uniform sampler2D albedo;

layout(push_constant) uniform Push {
    uint eye;
    float specular;
    float shininess;
} pc;

layout(location = 0) in vec3 in_position;
layout(location = 1) in vec3 in_normal;
layout(location = 2) in vec2 in_uv;
