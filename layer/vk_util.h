#pragma once

// Small Vulkan helpers for the work the layer itself submits (composites, readbacks, copies), so
// that each is written once.

#include "device.h"

namespace splitvk {

// The first memory type allowed by `bits` (VkMemoryRequirements::memoryTypeBits) that has every
// property in `want`, or UINT32_MAX when none has.
uint32_t find_memory_type(const DeviceState &device, uint32_t bits, VkMemoryPropertyFlags want);

// A barrier on one mip level and `layer_count` array layers from `layer` of a colour image, with
// no queue-family transfer; level 0, layer 0 unless told.
VkImageMemoryBarrier colour_image_barrier(VkImage image, VkAccessFlags src, VkAccessFlags dst,
                                          VkImageLayout from, VkImageLayout to, uint32_t mip = 0,
                                          uint32_t layer = 0, uint32_t layer_count = 1);

// A command pool of `family` on `device`.
VkResult create_command_pool(DeviceState &device, uint32_t family, VkCommandPoolCreateFlags flags,
                             VkCommandPool *pool);

// One primary command buffer from `pool`. It is a dispatchable object the layer made below the
// loader, so it gets the loader's dispatch pointer before any call can reach the loader's
// trampolines (or the layers above splitvk).
VkResult allocate_primary_command_buffer(DeviceState &device, VkCommandPool pool,
                                         VkCommandBuffer *command_buffer);

} // namespace splitvk
