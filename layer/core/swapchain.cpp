// VkSwapchainKHR: the swapchains the layer keeps state for, on their device.

#include "core/swapchain.h"

namespace splitvk {

std::shared_ptr<SwapchainTable> make_swapchain_table() {
    return std::make_shared<SwapchainTable>();
}

SwapchainState *find_swapchain(const DeviceState &device, VkSwapchainKHR swapchain) {
    return device.swapchains->swapchains.find(swapchain);
}

} // namespace splitvk
