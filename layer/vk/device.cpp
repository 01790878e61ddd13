// VkDevice: the device chain (vkCreateDevice, vkDestroyDevice).

#include "vk/device.h"

#include "capture/command_buffer.h"
#include "capture/memory.h"
#include "capture/resource.h"
#include "capture/session.h"
#include "core/chain_info.h"
#include "core/gpu_timing.h"
#include "core/instance.h"
#include "core/layer_settings.h"
#include "layer_entry_points.h"
#include "log.h"
#include "present/compositor.h"
#include "present/present.h"
#include "present/verification.h"
#include "vk/queue.h"
#include "vk_codec.h"

#include <vulkan/vk_layer.h>

#include <cstdlib>
#include <mutex>
#include <string>

// glibc's own registration, which std::atexit in a shared library expands to (libc_nonshared's
// stub): the handler is tied to this library's handle, so that dlclose runs it. Called directly
// because ThreadSanitizer's atexit interceptor drops the handle and would run the handler at exit
// after the loader has unloaded this code.
extern "C" int __cxa_atexit(void (*handler)(void *), void *arg, void *dso_handle);
extern "C" void *__dso_handle;

namespace splitvk {

// Defined here, with what a DeviceState's destructor needs (its Session).
ObjectMap<DispatchKey, DeviceState> registry::g_devices;
using registry::g_devices;

namespace {

// The device extensions of a vkCreateDevice that splitvk does not forward (codegen/allowlist.py),
// joined with ", "; empty when it forwards them all.
std::string withheld_extensions(const VkDeviceCreateInfo &info) {
    std::string names;
    for (uint32_t i = 0; i < info.enabledExtensionCount; ++i) {
        const char *name = info.ppEnabledExtensionNames[i];
        if (!name || device_extension_forwarded(name)) continue;
        if (!names.empty()) names += ", ";
        names += name;
    }
    return names;
}

// What vkDestroyDevice says and stops, for the devices an application never destroys (hello_xr and
// many engines exit with theirs alive): at exit, or when the loader unloads this library, each
// such device has its present thread drain and stop (a joinable thread left in its map would end
// the process in std::terminate), its session close (the agent hears a normal end), and its split
// and verify lines printed, and SPLITVK_STATS keeps every row it wrote. Nothing is destroyed in
// the driver: the process is ending, and what the application left alive is the driver's to drop.
// glibc runs a library's atexit handlers when it is unloaded as well, so this never outlives the code.
void finish_devices_at_exit() {
    for (std::unique_ptr<DeviceState> &state : g_devices.take_all()) {
        if (state->passthrough || !state->session) continue;
        stop_presents(*state);
        state->session->close();
        report_verify_summary(*state);
        report_split_summary(*state);
        // Its threads joined, its upload memory freed while the driver is still loaded (its own
        // exit handlers were registered first, so they run after this one).
        state->session.reset();
        // The rest is left to the process's end, as the application left the device.
        (void)state.release();
    }
}

void make_tables(DeviceState &state) {
    state.memory = make_memory_objects();
    state.queues = make_queue_table();
    state.command_buffers = make_command_buffer_table();
    state.images = make_image_table();
    state.resources = make_resource_table();
    state.render_passes = make_render_pass_table();
    state.render_pass_depth = make_render_pass_depth_table();
    state.descriptors = make_descriptor_table();
    state.descriptor_templates = make_descriptor_template_table();
    state.pipelines = make_pipeline_table();
    state.swapchains = make_swapchain_table();
    state.screen = make_screen_table();
    state.gpu_timing = make_gpu_timing_table();
    state.compositors = make_compositor_table();
    state.readbacks = make_verify_table();
    state.presents = make_present_table();
}

} // namespace

namespace entry {

VKAPI_ATTR VkResult VKAPI_CALL CreateDevice(VkPhysicalDevice physicalDevice,
                                            const VkDeviceCreateInfo *pCreateInfo,
                                            const VkAllocationCallbacks *pAllocator, VkDevice *pDevice) {
    InstanceState *instance = find_instance(dispatch_key(physicalDevice));
    auto *link = find_loader_info<VkLayerDeviceCreateInfo>(
        pCreateInfo->pNext, VK_STRUCTURE_TYPE_LOADER_DEVICE_CREATE_INFO, VK_LAYER_LINK_INFO);
    if (!instance || !link || !link->u.pLayerInfo) return VK_ERROR_INITIALIZATION_FAILED;

    const PFN_vkGetInstanceProcAddr next_gipa = link->u.pLayerInfo->pfnNextGetInstanceProcAddr;
    const PFN_vkGetDeviceProcAddr next_gdpa = link->u.pLayerInfo->pfnNextGetDeviceProcAddr;
    const auto next_create =
        reinterpret_cast<PFN_vkCreateDevice>(next_gipa(instance->handle, "vkCreateDevice"));
    if (!next_create) return VK_ERROR_INITIALIZATION_FAILED;

    // An extension splitvk does not forward: its commands and structures would reach the driver
    // and never the agent, which then replays something else. One line, whatever happens next
    // (the loader asks vkEnumerateDeviceExtensionProperties first, and splitvk lets it see the
    // driver's extensions there so that the request gets this far: instance.cpp).
    const std::string withheld = withheld_extensions(*pCreateInfo);
    const bool passthrough =
        !withheld.empty() && layer_settings().settings.unsupported == UnsupportedMode::Passthrough;
    if (!withheld.empty()) {
        const char *app =
            instance->application_name.empty() ? "(unnamed application)" : instance->application_name.c_str();
        if (!passthrough) {
            SPLITVK_WARN("'%s' enables device extensions splitvk does not forward: %s; vkCreateDevice fails "
                         "with VK_ERROR_EXTENSION_NOT_PRESENT. To run it unsplit, set "
                         "SPLITVK_UNSUPPORTED=passthrough, or SPLITVK_DISABLE=1 to keep splitvk out",
                         app, withheld.c_str());
            return VK_ERROR_EXTENSION_NOT_PRESENT;
        }
        SPLITVK_WARN("'%s' enables device extensions splitvk does not forward: %s; SPLITVK_UNSUPPORTED="
                     "passthrough: splitvk passes this device through to the driver, unsplit",
                     app, withheld.c_str());
    }

    link->u.pLayerInfo = link->u.pLayerInfo->pNext;
    const VkResult result = next_create(physicalDevice, pCreateInfo, pAllocator, pDevice);
    if (result != VK_SUCCESS) return result;

    if (passthrough) {
        // Nothing of splitvk's for this device but the next layer's vkDestroyDevice: no session,
        // no tables; vkGetDeviceProcAddr answers with the next layer's commands (layer.cpp).
        auto device = std::make_unique<DeviceState>();
        device->handle = *pDevice;
        device->passthrough = true;
        device->next_get_device_proc_addr = next_gdpa;
        device->dispatch.DestroyDevice =
            reinterpret_cast<PFN_vkDestroyDevice>(next_gdpa(*pDevice, "vkDestroyDevice"));
        g_devices.insert(dispatch_key(*pDevice), std::move(device));
        return VK_SUCCESS;
    }

    auto state = std::make_unique<DeviceState>();
    make_tables(*state);
    state->handle = *pDevice;
    state->physical_device = physicalDevice;
    state->instance = instance;
    state->next_get_device_proc_addr = next_gdpa;
    load_device_dispatch_table(state->dispatch, *pDevice, next_gdpa);
    if (const auto *info = find_loader_info<VkLayerDeviceCreateInfo>(
            pCreateInfo->pNext, VK_STRUCTURE_TYPE_LOADER_DEVICE_CREATE_INFO, VK_LOADER_DATA_CALLBACK))
        state->set_loader_data = info->u.pfnSetDeviceLoaderData;
    instance->dispatch.GetPhysicalDeviceMemoryProperties(physicalDevice, &state->memory_properties);
    state->session = Session::open(*state, pCreateInfo, instance->application_name);
    g_devices.insert(dispatch_key(*pDevice), std::move(state));
    static std::once_flag exit_hook;
    std::call_once(exit_hook,
                   [] { __cxa_atexit([](void *) { finish_devices_at_exit(); }, nullptr, &__dso_handle); });
    SPLITVK_DEBUG("device created");
    return VK_SUCCESS;
}

VKAPI_ATTR void VKAPI_CALL DestroyDevice(VkDevice device, const VkAllocationCallbacks *pAllocator) {
    if (device == VK_NULL_HANDLE) return;
    const auto state = g_devices.remove(dispatch_key(device));
    if (!state) return;
    if (state->passthrough) {
        state->dispatch.DestroyDevice(device, pAllocator);
        return;
    }
    log_live_state(*state, "at vkDestroyDevice");
    if (state->session) {
        // What holds driver objects goes while the driver still has the device; the rest of the
        // state (every table) goes with `state`, after the driver's vkDestroyDevice.
        stop_presents(*state);       // its frames use the compositors and the queues
        release_compositors(*state); // of swapchains the application left alive
        release_gpu_timing(*state);
        if (state->session->live())
            state->session->record(LiveChange::Unchanged, 0,
                                   [&](codec::Encoder &e) { encode_vkDestroyDevice(e, device, nullptr); });
        state->session->close();
        report_verify_summary(*state);
        report_split_summary(*state);
    }
    state->dispatch.DestroyDevice(device, pAllocator);
}

} // namespace entry
} // namespace splitvk
