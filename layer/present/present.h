#pragma once

// Acquire and present (present.cpp): frame marks, split mode's asynchronous presents and composite.

#include "capture/session.h"
#include "core/device.h"
#include "model/frame_deadline.h"
#include "split_geometry.h"

#include <cstdint>
#include <optional>
#include <span>

namespace splitvk {

struct SwapchainState;

// Split mode's asynchronous presents: waits until the present thread has presented every frame
// handed to it (each bounded by SPLITVK_TILE_WAIT); stop_presents() then ends the thread
// (vkDestroyDevice).
void drain_presents(DeviceState &device);
void stop_presents(DeviceState &device);
// Before a submit that draws into these swapchain images (handle values; split.h): an image the
// application has not acquired marks its swapchain as one whose application uses its images in an
// order of its own, and one the present thread still holds is presented first.
void order_swapchain_writes(DeviceState &device, std::span<const uint64_t> images);
// Frees the readback resources verification keeps for a swapchain's images (verification.h), and
// what the asynchronous present knows of the swapchain (after drain_presents()).
void release_present_resources(DeviceState &device, VkSwapchainKHR swapchain);
// Split mode: the one summary line at vkDestroyDevice.
void report_split_summary(DeviceState &device);

// Frame marks of an OpenXR runtime's swapchain (docs/architecture.md §9). A runtime's frame never
// reaches vkQueuePresentKHR: the application acquires an image with xrAcquireSwapchainImage and hands
// it back with xrReleaseSwapchainImage, after which the runtime's barrier gives it to the
// compositor. Each release ends one splitvk frame of that image.

// xrAcquireSwapchainImage: FrameBegin for the image the runtime handed out.
void begin_runtime_frame(DeviceState &device, const SwapchainState &swapchain, uint32_t image_index);
// xrReleaseSwapchainImage, before the runtime's release: ends the frame (FramePresent) and, when its
// passes were split, waits for the agent's tiles and composites them into the image on `queue`,
// leaving it in COLOR_ATTACHMENT_OPTIMAL. The wait ends where the frame could no longer be composited
// and handed to the runtime before `display` (its xrWaitFrame's display time), and never later than
// SPLITVK_TILE_WAIT (deadline::tile_wait); tiles later than that leave the periphery in its centre,
// counted late. Synchronous, on the
// application's thread: the runtime's own barrier follows on the same queue as soon as this returns.
// The image's foveae are its `eyes`' (the projection views' so far), each at its view direction or
// at `gaze`'s point for it, or one centred in each layer before any (split::runtime_eye_foveae).
// `xr_frame` (xrEndFrame calls before this release) and `xr_view` (the first projection view that
// named this swapchain at the latest xrEndFrame, -1 before one) go to SPLITVK_STATS' row of the frame.
void end_runtime_frame(DeviceState &device, VkQueue queue, const SwapchainState &swapchain,
                       uint32_t image_index, const std::vector<split::RuntimeEye> &eyes,
                       const split::Gaze &gaze, uint64_t xr_frame, int32_t xr_view,
                       const deadline::FrameDisplay &display);
// xrEndFrame of OpenXR frame `xr_frame` (xrEndFrame calls before it) returned: the rows of its eye
// images, held since their releases, go to SPLITVK_STATS with the frame's latency (xrWaitFrame
// returning to now; unset when its xrWaitFrame was not seen).
void finish_runtime_frame(DeviceState &device, uint64_t xr_frame, std::optional<double> frame_latency_ms);
// xrEndFrame: a projection view gave an eye of this swapchain (its layer, sub-image rectangle and
// field of view) that differs from what was sent before: SwapchainView, after which both sides
// place that eye's fovea there (split::note_runtime_eye).
void send_runtime_view(DeviceState &device, const SwapchainState &swapchain,
                       const protocol::SwapchainView &view);

} // namespace splitvk
