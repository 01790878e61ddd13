// VkInstance: the instance chain, per-instance state and the layer's own extension lists.

#include "core/instance.h"

#include "core/chain_info.h"
#include "core/layer_chain.h"
#include "core/layer_settings.h"
#include "core/object_map.h"
#include "layer_entry_points.h"
#include "log.h"

#include <vulkan/vk_layer.h>

#include <algorithm>
#include <cstring>
#include <vector>

#include <dlfcn.h>
#include <execinfo.h>

namespace splitvk {
namespace {

ObjectMap<DispatchKey, InstanceState> g_instances;

// Whether this vkEnumerateDeviceExtensionProperties is the loader's check of a vkCreateDevice
// request rather than the application's question. The loader (1.3.2xx and later) validates the
// extensions an application enables against the top of the layer chain's list before any layer's
// vkCreateDevice runs, so with splitvk's list it would refuse a withheld extension silently and
// splitvk could neither say so nor pass the device through. The loader's check runs inside its
// exported vkCreateDevice, the application's question never does: that frame on the stack (the
// loader's library, libvulkan.so*) tells them apart, whatever layers sit above splitvk.
bool loader_checking_create_device() {
    void *frames[64];
    const int count = backtrace(frames, 64);
    for (int i = 1; i < count; ++i) {
        Dl_info info{};
        // A return address points after its call; one byte back is inside the calling function.
        if (!dladdr(static_cast<char *>(frames[i]) - 1, &info) || !info.dli_sname || !info.dli_fname)
            continue;
        if (std::strcmp(info.dli_sname, "vkCreateDevice") != 0) continue;
        const char *slash = std::strrchr(info.dli_fname, '/');
        const char *file = slash ? slash + 1 : info.dli_fname;
        if (std::strncmp(file, "libvulkan.so", 12) == 0) return true;
    }
    return false;
}

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
    auto *link = find_loader_info<VkLayerInstanceCreateInfo>(
        pCreateInfo->pNext, VK_STRUCTURE_TYPE_LOADER_INSTANCE_CREATE_INFO, VK_LAYER_LINK_INFO);
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
    // The loader checking a vkCreateDevice: the driver's whole list, so that a withheld extension
    // reaches splitvk's vkCreateDevice, which says so in one line and fails it or passes the
    // device through (SPLITVK_UNSUPPORTED, device.cpp).
    if (loader_checking_create_device())
        return next.EnumerateDeviceExtensionProperties(physicalDevice, nullptr, pPropertyCount, pProperties);

    // The driver's extensions, less those splitvk cannot forward (codegen/allowlist.py). Always
    // hidden, with or without an agent, so that an application behaves the same either way and a
    // session can start later (a resync) without the app already using something
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
