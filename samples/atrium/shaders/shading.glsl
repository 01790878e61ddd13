// The atrium's lighting, shared by the forward passes and the deferred lighting pass.
#include "frame.glsl"

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

// Linear HDR radiance of a surface point p with normal n (facing the viewer), seen from eye.
vec3 shade(vec3 base, vec3 n, vec3 p, uint eye, float specular, float shininess) {
    vec3 l = frame.sun_direction.xyz;
    vec3 v = normalize(frame.eye_position[eye].xyz - p);

    float sun = max(dot(n, l), 0.0);
    if (sun > 0.0)
        sun *= sun_visibility(p, l);
    float spec = specular * pow(max(dot(n, normalize(l + v)), 0.0), shininess) * sun;
    vec3 ambient = mix(frame.ground_color.rgb, frame.sky_color.rgb, 0.5 + 0.5 * n.y);

    return base * (ambient + frame.sun_color.rgb * sun) + frame.sun_color.rgb * spec;
}
