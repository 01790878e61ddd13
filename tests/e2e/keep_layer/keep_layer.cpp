// VK_LAYER_SPLITVK_test_keep: a test-only layer that, with TEST_KEEP_ALIVE=1, passes neither
// vkDestroyDevice nor vkDestroyInstance down, so that the layers below see an application that exits
// with its device and instance alive, as many do (engines that leave the end to the process, apps
// that exit() from a callback). The tests put it above splitvk (closest to the application), so that
// an unmodified application's process ends with splitvk's device state, its present thread and its
// session still there. Without TEST_KEEP_ALIVE it passes everything down.
//
// It prints "keep alive: <command> not passed down" on stderr at each call it keeps. Built into the
// build tree only and never installed.
#include "../test_layer/test_layer.h"

#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace splitvk::test_layer {
namespace {

bool keeping() {
    static const bool keep = [] {
        const char *value = std::getenv("TEST_KEEP_ALIVE");
        return value && std::strcmp(value, "1") == 0;
    }();
    return keep;
}

void kept(const char *command) {
    std::fprintf(stderr, "keep alive: %s not passed down\n", command);
    std::fflush(stderr);
}

VKAPI_ATTR void VKAPI_CALL DestroyDevice(VkDevice, const VkAllocationCallbacks *) {
    kept("vkDestroyDevice");
}

VKAPI_ATTR void VKAPI_CALL DestroyInstance(VkInstance, const VkAllocationCallbacks *) {
    kept("vkDestroyInstance");
}

} // namespace

PFN_vkVoidFunction lifetime_entry_point(const char *name) {
    if (!keeping()) return nullptr;
    if (!std::strcmp(name, "vkDestroyDevice")) return reinterpret_cast<PFN_vkVoidFunction>(DestroyDevice);
    if (!std::strcmp(name, "vkDestroyInstance")) return reinterpret_cast<PFN_vkVoidFunction>(DestroyInstance);
    return nullptr;
}

PFN_vkVoidFunction device_entry_point(const char *) {
    return nullptr;
}

void device_created(VkPhysicalDevice, VkDevice, PFN_vkGetDeviceProcAddr, const VkDeviceCreateInfo &) {}

void device_destroying(VkDevice) {}

} // namespace splitvk::test_layer
