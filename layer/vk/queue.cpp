// VkQueue submits (docs/architecture.md §2): dirty mapped memory first, then the submit itself.
//
// Every queue operation the layer passes down or makes takes the queue's lock (lock_queue(); the
// generated entry points take it by codegen/layer_overrides.py's LOCKED_HANDLES):
// split mode presents from a thread of the layer's (present.cpp) on the application's queue, and
// Vulkan requires the operations of one queue to be externally synchronised. vkQueueWaitIdle and
// vkDeviceWaitIdle first wait for the frames the present thread holds, so that "idle" includes
// the presents the application has already made.
//
// The agent executes every submit in order on one queue, so the wait and signal semaphores of
// the client's submits mean nothing there (and acquire/present, which signal and consume them
// on the client, are frame marks on the agent): the layer sends each submit with its
// semaphores and pNext removed, keeping the command buffers and the fence.

#include "vk/queue.h"

#include "capture/capture.h"
#include "capture/command_buffer.h"
#include "capture/memory.h"
#include "capture/resource.h"
#include "capture/split.h"
#include "core/gpu_timing.h"
#include "core/image.h"
#include "core/vk_util.h"
#include "layer_entry_points.h"
#include "present/present.h"
#include "submit_rules.h"

#include <algorithm>
#include <mutex>
#include <vector>

namespace splitvk {

namespace {

void capture_submit(DeviceState &dev, VkQueue queue, uint32_t submitCount, const VkSubmitInfo *pSubmits,
                    VkFence fence) {
    sync_mapped_memory(dev);
    const auto submits = codec::without_synchronization(pSubmits, submitCount);
    dev.session->send_encoded(
        [&](codec::Encoder &e) { encode_vkQueueSubmit(e, queue, submitCount, submits.data(), fence); });
}

void capture_submit(DeviceState &dev, VkQueue queue, uint32_t submitCount, const VkSubmitInfo2 *pSubmits,
                    VkFence fence) {
    sync_mapped_memory(dev);
    const auto submits = codec::without_synchronization(pSubmits, submitCount);
    dev.session->send_encoded(
        [&](codec::Encoder &e) { encode_vkQueueSubmit2(e, queue, submitCount, submits.data(), fence); });
}

void note_queue(DeviceState &dev, VkQueue queue, uint32_t family) {
    if (!dev.session || queue == VK_NULL_HANDLE) return;
    // Under the list's lock, so that a vkDeviceWaitIdle after any thread's vkGetDeviceQueue
    // returned finds the queue in its list, and finds it there once: it locks each queue it lists.
    QueueTable &t = *dev.queues;
    std::lock_guard lock(t.list_mutex);
    const auto make = [&] {
        auto info = std::make_unique<QueueInfo>();
        info->family = family;
        return info;
    };
    if (t.queues.insert_if_absent(queue, make).second) t.list.push_back(queue);
}

// Every queue of `dev`, locked in one order (by handle) so that two callers cannot deadlock.
std::vector<std::unique_lock<std::mutex>> lock_device_queues(const DeviceState &dev) {
    std::vector<VkQueue> queues;
    {
        std::lock_guard lock(dev.queues->list_mutex);
        queues = dev.queues->list;
    }
    std::sort(queues.begin(), queues.end());
    std::vector<std::unique_lock<std::mutex>> locks;
    for (VkQueue q : queues)
        locks.push_back(lock_queue(dev, q));
    return locks;
}

// What the submitted command buffers recorded, in submission order, in one walk under one hold of
// the image table; their split-pass timestamps after it (command_buffer.h: note_submitted).
template <class SubmitInfo>
void note_submit(DeviceState &dev, uint32_t count, const SubmitInfo *submits) {
    std::vector<const CommandTiming *> timed;
    {
        LockedImages images(dev);
        for_each_submitted(count, submits, [&](VkCommandBuffer command_buffer) {
            if (const CommandTiming *timing = note_submitted(dev, images, command_buffer))
                timed.push_back(timing);
        });
    }
    for (const CommandTiming *timing : timed)
        note_timed_submit(dev, *timing);
}

// vkQueueSubmit, vkQueueSubmit2 and its KHR alias, which differ only in their info type and the
// driver's entry point `down`.
template <class SubmitInfo, class Down>
VkResult submit(DeviceState &dev, Down down, VkQueue queue, uint32_t count, const SubmitInfo *submits,
                VkFence fence) {
    if (capturing(dev)) [[unlikely]]
        capture_submit(dev, queue, count, submits, fence);
    if (dev.session) order_swapchain_writes(dev, swapchain_images_drawn(dev, count, submits));
    const auto lock = lock_queue(dev, queue);
    if (dev.session) note_submit(dev, count, submits);
    return down(queue, count, submits, fence);
}

} // namespace

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
    return submit(dev, dev.dispatch.QueueSubmit, queue, submitCount, pSubmits, fence);
}

VKAPI_ATTR VkResult VKAPI_CALL QueueSubmit2(VkQueue queue, uint32_t submitCount,
                                            const VkSubmitInfo2 *pSubmits, VkFence fence) {
    DeviceState &dev = device_state(queue);
    return submit(dev, dev.dispatch.QueueSubmit2, queue, submitCount, pSubmits, fence);
}

VKAPI_ATTR VkResult VKAPI_CALL QueueSubmit2KHR(VkQueue queue, uint32_t submitCount,
                                               const VkSubmitInfo2 *pSubmits, VkFence fence) {
    DeviceState &dev = device_state(queue);
    return submit(dev, dev.dispatch.QueueSubmit2KHR, queue, submitCount, pSubmits, fence);
}

// Sparse binding is not forwarded to the agent (codegen/codec_policy.py); it is a queue operation.
VKAPI_ATTR VkResult VKAPI_CALL QueueBindSparse(VkQueue queue, uint32_t bindInfoCount,
                                               const VkBindSparseInfo *pBindInfo, VkFence fence) {
    DeviceState &dev = device_state(queue);
    const auto lock = lock_queue(dev, queue);
    return dev.dispatch.QueueBindSparse(queue, bindInfoCount, pBindInfo, fence);
}

VKAPI_ATTR VkResult VKAPI_CALL QueueWaitIdle(VkQueue queue) {
    DeviceState &dev = device_state(queue);
    if (dev.session) drain_presents(dev);
    const auto lock = lock_queue(dev, queue);
    return dev.dispatch.QueueWaitIdle(queue);
}

VKAPI_ATTR VkResult VKAPI_CALL DeviceWaitIdle(VkDevice device) {
    DeviceState &dev = device_state(device);
    if (!dev.session) return dev.dispatch.DeviceWaitIdle(device);
    drain_presents(dev);
    const auto locks = lock_device_queues(dev);
    return dev.dispatch.DeviceWaitIdle(device);
}

} // namespace entry
} // namespace splitvk
