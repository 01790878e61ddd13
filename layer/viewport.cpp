// Dynamic viewport and scissor state (split.h). The app's values are kept unscaled in the command
// buffer's tracker, since dynamic state outlives the render pass instance it was set in: a value
// set before a split pass must reach the driver scaled inside it and unscaled after it, so it is
// re-emitted at each split pass begin and end (render_pass.cpp). While a pipeline whose static
// state the layer made dynamic is bound, the app's values are only kept: the pipeline's own values
// must stay in effect until a pipeline with dynamic state is bound (pipeline.cpp).

#include "layer_entry_points.h"
#include "split.h"
#include "split_geometry.h"

#include <vector>

namespace splitvk {
namespace {

template <class Down>
void set_viewports(DeviceState &dev, VkCommandBuffer cb, uint32_t first, uint32_t count,
                   const VkViewport *viewports, bool with_count, Down &&down) {
    split::CommandTracker *tracker = split_tracker(cb);
    if (!tracker) return down(viewports);
    tracker->set_viewports(first, count, viewports, with_count);
    if (tracker->static_viewports()) return;
    if (tracker->secondary()) tracker->note_foveae();
    if (!tracker->in_split()) return down(viewports);
    tracker->note_foveae();
    // A cut pass keeps the app's viewports, but the scissors cut by them change with them.
    if (tracker->cut()) {
        down(viewports);
        return emit_scissors(dev, cb, *tracker);
    }
    const split::AxisScale scale = split::axis_scale(tracker->extent(), split_settings().scale);
    std::vector<VkViewport> scaled(viewports, viewports + count);
    for (VkViewport &v : scaled)
        v = split::scale_viewport(v, scale);
    down(scaled.data());
}

template <class Down>
void set_scissors(VkCommandBuffer cb, uint32_t first, uint32_t count, const VkRect2D *scissors,
                  bool with_count, Down &&down) {
    split::CommandTracker *tracker = split_tracker(cb);
    if (!tracker) return down(scissors);
    tracker->set_scissors(first, count, scissors, with_count);
    if (tracker->static_scissors()) return;
    if (!tracker->in_split()) return down(scissors);
    if (tracker->cut()) {
        std::vector<VkRect2D> cut(scissors, scissors + count);
        for (uint32_t i = 0; i < count; ++i)
            cut[i] = cut_scissor(*tracker, with_count ? i : first + i, scissors[i], split_settings());
        return down(cut.data());
    }
    const VkExtent2D extent = split::scaled_extent(tracker->extent(), split_settings().scale);
    const split::AxisScale scale = split::axis_scale(tracker->extent(), extent);
    std::vector<VkRect2D> scaled(scissors, scissors + count);
    for (VkRect2D &r : scaled)
        r = split::scale_rect(r, scale, extent);
    down(scaled.data());
}

} // namespace

namespace rewrite {

void CmdSetViewport(DeviceState &dev, PFN_vkCmdSetViewport down, VkCommandBuffer commandBuffer,
                    uint32_t firstViewport, uint32_t viewportCount, const VkViewport *pViewports) {
    set_viewports(dev, commandBuffer, firstViewport, viewportCount, pViewports, false,
                  [&](const VkViewport *v) { down(commandBuffer, firstViewport, viewportCount, v); });
}

void CmdSetViewportWithCount(DeviceState &dev, PFN_vkCmdSetViewportWithCount down,
                             VkCommandBuffer commandBuffer, uint32_t viewportCount,
                             const VkViewport *pViewports) {
    set_viewports(dev, commandBuffer, 0, viewportCount, pViewports, true,
                  [&](const VkViewport *v) { down(commandBuffer, viewportCount, v); });
}

void CmdSetScissor(DeviceState &, PFN_vkCmdSetScissor down, VkCommandBuffer commandBuffer,
                   uint32_t firstScissor, uint32_t scissorCount, const VkRect2D *pScissors) {
    set_scissors(commandBuffer, firstScissor, scissorCount, pScissors, false,
                 [&](const VkRect2D *r) { down(commandBuffer, firstScissor, scissorCount, r); });
}

void CmdSetScissorWithCount(DeviceState &, PFN_vkCmdSetScissorWithCount down, VkCommandBuffer commandBuffer,
                            uint32_t scissorCount, const VkRect2D *pScissors) {
    set_scissors(commandBuffer, 0, scissorCount, pScissors, true,
                 [&](const VkRect2D *r) { down(commandBuffer, scissorCount, r); });
}

} // namespace rewrite
} // namespace splitvk
