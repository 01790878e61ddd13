#pragma once

// Render pass instances and dynamic renderings: which are split passes (split.h), and their
// rewrite. A split pass draws into a swapchain image, found through the image views of its
// framebuffer (or of its VkRenderPassAttachmentBeginInfo when imageless, or of its dynamic
// rendering attachments); the layer tracks views -> images and framebuffers -> views here, and
// swapchain images -> their swapchain in each image's ImageState (image.h). A pass whose attachments include
// a screen-space target (screen_space.h) is scaled the same way, without foveae of its own: its framebuffer
// was created at the scaled size. Inside a split or scaled pass the render area and clear rects are scaled,
// and the viewports/scissors in effect are re-emitted scaled at its begin and unscaled at its end, because
// dynamic state outlives the pass (pipeline.cpp).

#include "core/device.h"

#include <vulkan/vulkan.h>

namespace splitvk {

// The image a view was created for (null if unknown).
VkImage image_of_view(const DeviceState &device, VkImageView view);
// Whether `image` is an image of a live composable swapchain (with its extent, and whether that is
// an OpenXR runtime's swapchain).
bool swapchain_image_extent(const DeviceState &device, VkImage image, VkExtent2D *extent,
                            bool *runtime = nullptr);
// vkBeginCommandBuffer of a secondary that continues a render pass: scaled like that pass's target
// (its inheritance's framebuffer, or the render pass's latest instance, or for a dynamic rendering
// the latest one with the formats and view mask it inherits), its viewports kept for the foveae of
// the pass that executes it (split_tracker.h).
void begin_secondary(DeviceState &device, VkCommandBuffer command_buffer,
                     const VkCommandBufferBeginInfo &begin);
// vkCreateRenderPass* and vkDestroyRenderPass (resource.cpp): the handle value's prediction for
// secondaries is dropped, since a driver may reuse the value for an unrelated render pass.
void forget_render_pass(DeviceState &device, VkRenderPass render_pass);

} // namespace splitvk
