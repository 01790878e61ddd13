#pragma once

#include "dispatch.h"

#include <string>

namespace splitvk {

struct InstanceState {
    VkInstance handle = VK_NULL_HANDLE;
    InstanceDispatchTable dispatch;
    PFN_vkGetInstanceProcAddr next_get_instance_proc_addr = nullptr;
    std::string application_name;
    uint32_t api_version = VK_API_VERSION_1_0;
};

// nullptr when the handle was not created through this layer.
InstanceState *find_instance(DispatchKey key);

} // namespace splitvk
