// The loader interface: version negotiation and the layer's vkGet*ProcAddr.

#include "vk/layer.h"

#include "core/device.h"
#include "core/instance.h"
#include "core/layer_settings.h"
#include "layer_entry_points.h"
#include "vk/entry_boundary.h"

#include <vulkan/vk_layer.h>

#include <atomic>
#include <cstring>

namespace splitvk {
namespace {

// Returns our entry point only where the next layer has the command too: an extension the
// driver lacks, or one the application did not enable, must stay NULL for the application.
PFN_vkVoidFunction intercept_if_available(const EntryPoint *entry, PFN_vkVoidFunction next) {
    return next ? entry->function : nullptr;
}

} // namespace

namespace entry {

VKAPI_ATTR PFN_vkVoidFunction VKAPI_CALL GetDeviceProcAddr(VkDevice device, const char *pName) {
    if (!pName) return nullptr;
    if (std::strcmp(pName, "vkGetDeviceProcAddr") == 0) {
        return reinterpret_cast<PFN_vkVoidFunction>(boundary::GetDeviceProcAddr);
    }
    const EntryPoint *entry = find_entry_point(pName);
    const bool device_level = entry && entry->level == EntryLevel::Device;
    // As in GetInstanceProcAddr: without a device we know, answer for what we intercept.
    DeviceState *state = device == VK_NULL_HANDLE ? nullptr : find_device(dispatch_key(device));
    // SPLITVK_UNSUPPORTED=passthrough: the next layer's commands, so that splitvk sees nothing of
    // this device but its end.
    if (!state && device != VK_NULL_HANDLE) {
        if (const PFN_vkGetDeviceProcAddr next = passthrough_device_proc_addr(dispatch_key(device))) {
            if (std::strcmp(pName, "vkDestroyDevice") == 0)
                return reinterpret_cast<PFN_vkVoidFunction>(boundary::DestroyDevice);
            return next(device, pName);
        }
    }
    if (!state) return device_level ? entry->function : nullptr;
    const PFN_vkVoidFunction next = state->next_get_device_proc_addr(device, pName);
    return device_level ? intercept_if_available(entry, next) : next;
}

VKAPI_ATTR PFN_vkVoidFunction VKAPI_CALL GetInstanceProcAddr(VkInstance instance, const char *pName) {
    if (!pName) return nullptr;
    if (std::strcmp(pName, "vkGetInstanceProcAddr") == 0) {
        return reinterpret_cast<PFN_vkVoidFunction>(boundary::GetInstanceProcAddr);
    }
    if (std::strcmp(pName, "vkGetDeviceProcAddr") == 0) {
        return reinterpret_cast<PFN_vkVoidFunction>(boundary::GetDeviceProcAddr);
    }
    const EntryPoint *entry = find_entry_point(pName);
    if (entry && entry->level == EntryLevel::Global) return entry->function;
    // Layers above us (MangoHud, the Mesa overlay, the old sample layer code) resolve the next
    // layer's vkCreateDevice and friends with a null instance while building their chains; a
    // NULL answer makes their vkCreateDevice fail. Without an instance we know, there is no next
    // table to ask, so every command we intercept is answered with our entry point.
    InstanceState *state = instance == VK_NULL_HANDLE ? nullptr : find_instance(dispatch_key(instance));
    if (!state) return entry ? entry->function : nullptr;
    const PFN_vkVoidFunction next = state->next_get_instance_proc_addr(instance, pName);
    return entry ? intercept_if_available(entry, next) : next;
}

} // namespace entry
} // namespace splitvk

namespace splitvk {
namespace {

VkResult negotiate(VkNegotiateLayerInterface *pVersionStruct) {
    if (!pVersionStruct || pVersionStruct->sType != LAYER_NEGOTIATE_INTERFACE_STRUCT) {
        return VK_ERROR_INITIALIZATION_FAILED;
    }
    // SPLITVK_DISABLE=1 wins over every way of enabling the layer. The loader checks it for the
    // implicit manifest; for VK_INSTANCE_LAYERS it does not, so the layer declines here.
    if (splitvk::disabled_by_environment()) return VK_ERROR_INITIALIZATION_FAILED;
    // Interface version 2: the loader takes our vkGet*ProcAddr from this struct and answers the
    // global enumeration commands from the manifest.
    if (pVersionStruct->loaderLayerInterfaceVersion < 2) return VK_ERROR_INITIALIZATION_FAILED;
    pVersionStruct->loaderLayerInterfaceVersion = 2;
    // Every function the library hands out is an entry point inside its exception boundary
    // (entry_boundary.h): these two, and all they answer with.
    pVersionStruct->pfnGetInstanceProcAddr = splitvk::boundary::GetInstanceProcAddr;
    pVersionStruct->pfnGetDeviceProcAddr = splitvk::boundary::GetDeviceProcAddr;
    // vk_layerGetPhysicalDeviceProcAddr is only asked for physical-device commands the loader does
    // not know; every one splitvk intercepts is known and reaches it through GetInstanceProcAddr.
    // Without one, the loader hands the layers above us the next layer's.
    pVersionStruct->pfnGetPhysicalDeviceProcAddr = nullptr;
    return VK_SUCCESS;
}

} // namespace
} // namespace splitvk

extern "C" {

// The library's only exported symbol (see layer.map). Interface version 2 hands the loader our
// vkGet*ProcAddr through the negotiation struct, so they are not exported: a loader that fails
// to negotiate then finds no fallback and leaves the layer out, which is how SPLITVK_DISABLE=1
// takes effect even when VK_INSTANCE_LAYERS names the layer. Not exporting them also means no
// call inside this library can bind to the loader's own vkGetInstanceProcAddr.
// Its exception boundary is written out here: it is in no table.
[[gnu::visibility("default")]] VKAPI_ATTR VkResult VKAPI_CALL
vkNegotiateLoaderLayerInterfaceVersion(VkNegotiateLayerInterface *pVersionStruct) {
    try {
        return splitvk::negotiate(pVersionStruct);
    } catch (...) {
        static std::atomic<bool> said{false};
        return splitvk::vk_result_of_throw(splitvk::entry_threw(
            "vkNegotiateLoaderLayerInterfaceVersion", nullptr, splitvk::EntryReturns::VkResult, false, said));
    }
}

} // extern "C"
