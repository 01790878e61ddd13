#version 450
// The swapped split's feathered seam (SPLITVK_SEAM=feather:N; layer/present/compositor.cpp): drawn over the
// upsampled periphery in the band of one fovea (split::seam_rect less the fovea, scissored), blended
// as out = client * w + periphery * (1 - w) with the fixed-function blend (colour: SRC_ALPHA,
// ONE_MINUS_SRC_ALPHA; the periphery's alpha kept). `client` holds the client's own pixels of the
// fovea's seam rectangle (the band; the fovea's texels are never read), copied out of the swapchain
// image before the upsample overwrote them; texelFetch reads them unfiltered (decoded, for sRGB, as
// the attachment's blend is in linear).
// w rises smoothly (smoothstep) from 0 at the band's outer edge to 1 at the fovea's edge, by the
// Euclidean distance from the pixel's centre to the fovea, so the band's corners are round; a pixel
// N or more away keeps the periphery (discarded).

layout(set = 0, binding = 0) uniform sampler2D client;

layout(push_constant) uniform Push {
    ivec2 seam_origin;   // the seam rectangle's offset in the image
    ivec2 client_origin; // where that rectangle's pixels start in `client`
    vec2 fovea_min;      // the fovea's top-left edge, in image pixels
    vec2 fovea_max;      // its bottom-right edge (offset + extent)
    float feather;       // N > 0
} pc;

layout(location = 0) out vec4 color;

void main() {
    const vec2 p = gl_FragCoord.xy; // the pixel's centre
    const vec2 outside = max(pc.fovea_min - p, vec2(0.0)) + max(p - pc.fovea_max, vec2(0.0));
    const float w = smoothstep(0.0, 1.0, 1.0 - length(outside) / pc.feather);
    if (w <= 0.0) discard;
    const ivec2 texel = ivec2(p) - pc.seam_origin + pc.client_origin;
    color = vec4(texelFetch(client, texel, 0).rgb, w);
}
