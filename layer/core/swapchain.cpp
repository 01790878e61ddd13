// VkSwapchainKHR: the swapchains the layer keeps state for, on their device.

#include "core/swapchain.h"

namespace splitvk {

std::shared_ptr<SwapchainTable> make_swapchain_table() {
    return std::make_shared<SwapchainTable>();
}

SwapchainState *find_swapchain(const DeviceState &device, VkSwapchainKHR swapchain) {
    return device.swapchains->swapchains.find(swapchain);
}

RuntimeEyes runtime_eyes(const SwapchainState &swapchain) {
    std::lock_guard lock(swapchain.eyes_mutex);
    return {swapchain.eyes, swapchain.eyes_version};
}

void set_runtime_eyes(SwapchainState &swapchain, std::vector<split::RuntimeEye> eyes) {
    std::lock_guard lock(swapchain.eyes_mutex);
    swapchain.eyes = std::move(eyes);
    ++swapchain.eyes_version;
}

} // namespace splitvk
