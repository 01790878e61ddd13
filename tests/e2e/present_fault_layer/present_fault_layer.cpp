// VK_LAYER_SPLITVK_test_present_fault: a test-only layer that makes the driver's vkQueuePresentKHR
// answer VK_ERROR_OUT_OF_DATE_KHR or VK_SUBOPTIMAL_KHR once, as a real window system does when a
// window is resized. Lavapipe under Xvfb never does on its own, and splitvk presents from a thread
// of its own: what the driver answered that thread must still reach the application (issue 12).
// The tests put this layer BELOW splitvk, next to the driver, so that it sees the presents splitvk
// makes, not the application's.
//
// TEST_PRESENT_FAULT=out_of_date:N or suboptimal:N: the Nth present that reaches this layer (from
// 0) answers that result. It prints "present fault: present N answered <result>" on stderr.
//  - suboptimal: the present goes to the driver as asked (the image is shown and released), and
//    VK_SUBOPTIMAL_KHR replaces the driver's VK_SUCCESS.
//  - out_of_date: what Mesa's WSI does for a surface that no longer matches its swapchain
//    (x11_queue_present returns the chain's error before it queues the image): the presentation
//    request is rejected, the image is not presented and stays acquired, but the present's
//    semaphore waits still execute ("if the presentation request is rejected by the presentation
//    engine with an error VK_ERROR_OUT_OF_DATE_KHR ... any semaphore wait operation specified in
//    VkPresentInfoKHR will execute when the corresponding queue operation is complete"). The layer
//    consumes them with an empty batch on the present queue, so that whoever signalled them may
//    signal them again; validation, which treats an image whose present answered an error as still
//    acquired, then agrees with the driver.
// Built into the build tree only and never installed.
#include <vulkan/vk_layer.h>
#include <vulkan/vulkan.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <string>
#include <unordered_map>
#include <vector>

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
    PFN_vkQueueSubmit submit = nullptr;
};

std::mutex g_mutex;
std::unordered_map<DispatchKey, InstanceLinks> g_instances;
std::unordered_map<DispatchKey, DeviceLinks> g_devices;
unsigned long long g_presents = 0;
VkInstance g_instance = VK_NULL_HANDLE; // see hold_layer.cpp: the tested apps create one instance

struct Fault {
    VkResult result = VK_SUCCESS;
    long long present = -1;
};

Fault fault() {
    Fault f;
    const char *value = std::getenv("TEST_PRESENT_FAULT");
    if (!value) return f;
    const std::string text(value);
    const auto colon = text.find(':');
    if (colon == std::string::npos) return f;
    const std::string kind = text.substr(0, colon);
    if (kind == "out_of_date")
        f.result = VK_ERROR_OUT_OF_DATE_KHR;
    else if (kind == "suboptimal")
        f.result = VK_SUBOPTIMAL_KHR;
    else
        return f;
    f.present = std::atoll(text.c_str() + colon + 1);
    return f;
}

const char *name_of(VkResult r) {
    return r == VK_ERROR_OUT_OF_DATE_KHR ? "VK_ERROR_OUT_OF_DATE_KHR" : "VK_SUBOPTIMAL_KHR";
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
            next_gdpa, reinterpret_cast<PFN_vkQueuePresentKHR>(next_gdpa(*device, "vkQueuePresentKHR")),
            reinterpret_cast<PFN_vkQueueSubmit>(next_gdpa(*device, "vkQueueSubmit"))};
    }
    return result;
}

VKAPI_ATTR VkResult VKAPI_CALL QueuePresentKHR(VkQueue queue, const VkPresentInfoKHR *info) {
    DeviceLinks links;
    unsigned long long present = 0;
    {
        std::lock_guard lock(g_mutex);
        links = g_devices[key(queue)]; // a queue shares its device's dispatch table
        present = g_presents++;
    }
    const Fault f = fault();
    if (static_cast<long long>(present) != f.present) return links.present(queue, info);

    VkResult result = VK_SUCCESS;
    if (f.result == VK_SUBOPTIMAL_KHR) {
        result = links.present(queue, info);
        if (result == VK_SUCCESS) result = VK_SUBOPTIMAL_KHR;
    } else {
        // Rejected: only the semaphore waits happen (the caller holds the queue, as for the present).
        const std::vector<VkPipelineStageFlags> stages(info->waitSemaphoreCount,
                                                       VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT);
        VkSubmitInfo submit{};
        submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
        submit.waitSemaphoreCount = info->waitSemaphoreCount;
        submit.pWaitSemaphores = info->pWaitSemaphores;
        submit.pWaitDstStageMask = stages.data();
        result = info->waitSemaphoreCount ? links.submit(queue, 1, &submit, VK_NULL_HANDLE) : VK_SUCCESS;
        if (result == VK_SUCCESS) {
            result = VK_ERROR_OUT_OF_DATE_KHR;
            if (info->pResults)
                for (uint32_t i = 0; i < info->swapchainCount; ++i)
                    info->pResults[i] = result;
        }
    }
    std::fprintf(stderr, "present fault: present %llu answered %s\n", present, name_of(result));
    std::fflush(stderr);
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
