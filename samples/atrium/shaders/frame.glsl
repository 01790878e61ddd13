// The per-frame uniforms; must match atrium::FrameUniforms (scene_gpu.h), std140.
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
    mat4 inv_view_proj[2];
} frame;
