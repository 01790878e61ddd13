// VkInstance: the instance chain, per-instance state and the layer's own extension lists.

#include "instance.h"

#include "chain_info.h"
#include "layer_entry_points.h"
#include "layer_settings.h"
#include "log.h"
#include "object_map.h"

#include <vulkan/vk_layer.h>

#include <algorithm>
#include <cstring>
#include <vector>

namespace splitvk {
namespace {

ObjectMap<DispatchKey, InstanceState> g_instances;

InstanceState &instance_state(DispatchKey key) {
    InstanceState *state = g_instances.find(key);
    if (!state) {
        SPLITVK_ERROR("internal: instance-level call on a handle this layer never saw");
        std::abort();
    }
    return *state;
}

} // namespace

InstanceState *find_instance(DispatchKey key) {
    return g_instances.find(key);
}

const InstanceDispatchTable &instance_dispatch(VkInstance instance) {
    return instance_state(dispatch_key(instance)).dispatch;
}

const InstanceDispatchTable &instance_dispatch(VkPhysicalDevice physical_device) {
    // The loader gives physical devices their instance's dispatch pointer.
    return instance_state(dispatch_key(physical_device)).dispatch;
}

namespace entry {

VKAPI_ATTR VkResult VKAPI_CALL CreateInstance(const VkInstanceCreateInfo *pCreateInfo,
                                              const VkAllocationCallbacks *pAllocator,
                                              VkInstance *pInstance) {
    auto *link = find_layer_link<VkLayerInstanceCreateInfo>(pCreateInfo->pNext,
                                                            VK_STRUCTURE_TYPE_LOADER_INSTANCE_CREATE_INFO);
    if (!link || !link->u.pLayerInfo) return VK_ERROR_INITIALIZATION_FAILED;
    report_layer_position(link->u.pLayerInfo);

    const PFN_vkGetInstanceProcAddr next_gipa = link->u.pLayerInfo->pfnNextGetInstanceProcAddr;
    const auto next_create =
        reinterpret_cast<PFN_vkCreateInstance>(next_gipa(VK_NULL_HANDLE, "vkCreateInstance"));
    if (!next_create) return VK_ERROR_INITIALIZATION_FAILED;

    link->u.pLayerInfo = link->u.pLayerInfo->pNext;
    const VkResult result = next_create(pCreateInfo, pAllocator, pInstance);
    if (result != VK_SUCCESS) return result;

    auto state = std::make_unique<InstanceState>();
    state->handle = *pInstance;
    state->next_get_instance_proc_addr = next_gipa;
    load_instance_dispatch_table(state->dispatch, *pInstance, next_gipa);
    if (const VkApplicationInfo *app = pCreateInfo->pApplicationInfo) {
        if (app->pApplicationName) state->application_name = app->pApplicationName;
        state->api_version = app->apiVersion;
    }

    layer_settings();
    // Greet the agent now, in the background, so that the device envelope can include its GPU by
    // the time the application asks for limits (agent_link.h).
    state->early_agent = EarlyAgent::start(state->application_name);
    SPLITVK_INFO("%s active in '%s'", kLayerName,
                 state->application_name.empty() ? "(unnamed application)" : state->application_name.c_str());
    g_instances.insert(dispatch_key(*pInstance), std::move(state));
    return VK_SUCCESS;
}

VKAPI_ATTR void VKAPI_CALL DestroyInstance(VkInstance instance, const VkAllocationCallbacks *pAllocator) {
    if (instance == VK_NULL_HANDLE) return;
    const auto state = g_instances.remove(dispatch_key(instance));
    if (state) state->dispatch.DestroyInstance(instance, pAllocator);
}

VKAPI_ATTR VkResult VKAPI_CALL EnumerateDeviceExtensionProperties(VkPhysicalDevice physicalDevice,
                                                                  const char *pLayerName,
                                                                  uint32_t *pPropertyCount,
                                                                  VkExtensionProperties *pProperties) {
    // splitvk adds no extensions of its own.
    if (pLayerName && std::strcmp(pLayerName, kLayerName) == 0) {
        *pPropertyCount = 0;
        return VK_SUCCESS;
    }
    const auto &next = instance_dispatch(physicalDevice);
    if (pLayerName)
        return next.EnumerateDeviceExtensionProperties(physicalDevice, pLayerName, pPropertyCount,
                                                       pProperties);

    // The driver's extensions, less those splitvk cannot forward (codegen/allowlist.py). Always
    // hidden, with or without an agent, so that an application behaves the same either way and a
    // session can start later (the reliability issue) without the app already using something
    // the agent cannot replay.
    std::vector<VkExtensionProperties> all;
    VkResult result;
    do {
        uint32_t count = 0;
        result = next.EnumerateDeviceExtensionProperties(physicalDevice, nullptr, &count, nullptr);
        if (result != VK_SUCCESS) return result;
        all.resize(count);
        result = next.EnumerateDeviceExtensionProperties(physicalDevice, nullptr, &count, all.data());
        all.resize(count);
    } while (result == VK_INCOMPLETE);
    if (result != VK_SUCCESS) return result;
    std::erase_if(
        all, [](const VkExtensionProperties &e) { return !device_extension_forwarded(e.extensionName); });

    const auto available = static_cast<uint32_t>(all.size());
    if (!pProperties) {
        *pPropertyCount = available;
        return VK_SUCCESS;
    }
    const uint32_t written = std::min(*pPropertyCount, available);
    std::copy_n(all.begin(), written, pProperties);
    *pPropertyCount = written;
    return written < available ? VK_INCOMPLETE : VK_SUCCESS;
}

} // namespace entry
} // namespace splitvk
