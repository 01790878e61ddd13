#version 450
// The compositor's periphery upsample: each swapchain pixel samples the periphery (the top-left
// part of `periphery`, a copy of what the application rendered at the reduced scale) at the
// point it maps to. Positions are in texels of `periphery` (texel i has its centre at i + 0.5)
// and clamped to the centres of the periphery's outer texels, so no filter tap ever reaches past
// the periphery into the stale rest of the image (clamp-to-edge of the region, not of the image).
//
// `periphery` is an array: a layered image (an OpenXR swapchain drawn with multiview) is drawn one
// layer per pass, each from the same layer of the periphery (pc.layer); a single image has one.
//
// FILTER (specialisation constant 0; compositor.h: kDefaultUpsampleFilter, SPLITVK_UPSAMPLE):
//   0 bilinear: one hardware-filtered tap.
//   1 Catmull-Rom bicubic: 9 hardware-filtered taps that stand for its 16 (the inner 2x2 pairs
//     of weights share a sign, so each pair becomes one bilinear tap at the weighted offset).
//     Sharper than bilinear; it can overshoot, and the UNORM/sRGB attachment clamps on write.

layout(constant_id = 0) const int FILTER = 0;

layout(set = 0, binding = 0) uniform sampler2DArray periphery;

layout(push_constant) uniform Push {
    vec2 scale;         // periphery extent / swapchain extent
    vec2 texel_size;    // 1 / periphery image extent (the image can be larger than the periphery)
    vec2 max_centre;    // periphery extent - 0.5: the centre of its last texel
    int layer;          // the layer of `periphery` this pass draws
} pc;

layout(location = 0) out vec4 color;

vec4 tap(vec2 p) {
    return textureLod(periphery, vec3(clamp(p, vec2(0.5), pc.max_centre) * pc.texel_size, float(pc.layer)),
                      0.0);
}

vec4 catmull_rom(vec2 p) {
    const vec2 centre1 = floor(p - 0.5) + 0.5; // the texel centre at or left of/above p
    const vec2 f = p - centre1;
    const vec2 w0 = f * (-0.5 + f * (1.0 - 0.5 * f));
    const vec2 w1 = 1.0 + f * f * (-2.5 + 1.5 * f);
    const vec2 w2 = f * (0.5 + f * (2.0 - 1.5 * f));
    const vec2 w3 = f * f * (-0.5 + 0.5 * f);
    const vec2 w12 = w1 + w2;
    const vec2 p0 = centre1 - 1.0;
    const vec2 p12 = centre1 + w2 / w12;
    const vec2 p3 = centre1 + 2.0;
    // Near the edge a clamped tap repeats the edge texel, which is what clamp-to-edge of the
    // periphery would read there (p12 between two centres clamps onto the last centre, whose
    // bilinear neighbour past the edge then gets weight 0).
    const vec4 row0 = tap(vec2(p0.x, p0.y)) * w0.x + tap(vec2(p12.x, p0.y)) * w12.x +
                      tap(vec2(p3.x, p0.y)) * w3.x;
    const vec4 row1 = tap(vec2(p0.x, p12.y)) * w0.x + tap(vec2(p12.x, p12.y)) * w12.x +
                      tap(vec2(p3.x, p12.y)) * w3.x;
    const vec4 row2 = tap(vec2(p0.x, p3.y)) * w0.x + tap(vec2(p12.x, p3.y)) * w12.x +
                      tap(vec2(p3.x, p3.y)) * w3.x;
    return row0 * w0.y + row1 * w12.y + row2 * w3.y;
}

void main() {
    // gl_FragCoord.xy is the pixel centre (x + 0.5, y + 0.5); the same point of the periphery.
    const vec2 p = clamp(gl_FragCoord.xy * pc.scale, vec2(0.5), pc.max_centre);
    color = FILTER == 1 ? catmull_rom(p) : tap(p);
}
