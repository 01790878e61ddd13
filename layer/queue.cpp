// VkQueue submits (DESIGN §2): dirty mapped memory first, then the submit itself.
//
// The agent executes every submit in order on one queue, so the wait and signal semaphores of
// the client's submits mean nothing there (and acquire/present, which signal and consume them
// on the client, are frame marks on the agent): the layer sends each submit with its
// semaphores and pNext removed, keeping the command buffers and the fence.

#include "capture.h"
#include "gpu_timing.h"
#include "layer_entry_points.h"
#include "object_map.h"
#include "resource.h"
#include "split.h"
#include "submit_rules.h"

#include <vector>

namespace splitvk {

void sync_mapped_memory(DeviceState &device); // memory.cpp

namespace {

void capture_submit(DeviceState &dev, VkQueue queue, uint32_t submitCount, const VkSubmitInfo *pSubmits,
                    VkFence fence) {
    sync_mapped_memory(dev);
    const auto submits = codec::without_synchronization(pSubmits, submitCount);
    dev.session->send_encoded(
        [&](codec::Encoder &e) { encode_vkQueueSubmit(e, queue, submitCount, submits.data(), fence); });
}

void capture_submit2(DeviceState &dev, VkQueue queue, uint32_t submitCount, const VkSubmitInfo2 *pSubmits,
                     VkFence fence) {
    sync_mapped_memory(dev);
    const auto submits = codec::without_synchronization(pSubmits, submitCount);
    dev.session->send_encoded(
        [&](codec::Encoder &e) { encode_vkQueueSubmit2(e, queue, submitCount, submits.data(), fence); });
}

struct QueueInfo {
    uint32_t family = UINT32_MAX;
};
ObjectMap<VkQueue, QueueInfo> g_queues;

void note_queue(DeviceState &dev, VkQueue queue, uint32_t family) {
    if (!dev.session || queue == VK_NULL_HANDLE) return;
    auto info = std::make_unique<QueueInfo>();
    info->family = family;
    g_queues.insert(queue, std::move(info));
}

// What the submitted command buffers recorded, in submission order: split passes (split.h),
// image layouts (resource.h) and split-pass timestamps (gpu_timing.h).
void note_submit(DeviceState &dev, uint32_t count, const VkSubmitInfo *submits) {
    note_split_submit(dev, count, submits);
    note_layout_submit(dev, count, submits);
    for (uint32_t i = 0; i < count; ++i)
        note_timed_submit(dev, submits[i].commandBufferCount, submits[i].pCommandBuffers);
}

void note_submit(DeviceState &dev, uint32_t count, const VkSubmitInfo2 *submits) {
    note_split_submit(dev, count, submits);
    note_layout_submit(dev, count, submits);
    for (uint32_t i = 0; i < count; ++i)
        for (uint32_t j = 0; j < submits[i].commandBufferInfoCount; ++j)
            note_timed_submit(dev, 1, &submits[i].pCommandBufferInfos[j].commandBuffer);
}

} // namespace

uint32_t queue_family_of(VkQueue queue) {
    const QueueInfo *info = g_queues.find(queue);
    return info ? info->family : UINT32_MAX;
}

namespace entry {

VKAPI_ATTR void VKAPI_CALL GetDeviceQueue(VkDevice device, uint32_t queueFamilyIndex, uint32_t queueIndex,
                                          VkQueue *pQueue) {
    DeviceState &dev = device_state(device);
    dev.dispatch.GetDeviceQueue(device, queueFamilyIndex, queueIndex, pQueue);
    note_queue(dev, *pQueue, queueFamilyIndex);
    if (capturing(dev))
        record_global(dev, LiveChange::Created, codec::handle_value(*pQueue), [&](codec::Encoder &e) {
            encode_vkGetDeviceQueue(e, device, queueFamilyIndex, queueIndex, pQueue);
        });
}

VKAPI_ATTR void VKAPI_CALL GetDeviceQueue2(VkDevice device, const VkDeviceQueueInfo2 *pQueueInfo,
                                           VkQueue *pQueue) {
    DeviceState &dev = device_state(device);
    dev.dispatch.GetDeviceQueue2(device, pQueueInfo, pQueue);
    note_queue(dev, *pQueue, pQueueInfo->queueFamilyIndex);
    if (capturing(dev))
        record_global(dev, LiveChange::Created, codec::handle_value(*pQueue),
                      [&](codec::Encoder &e) { encode_vkGetDeviceQueue2(e, device, pQueueInfo, pQueue); });
}

VKAPI_ATTR VkResult VKAPI_CALL QueueSubmit(VkQueue queue, uint32_t submitCount, const VkSubmitInfo *pSubmits,
                                           VkFence fence) {
    DeviceState &dev = device_state(queue);
    if (capturing(dev)) [[unlikely]]
        capture_submit(dev, queue, submitCount, pSubmits, fence);
    if (dev.session) note_submit(dev, submitCount, pSubmits);
    return dev.dispatch.QueueSubmit(queue, submitCount, pSubmits, fence);
}

VKAPI_ATTR VkResult VKAPI_CALL QueueSubmit2(VkQueue queue, uint32_t submitCount,
                                            const VkSubmitInfo2 *pSubmits, VkFence fence) {
    DeviceState &dev = device_state(queue);
    if (capturing(dev)) [[unlikely]]
        capture_submit2(dev, queue, submitCount, pSubmits, fence);
    if (dev.session) note_submit(dev, submitCount, pSubmits);
    return dev.dispatch.QueueSubmit2(queue, submitCount, pSubmits, fence);
}

VKAPI_ATTR VkResult VKAPI_CALL QueueSubmit2KHR(VkQueue queue, uint32_t submitCount,
                                               const VkSubmitInfo2 *pSubmits, VkFence fence) {
    DeviceState &dev = device_state(queue);
    if (capturing(dev)) [[unlikely]]
        capture_submit2(dev, queue, submitCount, pSubmits, fence);
    if (dev.session) note_submit(dev, submitCount, pSubmits);
    return dev.dispatch.QueueSubmit2KHR(queue, submitCount, pSubmits, fence);
}

} // namespace entry
} // namespace splitvk
