#include "test_layer.h"

#include <cstring>
#include <mutex>
#include <unordered_map>

namespace splitvk::test_layer {
namespace {

std::mutex g_mutex;
std::unordered_map<DispatchKey, PFN_vkGetInstanceProcAddr> g_instances;
std::unordered_map<DispatchKey, PFN_vkGetDeviceProcAddr> g_devices;
// The instance vkCreateDevice resolves the next vkCreateDevice through: layers below may answer
// vkGetInstanceProcAddr only for an instance they know. The tested apps create one instance.
VkInstance g_instance = VK_NULL_HANDLE;

// The loader's link info for this layer in a create info's pNext chain, moved on to the next layer.
template <class LinkInfo>
auto *take_link(const void *next, VkStructureType type) {
    auto *chain = static_cast<LinkInfo *>(const_cast<void *>(next));
    while (chain && !(chain->sType == type && chain->function == VK_LAYER_LINK_INFO))
        chain = static_cast<LinkInfo *>(const_cast<void *>(chain->pNext));
    if (!chain) return decltype(chain->u.pLayerInfo){nullptr};
    auto *link = chain->u.pLayerInfo;
    chain->u.pLayerInfo = link->pNext;
    return link;
}

VKAPI_ATTR VkResult VKAPI_CALL CreateInstance(const VkInstanceCreateInfo *info,
                                              const VkAllocationCallbacks *alloc, VkInstance *instance) {
    const auto *link =
        take_link<VkLayerInstanceCreateInfo>(info->pNext, VK_STRUCTURE_TYPE_LOADER_INSTANCE_CREATE_INFO);
    if (!link) return VK_ERROR_INITIALIZATION_FAILED;
    const PFN_vkGetInstanceProcAddr next = link->pfnNextGetInstanceProcAddr;
    auto create = reinterpret_cast<PFN_vkCreateInstance>(next(VK_NULL_HANDLE, "vkCreateInstance"));
    const VkResult result = create(info, alloc, instance);
    if (result == VK_SUCCESS) {
        std::lock_guard lock(g_mutex);
        g_instances[key(*instance)] = next;
        g_instance = *instance;
    }
    return result;
}

VKAPI_ATTR VkResult VKAPI_CALL CreateDevice(VkPhysicalDevice gpu, const VkDeviceCreateInfo *info,
                                            const VkAllocationCallbacks *alloc, VkDevice *device) {
    const auto *link =
        take_link<VkLayerDeviceCreateInfo>(info->pNext, VK_STRUCTURE_TYPE_LOADER_DEVICE_CREATE_INFO);
    if (!link) return VK_ERROR_INITIALIZATION_FAILED;
    const PFN_vkGetInstanceProcAddr next_gipa = link->pfnNextGetInstanceProcAddr;
    const PFN_vkGetDeviceProcAddr next_gdpa = link->pfnNextGetDeviceProcAddr;
    VkInstance instance = VK_NULL_HANDLE;
    {
        std::lock_guard lock(g_mutex);
        instance = g_instance;
    }
    auto create = reinterpret_cast<PFN_vkCreateDevice>(next_gipa(instance, "vkCreateDevice"));
    const VkResult result = create(gpu, info, alloc, device);
    if (result == VK_SUCCESS) {
        {
            std::lock_guard lock(g_mutex);
            g_devices[key(*device)] = next_gdpa;
        }
        device_created(*device, next_gdpa, *info);
    }
    return result;
}

VKAPI_ATTR PFN_vkVoidFunction VKAPI_CALL GetDeviceProcAddr(VkDevice device, const char *name);

VKAPI_ATTR PFN_vkVoidFunction VKAPI_CALL GetInstanceProcAddr(VkInstance instance, const char *name) {
    if (!std::strcmp(name, "vkGetInstanceProcAddr"))
        return reinterpret_cast<PFN_vkVoidFunction>(GetInstanceProcAddr);
    if (!std::strcmp(name, "vkCreateInstance")) return reinterpret_cast<PFN_vkVoidFunction>(CreateInstance);
    if (!std::strcmp(name, "vkCreateDevice")) return reinterpret_cast<PFN_vkVoidFunction>(CreateDevice);
    if (!std::strcmp(name, "vkGetDeviceProcAddr"))
        return reinterpret_cast<PFN_vkVoidFunction>(GetDeviceProcAddr);
    if (!instance) return nullptr;
    std::lock_guard lock(g_mutex);
    return g_instances[key(instance)](instance, name);
}

VKAPI_ATTR PFN_vkVoidFunction VKAPI_CALL GetDeviceProcAddr(VkDevice device, const char *name) {
    if (!std::strcmp(name, "vkGetDeviceProcAddr"))
        return reinterpret_cast<PFN_vkVoidFunction>(GetDeviceProcAddr);
    if (const PFN_vkVoidFunction own = device_entry_point(name)) return own;
    return next_device_proc_addr(device)(device, name);
}

} // namespace

PFN_vkGetDeviceProcAddr next_device_proc_addr(const void *dispatchable) {
    std::lock_guard lock(g_mutex);
    return g_devices[key(dispatchable)];
}

} // namespace splitvk::test_layer

extern "C" __attribute__((visibility("default"))) VKAPI_ATTR VkResult VKAPI_CALL
vkNegotiateLoaderLayerInterfaceVersion(VkNegotiateLayerInterface *interface) {
    if (!interface || interface->sType != LAYER_NEGOTIATE_INTERFACE_STRUCT)
        return VK_ERROR_INITIALIZATION_FAILED;
    if (interface->loaderLayerInterfaceVersion > 2) interface->loaderLayerInterfaceVersion = 2;
    interface->pfnGetInstanceProcAddr = splitvk::test_layer::GetInstanceProcAddr;
    interface->pfnGetDeviceProcAddr = splitvk::test_layer::GetDeviceProcAddr;
    interface->pfnGetPhysicalDeviceProcAddr = nullptr;
    return VK_SUCCESS;
}
