// VkSwapchainKHR: the agent has no surface, so a swapchain becomes offscreen images there
// (DESIGN §3). After vkCreateSwapchainKHR the layer sends SwapchainImages (its images' ids, extent,
// format, usage, layers); vkDestroySwapchainKHR sends SwapchainDestroyed. With SPLITVK_VERIFY=full
// the layer adds TRANSFER_SRC to the usage so that it can read presented images back (and retries
// without it if the driver refuses).

#include "swapchain.h"

#include "capture.h"
#include "layer_entry_points.h"
#include "object_map.h"
#include "session.h"

namespace splitvk {
namespace {

ObjectMap<VkSwapchainKHR, SwapchainState> g_swapchains;

} // namespace

SwapchainState *find_swapchain(VkSwapchainKHR swapchain) {
    return g_swapchains.find(swapchain);
}

namespace entry {

VKAPI_ATTR VkResult VKAPI_CALL CreateSwapchainKHR(VkDevice device,
                                                  const VkSwapchainCreateInfoKHR *pCreateInfo,
                                                  const VkAllocationCallbacks *pAllocator,
                                                  VkSwapchainKHR *pSwapchain) {
    DeviceState &dev = device_state(device);
    if (!capturing(dev)) return dev.dispatch.CreateSwapchainKHR(device, pCreateInfo, pAllocator, pSwapchain);

    bool transfer_src = (pCreateInfo->imageUsage & VK_IMAGE_USAGE_TRANSFER_SRC_BIT) != 0;
    VkResult result = VK_ERROR_INITIALIZATION_FAILED;
    if (dev.session->verify() && !transfer_src) {
        VkSwapchainCreateInfoKHR info = *pCreateInfo;
        info.imageUsage |= VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
        result = dev.dispatch.CreateSwapchainKHR(device, &info, pAllocator, pSwapchain);
        transfer_src = result == VK_SUCCESS;
    }
    if (result != VK_SUCCESS)
        result = dev.dispatch.CreateSwapchainKHR(device, pCreateInfo, pAllocator, pSwapchain);
    if (result != VK_SUCCESS) return result;

    auto state = std::make_unique<SwapchainState>();
    state->device = &dev;
    state->handle = *pSwapchain;
    state->extent = pCreateInfo->imageExtent;
    state->format = pCreateInfo->imageFormat;
    state->usage = pCreateInfo->imageUsage;
    state->array_layers = pCreateInfo->imageArrayLayers;
    state->transfer_src = transfer_src;
    uint32_t count = 0;
    if (dev.dispatch.GetSwapchainImagesKHR(device, *pSwapchain, &count, nullptr) == VK_SUCCESS) {
        state->images.resize(count);
        if (dev.dispatch.GetSwapchainImagesKHR(device, *pSwapchain, &count, state->images.data()) !=
            VK_SUCCESS)
            count = 0;
        state->images.resize(count);
    }

    protocol::SwapchainImages message;
    message.device_id = dev.session->device_id();
    message.swapchain_id = codec::handle_value(*pSwapchain);
    message.width = state->extent.width;
    message.height = state->extent.height;
    message.format = static_cast<uint32_t>(state->format);
    message.usage = state->usage;
    message.array_layers = state->array_layers;
    for (VkImage image : state->images)
        message.image_ids.push_back(codec::handle_value(image));
    g_swapchains.insert(*pSwapchain, std::move(state));
    dev.session->send_metadata_logged(protocol::MessageType::SwapchainImages, protocol::encode(message),
                                      message.swapchain_id);
    return result;
}

VKAPI_ATTR void VKAPI_CALL DestroySwapchainKHR(VkDevice device, VkSwapchainKHR swapchain,
                                               const VkAllocationCallbacks *pAllocator) {
    DeviceState &dev = device_state(device);
    if (dev.session && swapchain != VK_NULL_HANDLE) {
        release_present_resources(dev, swapchain);
        if (g_swapchains.remove(swapchain)) {
            const uint64_t id = codec::handle_value(swapchain);
            dev.session->forget(std::span(&id, 1)); // its SwapchainImages leaves the live-state log
            if (capturing(dev)) {
                protocol::SwapchainDestroyed message{dev.session->device_id(), id};
                dev.session->send_metadata(protocol::MessageType::SwapchainDestroyed,
                                           protocol::encode(message));
            }
        }
    }
    dev.dispatch.DestroySwapchainKHR(device, swapchain, pAllocator);
}

} // namespace entry
} // namespace splitvk
