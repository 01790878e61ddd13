// Colour helpers shared by the passes that write display colours.

vec3 linear_to_srgb(vec3 c) {
    return mix(c * 12.92, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, greaterThan(c, vec3(0.0031308)));
}

// The atrium's tone curve: a simple exponential, the same in every render path.
vec3 tone_map(vec3 c) {
    return vec3(1.0) - exp(-c);
}
