#pragma once

// Small Vulkan helpers, so that each is written once: for the work the layer itself submits
// (composites, readbacks, copies) and for reading the application's pNext chains.

#include "core/device.h"

#include <span>

namespace splitvk {

// The first memory type allowed by `bits` (VkMemoryRequirements::memoryTypeBits) that has every
// property in `want`, or UINT32_MAX when none has.
uint32_t find_memory_type(const DeviceState &device, uint32_t bits, VkMemoryPropertyFlags want);

// A barrier on one mip level and `layer_count` array layers from `layer` of a colour image, with
// no queue-family transfer; level 0, layer 0 unless told.
VkImageMemoryBarrier colour_image_barrier(VkImage image, VkAccessFlags src, VkAccessFlags dst,
                                          VkImageLayout from, VkImageLayout to, uint32_t mip = 0,
                                          uint32_t layer = 0, uint32_t layer_count = 1);

// The first structure of type `s_type` in the pNext chain that starts at `next`, or null. An
// application's structure type stands only once in a chain (Vulkan's unique-sType rule), so the
// first is the only one; the loader's entries share a type, and find_loader_info (chain_info.h)
// walks on past the first.
template <typename T>
const T *find_in_chain(const void *next, VkStructureType s_type) {
    for (auto *s = static_cast<const VkBaseInStructure *>(next); s; s = s->pNext)
        if (s->sType == s_type) return reinterpret_cast<const T *>(s);
    return nullptr;
}

// The same in a chain the layer may write to (one the driver fills for the application).
template <typename T>
T *find_in_chain(void *next, VkStructureType s_type) {
    for (auto *s = static_cast<VkBaseOutStructure *>(next); s; s = s->pNext)
        if (s->sType == s_type) return reinterpret_cast<T *>(s);
    return nullptr;
}

// Calls visit(command_buffer) for every command buffer of a vkQueueSubmit's or vkQueueSubmit2's
// infos, in submission order.
template <class Visit>
void for_each_submitted(uint32_t count, const VkSubmitInfo *submits, Visit &&visit) {
    for (uint32_t i = 0; i < count; ++i)
        for (uint32_t j = 0; j < submits[i].commandBufferCount; ++j)
            visit(submits[i].pCommandBuffers[j]);
}
template <class Visit>
void for_each_submitted(uint32_t count, const VkSubmitInfo2 *submits, Visit &&visit) {
    for (uint32_t i = 0; i < count; ++i)
        for (uint32_t j = 0; j < submits[i].commandBufferInfoCount; ++j)
            visit(submits[i].pCommandBufferInfos[j].commandBuffer);
}

// An unsignalled fence on `device`.
VkResult create_fence(DeviceState &device, VkFence *fence);

// A binary semaphore on `device`.
VkResult create_semaphore(DeviceState &device, VkSemaphore *semaphore);

// A submit of `command_buffer` (none where null) after `waits`, each waited on at its entry of
// `wait_stages`, that signals `signal` where not null. It points at what it is given, which must
// outlive the vkQueueSubmit.
VkSubmitInfo submit_info(const VkCommandBuffer *command_buffer, std::span<const VkSemaphore> waits = {},
                         const VkPipelineStageFlags *wait_stages = nullptr,
                         const VkSemaphore *signal = nullptr);

// A command pool of `family` on `device`.
VkResult create_command_pool(DeviceState &device, uint32_t family, VkCommandPoolCreateFlags flags,
                             VkCommandPool *pool);

// One primary command buffer from `pool`. It is a dispatchable object the layer made below the
// loader, so it gets the loader's dispatch pointer before any call can reach the loader's
// trampolines (or the layers above splitvk).
VkResult allocate_primary_command_buffer(DeviceState &device, VkCommandPool pool,
                                         VkCommandBuffer *command_buffer);

} // namespace splitvk
