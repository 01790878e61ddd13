#pragma once

// VkQueue (queue.cpp): the queues a device was got, their families and locks; the submits are
// vk/queue.cpp's.

#include "core/device.h"
#include "core/object_map.h"

#include <cstdint>
#include <mutex>
#include <vector>

namespace splitvk {

// The queue family a queue of `device` was got from; UINT32_MAX if unknown.
uint32_t queue_family_of(const DeviceState &device, VkQueue queue);

// The lock of a queue: Vulkan requires a queue's operations to be externally synchronised, and the
// layer's present thread (present.cpp) uses the application's queues, so the layer takes it around
// every queue operation it makes or passes down. Not owning (no lock) for a queue got without a
// session. Never held while waiting for the present thread. Without `device`, the queue's own (its
// dispatch key finds it).
std::unique_lock<std::mutex> lock_queue(const DeviceState &device, VkQueue queue);
std::unique_lock<std::mutex> lock_queue(VkQueue queue);

struct QueueInfo {
    uint32_t family = UINT32_MAX;
    std::mutex mutex; // lock_queue()
};

// A device's queues (DeviceState::queues): each one got while it had a session, learnt once under
// the table's lock whichever thread gets it first (vk/queue.cpp).
struct QueueTable {
    ObjectMap<VkQueue, QueueInfo> queues;
    // Every queue of the device, for vkDeviceWaitIdle (which needs all of them). A queue lives as
    // long as its device, and vkGetDeviceQueue returns the same handle every time.
    std::mutex list_mutex;
    std::vector<VkQueue> list;
};

} // namespace splitvk
