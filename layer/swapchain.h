#pragma once

// VkSwapchainKHR state the layer keeps while a session exists (swapchain.cpp): what
// SwapchainImages carried, and what verification reads back.

#include "device.h"

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
    std::vector<VkImage> images;
    // How many images may be acquired and not yet handed to the driver's present at once: the
    // image count less the surface's minImageCount (present.cpp keeps acquires within it).
    uint32_t acquire_allowance = 0;
};

// nullptr when the swapchain was created without a session.
SwapchainState *find_swapchain(VkSwapchainKHR swapchain);

} // namespace splitvk

namespace splitvk {
// present.cpp: frees the readback resources verification keeps for a swapchain's images, and what
// the asynchronous present knows of the swapchain (after drain_presents()).
void release_present_resources(DeviceState &device, VkSwapchainKHR swapchain);
} // namespace splitvk
