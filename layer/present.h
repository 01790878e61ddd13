#pragma once

// Frame marks of an OpenXR runtime's swapchain (present.cpp; DESIGN §9). A runtime's frame never
// reaches vkQueuePresentKHR: the application acquires an image with xrAcquireSwapchainImage and hands
// it back with xrReleaseSwapchainImage, after which the runtime's barrier gives it to the
// compositor. Each release ends one splitvk frame of that image.

#include "device.h"
#include "session.h"
#include "split_geometry.h"

namespace splitvk {

struct SwapchainState;

// xrAcquireSwapchainImage: FrameBegin for the image the runtime handed out.
void begin_runtime_frame(DeviceState &device, const SwapchainState &swapchain, uint32_t image_index);
// xrReleaseSwapchainImage, before the runtime's release: ends the frame (FramePresent) and, when its
// passes were split, waits (bounded by SPLITVK_TILE_WAIT) for the agent's tiles and composites them
// into the image on `queue`, leaving it in COLOR_ATTACHMENT_OPTIMAL. Synchronous, on the
// application's thread: the runtime's own barrier follows on the same queue as soon as this returns.
// The image's foveae are its `eyes`' (the projection views' so far), or one centred in each layer
// before any (split::runtime_eye_foveae).
// `xr_frame` (xrEndFrame calls before this release) and `xr_view` (the first projection view that
// named this swapchain at the latest xrEndFrame, -1 before one) go to SPLITVK_STATS' row of the frame.
void end_runtime_frame(DeviceState &device, VkQueue queue, const SwapchainState &swapchain,
                       uint32_t image_index, const std::vector<split::RuntimeEye> &eyes, uint64_t xr_frame,
                       int32_t xr_view);
// xrEndFrame: a projection view gave an eye of this swapchain (its layer, sub-image rectangle and
// field of view) that differs from what was sent before: SwapchainView, after which both sides
// place that eye's fovea there (split::note_runtime_eye).
void send_runtime_view(DeviceState &device, const SwapchainState &swapchain,
                       const protocol::SwapchainView &view);

} // namespace splitvk
