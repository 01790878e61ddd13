#pragma once

// VkSwapchainKHR state the layer keeps while a session exists (swapchain.cpp): what
// SwapchainImages carried, and what verification reads back.

#include "device.h"
#include "frame_deadline.h"

#include <vector>

namespace splitvk {

struct SwapchainState {
    DeviceState *device = nullptr;
    VkSwapchainKHR handle = VK_NULL_HANDLE;
    VkExtent2D extent{};
    VkFormat format = VK_FORMAT_UNDEFINED;
    VkImageUsageFlags usage = 0;
    uint32_t array_layers = 1;
    bool transfer_src = false; // the layer could add TRANSFER_SRC (verification reads it back)
    // The images have the usage composition needs (Compositor::kSwapchainUsage, added by the layer
    // when the application did not ask for it) and a format the compositor handles. The split
    // rewrite must leave a swapchain that is not composable unsplit: nothing could upsample it.
    bool composable = false;
    // The layout the application presents in, and the compositor leaves the image in:
    // SHARED_PRESENT_KHR for the shared present modes, PRESENT_SRC_KHR otherwise.
    VkImageLayout present_layout = VK_IMAGE_LAYOUT_PRESENT_SRC_KHR;
    // An OpenXR runtime's swapchain (runtime_swapchain.h): its images are the application's own
    // vkCreateImage, a frame ends at xrReleaseSwapchainImage rather than vkQueuePresentKHR, and no
    // semaphore hands the image on (the runtime's barrier follows on the queue). present_layout is
    // then COLOR_ATTACHMENT_OPTIMAL, the layout OpenXR releases colour images in.
    bool runtime = false;
    std::vector<VkImage> images;
    // How many images may be acquired and not yet handed to the driver's present at once: the
    // image count less the surface's minImageCount (present.cpp keeps acquires within it).
    uint32_t acquire_allowance = 0;
    // An OpenXR runtime's swapchain: what its recent composites cost, which each frame's display-time
    // deadline must leave for the next (present.cpp). Mutable on the const state the frame carries;
    // only xrReleaseSwapchainImage reaches it, which OpenXR synchronises per swapchain.
    mutable deadline::CompositeCost composite_cost;
};

// nullptr when the swapchain was created without a session.
SwapchainState *find_swapchain(const DeviceState &device, VkSwapchainKHR swapchain);

// An OpenXR runtime's swapchain (docs/architecture.md §9, xr_layer.cpp): images the runtime created with
// vkCreateImage on the application's device, which the application renders each eye into.
struct RuntimeSwapchain {
    VkExtent2D extent{};
    VkFormat format = VK_FORMAT_UNDEFINED;
    VkImageUsageFlags usage = 0; // what the images were created with, the layer's bits included
    uint32_t array_layers = 1;
    std::vector<VkImage> images;
};
// Makes the runtime's swapchain a swapchain of the split under `key` (a value no VkSwapchainKHR of
// the device has: the XrSwapchain's), and tells the agent to adopt its images. Returns the state,
// or nullptr when the device has no session (nothing to split). A swapchain that cannot be
// composited (usage, format; a layered one's format must blit) is registered not composable, with one line
// saying why: its frames are replicated but not split.
SwapchainState *register_runtime_swapchain(DeviceState &device, VkSwapchainKHR key,
                                           const RuntimeSwapchain &swapchain);
// xrDestroySwapchain, before the runtime destroys the images.
void unregister_runtime_swapchain(DeviceState &device, VkSwapchainKHR key);

} // namespace splitvk
