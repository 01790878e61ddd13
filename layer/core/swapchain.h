#pragma once

// VkSwapchainKHR state the layer keeps while a session exists (core/swapchain.cpp): what
// SwapchainImages carried, and what verification reads back.

#include "core/device.h"
#include "core/object_map.h"
#include "model/frame_deadline.h"
#include "split_geometry.h"

#include <cstdint>
#include <mutex>
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
    // An OpenXR runtime's swapchain: the eyes its projection views placed in its images
    // (split::note_runtime_eye, set by the OpenXR layer at xrEndFrame), which the swapped split cuts
    // the passes into its images by at record time. `eyes_version` counts their changes, so that a
    // frame's release can tell whether its passes were cut by the eyes its foveae are placed with.
    mutable std::mutex eyes_mutex;
    std::vector<split::RuntimeEye> eyes;
    uint64_t eyes_version = 0;
};

// An OpenXR runtime's swapchain's eyes and their version, as one consistent pair.
struct RuntimeEyes {
    std::vector<split::RuntimeEye> eyes;
    uint64_t version = 0;
};
RuntimeEyes runtime_eyes(const SwapchainState &swapchain);
// Called with the swapchain's new eyes whenever they change.
void set_runtime_eyes(SwapchainState &swapchain, std::vector<split::RuntimeEye> eyes);

// nullptr when the swapchain was created without a session.
SwapchainState *find_swapchain(const DeviceState &device, VkSwapchainKHR swapchain);

// A device's swapchains that the layer keeps state for (DeviceState::swapchains): vkCreateSwapchainKHR
// and an OpenXR runtime's swapchain add, their destroy removes (present/swapchain.cpp); everything
// else finds one with find_swapchain.
struct SwapchainTable {
    ObjectMap<VkSwapchainKHR, SwapchainState> swapchains;
};

} // namespace splitvk
