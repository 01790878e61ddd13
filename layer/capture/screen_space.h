#pragma once

// Screen-space targets on the client (docs/architecture.md §4). At vkCreateImage, once the device has
// a composable swapchain and splits, each image is classified by common/target_rule.h's rule; a
// screen-space target is created down the chain at SPLITVK_SCALE (the capture keeps the app's create
// info: the agent replays it full size), and every command that names a region of one scales that
// region by the image's ImageState (image.h), looked up by handle:
//
//   framebuffers and imageless attachment infos   extent scaled (render_pass.cpp)
//   render pass / dynamic rendering areas          scale_rect, viewports/scissors/clear rects
//                                                  through the split tracker (render_pass.cpp)
//   copy, blit, resolve, buffer<->image regions    scale_image_rect per side (transfer.cpp)
//   dispatches with a scaled storage image bound   group counts (and bases) scaled (transfer.cpp)
//
// A pass into a swapchain image is drawn into its top-left ceil(s·W) x ceil(s·H) as before, and so
// is a copy or blit into one. What the app is told about the image (its extent in every call it
// makes) stays what it asked for; only vkGetImageMemoryRequirements reports the smaller image's
// needs, which the app then allocates (the agent allocates its own memory: memory_rebind.h).
//
// An image stays screen-space for its lifetime: Session::splitting() never turns off again once on
// (a lost agent leaves the periphery filling the frames), so every pass into one stays scaled.

#include "core/device.h"
#include "target_rule.h"

#include <vulkan/vulkan.h>

namespace splitvk {

// swapchain.cpp: the device's newest composable swapchain has this extent (what targets are
// classified against from now on).
void note_screen_extent(DeviceState &device, VkExtent2D extent);

// vkCreateImage: whether `app` is a screen-space target; if so `*down` (a copy of it) gets the
// scaled extent. Logs the classification at info level. resource.cpp keeps the answer and the
// app's extent in the image's ImageState (image.h).
//
// SPLITVK_CLIENT_RENDERS=fovea: a target stays full size (false), and `*guard` gets its
// class, for the passes into it that the client cuts to the guard (split::window_guard_rect).
struct GuardTarget {
    split::TargetClass kind; // kind.screen_space: classified as a target
    VkExtent2D screen{};     // the swapchain extent it was classified against
};
bool screen_space_create_info(DeviceState &device, const VkImageCreateInfo &app, VkImageCreateInfo *down,
                              GuardTarget *guard);
// Whether the device created a screen-space target at the scaled size (in periphery mode, or before
// the agent chose the mode): passes then cannot be cut (split_cutting).
bool scaled_targets_created(const DeviceState &device);
// The device's newest composable swapchain extent; false before the first.
bool screen_extent(const DeviceState &device, VkExtent2D *screen);

// The app-visible extent of a screen-space target (its mip 0, from its ImageState); false for any
// other image.
bool screen_space_extent(const DeviceState &device, VkImage image, VkExtent2D *full);
inline bool is_screen_space(const DeviceState &device, VkImage image) {
    VkExtent2D e;
    return image != VK_NULL_HANDLE && screen_space_extent(device, image, &e);
}

// A rectangle of mip `mip` of `image` as the driver must see it: scaled for a screen-space target,
// unchanged otherwise.
VkRect2D scale_image_rect(const DeviceState &device, VkImage image, uint32_t mip, const VkRect2D &rect);

// Imageless framebuffers: the attachment info of an image the rule classifies as screen-space
// describes the scaled image.
bool screen_space_attachment(const DeviceState &device, const VkFramebufferAttachmentImageInfo &info);

// One info line per reason the layer met a structure it cannot scale consistently: what
// runs unsplit or with which periphery artefact.
void log_unscalable_once(const char *reason);

} // namespace splitvk
