#pragma once

// The client does not shade the foveae (SPLITVK_FOVEA_MASK=depth): the tiles replace
// them, so every fragment the periphery shades there is wasted. Right after a split pass into a
// window's swapchain image (not an OpenXR runtime's, whose foveae follow its views) begins, the layer clears
// the scaled foveae of its depth attachment to the near end of the depth range (the end the pass's own clear
// value is not at), so that every depth-tested draw fails there before its fragment shader runs. Nothing goes
// into the capture: the agent replays the application's pass as it was.
//
// It must stay exact, so it is done only where nothing else can see it:
// - the depth attachment is cleared when the pass begins and not stored (DONT_CARE), so no later
//   pass or frame reads the mask, in a render pass of one subpass without a depth resolve, or a
//   dynamic rendering that neither resumes nor resolves depth;
// - the foveae are known when the pass is recorded, since command buffers are replayed for many
//   frames: a fixed gaze and SPLITVK_EYES 1 or 2 (with auto, a frame's foveae are decided by
//   everything it draws). With SPLITVK_FOVEA=auto the mask takes the size of the moment, and the pass
//   notes it (split::DrawnImage::masked): a frame whose passes masked a larger fovea than the sizing
//   now asks for takes that larger size, so the fovea shrinks only once its passes are recorded
//   anew (a command buffer recorded once and replayed keeps the fovea at least its mask's size);
// - the mask is the fovea's scaled rectangle shrunk by kGuard texels on every side, so that the
//   composite's upsample of the pixels around the fovea (bilinear or Catmull-Rom, two texels at
//   most) reads only texels that were shaded.
// Draws that do not test depth (a sky, a full-screen pass) still shade the foveae: no saving, and
// no harm, since only texels inside the mask can differ and the tiles cover them.

#include "core/device.h"
#include "split_tracker.h"

#include <vulkan/vulkan.h>

namespace splitvk {

inline constexpr uint32_t kFoveaMaskGuard = 3;

// vkCreateRenderPass*, vkDestroyRenderPass (resource.cpp): whether a render pass's depth attachment
// can carry the mask, and which it is.
void note_render_pass_depth(DeviceState &device, VkRenderPass render_pass,
                            const VkRenderPassCreateInfo &info);
void note_render_pass_depth(DeviceState &device, VkRenderPass render_pass,
                            const VkRenderPassCreateInfo2 &info);
void forget_render_pass_depth(DeviceState &device, VkRenderPass render_pass);

// render_pass.cpp, right after a split pass into a window's swapchain image (never an OpenXR
// runtime's) of `image` extent began
// with inline contents (and `tracker` entered it), its render area scaled to `area`: records the
// mask where it is exact.
void mask_foveae(DeviceState &device, VkCommandBuffer command_buffer, split::CommandTracker &tracker,
                 const VkRenderPassBeginInfo &begin, VkExtent2D image, const VkRect2D &area);
void mask_foveae(DeviceState &device, VkCommandBuffer command_buffer, split::CommandTracker &tracker,
                 const VkRenderingInfo &info, VkExtent2D image, const VkRect2D &area);

} // namespace splitvk
