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

#include "device.h"
#include "session.h"

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
void note_render_pass_begin(VkCommandBuffer command_buffer, VkRenderPass render_pass,
                            std::span<const AttachmentImage> attachments);
void note_render_pass_end(VkCommandBuffer command_buffer);

// At submit (command_buffer.h: note_submitted): a submitted command buffer's transitions, applied
// in submission order.
void apply_layouts(LockedImages &images, const CommandLayouts &layouts);

// vkDestroyDevice.
void forget_resources(DeviceState &device);

// The contents of every live buffer and image, read back with a copy submitted on `queue` (of
// family `family`), which must be idle; and the messages that give them to a fresh agent after the
// object log: MemoryData for buffers, and for images a staging buffer with the bytes plus a
// command buffer that copies them in and leaves each subresource in its tracked layout. Images the
// layer cannot read back (no TRANSFER_SRC, multisampled, depth/stencil, a format vk.xml does not
// describe as single-plane, or no known layout) are counted in `skipped_images`; screen-space
// targets (screen_space.h) in `screen_space_images`.
struct ContentSnapshot {
    std::vector<LiveMessage> messages;
    uint64_t buffers = 0;
    uint64_t images = 0;
    uint64_t skipped_images = 0;
    uint64_t screen_space_images = 0; // left out: scaled on the client, rewritten every frame
    uint64_t bytes = 0;
};
bool snapshot_contents(DeviceState &device, VkQueue queue, uint32_t family, ContentSnapshot *out,
                       std::string *error);

} // namespace splitvk
