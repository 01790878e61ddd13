#include "test_layer.h"

#include <cstring>
#include <mutex>
#include <unordered_map>

namespace splitvk::test_layer {
namespace {

struct Instance {
    VkInstance handle = VK_NULL_HANDLE;
    PFN_vkGetInstanceProcAddr next = nullptr;
};
struct Device {
    PFN_vkGetDeviceProcAddr next = nullptr;
    PFN_vkSetDeviceLoaderData set_loader_data = nullptr;
};

std::mutex g_mutex;
// A physical device shares its instance's dispatch key: vkCreateDevice resolves the next
// vkCreateDevice through the instance the device is made on, as layers below may answer
// vkGetInstanceProcAddr only for an instance they know. An OpenXR process has two (the
// application's and the runtime's).
std::unordered_map<DispatchKey, Instance> g_instances;
std::unordered_map<DispatchKey, Device> g_devices; // a device's queues and command buffers share its key

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

PFN_vkSetDeviceLoaderData loader_data_callback(const VkDeviceCreateInfo &info) {
    for (auto *s = static_cast<const VkLayerDeviceCreateInfo *>(info.pNext); s;
         s = static_cast<const VkLayerDeviceCreateInfo *>(s->pNext))
        if (s->sType == VK_STRUCTURE_TYPE_LOADER_DEVICE_CREATE_INFO && s->function == VK_LOADER_DATA_CALLBACK)
            return s->u.pfnSetDeviceLoaderData;
    return nullptr;
}

Instance instance_of(VkPhysicalDevice gpu) {
    std::lock_guard lock(g_mutex);
    const auto it = g_instances.find(key(gpu));
    return it == g_instances.end() ? Instance{} : it->second;
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
        g_instances[key(*instance)] = {*instance, next};
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
    auto create = reinterpret_cast<PFN_vkCreateDevice>(next_gipa(instance_of(gpu).handle, "vkCreateDevice"));
    const VkResult result = create(gpu, info, alloc, device);
    if (result == VK_SUCCESS) {
        {
            std::lock_guard lock(g_mutex);
            g_devices[key(*device)] = {next_gdpa, loader_data_callback(*info)};
        }
        device_created(gpu, *device, next_gdpa, *info);
    }
    return result;
}

VKAPI_ATTR void VKAPI_CALL DestroyDevice(VkDevice device, const VkAllocationCallbacks *alloc) {
    if (!device) return;
    device_destroying(device);
    const PFN_vkGetDeviceProcAddr next = next_device_proc_addr(device);
    // The key is read through the handle, which the driver frees: take it first.
    const DispatchKey device_key = key(device);
    reinterpret_cast<PFN_vkDestroyDevice>(next(device, "vkDestroyDevice"))(device, alloc);
    std::lock_guard lock(g_mutex);
    g_devices.erase(device_key);
}

VKAPI_ATTR PFN_vkVoidFunction VKAPI_CALL GetDeviceProcAddr(VkDevice device, const char *name);

VKAPI_ATTR PFN_vkVoidFunction VKAPI_CALL GetInstanceProcAddr(VkInstance instance, const char *name) {
    if (!std::strcmp(name, "vkGetInstanceProcAddr"))
        return reinterpret_cast<PFN_vkVoidFunction>(GetInstanceProcAddr);
    if (!std::strcmp(name, "vkCreateInstance")) return reinterpret_cast<PFN_vkVoidFunction>(CreateInstance);
    if (!std::strcmp(name, "vkCreateDevice")) return reinterpret_cast<PFN_vkVoidFunction>(CreateDevice);
    if (!std::strcmp(name, "vkGetDeviceProcAddr"))
        return reinterpret_cast<PFN_vkVoidFunction>(GetDeviceProcAddr);
    if (const PFN_vkVoidFunction own = lifetime_entry_point(name)) return own;
    if (!instance) return nullptr;
    std::lock_guard lock(g_mutex);
    return g_instances[key(instance)].next(instance, name);
}

VKAPI_ATTR PFN_vkVoidFunction VKAPI_CALL GetDeviceProcAddr(VkDevice device, const char *name) {
    if (!std::strcmp(name, "vkGetDeviceProcAddr"))
        return reinterpret_cast<PFN_vkVoidFunction>(GetDeviceProcAddr);
    if (const PFN_vkVoidFunction own = lifetime_entry_point(name)) return own;
    if (!std::strcmp(name, "vkDestroyDevice")) return reinterpret_cast<PFN_vkVoidFunction>(DestroyDevice);
    const PFN_vkVoidFunction next = next_device_proc_addr(device)(device, name);
    if (!next) return nullptr;
    if (const PFN_vkVoidFunction own = device_entry_point(name)) return own;
    return next;
}

} // namespace

[[gnu::weak]] PFN_vkVoidFunction lifetime_entry_point(const char *) {
    return nullptr;
}

PFN_vkGetDeviceProcAddr next_device_proc_addr(const void *dispatchable) {
    std::lock_guard lock(g_mutex);
    return g_devices[key(dispatchable)].next;
}

PFN_vkVoidFunction next_instance_proc(VkPhysicalDevice gpu, const char *name) {
    const Instance instance = instance_of(gpu);
    return instance.next ? instance.next(instance.handle, name) : nullptr;
}

VkResult set_loader_data(VkDevice device, void *object) {
    PFN_vkSetDeviceLoaderData set = nullptr;
    {
        std::lock_guard lock(g_mutex);
        set = g_devices[key(device)].set_loader_data;
    }
    return set ? set(device, object) : VK_ERROR_INITIALIZATION_FAILED;
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
