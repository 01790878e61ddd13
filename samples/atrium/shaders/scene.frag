#version 450

// True when the swapchain format is UNORM: the shader then encodes to sRGB itself, so that UNORM
// and SRGB swapchains show the same picture.
layout(constant_id = 0) const bool encode_srgb = true;

layout(set = 0, binding = 0) uniform Frame {
    mat4 view_proj[2];
    vec4 eye_position[2];
    vec4 sun_direction; // xyz: unit vector towards the sun
    vec4 sun_color;     // rgb: linear
    vec4 sky_color;     // ambient from above
    vec4 ground_color;  // ambient from below
    vec4 sun_opening;   // x0, x1, z0, z1 of the open roof (x0 >= x1: no occlusion)
    vec4 sun_facades;   // |z| of the facades, top of the ground openings, gallery openings bottom / top
    vec4 sun_params;    // x: height of the open roof
} frame;

layout(set = 1, binding = 0) uniform sampler2D albedo;

layout(push_constant) uniform Push {
    uint eye;
    float specular;
    float shininess;
} pc;

layout(location = 0) in vec3 in_position;
layout(location = 1) in vec3 in_normal;
layout(location = 2) in vec2 in_uv;

layout(location = 0) out vec4 out_color;

// Analytic sun occlusion for the atrium (see SunOcclusion in scene.h).
float sun_visibility(vec3 p, vec3 l) {
    if (frame.sun_opening.x >= frame.sun_opening.y)
        return 1.0;
    vec2 q = p.xz + l.xz * ((frame.sun_params.x - p.y) / l.y);
    if (any(lessThan(q, frame.sun_opening.xz)) || any(greaterThan(q, frame.sun_opening.yw)))
        return 0.0;
    float behind = abs(p.z) - frame.sun_facades.x;
    if (behind > 0.0) {
        float y = p.y + l.y * behind / max(abs(l.z), 1e-4);
        if (y > frame.sun_facades.y && (y < frame.sun_facades.z || y > frame.sun_facades.w))
            return 0.0;
    }
    return 1.0;
}

vec3 linear_to_srgb(vec3 c) {
    return mix(c * 12.92, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, greaterThan(c, vec3(0.0031308)));
}

void main() {
    vec3 base = texture(albedo, in_uv).rgb; // sRGB texture, so already linear
    vec3 n = normalize(gl_FrontFacing ? in_normal : -in_normal);
    vec3 l = frame.sun_direction.xyz;
    vec3 v = normalize(frame.eye_position[pc.eye].xyz - in_position);

    float sun = max(dot(n, l), 0.0);
    if (sun > 0.0)
        sun *= sun_visibility(in_position, l);
    float spec = pc.specular * pow(max(dot(n, normalize(l + v)), 0.0), pc.shininess) * sun;
    vec3 ambient = mix(frame.ground_color.rgb, frame.sky_color.rgb, 0.5 + 0.5 * n.y);

    vec3 color = base * (ambient + frame.sun_color.rgb * sun) + frame.sun_color.rgb * spec;
    color = vec3(1.0) - exp(-color); // simple exponential tone mapping
    out_color = vec4(encode_srgb ? linear_to_srgb(color) : color, 1.0);
}
