// The split's re-emitted state and the per-image record of what split passes drew (split.h).

#include "capture/split.h"

#include "capture/screen_space.h"
#include "capture/session.h"
#include "core/image.h"
#include "core/layer_settings.h"
#include "core/swapchain.h"
#include "core/vk_util.h"
#include "log.h"
#include "split_geometry.h"

#include <mutex>
#include <optional>
#include <utility>

namespace splitvk {

bool split_enabled(const DeviceState &device) {
    return device.session != nullptr && device.session->splitting();
}

bool split_recording(const DeviceState &device) {
    return split_enabled(device) && !device.session->passing_through();
}

bool split_cutting(const DeviceState &device) {
    if (!split_enabled(device) || !device.session->cutting()) return false;
    if (!scaled_targets_created(device)) return true;
    static std::once_flag logged;
    std::call_once(logged, [] {
        SPLITVK_INFO("swapped split: screen-space targets were created scaled before the agent chose "
                     "SPLITVK_CLIENT_RENDERS=fovea; this device renders whole frames (not cut)");
    });
    return false;
}

bool split_swapped(const DeviceState &device) {
    return split_enabled(device) && device.session->client_renders() == ClientRenders::Fovea;
}

bool swapchain_composable(const SwapchainState &swapchain) {
    return swapchain.composable;
}

const Settings &split_settings() {
    return layer_settings().settings;
}

SplitFrame take_split_frame(DeviceState &dev, VkImage image, EyeMode eyes, const split::Gaze &gaze,
                            const split::FrameFoveaSize &size) {
    SplitFrame frame;
    std::optional<split::DrawnImage> drawn;
    {
        LockedImages images(dev);
        ImageState *state = images.find(image);
        if (!state || !state->drawn) return frame;
        drawn = std::exchange(state->drawn, std::nullopt);
    }
    frame.split = true;
    frame.cut = drawn->cut;
    frame.cut_eyes = drawn->cut_eyes;
    frame.periphery = split::scaled_extent(drawn->extent, split_settings().scale);
    // The whole frame's coverage decides its foveae (split::frame_foveae), as the agent's does.
    // Never smaller than a fovea its passes left unshaded (fovea_mask.h): a mask recorded before the
    // fovea shrank would otherwise show as a hole around the tiles.
    frame.fovea_size = size.set() ? split::larger(size, drawn->masked) : size;
    frame.foveae = split::in_layer_zero(
        drawn->foveae(eyes, split::frame_fovea_size(split_settings().fovea, frame.fovea_size), gaze));
    return frame;
}

namespace {

template <class SubmitInfo>
std::vector<uint64_t> images_drawn(const DeviceState &device, uint32_t count, const SubmitInfo *submits) {
    std::vector<uint64_t> out;
    if (!split_enabled(device)) return out;
    for_each_submitted(count, submits, [&](VkCommandBuffer command_buffer) {
        if (const split::CommandTracker *tracker = split_tracker(command_buffer))
            for (const split::DrawnImage &drawn : tracker->drawn())
                out.push_back(drawn.image);
    });
    return out;
}

} // namespace

std::vector<uint64_t> swapchain_images_drawn(const DeviceState &device, uint32_t count,
                                             const VkSubmitInfo *submits) {
    return images_drawn(device, count, submits);
}

std::vector<uint64_t> swapchain_images_drawn(const DeviceState &device, uint32_t count,
                                             const VkSubmitInfo2 *submits) {
    return images_drawn(device, count, submits);
}

// What the submitted split passes drew goes into each swapchain image's ImageState (image.h), to be
// taken at its present.

void note_split_drawn(LockedImages &images, const split::CommandTracker &tracker) {
    for (const split::DrawnImage &drawn : tracker.drawn()) {
        ImageState *image = images.find(codec::to_handle<VkImage>(drawn.image));
        // An image whose swapchain is gone (an OpenXR runtime may keep its images for the next
        // one) takes no record: nothing would take it before it joins a new swapchain's frames.
        if (!image || !image->swapchain) continue;
        if (!image->drawn) {
            image->drawn = drawn;
            continue;
        }
        image->drawn->extent = drawn.extent;
        image->drawn->coverage |= drawn.coverage;
        image->drawn->masked = split::larger(image->drawn->masked, drawn.masked);
        image->drawn->cut = image->drawn->cut || drawn.cut;
        image->drawn->cut_eyes = split::merge_cut_eyes(image->drawn->cut_eyes, drawn.cut_eyes);
    }
}

VkRect2D cut_scissor(const split::CommandTracker &tracker, size_t index, const VkRect2D &scissor,
                     const Settings &settings) {
    if (tracker.guard()) return split::intersect(scissor, *tracker.guard());
    if (!tracker.swapchain_pass()) return scissor;
    // An OpenXR eye image: its foveae sit at its views' directions, as the agent's scissors place
    // them in the paper's split (server-agent/fovea_shading.cpp); without viewport `index` the eye is
    // unknown, and the scissor is narrowed once the viewport is set.
    if (const auto *areas = tracker.runtime_areas())
        return split::intersect(scissor, split::runtime_scissor(*areas, tracker.viewport(index)));
    // The configured fovea size: SPLITVK_FOVEA=auto is off in fovea mode, and the agent's scissors are
    // recorded for that size too.
    // Grown by the seam's feather (SPLITVK_SEAM), which the compositor blends across.
    return split::narrow_to_foveae(scissor, tracker.viewport(index), tracker.extent(), settings.eyes,
                                   settings.fovea, settings.gaze != GazeMode::Fixed, settings.seam.feather);
}

void emit_viewports(DeviceState &device, VkCommandBuffer command_buffer,
                    const split::CommandTracker &tracker) {
    const double scale = split_settings().scale;
    // A cut pass keeps the app's viewports: only its scissors are cut.
    const auto out = [&](const VkViewport &v) {
        return tracker.in_split() && !tracker.cut() ? split::scaled_pass_viewport(v, tracker.extent(), scale)
                                                    : v;
    };
    std::vector<VkViewport> values;
    if (tracker.static_viewports()) {
        for (const VkViewport &v : tracker.pipeline()->viewports)
            values.push_back(out(v));
        device.dispatch.CmdSetViewport(command_buffer, 0, static_cast<uint32_t>(values.size()),
                                       values.data());
        return;
    }
    const auto &dynamic = tracker.dynamic_viewports();
    if (dynamic.empty()) return;
    for (const VkViewport &v : dynamic.values)
        values.push_back(out(v));
    if (dynamic.with_count) {
        const auto set = device.dispatch.CmdSetViewportWithCount ? device.dispatch.CmdSetViewportWithCount
                                                                 : device.dispatch.CmdSetViewportWithCountEXT;
        if (set) set(command_buffer, static_cast<uint32_t>(values.size()), values.data());
        return;
    }
    split::for_each_valid_run(dynamic, values, [&](uint32_t first, uint32_t count, const VkViewport *v) {
        device.dispatch.CmdSetViewport(command_buffer, first, count, v);
    });
}

void emit_scissors(DeviceState &device, VkCommandBuffer command_buffer,
                   const split::CommandTracker &tracker) {
    const Settings &settings = split_settings();
    const auto out = [&](size_t i, const VkRect2D &r) {
        if (!tracker.in_split()) return r;
        if (!tracker.cut()) return split::scaled_pass_rect(r, tracker.extent(), settings.scale);
        return cut_scissor(tracker, i, r, settings);
    };
    std::vector<VkRect2D> values;
    if (tracker.static_scissors()) {
        for (size_t i = 0; i < tracker.pipeline()->scissors.size(); ++i)
            values.push_back(out(i, tracker.pipeline()->scissors[i]));
        device.dispatch.CmdSetScissor(command_buffer, 0, static_cast<uint32_t>(values.size()), values.data());
        return;
    }
    const auto &dynamic = tracker.dynamic_scissors();
    if (dynamic.empty()) return;
    for (size_t i = 0; i < dynamic.values.size(); ++i)
        values.push_back(out(i, dynamic.values[i]));
    if (dynamic.with_count) {
        const auto set = device.dispatch.CmdSetScissorWithCount ? device.dispatch.CmdSetScissorWithCount
                                                                : device.dispatch.CmdSetScissorWithCountEXT;
        if (set) set(command_buffer, static_cast<uint32_t>(values.size()), values.data());
        return;
    }
    split::for_each_valid_run(dynamic, values, [&](uint32_t first, uint32_t count, const VkRect2D *r) {
        device.dispatch.CmdSetScissor(command_buffer, first, count, r);
    });
}

} // namespace splitvk
