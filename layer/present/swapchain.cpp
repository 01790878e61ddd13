// VkSwapchainKHR: the agent has no surface, so a swapchain becomes offscreen images there
// (docs/architecture.md §3). After vkCreateSwapchainKHR the layer sends SwapchainImages (its images' ids,
// extent, format, usage, layers); vkDestroySwapchainKHR sends SwapchainDestroyed.
//
// Usage the layer adds (docs/architecture.md §4), only while a session captures, and only bits the surface
// supports: Compositor::kSwapchainUsage (TRANSFER_SRC, TRANSFER_DST, COLOR_ATTACHMENT) so the
// compositor can upsample the periphery and write the fovea tiles, and TRANSFER_SRC with
// SPLITVK_VERIFY=full to read presented images back. If the driver refuses the swapchain with
// them, the layer retries with less (verification's bit alone, then the application's usage)
// and marks the swapchain not composable. The application never sees the added bits: the state
// and the agent get its own usage, and no query returns a swapchain's usage. (What can leak: a
// driver may pick a slower image layout or drop compression for the wider usage.)
//
// Images the layer adds: split mode's present thread (present.cpp) holds up to
// SPLITVK_PRESENT_DEPTH images the application has presented but the driver has not been given yet.
// So that the application can still acquire as many images as it asked for meanwhile, a composable
// swapchain gets that many more images where the surface allows (the application sees them in
// vkGetSwapchainImagesKHR). Where it does not, vkAcquireNextImageKHR waits for the present thread
// rather than acquire more images than the surface allows at once.
#include "present/swapchain.h"

#include "capture/capture.h"
#include "capture/screen_space.h"
#include "capture/session.h"
#include "capture/split.h"
#include "core/image.h"
#include "core/instance.h"
#include "core/object_map.h"
#include "layer_entry_points.h"
#include "log.h"
#include "present/compositor.h"
#include "present/present.h"
#include "vk_format_info.h"

#include <algorithm>

namespace splitvk {

namespace {

// Whether the compositor could work on this swapchain if the layer adds kSwapchainUsage.
bool can_compose(DeviceState &dev, const VkSwapchainCreateInfoKHR &info, VkSurfaceCapabilitiesKHR &caps,
                 std::string *why) {
    if (info.imageArrayLayers != 1) {
        *why = std::to_string(info.imageArrayLayers) + " array layers";
        return false;
    }
    if (info.flags & VK_SWAPCHAIN_CREATE_PROTECTED_BIT_KHR) {
        *why = "protected images";
        return false;
    }
    if (!dev.instance->dispatch.GetPhysicalDeviceSurfaceCapabilitiesKHR ||
        dev.instance->dispatch.GetPhysicalDeviceSurfaceCapabilitiesKHR(dev.physical_device, info.surface,
                                                                       &caps) != VK_SUCCESS) {
        *why = "the surface's capabilities are unknown";
        return false;
    }
    if ((caps.supportedUsageFlags & Compositor::kSwapchainUsage) != Compositor::kSwapchainUsage) {
        *why = "the surface does not support transfer and colour attachment usage";
        return false;
    }
    return Compositor::supports(dev, info.imageFormat, why);
}

void send_swapchain_images(DeviceState &dev, const SwapchainState &state) {
    protocol::SwapchainImages message;
    message.device_id = dev.session->device_id();
    message.swapchain_id = codec::handle_value(state.handle);
    message.width = state.extent.width;
    message.height = state.extent.height;
    message.format = static_cast<uint32_t>(state.format);
    message.usage = state.usage;
    message.array_layers = state.array_layers;
    for (VkImage image : state.images)
        message.image_ids.push_back(codec::handle_value(image));
    if (state.runtime) {
        message.source = protocol::SwapchainImages::Source::Runtime;
        message.presented_layout = static_cast<uint32_t>(state.present_layout);
    }
    dev.session->send_metadata_logged(protocol::MessageType::SwapchainImages, protocol::encode(message),
                                      message.swapchain_id);
}

void send_swapchain_destroyed(DeviceState &dev, VkSwapchainKHR swapchain) {
    const uint64_t id = codec::handle_value(swapchain);
    dev.session->forget(std::span(&id, 1)); // its SwapchainImages leaves the live-state log
    if (capturing(dev)) {
        protocol::SwapchainDestroyed message{dev.session->device_id(), id};
        dev.session->send_metadata(protocol::MessageType::SwapchainDestroyed, protocol::encode(message));
    }
}

// Before the driver (or the OpenXR runtime) destroys the swapchain's images: the agent is told, and
// the images stop being split targets (image.h).
void forget_swapchain(DeviceState &dev, VkSwapchainKHR swapchain) {
    const std::unique_ptr<SwapchainState> state = dev.swapchains->swapchains.remove(swapchain);
    if (!state) return;
    forget_swapchain_images(dev, swapchain, static_cast<uint32_t>(state->images.size()),
                            state->images.data());
    send_swapchain_destroyed(dev, swapchain);
}

} // namespace

SwapchainState *register_runtime_swapchain(DeviceState &dev, VkSwapchainKHR key,
                                           const RuntimeSwapchain &info) {
    if (!dev.session || info.images.empty()) return nullptr;
    auto state = std::make_unique<SwapchainState>();
    state->device = &dev;
    state->handle = key;
    state->extent = info.extent;
    state->format = info.format;
    state->usage = info.usage;
    state->array_layers = info.array_layers;
    state->transfer_src = (info.usage & VK_IMAGE_USAGE_TRANSFER_SRC_BIT) != 0;
    state->runtime = true;
    state->present_layout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
    state->images = info.images;
    std::string why;
    // Several layers are eyes of one image drawn with multiview (split::runtime_eye_foveae): each
    // layer gets its periphery upsampled and its eye's fovea, as a swapchain per eye does.
    // A depth (or stencil) swapchain is no eye picture: it is never split, and that is no news.
    const bool depth = (info.usage & VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT) != 0 ||
                       format_info(info.format).depth || format_info(info.format).stencil;
    if (depth)
        why = "a depth swapchain";
    else if ((info.usage & Compositor::kSwapchainUsage) != Compositor::kSwapchainUsage)
        why = std::string("its ") + format_name(info.format) +
              " images lack transfer and colour attachment usage";
    else
        Compositor::supports(dev, info.format, &why, info.array_layers);
    state->composable = why.empty();
    // A colour swapchain that cannot be split is what a user asks about when their eyes are not
    // split: its line says why, at the level a user sees.
    if (!state->composable && depth)
        SPLITVK_INFO("OpenXR swapchain %ux%u (%s) is a depth swapchain: it is not split", info.extent.width,
                     info.extent.height, format_name(info.format));
    else if (!state->composable)
        SPLITVK_WARN("OpenXR swapchain %ux%u is not split: %s", info.extent.width, info.extent.height,
                     why.c_str());
    note_swapchain_images(dev, key, static_cast<uint32_t>(state->images.size()), state->images.data());
    if (state->composable) note_screen_extent(dev, info.extent);
    SwapchainState *registered = dev.swapchains->swapchains.insert(key, std::move(state));
    // Logged like a window's, so that an agent joining later adopts the images too.
    send_swapchain_images(dev, *registered);
    return registered;
}

void unregister_runtime_swapchain(DeviceState &dev, VkSwapchainKHR key) {
    if (!dev.session) return;
    drain_presents(dev);
    release_compositor(dev, key);
    release_present_resources(dev, key); // verification's readbacks
    forget_swapchain(dev, key);
}

namespace entry {

VKAPI_ATTR VkResult VKAPI_CALL CreateSwapchainKHR(VkDevice device,
                                                  const VkSwapchainCreateInfoKHR *pCreateInfo,
                                                  const VkAllocationCallbacks *pAllocator,
                                                  VkSwapchainKHR *pSwapchain) {
    DeviceState &dev = device_state(device);
    if (!capturing(dev)) return dev.dispatch.CreateSwapchainKHR(device, pCreateInfo, pAllocator, pSwapchain);
    // The retired swapchain's frames still in the present thread go to it before it is retired.
    if (pCreateInfo->oldSwapchain) drain_presents(dev);
    // SPLITVK_SPLIT=auto: a switch between splitting and passing through that a present asked for takes
    // effect here, where the application makes its swapchain, and then its targets, again.
    dev.session->swapchain_recreated();

    const VkImageUsageFlags app_usage = pCreateInfo->imageUsage;
    std::string why;
    VkSurfaceCapabilitiesKHR caps{};
    // Frames passed through are shown as drawn: the swapchain is the application's own, without the
    // compositor's usage or images, so that a frame passed through costs what a native one does (the
    // wider usage made the window system's copy of every image to the X server 4x slower on
    // lavapipe). A switch back to the split recreates it composable.
    const bool passing_through = dev.session->passing_through();
    const bool compose = !passing_through && can_compose(dev, *pCreateInfo, caps, &why);
    const VkImageUsageFlags verify_usage = dev.session->verify() ? VK_IMAGE_USAGE_TRANSFER_SRC_BIT : 0;
    // Most usage first; each attempt that adds nothing new over the next one is skipped.
    const VkImageUsageFlags attempts[] = {
        app_usage | verify_usage | (compose ? Compositor::kSwapchainUsage : 0),
        app_usage | verify_usage,
        app_usage,
    };
    VkSwapchainCreateInfoKHR info = *pCreateInfo;
    const uint32_t depth = dev.session->settings().present_depth;
    if (compose && depth > 0 && !dev.session->settings().verify) {
        const uint32_t most = caps.maxImageCount ? caps.maxImageCount : UINT32_MAX;
        info.minImageCount = std::min(most, std::max(info.minImageCount, caps.minImageCount) + depth);
    }
    VkResult result = VK_ERROR_INITIALIZATION_FAILED;
    for (size_t i = 0; i < std::size(attempts); ++i) {
        if (i > 0 && attempts[i] == attempts[i - 1]) continue;
        info.imageUsage = attempts[i];
        result = dev.dispatch.CreateSwapchainKHR(device, &info, pAllocator, pSwapchain);
        if (result == VK_SUCCESS) break;
        // A failed vkCreateSwapchainKHR retires oldSwapchain all the same, and a retired
        // swapchain must not be passed again: the retry replaces nothing.
        info.oldSwapchain = VK_NULL_HANDLE;
        if (i + 1 < std::size(attempts) && attempts[i + 1] != attempts[i])
            SPLITVK_INFO("swapchain: the driver refused usage 0x%x (%d); retrying with less",
                         unsigned(attempts[i]), int(result));
    }
    if (result != VK_SUCCESS) return result;
    const bool composable =
        compose && (info.imageUsage & Compositor::kSwapchainUsage) == Compositor::kSwapchainUsage;
    if (!composable && !passing_through)
        SPLITVK_INFO("swapchain %ux%u is not composable (%s): it will not be split",
                     pCreateInfo->imageExtent.width, pCreateInfo->imageExtent.height,
                     compose ? "the driver refused the usage" : why.c_str());

    auto state = std::make_unique<SwapchainState>();
    state->device = &dev;
    state->handle = *pSwapchain;
    state->extent = pCreateInfo->imageExtent;
    state->format = pCreateInfo->imageFormat;
    state->usage = app_usage; // the application's: what the agent's images need
    state->array_layers = pCreateInfo->imageArrayLayers;
    state->transfer_src = (info.imageUsage & VK_IMAGE_USAGE_TRANSFER_SRC_BIT) != 0;
    state->composable = composable;
    state->present_layout = pCreateInfo->presentMode == VK_PRESENT_MODE_SHARED_DEMAND_REFRESH_KHR ||
                                    pCreateInfo->presentMode == VK_PRESENT_MODE_SHARED_CONTINUOUS_REFRESH_KHR
                                ? VK_IMAGE_LAYOUT_SHARED_PRESENT_KHR
                                : VK_IMAGE_LAYOUT_PRESENT_SRC_KHR;
    uint32_t count = 0;
    if (dev.dispatch.GetSwapchainImagesKHR(device, *pSwapchain, &count, nullptr) == VK_SUCCESS) {
        state->images.resize(count);
        if (dev.dispatch.GetSwapchainImagesKHR(device, *pSwapchain, &count, state->images.data()) !=
            VK_SUCCESS)
            count = 0;
        state->images.resize(count);
    }
    // Unknown capabilities (compose false): the application's own count is all that is known.
    const uint32_t surface_min = compose ? caps.minImageCount : pCreateInfo->minImageCount;
    state->acquire_allowance = count > surface_min ? count - surface_min : 0;

    if (composable) note_screen_extent(dev, pCreateInfo->imageExtent);
    send_swapchain_images(dev, *dev.swapchains->swapchains.insert(*pSwapchain, std::move(state)));
    return result;
}

VKAPI_ATTR void VKAPI_CALL DestroySwapchainKHR(VkDevice device, VkSwapchainKHR swapchain,
                                               const VkAllocationCallbacks *pAllocator) {
    DeviceState &dev = device_state(device);
    if (dev.session && swapchain != VK_NULL_HANDLE) {
        drain_presents(dev); // its frames still in the present thread
        release_present_resources(dev, swapchain);
        release_compositor(dev, swapchain);
        forget_swapchain(dev, swapchain);
    }
    dev.dispatch.DestroySwapchainKHR(device, swapchain, pAllocator);
}

} // namespace entry
} // namespace splitvk
