#pragma once

// SPLITVK_VERIFY=full (present.cpp's frames, docs/architecture.md §2): the layer reads each presented image
// back with a copy of its own and compares it pixel by pixel with the agent's VerifyFrame of the same frame
// (frame_difference.h).
//
// The paper's split is off then (agent_link.cpp, base_hello): its scaled periphery makes every
// pixel differ on purpose, so both sides render whole frames and every pixel must match. The
// swapped split (SPLITVK_CLIENT_RENDERS=fovea) stays on: its agent renders the whole frame at full
// size anyway, so its VerifyFrame is the native picture. The layer reads back what it presents,
// the client's foveae over the agent's upsampled periphery (after Compositor::composite_periphery):
// the foveae must match bit for bit, and the whole image is measured by PSNR, the periphery's
// distance from native, per frame in SPLITVK_STATS and over the run at exit.

#include "core/device.h"

#include <vulkan/vulkan.h>

#include <cstdint>
#include <mutex>
#include <optional>
#include <vector>

namespace splitvk {

struct SwapchainState;
struct VerifyReadback;

// The layer's copy of one presented image, submitted and not yet compared.
struct PendingVerify {
    uint64_t frame = 0;
    const SwapchainState *swapchain = nullptr;
    uint32_t image_index = 0;
    VerifyReadback *readback = nullptr;
    // vkQueuePresentKHR's copy keeps its readback locked until it is compared, so that nothing
    // releases or reuses it meanwhile; an OpenXR image's does not (end_runtime_frame).
    std::unique_lock<std::mutex> lock;
    // The swapped split, a frame cut to its foveae: what it shows around them is the agent's
    // periphery, so only `foveae` (rects of layer 0) must match, and the frame's PSNR is measured.
    // `late`: that periphery was an earlier frame's (the frame's own did not come in time), or none
    // before the first came. Unset: every pixel must match.
    bool periphery = false;
    std::vector<VkRect2D> foveae;
    bool late = false;
};

// Whether read_back_presented_image() can read `present`'s first image back on `queue`: the
// swapped split decides the FramePresent's kPresentVerify by this before its composite, and reads
// the image back after it.
bool presented_image_verifiable(const DeviceState &device, VkQueue queue, const VkPresentInfoKHR &present);
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
// VerifyFrame of the same frame, compares them and counts the result in the session. Returns the
// frame's PSNR when it showed the agent's periphery (`pending.periphery`) and both images came.
std::optional<double> compare_verified_frame(DeviceState &device, const PendingVerify &pending);

// Swapchain destruction: frees the readback resources of the swapchain's images.
void release_verify_readbacks(DeviceState &device, VkSwapchainKHR swapchain);

// The summary at vkDestroyDevice: `verify: F frames, M mismatching pixels`, or in the swapped split
// `verify: F frames, foveae M mismatching pixels, periphery PSNR X dB (lowest Y dB)`, each on a line of
// its own for scripts, and the details after it.
void report_verify_summary(DeviceState &device);

} // namespace splitvk
