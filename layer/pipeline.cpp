// VkPipeline: static viewport/scissor state made dynamic (docs/architecture.md §4). Inside a split pass the
// layer must draw with scaled viewports and scissors, which a pipeline's static state would
// override; so pipelines are created down the chain with VIEWPORT/SCISSOR added to their dynamic
// state (the capture keeps the app's create info: the agent decides for itself), the static
// values are kept here, and binding such a pipeline sets them (scaled inside a split pass).

#include "pipeline.h"

#include "layer_entry_points.h"
#include "object_map.h"
#include "split.h"

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
