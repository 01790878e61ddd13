#pragma once

// The client half of the image-space split (docs/architecture.md §4). A split pass is a render pass
// instance (or dynamic rendering) that draws into a swapchain image of a composable swapchain;
// inside it the layer passes down a rewritten call (render area, viewports, scissors and clear
// rects scaled into the top-left ceil(s·W) x ceil(s·H)) while the capture stream keeps the app's
// original call, which the agent replays at full resolution and narrows to the foveae.
//
// Files: render_pass.cpp (image views, framebuffers, swapchain images, pass begin/end, clears),
// pipeline.cpp (static viewport/scissor made dynamic, and the dynamic state), split.cpp
// (what is re-emitted, and the per-image record the present path takes).

#include "capture/capture.h"
#include "capture/render_pass.h" // the split passes
#include "split_tracker.h"

#include <vector>

namespace splitvk {

class LockedImages;

struct SwapchainState;

struct SplitFrame {
    bool split = false;
    VkExtent2D periphery{};
    std::vector<split::LayerFovea> foveae; // layer 0 but in a layered OpenXR eye image
    split::FrameFoveaSize fovea_size;      // the size they take (SPLITVK_FOVEA=auto); unset: SPLITVK_FOVEA
    // SPLITVK_CLIENT_RENDERS=fovea: some pass of the frame was cut to the foveae, so its periphery
    // is the agent's to fill. False for a frame drawn wholly uncut (recorded before the agent joined
    // or after it was lost): it is presented as it is.
    bool cut = false;
    // An OpenXR eye image: the version of the eyes its cut passes were cut by (DrawnImage::cut_eyes).
    int64_t cut_eyes = split::DrawnImage::kNoRuntimeCut;
};

// What the submits since the last call rendered into swapchain image `image`: whether a split pass
// drew into it, the scaled periphery extent, and the fovea rects (full-resolution image coordinates,
// sorted by x then y: the agent's take_drawn_foveae order) that split::frame_foveae gives for what
// the split passes drew, with `eyes` (SPLITVK_EYES for a window; for an OpenXR runtime's image the
// caller replaces them with its eyes' foveae, as the agent does), each at `gaze` and of `size` (the
// frame's), or larger where its passes left a larger fovea unshaded (SplitFrame::fovea_size: what
// its FramePresent must name). Clears the image's record.
SplitFrame take_split_frame(DeviceState &device, VkImage image, EyeMode eyes, const split::Gaze &gaze = {},
                            const split::FrameFoveaSize &size = {});

// Whether the layer rewrites split passes on this device: it has a session whose agent accepted the
// split (Session::splitting(); under SPLITVK_VERIFY only the swapped split, whose agent renders
// whole frames to compare with: the paper's split makes every pixel differ on purpose).
bool split_enabled(const DeviceState &device);
// Whether passes recorded and targets created now are split: split_enabled, and the session not
// passing its frames through (SPLITVK_SPLIT=auto where the split does not pay: Session::
// passing_through()). Submits and presents go by split_enabled: a command buffer recorded split
// before the switch still draws scaled, and its frame is still composited.
bool split_recording(const DeviceState &device);
// Whether passes recorded now are cut to the foveae rather than scaled (SPLITVK_CLIENT_RENDERS=fovea):
// split_enabled, the session cutting (Session::cutting(): fovea mode with a live agent),
// and no screen-space target of the device created scaled (one made before the agent chose the mode
// keeps its scaled size, which a cut frame cannot use: the device then stays uncut, said once).
bool split_cutting(const DeviceState &device);
// The session is in the swapped split (SPLITVK_CLIENT_RENDERS=fovea), whether or not it cuts now:
// when it does not (no agent to render the periphery), passes into swapchain images run whole, as
// the application recorded them, and their frames are shown as drawn; never scaled.
bool split_swapped(const DeviceState &device);
// Whether a swapchain's images are composited (the present path can join periphery and foveae).
bool swapchain_composable(const SwapchainState &swapchain);

const Settings &split_settings();

// Sets the viewports / scissors in effect (the bound pipeline's static ones or the app's dynamic
// ones), scaled inside a split pass and unscaled outside it.
void emit_viewports(DeviceState &device, VkCommandBuffer command_buffer,
                    const split::CommandTracker &tracker);
void emit_scissors(DeviceState &device, VkCommandBuffer command_buffer, const split::CommandTracker &tracker);
// The scissor at `index` of a cut pass (tracker.cut()) as it goes down: within the guard of a guarded
// pass, narrowed to the foveae grown by SPLITVK_SEAM's feather (split::narrow_to_foveae, the agent's
// rule, with split::seam_rect) in a pass into a swapchain image, as recorded otherwise.
VkRect2D cut_scissor(const split::CommandTracker &tracker, size_t index, const VkRect2D &scissor,
                     const Settings &settings);

// queue.cpp, before the submit: the swapchain images (handle values) split passes in these
// submits draw into; empty unless split_enabled().
std::vector<uint64_t> swapchain_images_drawn(const DeviceState &device, uint32_t count,
                                             const VkSubmitInfo *submits);
std::vector<uint64_t> swapchain_images_drawn(const DeviceState &device, uint32_t count,
                                             const VkSubmitInfo2 *submits);
// At submit (command_buffer.h: note_submitted): unions what a submitted command buffer's split
// passes drew into its images' records.
void note_split_drawn(LockedImages &images, const split::CommandTracker &tracker);

} // namespace splitvk
