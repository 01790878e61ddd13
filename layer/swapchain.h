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
    std::vector<VkImage> images;
};

// nullptr when the swapchain was created without a session.
SwapchainState *find_swapchain(VkSwapchainKHR swapchain);

} // namespace splitvk

namespace splitvk {
// present.cpp: frees the readback resources verification keeps for a swapchain's images.
void release_present_resources(DeviceState &device, VkSwapchainKHR swapchain);
} // namespace splitvk
