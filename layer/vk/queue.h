#pragma once

// VkQueue's entry points (vk/queue.cpp): vkGetDeviceQueue*, the submits, the waits for idle.

#include "core/queue.h"

namespace splitvk {

// vkDestroyDevice: forgets the device's queues.
void forget_queues(DeviceState &device);

} // namespace splitvk
