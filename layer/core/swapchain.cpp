// VkSwapchainKHR: the swapchains the layer keeps state for.

#include "core/swapchain.h"

namespace splitvk {

ObjectMap<VkSwapchainKHR, SwapchainState> registry::g_swapchains;
using registry::g_swapchains;

SwapchainState *find_swapchain(VkSwapchainKHR swapchain) {
    return g_swapchains.find(swapchain);
}

} // namespace splitvk
