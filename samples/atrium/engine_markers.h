// --engine-extensions: what engines such as DXVK and vkd3d-proton record with the device extensions
// they enable at startup, drawn over the direct path's scene so that a split run can be compared
// with a native one. Each frame:
//   - transform feedback (VK_EXT_transform_feedback) captures a small triangle's positions into a
//     buffer, in a pass with no attachments, and writes the byte count to a counter buffer;
//   - the frame's command buffer fills a predicate buffer with 0 and 1 (GPU-written, as engines
//     copy occlusion results into theirs);
//   - in each eye, the captured triangle is drawn from the counter (vkCmdDrawIndirectByteCountEXT)
//     in orange under the predicate 1 and in magenta under the predicate 0 (VK_EXT_conditional_
//     rendering): the orange one shows, the magenta one must not;
//   - the marker pipeline's polygon mode, sample mask, alpha-to-coverage and colour write mask are
//     dynamic (VK_EXT_extended_dynamic_state3) and set before the draws: left unset, the sample
//     mask and the write mask would draw nothing.
// The triangle sits at the centre of each eye, in the fovea.
#pragma once

#include "vk_context.h"

namespace atrium {

class EngineMarkers {
public:
    // The device extensions and features the markers need; Error names what the device lacks.
    static void check_support(VkPhysicalDevice physical_device);

    // `pass`: the render pass (subpass 0) the markers are drawn in.
    EngineMarkers(VkContext &context, VkRenderPass pass);
    ~EngineMarkers();
    EngineMarkers(const EngineMarkers &) = delete;
    EngineMarkers &operator=(const EngineMarkers &) = delete;

    // Outside a render pass, before the one the markers are drawn in.
    void record_capture(VkCommandBuffer cmd) const;
    // In the render pass, with the eye's viewport and scissor set; binds its own pipeline.
    void record_draw(VkCommandBuffer cmd) const;

private:
    VkContext &context_;
    VkDevice device_;
    PFN_vkCmdBindTransformFeedbackBuffersEXT bind_transform_feedback_buffers_ = nullptr;
    PFN_vkCmdBeginTransformFeedbackEXT begin_transform_feedback_ = nullptr;
    PFN_vkCmdEndTransformFeedbackEXT end_transform_feedback_ = nullptr;
    PFN_vkCmdDrawIndirectByteCountEXT draw_indirect_byte_count_ = nullptr;
    PFN_vkCmdBeginConditionalRenderingEXT begin_conditional_rendering_ = nullptr;
    PFN_vkCmdEndConditionalRenderingEXT end_conditional_rendering_ = nullptr;
    PFN_vkCmdSetPolygonModeEXT set_polygon_mode_ = nullptr;
    PFN_vkCmdSetSampleMaskEXT set_sample_mask_ = nullptr;
    PFN_vkCmdSetAlphaToCoverageEnableEXT set_alpha_to_coverage_enable_ = nullptr;
    PFN_vkCmdSetColorWriteMaskEXT set_color_write_mask_ = nullptr;

    Buffer captured_;  // the triangle's positions, 16 bytes a vertex
    Buffer counter_;   // transform feedback's byte count
    Buffer predicate_; // two uint32: 0 (not drawn), 1 (drawn)
    VkRenderPass capture_pass_ = VK_NULL_HANDLE;
    VkFramebuffer capture_framebuffer_ = VK_NULL_HANDLE;
    VkPipelineLayout layout_ = VK_NULL_HANDLE;
    VkPipeline capture_pipeline_ = VK_NULL_HANDLE;
    VkPipeline draw_pipeline_ = VK_NULL_HANDLE;
};

} // namespace atrium
