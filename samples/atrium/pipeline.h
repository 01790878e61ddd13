// One builder for the graphics pipelines of every render path: triangle lists, one viewport and
// scissor (dynamic unless given), filled polygons, one sample, colour attachments that write RGBA.
#pragma once

#include "vk_util.h"

#include <cstddef>
#include <cstdint>

namespace atrium {

struct ShaderCode {
    const uint32_t *code = nullptr;
    size_t bytes = 0;
    const VkSpecializationInfo *specialization = nullptr;
};

struct GraphicsPipelineInfo {
    ShaderCode vertex, fragment;
    const VkPipelineVertexInputStateCreateInfo *vertex_input = nullptr; // none: no vertex buffers
    VkCullModeFlags cull = VK_CULL_MODE_NONE;
    bool depth_test = false; // LESS, with depth writes; without: no test, no writes
    uint32_t color_attachments = 1;
    bool additive = false; // add to the target instead of replacing it
    VkPipelineLayout layout = VK_NULL_HANDLE;
    VkRenderPass render_pass = VK_NULL_HANDLE;
    const void *next = nullptr;                  // e.g. VkPipelineRenderingCreateInfoKHR with no render pass
    const VkViewport *static_viewport = nullptr; // baked in instead of dynamic state
    const VkRect2D *static_scissor = nullptr;
    bool rasterizer_discard = false; // vertices only (transform feedback captures them)
    // Dynamic beyond the viewport and scissor (--engine-extensions: VK_EXT_extended_dynamic_state3).
    const VkDynamicState *extra_dynamic_states = nullptr;
    uint32_t extra_dynamic_state_count = 0;
};

VkPipeline create_graphics_pipeline(VkDevice device, const GraphicsPipelineInfo &info);

} // namespace atrium
