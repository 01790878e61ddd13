#pragma once

#include "core/dispatch.h"
#include "core/object_map.h"

#include <vulkan/vk_layer.h>

#include <memory>
#include <mutex>
#include <span>

namespace splitvk {

struct InstanceState;
struct MemoryObjects;
class Session;

// The tables of a device's objects, each defined by the file that keeps it, which alone sees
// inside (and says what its lock guards), and made by that file's make_*(). A std::shared_ptr,
// whose deleter is fixed where the table is made, so that a DeviceState is destroyed wherever it
// is without the tables' types.
struct CommandBufferTable;      // command_buffer.cpp: command buffers and their pools
struct CompositorTable;         // compositor.cpp: the compositor of each swapchain
struct DescriptorTable;         // descriptor_set.cpp: set layouts, sets and their pools
struct DescriptorTemplateTable; // descriptor_template.cpp: update templates
struct GpuTimingTable;          // gpu_timing.cpp: the split pass timestamps' query pool
struct ImageTable;              // image.cpp: images (image.h)
struct PipelineTable;           // pipeline.cpp: static viewport state made dynamic
struct PresentTable;            // present.cpp: the present thread, each swapchain's presents, redirects
struct QueueTable;              // queue.cpp: queues and their locks
struct RenderPassTable;         // render_pass.cpp: image views and framebuffers
struct RenderPassDepthTable;    // fovea_mask.cpp: render passes whose depth can carry the mask
struct ResourceTable;           // resource.cpp: buffers and render passes' final layouts
struct ScreenTable;             // screen_space.cpp: the newest screen extent
struct SwapchainTable;          // swapchain.cpp: swapchains (swapchain.h)
struct VerifyTable;             // verification.cpp: readbacks of presented images

// memory.cpp: the device's allocations and mapped ranges.
std::shared_ptr<MemoryObjects> make_memory_objects();
std::shared_ptr<CommandBufferTable> make_command_buffer_table();
std::shared_ptr<CompositorTable> make_compositor_table();
std::shared_ptr<DescriptorTable> make_descriptor_table();
std::shared_ptr<DescriptorTemplateTable> make_descriptor_template_table();
std::shared_ptr<GpuTimingTable> make_gpu_timing_table();
std::shared_ptr<ImageTable> make_image_table();
std::shared_ptr<PipelineTable> make_pipeline_table();
std::shared_ptr<PresentTable> make_present_table();
std::shared_ptr<QueueTable> make_queue_table();
std::shared_ptr<RenderPassTable> make_render_pass_table();
std::shared_ptr<RenderPassDepthTable> make_render_pass_depth_table();
std::shared_ptr<ResourceTable> make_resource_table();
std::shared_ptr<ScreenTable> make_screen_table();
std::shared_ptr<SwapchainTable> make_swapchain_table();
std::shared_ptr<VerifyTable> make_verify_table();

struct DeviceState {
    VkDevice handle = VK_NULL_HANDLE;
    VkPhysicalDevice physical_device = VK_NULL_HANDLE;
    InstanceState *instance = nullptr;
    DeviceDispatchTable dispatch;
    PFN_vkGetDeviceProcAddr next_get_device_proc_addr = nullptr;
    VkPhysicalDeviceMemoryProperties memory_properties{};
    // The replication session (session.h); null when no agent answered at vkCreateDevice. Set
    // before the device is published and kept until vkDestroyDevice, so reading it needs no lock.
    std::unique_ptr<Session> session;
    // Its VkDeviceMemory objects and their shadows (memory.cpp), under a lock of their own; made
    // with the device, before it is published.
    std::shared_ptr<MemoryObjects> memory;
    // The loader's vkSetDeviceLoaderData, for dispatchable objects the layer creates itself.
    PFN_vkSetDeviceLoaderData set_loader_data = nullptr;
    // SPLITVK_UNSUPPORTED=passthrough: a device created with an extension splitvk does not forward
    // keeps only its handle, next_get_device_proc_addr and dispatch.DestroyDevice: no session and
    // no tables (find_device never returns it).
    bool passthrough = false;

    // Its objects' tables, made with the device before it is published (every device with a
    // session has them all; a device without one makes them too, and they stay empty), and freed
    // with it: vkDestroyDevice first releases what the driver must destroy (the present thread,
    // compositors, timestamps), then the state goes. Declared last, so that they go before
    // `session` and `memory`.
    std::shared_ptr<QueueTable> queues;
    std::shared_ptr<CommandBufferTable> command_buffers;
    std::shared_ptr<ImageTable> images;
    std::shared_ptr<ResourceTable> resources;
    std::shared_ptr<RenderPassTable> render_passes;
    std::shared_ptr<RenderPassDepthTable> render_pass_depth;
    std::shared_ptr<DescriptorTable> descriptors;
    std::shared_ptr<DescriptorTemplateTable> descriptor_templates;
    std::shared_ptr<PipelineTable> pipelines;
    std::shared_ptr<SwapchainTable> swapchains;
    std::shared_ptr<ScreenTable> screen;
    std::shared_ptr<GpuTimingTable> gpu_timing;
    std::shared_ptr<CompositorTable> compositors;
    std::shared_ptr<VerifyTable> readbacks;
    std::shared_ptr<PresentTable> presents;
};

// nullptr when the handle was not created through this layer, or is a passthrough device.
DeviceState *find_device(DispatchKey key);
// SPLITVK_UNSUPPORTED=passthrough: the next layer's vkGetDeviceProcAddr of a device splitvk stays
// out of, so that vkGetDeviceProcAddr hands the application the next layer's commands
// (vkDestroyDevice excepted, which forgets the device). nullptr for every other device.
PFN_vkGetDeviceProcAddr passthrough_device_proc_addr(DispatchKey key);

// The state of the device a handle belongs to (aborts, like device_dispatch, on an unknown handle).
DeviceState &device_state(VkDevice device);
DeviceState &device_state(VkQueue queue);
DeviceState &device_state(VkCommandBuffer command_buffer);

// The devices created through this layer, passthrough ones included (DeviceState::passthrough), by
// dispatch key: filled at vkCreateDevice and emptied at vkDestroyDevice (vk/device.cpp); everything
// else finds a device with find_device / device_state. In a namespace of its own, so that no file's
// own names clash with it.
namespace registry {
extern ObjectMap<DispatchKey, DeviceState> g_devices;
} // namespace registry

} // namespace splitvk
