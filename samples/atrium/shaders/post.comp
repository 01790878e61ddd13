#version 450
#extension GL_GOOGLE_include_directive : require

// The compute path's post-processing: a light 3x3 blur, tone mapping and (for a UNORM swapchain)
// sRGB encoding of the HDR scene, into a storage image of the same size that is then blitted into
// the swapchain image. One invocation per pixel in 8x8 groups; the dispatch covers the image
// rounded up, so the edge groups check the bounds.
layout(constant_id = 0) const bool encode_srgb = true;

#include "color.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0) uniform sampler2D scene;
layout(set = 0, binding = 1, rgba16f) uniform writeonly image2D result;

void main() {
    ivec2 size = imageSize(result);
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, size)))
        return;
    vec3 sum = vec3(0.0);
    for (int y = -1; y <= 1; ++y)
        for (int x = -1; x <= 1; ++x)
            sum += texelFetch(scene, clamp(p + ivec2(x, y), ivec2(0), size - 1), 0).rgb *
                   float((2 - abs(x)) * (2 - abs(y)));
    vec3 c = tone_map(mix(texelFetch(scene, p, 0).rgb, sum / 16.0, 0.5));
    imageStore(result, p, vec4(encode_srgb ? linear_to_srgb(c) : c, 1.0));
}
