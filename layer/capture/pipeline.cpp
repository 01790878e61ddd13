// VkPipeline: static viewport/scissor state made dynamic (docs/architecture.md §4). Inside a split pass the
// layer must draw with scaled viewports and scissors, which a pipeline's static state would
// override; so pipelines are created down the chain with VIEWPORT/SCISSOR added to their dynamic
// state (the capture keeps the app's create info: the agent decides for itself), the static
// values are kept here, and binding such a pipeline sets them (scaled inside a split pass).

#include "capture/pipeline.h"

#include "capture/split.h"
#include "core/object_map.h"
#include "layer_entry_points.h"
#include "split_geometry.h"

#include <vector>

namespace splitvk {
namespace {

struct PipelineState {
    std::shared_ptr<const split::StaticViewportState> viewport_state;
};

} // namespace

struct PipelineTable {
    ObjectMap<VkPipeline, PipelineState> pipelines;
};

std::shared_ptr<PipelineTable> make_pipeline_table() {
    return std::make_shared<PipelineTable>();
}

std::shared_ptr<const split::StaticViewportState> pipeline_static_state(const DeviceState &device,
                                                                        VkPipeline pipeline) {
    const PipelineState *state = device.pipelines->pipelines.find(pipeline);
    return state ? state->viewport_state : nullptr;
}

namespace observe {

// Forgotten before the driver may hand the value to a pipeline another thread creates (as every
// destroy: codegen/emit_layer.py).
void DestroyPipeline(DeviceState &dev, VkDevice, VkPipeline pipeline, const VkAllocationCallbacks *) {
    if (pipeline != VK_NULL_HANDLE) dev.pipelines->pipelines.remove(pipeline);
}

} // namespace observe

namespace rewrite {

VkResult CreateGraphicsPipelines(DeviceState &dev, PFN_vkCreateGraphicsPipelines down, VkDevice device,
                                 VkPipelineCache pipelineCache, uint32_t createInfoCount,
                                 const VkGraphicsPipelineCreateInfo *pCreateInfos,
                                 const VkAllocationCallbacks *pAllocator, VkPipeline *pPipelines) {
    std::vector<std::shared_ptr<split::StaticViewportState>> statics;
    std::vector<VkGraphicsPipelineCreateInfo> infos;
    std::vector<split::DynamicStateStorage> storage;
    if (split_enabled(dev)) {
        statics.resize(createInfoCount);
        infos.resize(createInfoCount);
        storage.resize(createInfoCount); // not resized again: infos point into it
        for (uint32_t i = 0; i < createInfoCount; ++i) {
            statics[i] = split::static_viewport_state(pCreateInfos[i]);
            const bool viewports = statics[i] && statics[i]->has_viewports;
            const bool scissors = statics[i] && statics[i]->has_scissors;
            split::add_dynamic_states(pCreateInfos[i], viewports, scissors, storage[i], infos[i]);
        }
    }
    const VkResult result = down(device, pipelineCache, createInfoCount,
                                 infos.empty() ? pCreateInfos : infos.data(), pAllocator, pPipelines);
    for (uint32_t i = 0; i < statics.size(); ++i)
        if (statics[i] && pPipelines[i] != VK_NULL_HANDLE) {
            auto state = std::make_unique<PipelineState>();
            state->viewport_state = std::move(statics[i]);
            dev.pipelines->pipelines.insert(pPipelines[i], std::move(state));
        }
    return result;
}

void CmdBindPipeline(DeviceState &dev, PFN_vkCmdBindPipeline down, VkCommandBuffer commandBuffer,
                     VkPipelineBindPoint pipelineBindPoint, VkPipeline pipeline) {
    down(commandBuffer, pipelineBindPoint, pipeline);
    if (pipelineBindPoint != VK_PIPELINE_BIND_POINT_GRAPHICS) return;
    split::CommandTracker *tracker = split_tracker(commandBuffer);
    if (!tracker) return;
    const bool had_viewports = tracker->static_viewports(), had_scissors = tracker->static_scissors();
    tracker->bind_pipeline(pipeline_static_state(dev, pipeline));
    // A pipeline the layer made dynamic needs its values set; leaving one, the app's dynamic
    // values (held back while it was bound) apply again.
    if (had_viewports || tracker->static_viewports()) emit_viewports(dev, commandBuffer, *tracker);
    // A cut pass's scissors follow its viewports (split.h: cut_scissor), as the agent's do.
    const bool viewports_changed = had_viewports || tracker->static_viewports();
    if (had_scissors || tracker->static_scissors() || (tracker->cut() && viewports_changed))
        emit_scissors(dev, commandBuffer, *tracker);
    if (had_viewports || tracker->static_viewports()) tracker->note_foveae();
}

} // namespace rewrite
} // namespace splitvk

// Dynamic viewport and scissor state (split.h). The app's values are kept unscaled in the command
// buffer's tracker, since dynamic state outlives the render pass instance it was set in: a value
// set before a split pass must reach the driver scaled inside it and unscaled after it, so it is
// re-emitted at each split pass begin and end (render_pass.cpp). While a pipeline whose static
// state the layer made dynamic is bound, the app's values are only kept: the pipeline's own values
// must stay in effect until a pipeline with dynamic state is bound (CmdBindPipeline above).

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
