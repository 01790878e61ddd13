#pragma once

#include "core/dispatch.h"
#include "core/object_map.h"

#include <vulkan/vk_layer.h>

#include <memory>
#include <mutex>
#include <span>

namespace splitvk {

struct InstanceState;
struct MemoryObjects;
class Session;

// memory.cpp: the device's allocations and mapped ranges.
std::shared_ptr<MemoryObjects> make_memory_objects();

struct DeviceState {
    VkDevice handle = VK_NULL_HANDLE;
    VkPhysicalDevice physical_device = VK_NULL_HANDLE;
    InstanceState *instance = nullptr;
    DeviceDispatchTable dispatch;
    PFN_vkGetDeviceProcAddr next_get_device_proc_addr = nullptr;
    VkPhysicalDeviceMemoryProperties memory_properties{};
    // The replication session (session.h); null when no agent answered at vkCreateDevice. Set
    // before the device is published and kept until vkDestroyDevice, so reading it needs no lock.
    std::unique_ptr<Session> session;
    // Its VkDeviceMemory objects and their shadows (memory.cpp), under a lock of their own; made
    // with the device, before it is published.
    std::shared_ptr<MemoryObjects> memory;
    // The loader's vkSetDeviceLoaderData, for dispatchable objects the layer creates itself.
    PFN_vkSetDeviceLoaderData set_loader_data = nullptr;
};

// nullptr when the handle was not created through this layer.
DeviceState *find_device(DispatchKey key);
// SPLITVK_UNSUPPORTED=passthrough: a device created with an extension splitvk does not forward has
// no DeviceState; the layer only remembers the next layer's vkGetDeviceProcAddr, so that
// vkGetDeviceProcAddr hands the application the next layer's commands (vkDestroyDevice excepted,
// which forgets it). nullptr for every other device.
PFN_vkGetDeviceProcAddr passthrough_device_proc_addr(DispatchKey key);

// The state of the device a handle belongs to (aborts, like device_dispatch, on an unknown handle).
DeviceState &device_state(VkDevice device);
DeviceState &device_state(VkQueue queue);
DeviceState &device_state(VkCommandBuffer command_buffer);

// SPLITVK_UNSUPPORTED=passthrough: the devices splitvk stays out of (passthrough_device_proc_addr).
struct PassthroughDevice {
    PFN_vkGetDeviceProcAddr next_get_device_proc_addr = nullptr;
    PFN_vkDestroyDevice next_destroy_device = nullptr;
};

// The devices created through this layer, and those it passes through, by dispatch key: filled at
// vkCreateDevice and emptied at vkDestroyDevice (vk/device.cpp); everything else finds a device with
// find_device / device_state. In a namespace of their own, so that a file's own g_devices
// (core/gpu_timing.cpp's timestamp pools) stays unambiguous.
namespace registry {
extern ObjectMap<DispatchKey, DeviceState> g_devices;
extern ObjectMap<DispatchKey, PassthroughDevice> g_passthrough_devices;
} // namespace registry

} // namespace splitvk
