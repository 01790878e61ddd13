#pragma once

// VkSwapchainKHR's entry points and an OpenXR runtime's swapchains (present/swapchain.cpp): they make and
// drop the SwapchainState (core/swapchain.h) and tell the agent.

#include "core/swapchain.h"

#include <vector>

namespace splitvk {

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
