#pragma once

#include "dispatch.h"

namespace splitvk {

struct InstanceState;

struct DeviceState {
    VkDevice handle = VK_NULL_HANDLE;
    VkPhysicalDevice physical_device = VK_NULL_HANDLE;
    InstanceState *instance = nullptr;
    DeviceDispatchTable dispatch;
    PFN_vkGetDeviceProcAddr next_get_device_proc_addr = nullptr;
};

// nullptr when the handle was not created through this layer.
DeviceState *find_device(DispatchKey key);

} // namespace splitvk
