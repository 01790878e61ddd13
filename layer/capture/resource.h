#pragma once

// VkBuffer and VkImage as a snapshot needs them (session.h: a new agent is brought in with the
// contents of every live buffer and image, read back on the client).
//
// Contents can only be copied from a buffer or an image created with TRANSFER_SRC usage, so the
// layer adds it on the way down wherever the implementation allows it (the capture keeps the
// application's create info). An image's contents can only be copied out of a known layout, so
// the layer tracks the layout of every subresource the way the GPU will see it: each command
// buffer records its transitions (pipeline barriers, wait events, render pass final layouts), and
// each submit applies them in order.

#include "capture/session.h"
#include "core/device.h"

#include <functional>
#include <span>
#include <string>
#include <utility>
#include <vector>

namespace splitvk {

class LockedImages;

struct LayoutTransition {
    VkImage image = VK_NULL_HANDLE;
    VkImageSubresourceRange range{};
    VkImageLayout layout = VK_IMAGE_LAYOUT_UNDEFINED;
};

// What a command buffer recorded of image layouts (its CommandBufferState keeps it, begun afresh
// with each recording: command_buffer.h): applied at every submit of the command buffer.
struct CommandLayouts {
    std::vector<LayoutTransition> transitions;
    std::vector<LayoutTransition> at_pass_end; // the render pass instance's final layouts
};

// render_pass.cpp: a render pass instance begins on these attachments (attachment i's image and
// the subresources its view covers); its final layouts apply at its end.
struct AttachmentImage {
    VkImage image = VK_NULL_HANDLE;
    VkImageSubresourceRange range{};
};
void note_render_pass_begin(DeviceState &device, VkCommandBuffer command_buffer, VkRenderPass render_pass,
                            std::span<const AttachmentImage> attachments);
void note_render_pass_end(VkCommandBuffer command_buffer);

// At submit (command_buffer.h: note_submitted): a submitted command buffer's transitions, applied
// in submission order.
void apply_layouts(LockedImages &images, const CommandLayouts &layouts);

// Every buffer of `device` a snapshot can read back (created with TRANSFER_SRC, bound, not empty),
// with its memory, its offset in it and its size; under the buffer table's lock, so `each` must not
// call back into resource.h.
void for_each_readable_buffer(
    const DeviceState &device,
    const std::function<void(VkBuffer, VkDeviceMemory, VkDeviceSize offset, VkDeviceSize size)> &each);

} // namespace splitvk
