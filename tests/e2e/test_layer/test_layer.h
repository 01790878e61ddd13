#pragma once

// The loader plumbing of the e2e tests' own Vulkan layers (present_layer/ with hold_layer/ and
// present_fault_layer/, reuse_layer/, xr_readback_layer/): vkNegotiateLoaderLayerInterfaceVersion,
// vkCreateInstance, vkCreateDevice and vkDestroyDevice down the chain, and the vkGet*ProcAddr that
// answer with the layer's own entry points and the next layer's for everything else.
// test_layer.cpp, linked into each layer, holds it; a layer writes only the three functions
// declared at the bottom.

#include <vulkan/vk_layer.h>
#include <vulkan/vulkan.h>

namespace splitvk::test_layer {

// Every dispatchable handle starts with the loader's dispatch-table pointer, shared by a device's
// queues and command buffers: the key to its device.
using DispatchKey = void *;
inline DispatchKey key(const void *dispatchable) {
    return *static_cast<void *const *>(dispatchable);
}

// The next layer's vkGetDeviceProcAddr for `device` (or any queue or command buffer of it).
PFN_vkGetDeviceProcAddr next_device_proc_addr(const void *dispatchable);
// The next layer's instance-level command `name` for the instance `gpu` belongs to, or nullptr.
PFN_vkVoidFunction next_instance_proc(VkPhysicalDevice gpu, const char *name);
// Gives a dispatchable object the layer made itself below the loader (a command buffer it
// allocated from the next layer) the dispatch pointer the loader's trampolines read.
VkResult set_loader_data(VkDevice device, void *object);

// Defined by a layer that replaces the plumbing's own end of an object (keep_layer/), or answers a
// command whatever the next layer has (queue_guard_layer/); a weak default answers nullptr for the
// others: its vkDestroyDevice or vkDestroyInstance (or that command) for `name`, or nullptr to pass
// the call down as the plumbing does.
PFN_vkVoidFunction lifetime_entry_point(const char *name);

// Defined by each layer:
// Its own device-level entry point for `name` (vkQueuePresentKHR, ...), or nullptr to hand the
// next layer's out. Handed out only where the next layer has `name` (an extension's command is
// nullptr when the device did not enable it).
PFN_vkVoidFunction device_entry_point(const char *name);
// Called once the next layer created `device` on `gpu`: the layer resolves the next layer's
// commands it calls (with `next`) and keeps what it needs of `info`.
void device_created(VkPhysicalDevice gpu, VkDevice device, PFN_vkGetDeviceProcAddr next,
                    const VkDeviceCreateInfo &info);
// Called before the next layer destroys `device`: the layer destroys what it made on it and
// forgets it (a later device may get the same dispatch key).
void device_destroying(VkDevice device);

} // namespace splitvk::test_layer
