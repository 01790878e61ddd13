#include "core/vk_util.h"

namespace splitvk {

uint32_t find_memory_type(const DeviceState &device, uint32_t bits, VkMemoryPropertyFlags want) {
    for (uint32_t i = 0; i < device.memory_properties.memoryTypeCount; ++i)
        if ((bits & (1u << i)) && (device.memory_properties.memoryTypes[i].propertyFlags & want) == want)
            return i;
    return UINT32_MAX;
}

VkImageMemoryBarrier colour_image_barrier(VkImage image, VkAccessFlags src, VkAccessFlags dst,
                                          VkImageLayout from, VkImageLayout to, uint32_t mip, uint32_t layer,
                                          uint32_t layer_count) {
    VkImageMemoryBarrier b{};
    b.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER;
    b.srcAccessMask = src;
    b.dstAccessMask = dst;
    b.oldLayout = from;
    b.newLayout = to;
    b.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    b.image = image;
    b.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, mip, 1, layer, layer_count};
    return b;
}

VkResult create_fence(DeviceState &device, VkFence *fence) {
    VkFenceCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
    return device.dispatch.CreateFence(device.handle, &info, nullptr, fence);
}

VkResult create_semaphore(DeviceState &device, VkSemaphore *semaphore) {
    VkSemaphoreCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO;
    return device.dispatch.CreateSemaphore(device.handle, &info, nullptr, semaphore);
}

VkSubmitInfo submit_info(const VkCommandBuffer *command_buffer, std::span<const VkSemaphore> waits,
                         const VkPipelineStageFlags *wait_stages, const VkSemaphore *signal) {
    VkSubmitInfo submit{};
    submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
    submit.waitSemaphoreCount = static_cast<uint32_t>(waits.size());
    submit.pWaitSemaphores = waits.data();
    submit.pWaitDstStageMask = wait_stages;
    submit.commandBufferCount = command_buffer ? 1 : 0;
    submit.pCommandBuffers = command_buffer;
    submit.signalSemaphoreCount = signal ? 1 : 0;
    submit.pSignalSemaphores = signal;
    return submit;
}

VkResult create_command_pool(DeviceState &device, uint32_t family, VkCommandPoolCreateFlags flags,
                             VkCommandPool *pool) {
    VkCommandPoolCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
    info.flags = flags;
    info.queueFamilyIndex = family;
    return device.dispatch.CreateCommandPool(device.handle, &info, nullptr, pool);
}

VkResult allocate_primary_command_buffer(DeviceState &device, VkCommandPool pool,
                                         VkCommandBuffer *command_buffer) {
    VkCommandBufferAllocateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
    info.commandPool = pool;
    info.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    info.commandBufferCount = 1;
    const VkResult result = device.dispatch.AllocateCommandBuffers(device.handle, &info, command_buffer);
    if (result != VK_SUCCESS) return result;
    if (device.set_loader_data)
        device.set_loader_data(device.handle, *command_buffer);
    else
        *reinterpret_cast<void **>(*command_buffer) = *reinterpret_cast<void **>(device.handle);
    return VK_SUCCESS;
}

} // namespace splitvk
