#include "present_layer.h"

#include "../test_layer/test_layer.h"

#include <cstring>
#include <mutex>
#include <unordered_map>

namespace splitvk::present_layer {
namespace {

std::mutex g_mutex;
std::unordered_map<test_layer::DispatchKey, Next> g_next;

VKAPI_ATTR VkResult VKAPI_CALL QueuePresentKHR(VkQueue queue, const VkPresentInfoKHR *info) {
    Next next;
    {
        std::lock_guard lock(g_mutex);
        next = g_next[test_layer::key(queue)]; // a queue shares its device's dispatch table
    }
    return present(next, queue, info);
}

} // namespace
} // namespace splitvk::present_layer

namespace splitvk::test_layer {

PFN_vkVoidFunction device_entry_point(const char *name) {
    if (!std::strcmp(name, "vkQueuePresentKHR"))
        return reinterpret_cast<PFN_vkVoidFunction>(present_layer::QueuePresentKHR);
    return nullptr;
}

void device_created(VkPhysicalDevice, VkDevice device, PFN_vkGetDeviceProcAddr next,
                    const VkDeviceCreateInfo &) {
    const present_layer::Next n{reinterpret_cast<PFN_vkQueuePresentKHR>(next(device, "vkQueuePresentKHR")),
                                reinterpret_cast<PFN_vkQueueSubmit>(next(device, "vkQueueSubmit")),
                                reinterpret_cast<PFN_vkQueueWaitIdle>(next(device, "vkQueueWaitIdle"))};
    std::lock_guard lock(present_layer::g_mutex);
    present_layer::g_next[key(device)] = n;
}

void device_destroying(VkDevice device) {
    std::lock_guard lock(present_layer::g_mutex);
    present_layer::g_next.erase(key(device));
}

} // namespace splitvk::test_layer
