// The render paths other than direct, each in its own path_*.cpp.
#pragma once

#include "render_path.h"

namespace atrium {

std::unique_ptr<RenderPath> make_hdr_path(const SceneGpu &scene, const Swapchain &swapchain,
                                          const RendererOptions &options);
std::unique_ptr<RenderPath> make_deferred_path(const SceneGpu &scene, const Swapchain &swapchain,
                                               const RendererOptions &options);
std::unique_ptr<RenderPath> make_multiview_path(const SceneGpu &scene, const Swapchain &swapchain,
                                                const RendererOptions &options);
std::unique_ptr<RenderPath> make_secondary_path(const SceneGpu &scene, const Swapchain &swapchain,
                                                const RendererOptions &options);
std::unique_ptr<RenderPath> make_compute_path(const SceneGpu &scene, const Swapchain &swapchain,
                                              const RendererOptions &options);

} // namespace atrium
