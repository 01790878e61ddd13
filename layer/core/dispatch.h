#pragma once

// Finding the next layer's function table for any handle the application calls us with.
//
// Every dispatchable handle (VkInstance, VkPhysicalDevice, VkDevice, VkQueue, VkCommandBuffer)
// starts with the loader's dispatch-table pointer, and all children of one instance or device
// share their parent's. That pointer, the "dispatch key", finds the parent's state with one
// lookup, without tracking every queue and command buffer.

#include "vk_dispatch_table.h"

#include <vulkan/vulkan.h>

namespace splitvk {

using DispatchKey = const void *;

template <typename DispatchableHandle>
inline DispatchKey dispatch_key(DispatchableHandle handle) {
    return *reinterpret_cast<const void *const *>(handle);
}

const InstanceDispatchTable &instance_dispatch(VkInstance instance);
const InstanceDispatchTable &instance_dispatch(VkPhysicalDevice physical_device);
const DeviceDispatchTable &device_dispatch(VkDevice device);
const DeviceDispatchTable &device_dispatch(VkQueue queue);
const DeviceDispatchTable &device_dispatch(VkCommandBuffer command_buffer);

} // namespace splitvk
