#pragma once

// VkQueue (queue.cpp): the queues a device was got, their families and locks, and the submits.

#include "device.h"

#include <cstdint>
#include <mutex>

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

} // namespace splitvk
