#pragma once

#include "core/agent_link.h"
#include "core/dispatch.h"
#include "core/physical_device.h"

#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>

namespace splitvk {

struct InstanceState {
    VkInstance handle = VK_NULL_HANDLE;
    InstanceDispatchTable dispatch;
    PFN_vkGetInstanceProcAddr next_get_instance_proc_addr = nullptr;
    std::string application_name;
    uint32_t api_version = VK_API_VERSION_1_0;
    // The agent greeted at vkCreateInstance (agent_link.h); null when settings are invalid.
    std::unique_ptr<EarlyAgent> early_agent;
    // The instance's physical devices, made on first use (physical_device.cpp).
    std::mutex physical_devices_mutex;
    std::unordered_map<VkPhysicalDevice, std::unique_ptr<PhysicalDeviceState>> physical_devices;
};

// nullptr when the handle was not created through this layer.
InstanceState *find_instance(DispatchKey key);

} // namespace splitvk
