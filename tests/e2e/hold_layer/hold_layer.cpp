// VK_LAYER_SPLITVK_test_hold: a test-only layer that freezes an application right after it has
// presented frame N, so that the X server can be grabbed showing exactly that frame. splitvk-atrium
// has --hold for this; vkcube and other unmodified apps do not, so the tests put this layer above
// splitvk (closest to the app) with TEST_HOLD_FRAME=N.
//
// After the present of frame N returns it prints "holding frame N" on stdout and blocks the
// presenting thread until the process is signalled. It is built into the build tree only and
// never installed.
#include <vulkan/vk_layer.h>
#include <vulkan/vulkan.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <unordered_map>

#include <unistd.h>

namespace {

using DispatchKey = void *;
DispatchKey key(const void *dispatchable) {
    return *static_cast<void *const *>(dispatchable);
}

struct InstanceLinks {
    PFN_vkGetInstanceProcAddr next_gipa = nullptr;
};
struct DeviceLinks {
    PFN_vkGetDeviceProcAddr next_gdpa = nullptr;
    PFN_vkQueuePresentKHR present = nullptr;
};

std::mutex g_mutex;
std::unordered_map<DispatchKey, InstanceLinks> g_instances;
std::unordered_map<DispatchKey, DeviceLinks> g_devices;
unsigned long long g_presents = 0;
// The instance vkCreateDevice resolves the next vkCreateDevice through: layers below may answer
// vkGetInstanceProcAddr only for an instance they know. The tested apps create one instance.
VkInstance g_instance = VK_NULL_HANDLE;

long long hold_frame() {
    const char *value = std::getenv("TEST_HOLD_FRAME");
    return value ? std::atoll(value) : -1;
}

VKAPI_ATTR VkResult VKAPI_CALL CreateInstance(const VkInstanceCreateInfo *info,
                                              const VkAllocationCallbacks *alloc, VkInstance *instance) {
    auto *chain = static_cast<VkLayerInstanceCreateInfo *>(const_cast<void *>(info->pNext));
    while (chain && !(chain->sType == VK_STRUCTURE_TYPE_LOADER_INSTANCE_CREATE_INFO &&
                      chain->function == VK_LAYER_LINK_INFO))
        chain = static_cast<VkLayerInstanceCreateInfo *>(const_cast<void *>(chain->pNext));
    if (!chain) return VK_ERROR_INITIALIZATION_FAILED;
    const PFN_vkGetInstanceProcAddr next = chain->u.pLayerInfo->pfnNextGetInstanceProcAddr;
    chain->u.pLayerInfo = chain->u.pLayerInfo->pNext;
    auto create = reinterpret_cast<PFN_vkCreateInstance>(next(VK_NULL_HANDLE, "vkCreateInstance"));
    const VkResult result = create(info, alloc, instance);
    if (result == VK_SUCCESS) {
        std::lock_guard lock(g_mutex);
        g_instances[key(*instance)] = {next};
        g_instance = *instance;
    }
    return result;
}

VKAPI_ATTR VkResult VKAPI_CALL CreateDevice(VkPhysicalDevice gpu, const VkDeviceCreateInfo *info,
                                            const VkAllocationCallbacks *alloc, VkDevice *device) {
    auto *chain = static_cast<VkLayerDeviceCreateInfo *>(const_cast<void *>(info->pNext));
    while (chain && !(chain->sType == VK_STRUCTURE_TYPE_LOADER_DEVICE_CREATE_INFO &&
                      chain->function == VK_LAYER_LINK_INFO))
        chain = static_cast<VkLayerDeviceCreateInfo *>(const_cast<void *>(chain->pNext));
    if (!chain) return VK_ERROR_INITIALIZATION_FAILED;
    const PFN_vkGetInstanceProcAddr next_gipa = chain->u.pLayerInfo->pfnNextGetInstanceProcAddr;
    const PFN_vkGetDeviceProcAddr next_gdpa = chain->u.pLayerInfo->pfnNextGetDeviceProcAddr;
    chain->u.pLayerInfo = chain->u.pLayerInfo->pNext;
    VkInstance instance = VK_NULL_HANDLE;
    {
        std::lock_guard lock(g_mutex);
        instance = g_instance;
    }
    auto create = reinterpret_cast<PFN_vkCreateDevice>(next_gipa(instance, "vkCreateDevice"));
    const VkResult result = create(gpu, info, alloc, device);
    if (result == VK_SUCCESS) {
        std::lock_guard lock(g_mutex);
        g_devices[key(*device)] = {
            next_gdpa, reinterpret_cast<PFN_vkQueuePresentKHR>(next_gdpa(*device, "vkQueuePresentKHR"))};
    }
    return result;
}

VKAPI_ATTR VkResult VKAPI_CALL QueuePresentKHR(VkQueue queue, const VkPresentInfoKHR *info) {
    PFN_vkQueuePresentKHR present = nullptr;
    {
        std::lock_guard lock(g_mutex);
        present = g_devices[key(queue)].present; // a queue shares its device's dispatch table
    }
    const VkResult result = present(queue, info);
    const unsigned long long frame = g_presents++;
    if (static_cast<long long>(frame) == hold_frame()) {
        std::printf("holding frame %llu\n", frame);
        std::fflush(stdout);
        for (;;)
            ::pause(); // until a signal ends the process
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
    return g_instances[key(instance)].next_gipa(instance, name);
}

VKAPI_ATTR PFN_vkVoidFunction VKAPI_CALL GetDeviceProcAddr(VkDevice device, const char *name) {
    if (!std::strcmp(name, "vkGetDeviceProcAddr"))
        return reinterpret_cast<PFN_vkVoidFunction>(GetDeviceProcAddr);
    if (!std::strcmp(name, "vkQueuePresentKHR")) return reinterpret_cast<PFN_vkVoidFunction>(QueuePresentKHR);
    std::lock_guard lock(g_mutex);
    return g_devices[key(device)].next_gdpa(device, name);
}

} // namespace

extern "C" __attribute__((visibility("default"))) VKAPI_ATTR VkResult VKAPI_CALL
vkNegotiateLoaderLayerInterfaceVersion(VkNegotiateLayerInterface *interface) {
    if (!interface || interface->sType != LAYER_NEGOTIATE_INTERFACE_STRUCT)
        return VK_ERROR_INITIALIZATION_FAILED;
    if (interface->loaderLayerInterfaceVersion > 2) interface->loaderLayerInterfaceVersion = 2;
    interface->pfnGetInstanceProcAddr = GetInstanceProcAddr;
    interface->pfnGetDeviceProcAddr = GetDeviceProcAddr;
    interface->pfnGetPhysicalDeviceProcAddr = nullptr;
    return VK_SUCCESS;
}
