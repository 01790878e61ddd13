#pragma once

// VkDevice's chain (device_entry.cpp): vkCreateDevice makes a device's DeviceState and its session,
// vkDestroyDevice drops them.

#include "core/device.h"

namespace splitvk {

// vkDestroyDevice: drops the per-object state (command buffers, memory, swapchains) of a device.
void forget_device_objects(DeviceState &device);

} // namespace splitvk
