#pragma once

// SPLITVK_VERIFY=full (present.cpp's frames, DESIGN §2): the layer reads each presented image back
// with a copy of its own and compares it pixel by pixel with the agent's VerifyFrame of the same
// frame. Split mode is off then (split.h, split_enabled()): the split makes the two differ on purpose.

#include "device.h"

#include <vulkan/vulkan.h>

#include <cstdint>
#include <mutex>
#include <optional>

namespace splitvk {

struct SwapchainState;
struct VerifyReadback;

// The layer's copy of one presented image, submitted and not yet compared.
struct PendingVerify {
    uint64_t frame = 0;
    const SwapchainState *swapchain = nullptr;
    uint32_t image_index = 0;
    VerifyReadback *readback = nullptr;
    // vkQueuePresentKHR's copy keeps the readbacks locked until it is compared, so that nothing
    // releases or reuses its slot meanwhile; an OpenXR image's does not (end_runtime_frame).
    std::unique_lock<std::mutex> lock;
};

// vkQueuePresentKHR, the queue's lock held: the layer's copy of the first swapchain's image, submitted
// on `queue` after `present`'s wait semaphores, which `present` then waits on the copy instead of.
// None where the image cannot be read back (the present is left as it was).
std::optional<PendingVerify> read_back_presented_image(DeviceState &device, VkQueue queue,
                                                       VkPresentInfoKHR &present, uint64_t frame);
// An OpenXR eye image: the layer's copy of every layer of it, submitted on `queue` after the
// application's rendering and before the runtime's release barrier (the queue orders them: a runtime's
// image has no semaphores). None where it cannot be read back.
std::optional<PendingVerify> read_back_runtime_image(DeviceState &device, VkQueue queue,
                                                     const SwapchainState &swapchain, uint32_t image_index,
                                                     uint64_t frame);
// After the present (the queue's lock released): waits (bounded) for the layer's copy and the agent's
// VerifyFrame of the same frame, compares them and counts the result in the session.
void compare_verified_frame(DeviceState &device, const PendingVerify &pending);

// Swapchain destruction: frees the readback resources of the swapchain's images.
void release_verify_readbacks(DeviceState &device, VkSwapchainKHR swapchain);

// The one summary line at vkDestroyDevice.
void report_verify_summary(DeviceState &device);

} // namespace splitvk
