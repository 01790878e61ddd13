// The split's re-emitted state and the per-image record of what split passes drew (split.h).

#include "split.h"

#include "image.h"
#include "layer_settings.h"
#include "split_geometry.h"
#include "swapchain.h"
#include "vk_util.h"

#include <optional>
#include <utility>

namespace splitvk {

bool split_enabled(const DeviceState &device) {
    return device.session != nullptr && device.session->splitting();
}

bool swapchain_composable(const SwapchainState &swapchain) {
    return swapchain.composable;
}

const Settings &split_settings() {
    return layer_settings().settings;
}

SplitFrame take_split_frame(DeviceState &, VkImage image, EyeMode eyes, const split::Gaze &gaze,
                            const split::FrameFoveaSize &size) {
    SplitFrame frame;
    std::optional<split::DrawnImage> drawn;
    {
        LockedImages images;
        ImageState *state = images.find(image);
        if (!state || !state->drawn) return frame;
        drawn = std::exchange(state->drawn, std::nullopt);
    }
    frame.split = true;
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
    }
}

void emit_viewports(DeviceState &device, VkCommandBuffer command_buffer,
                    const split::CommandTracker &tracker) {
    const double scale = split_settings().scale;
    const auto out = [&](const VkViewport &v) {
        return tracker.in_split() ? split::scale_viewport(v, scale) : v;
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
    const double scale = split_settings().scale;
    const VkExtent2D scaled = split::scaled_extent(tracker.extent(), scale);
    const auto out = [&](const VkRect2D &r) {
        return tracker.in_split() ? split::scale_rect(r, scale, scaled) : r;
    };
    std::vector<VkRect2D> values;
    if (tracker.static_scissors()) {
        for (const VkRect2D &r : tracker.pipeline()->scissors)
            values.push_back(out(r));
        device.dispatch.CmdSetScissor(command_buffer, 0, static_cast<uint32_t>(values.size()), values.data());
        return;
    }
    const auto &dynamic = tracker.dynamic_scissors();
    if (dynamic.empty()) return;
    for (const VkRect2D &r : dynamic.values)
        values.push_back(out(r));
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
