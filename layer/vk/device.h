#pragma once

// VkDevice's chain (vk/device.cpp): vkCreateDevice makes a device's DeviceState and its session,
// vkDestroyDevice drops them.

#include "core/device.h"

namespace splitvk {

// vkDestroyDevice: drops the per-object state (command buffers, memory, swapchains) of a device.
void forget_device_objects(DeviceState &device);

} // namespace splitvk
