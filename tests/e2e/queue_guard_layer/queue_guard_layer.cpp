// VK_LAYER_SPLITVK_test_queue_guard: a test-only layer, placed BELOW splitvk, that checks that a
// queue debug label another thread makes through splitvk waits for a present splitvk is making on
// the same queue. Vulkan requires the operations of one queue to be externally synchronised, and
// splitvk presents on the application's queue from a thread of its own: its queue lock is what
// keeps the application's queue operations off the queue meanwhile.
//
// At the present numbered TEST_QUEUE_GUARD_PRESENT (from 0) that reaches it, the layer starts a
// thread that calls vkQueueInsertDebugUtilsLabelEXT on that queue through splitvk's own
// vkGetDeviceProcAddr (from the library TEST_QUEUE_GUARD_TOP names: the loader hands debug-utils
// commands only to an application that enabled VK_EXT_debug_utils), then holds the present for
// 300 ms before passing it down. When the label reaches this layer it prints, on stderr, either
//   queue guard: the label waited for the present
// or, when it arrives while the present is still held here,
//   queue guard: the label overlapped the present
// The label ends here: the application did not enable VK_EXT_debug_utils, so the driver is not
// asked. Built into the build tree only and never installed.
#include "../test_layer/test_layer.h"

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <thread>
#include <unordered_map>

#include <dlfcn.h>

namespace splitvk::queue_guard_layer {
namespace {

using namespace std::chrono_literals;

constexpr const char *kLabelName = "splitvk queue guard";

struct Device {
    VkDevice handle = VK_NULL_HANDLE;
    PFN_vkQueuePresentKHR present = nullptr;
};

std::mutex g_mutex;
std::unordered_map<test_layer::DispatchKey, Device> g_devices;
std::thread g_label_thread; // joined when its device is destroyed
std::atomic<long long> g_presents{0};
std::atomic<bool> g_holding{false};

long long guarded_present() {
    static const long long n = [] {
        const char *value = std::getenv("TEST_QUEUE_GUARD_PRESENT");
        return value ? std::atoll(value) : -1;
    }();
    return n;
}

// splitvk's vkQueueInsertDebugUtilsLabelEXT for `device`, asked of the library's own
// vkGetDeviceProcAddr as the loader would.
PFN_vkQueueInsertDebugUtilsLabelEXT splitvk_insert_label(VkDevice device) {
    const char *path = std::getenv("TEST_QUEUE_GUARD_TOP");
    void *library = path ? dlopen(path, RTLD_NOW | RTLD_NOLOAD) : nullptr;
    if (!library) return nullptr;
    const auto negotiate = reinterpret_cast<PFN_vkNegotiateLoaderLayerInterfaceVersion>(
        dlsym(library, "vkNegotiateLoaderLayerInterfaceVersion"));
    VkNegotiateLayerInterface version{};
    version.sType = LAYER_NEGOTIATE_INTERFACE_STRUCT;
    version.loaderLayerInterfaceVersion = 2;
    if (!negotiate || negotiate(&version) != VK_SUCCESS || !version.pfnGetDeviceProcAddr) return nullptr;
    return reinterpret_cast<PFN_vkQueueInsertDebugUtilsLabelEXT>(
        version.pfnGetDeviceProcAddr(device, "vkQueueInsertDebugUtilsLabelEXT"));
}

VKAPI_ATTR VkResult VKAPI_CALL QueuePresentKHR(VkQueue queue, const VkPresentInfoKHR *info) {
    Device device;
    {
        std::lock_guard lock(g_mutex);
        device = g_devices[test_layer::key(queue)];
    }
    if (g_presents.fetch_add(1) != guarded_present()) return device.present(queue, info);
    const PFN_vkQueueInsertDebugUtilsLabelEXT insert_label = splitvk_insert_label(device.handle);
    if (!insert_label) {
        std::fprintf(stderr, "queue guard: splitvk's vkQueueInsertDebugUtilsLabelEXT is not found\n");
        return device.present(queue, info);
    }
    g_holding = true;
    {
        std::lock_guard lock(g_mutex);
        g_label_thread = std::thread([insert_label, queue] {
            VkDebugUtilsLabelEXT label{};
            label.sType = VK_STRUCTURE_TYPE_DEBUG_UTILS_LABEL_EXT;
            label.pLabelName = kLabelName;
            insert_label(queue, &label);
        });
    }
    // Long enough for the label thread to get here on a loaded machine had nothing stopped it.
    std::this_thread::sleep_for(300ms);
    const VkResult result = device.present(queue, info);
    g_holding = false;
    return result;
}

VKAPI_ATTR void VKAPI_CALL QueueInsertDebugUtilsLabelEXT(VkQueue, const VkDebugUtilsLabelEXT *label) {
    if (!label || !label->pLabelName || std::strcmp(label->pLabelName, kLabelName) != 0) return;
    std::fprintf(stderr, g_holding ? "queue guard: the label overlapped the present\n"
                                   : "queue guard: the label waited for the present\n");
}

} // namespace
} // namespace splitvk::queue_guard_layer

namespace splitvk::test_layer {

// The label is answered whatever the driver has: it ends in this layer.
PFN_vkVoidFunction lifetime_entry_point(const char *name) {
    if (!std::strcmp(name, "vkQueueInsertDebugUtilsLabelEXT"))
        return reinterpret_cast<PFN_vkVoidFunction>(queue_guard_layer::QueueInsertDebugUtilsLabelEXT);
    return nullptr;
}

PFN_vkVoidFunction device_entry_point(const char *name) {
    if (!std::strcmp(name, "vkQueuePresentKHR"))
        return reinterpret_cast<PFN_vkVoidFunction>(queue_guard_layer::QueuePresentKHR);
    return nullptr;
}

void device_created(VkPhysicalDevice, VkDevice device, PFN_vkGetDeviceProcAddr next,
                    const VkDeviceCreateInfo &) {
    using namespace queue_guard_layer;
    const Device d{device, reinterpret_cast<PFN_vkQueuePresentKHR>(next(device, "vkQueuePresentKHR"))};
    std::lock_guard lock(g_mutex);
    g_devices[key(device)] = d;
}

void device_destroying(VkDevice device) {
    using namespace queue_guard_layer;
    std::thread label_thread;
    {
        std::lock_guard lock(g_mutex);
        g_devices.erase(key(device));
        label_thread = std::move(g_label_thread);
    }
    if (label_thread.joinable()) label_thread.join();
}

} // namespace splitvk::test_layer
