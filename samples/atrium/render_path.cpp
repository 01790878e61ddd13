#include "render_path.h"

#include "path_direct.h"
#include "paths.h"

#include <cmath>

namespace atrium {

namespace {

// The sky, the clear colour of the direct path, in sRGB.
const float sky_srgb[3] = {135.0f / 255.0f, 180.0f / 255.0f, 235.0f / 255.0f};

float srgb_to_linear(float c) {
    return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
}

} // namespace

VkClearColorValue sky_clear(VkFormat format) {
    // An 8-bit UNORM target stores the clear colour as given; one that takes linear colours is
    // cleared to the linear sky (an sRGB one encodes it back).
    VkClearColorValue clear{{sky_srgb[0], sky_srgb[1], sky_srgb[2], 1.0f}};
    if (takes_linear(format))
        for (int i = 0; i < 3; ++i)
            clear.float32[i] = srgb_to_linear(sky_srgb[i]);
    return clear;
}

VkClearColorValue sky_radiance() {
    // The inverse of the tone curve 1 - exp(-x) of the linear sky.
    VkClearColorValue clear{{0.0f, 0.0f, 0.0f, 1.0f}};
    for (int i = 0; i < 3; ++i)
        clear.float32[i] = -std::log(1.0f - srgb_to_linear(sky_srgb[i]));
    return clear;
}

std::unique_ptr<RenderPath> make_render_path(const SceneGpu &scene, const Swapchain &swapchain,
                                             const RendererOptions &options) {
    switch (options.path) {
    case PathKind::direct:
        return std::make_unique<DirectPath>(scene, swapchain, options);
    case PathKind::hdr:
        return make_hdr_path(scene, swapchain, options);
    case PathKind::deferred:
        return make_deferred_path(scene, swapchain, options);
    case PathKind::multiview:
        return make_multiview_path(scene, swapchain, options);
    case PathKind::secondary:
        return make_secondary_path(scene, swapchain, options);
    case PathKind::compute:
        return make_compute_path(scene, swapchain, options);
    }
    throw Error("unknown render path");
}

} // namespace atrium
