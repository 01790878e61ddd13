#pragma once

// VkQueue (queue.cpp): the queues a device was got, their families and locks; the submits are
// vk/queue.cpp's.

#include "core/device.h"
#include "core/object_map.h"

#include <cstdint>
#include <mutex>

namespace splitvk {

// The queue family a queue was got from; UINT32_MAX if unknown.
uint32_t queue_family_of(VkQueue queue);

// The lock of a queue: Vulkan requires a queue's operations to be externally synchronised, and the
// layer's present thread (present.cpp) uses the application's queues, so the layer takes it around
// every queue operation it makes or passes down. Not owning (no lock) for a queue got without a
// session. Never held while waiting for the present thread.
std::unique_lock<std::mutex> lock_queue(VkQueue queue);

struct QueueInfo {
    uint32_t family = UINT32_MAX;
    std::mutex mutex; // lock_queue()
};
// Every queue got while its device had a session; vkGetDeviceQueue adds, vkDestroyDevice removes
// (vk/queue.cpp).
namespace registry {
extern ObjectMap<VkQueue, QueueInfo> g_queues;
} // namespace registry

} // namespace splitvk
