// VkDevice: the per-device state and its registry.

#include "core/device.h"

#include "log.h"

#include <cstdlib>

namespace splitvk {

using registry::g_devices;

namespace {

const DeviceDispatchTable &device_table(DispatchKey key) {
    DeviceState *state = g_devices.find(key);
    if (!state || state->passthrough) {
        SPLITVK_ERROR("internal: device-level call on a handle this layer never saw");
        std::abort();
    }
    return state->dispatch;
}

DeviceState &device_state_by_key(DispatchKey key) {
    DeviceState *state = g_devices.find(key);
    if (!state || state->passthrough) {
        SPLITVK_ERROR("internal: device-level call on a handle this layer never saw");
        std::abort();
    }
    return *state;
}

} // namespace

DeviceState &device_state(VkDevice device) {
    return device_state_by_key(dispatch_key(device));
}
DeviceState &device_state(VkQueue queue) {
    return device_state_by_key(dispatch_key(queue));
}
DeviceState &device_state(VkCommandBuffer command_buffer) {
    return device_state_by_key(dispatch_key(command_buffer));
}

DeviceState *find_device(DispatchKey key) {
    DeviceState *state = g_devices.find(key);
    return state && !state->passthrough ? state : nullptr;
}

PFN_vkGetDeviceProcAddr passthrough_device_proc_addr(DispatchKey key) {
    const DeviceState *state = g_devices.find(key);
    return state && state->passthrough ? state->next_get_device_proc_addr : nullptr;
}

const DeviceDispatchTable &device_dispatch(VkDevice device) {
    return device_table(dispatch_key(device));
}
const DeviceDispatchTable &device_dispatch(VkQueue queue) {
    return device_table(dispatch_key(queue));
}
const DeviceDispatchTable &device_dispatch(VkCommandBuffer command_buffer) {
    return device_table(dispatch_key(command_buffer));
}

} // namespace splitvk
