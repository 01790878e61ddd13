#include "engine_markers.h"

#include "atrium_spirv.h"
#include "error.h"
#include "passes.h"
#include "pipeline.h"

#include <algorithm>
#include <cstring>
#include <string>
#include <vector>

namespace atrium {
namespace {

constexpr VkDeviceSize kVertexBytes = 16; // marker_capture.vert's xfb_stride
constexpr VkDeviceSize kPredicateOff = 0;
constexpr VkDeviceSize kPredicateOn = 4;

template <class F>
F device_command(VkDevice device, const char *name) {
    auto f = reinterpret_cast<F>(vkGetDeviceProcAddr(device, name));
    if (!f) throw Error(std::string("--engine-extensions: ") + name + " is missing");
    return f;
}

// The pass transform feedback captures in: no attachments, so nothing is rasterised into an image.
// Its dependencies order the capture after the previous frame's draws read the buffers, and the
// draws of this frame after the capture wrote them.
VkRenderPass create_capture_pass(VkDevice device) {
    VkSubpassDescription subpass{};
    subpass.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
    VkSubpassDependency deps[2] = {};
    deps[0].srcSubpass = VK_SUBPASS_EXTERNAL;
    deps[0].dstSubpass = 0;
    deps[0].srcStageMask = VK_PIPELINE_STAGE_VERTEX_INPUT_BIT | VK_PIPELINE_STAGE_DRAW_INDIRECT_BIT;
    deps[0].dstStageMask = VK_PIPELINE_STAGE_TRANSFORM_FEEDBACK_BIT_EXT;
    deps[1].srcSubpass = 0;
    deps[1].dstSubpass = VK_SUBPASS_EXTERNAL;
    deps[1].srcStageMask = VK_PIPELINE_STAGE_TRANSFORM_FEEDBACK_BIT_EXT;
    deps[1].srcAccessMask =
        VK_ACCESS_TRANSFORM_FEEDBACK_WRITE_BIT_EXT | VK_ACCESS_TRANSFORM_FEEDBACK_COUNTER_WRITE_BIT_EXT;
    deps[1].dstStageMask = VK_PIPELINE_STAGE_VERTEX_INPUT_BIT | VK_PIPELINE_STAGE_DRAW_INDIRECT_BIT;
    deps[1].dstAccessMask = VK_ACCESS_VERTEX_ATTRIBUTE_READ_BIT | VK_ACCESS_INDIRECT_COMMAND_READ_BIT;
    VkRenderPassCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO;
    info.subpassCount = 1;
    info.pSubpasses = &subpass;
    info.dependencyCount = 2;
    info.pDependencies = deps;
    VkRenderPass pass;
    ATRIUM_VK_CHECK(vkCreateRenderPass(device, &info, nullptr, &pass));
    return pass;
}

} // namespace

void EngineMarkers::check_support(VkPhysicalDevice physical_device) {
    uint32_t count = 0;
    vkEnumerateDeviceExtensionProperties(physical_device, nullptr, &count, nullptr);
    std::vector<VkExtensionProperties> extensions(count);
    vkEnumerateDeviceExtensionProperties(physical_device, nullptr, &count, extensions.data());
    for (const char *name :
         {VK_EXT_CONDITIONAL_RENDERING_EXTENSION_NAME, VK_EXT_TRANSFORM_FEEDBACK_EXTENSION_NAME,
          VK_EXT_EXTENDED_DYNAMIC_STATE_3_EXTENSION_NAME}) {
        if (std::none_of(extensions.begin(), extensions.end(), [&](const VkExtensionProperties &e) {
                return std::strcmp(e.extensionName, name) == 0;
            }))
            throw Error(std::string("--engine-extensions: the device does not offer ") + name);
    }
    VkPhysicalDeviceExtendedDynamicState3FeaturesEXT eds3{};
    eds3.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_EXTENDED_DYNAMIC_STATE_3_FEATURES_EXT;
    VkPhysicalDeviceTransformFeedbackFeaturesEXT xfb{};
    xfb.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_TRANSFORM_FEEDBACK_FEATURES_EXT;
    xfb.pNext = &eds3;
    VkPhysicalDeviceConditionalRenderingFeaturesEXT conditional{};
    conditional.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_CONDITIONAL_RENDERING_FEATURES_EXT;
    conditional.pNext = &xfb;
    VkPhysicalDeviceFeatures2 features{};
    features.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2;
    features.pNext = &conditional;
    vkGetPhysicalDeviceFeatures2(physical_device, &features);
    if (!conditional.conditionalRendering || !xfb.transformFeedback ||
        !eds3.extendedDynamicState3PolygonMode || !eds3.extendedDynamicState3SampleMask ||
        !eds3.extendedDynamicState3AlphaToCoverageEnable || !eds3.extendedDynamicState3ColorWriteMask)
        throw Error("--engine-extensions: the device lacks conditionalRendering, transformFeedback or an "
                    "extendedDynamicState3 feature the markers use");
}

EngineMarkers::EngineMarkers(VkContext &context, VkRenderPass pass)
    : context_(context), device_(context.device()) {
    bind_transform_feedback_buffers_ = device_command<PFN_vkCmdBindTransformFeedbackBuffersEXT>(
        device_, "vkCmdBindTransformFeedbackBuffersEXT");
    begin_transform_feedback_ =
        device_command<PFN_vkCmdBeginTransformFeedbackEXT>(device_, "vkCmdBeginTransformFeedbackEXT");
    end_transform_feedback_ =
        device_command<PFN_vkCmdEndTransformFeedbackEXT>(device_, "vkCmdEndTransformFeedbackEXT");
    draw_indirect_byte_count_ =
        device_command<PFN_vkCmdDrawIndirectByteCountEXT>(device_, "vkCmdDrawIndirectByteCountEXT");
    begin_conditional_rendering_ =
        device_command<PFN_vkCmdBeginConditionalRenderingEXT>(device_, "vkCmdBeginConditionalRenderingEXT");
    end_conditional_rendering_ =
        device_command<PFN_vkCmdEndConditionalRenderingEXT>(device_, "vkCmdEndConditionalRenderingEXT");
    set_polygon_mode_ = device_command<PFN_vkCmdSetPolygonModeEXT>(device_, "vkCmdSetPolygonModeEXT");
    set_sample_mask_ = device_command<PFN_vkCmdSetSampleMaskEXT>(device_, "vkCmdSetSampleMaskEXT");
    set_alpha_to_coverage_enable_ =
        device_command<PFN_vkCmdSetAlphaToCoverageEnableEXT>(device_, "vkCmdSetAlphaToCoverageEnableEXT");
    set_color_write_mask_ =
        device_command<PFN_vkCmdSetColorWriteMaskEXT>(device_, "vkCmdSetColorWriteMaskEXT");

    captured_ = context_.create_buffer(3 * kVertexBytes,
                                       VK_BUFFER_USAGE_TRANSFORM_FEEDBACK_BUFFER_BIT_EXT |
                                           VK_BUFFER_USAGE_VERTEX_BUFFER_BIT,
                                       VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
    counter_ = context_.create_buffer(
        16, VK_BUFFER_USAGE_TRANSFORM_FEEDBACK_COUNTER_BUFFER_BIT_EXT | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT,
        VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
    predicate_ = context_.create_buffer(
        8, VK_BUFFER_USAGE_CONDITIONAL_RENDERING_BIT_EXT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
        VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);

    capture_pass_ = create_capture_pass(device_);
    capture_framebuffer_ = create_framebuffer(device_, capture_pass_, {}, VkExtent2D{1, 1});

    const VkPushConstantRange push{VK_SHADER_STAGE_FRAGMENT_BIT, 0, 16};
    VkPipelineLayoutCreateInfo layout{};
    layout.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
    layout.pushConstantRangeCount = 1;
    layout.pPushConstantRanges = &push;
    ATRIUM_VK_CHECK(vkCreatePipelineLayout(device_, &layout, nullptr, &layout_));

    GraphicsPipelineInfo capture;
    capture.vertex = {spirv::marker_capture_vert, sizeof(spirv::marker_capture_vert)};
    capture.fragment = {spirv::marker_frag, sizeof(spirv::marker_frag)};
    capture.color_attachments = 0;
    capture.rasterizer_discard = true;
    capture.layout = layout_;
    capture.render_pass = capture_pass_;
    capture_pipeline_ = create_graphics_pipeline(device_, capture);

    const VkVertexInputBindingDescription binding{0, uint32_t(kVertexBytes), VK_VERTEX_INPUT_RATE_VERTEX};
    const VkVertexInputAttributeDescription attribute{0, 0, VK_FORMAT_R32G32B32A32_SFLOAT, 0};
    VkPipelineVertexInputStateCreateInfo vertex_input{};
    vertex_input.sType = VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO;
    vertex_input.vertexBindingDescriptionCount = 1;
    vertex_input.pVertexBindingDescriptions = &binding;
    vertex_input.vertexAttributeDescriptionCount = 1;
    vertex_input.pVertexAttributeDescriptions = &attribute;
    const VkDynamicState eds3[] = {VK_DYNAMIC_STATE_POLYGON_MODE_EXT, VK_DYNAMIC_STATE_SAMPLE_MASK_EXT,
                                   VK_DYNAMIC_STATE_ALPHA_TO_COVERAGE_ENABLE_EXT,
                                   VK_DYNAMIC_STATE_COLOR_WRITE_MASK_EXT};
    GraphicsPipelineInfo draw;
    draw.vertex = {spirv::marker_vert, sizeof(spirv::marker_vert)};
    draw.fragment = {spirv::marker_frag, sizeof(spirv::marker_frag)};
    draw.vertex_input = &vertex_input;
    draw.layout = layout_;
    draw.render_pass = pass;
    draw.extra_dynamic_states = eds3;
    draw.extra_dynamic_state_count = uint32_t(std::size(eds3));
    draw_pipeline_ = create_graphics_pipeline(device_, draw);
}

EngineMarkers::~EngineMarkers() {
    vkDestroyPipeline(device_, draw_pipeline_, nullptr);
    vkDestroyPipeline(device_, capture_pipeline_, nullptr);
    vkDestroyPipelineLayout(device_, layout_, nullptr);
    vkDestroyFramebuffer(device_, capture_framebuffer_, nullptr);
    vkDestroyRenderPass(device_, capture_pass_, nullptr);
    context_.destroy(predicate_);
    context_.destroy(counter_);
    context_.destroy(captured_);
}

void EngineMarkers::record_capture(VkCommandBuffer cmd) const {
    // The predicates, written by the GPU: after the previous frame's draws read them, and before
    // this frame's read them.
    VkBufferMemoryBarrier barrier{};
    barrier.sType = VK_STRUCTURE_TYPE_BUFFER_MEMORY_BARRIER;
    barrier.srcQueueFamilyIndex = barrier.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    barrier.buffer = predicate_.buffer;
    barrier.size = VK_WHOLE_SIZE;
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_CONDITIONAL_RENDERING_BIT_EXT, VK_PIPELINE_STAGE_TRANSFER_BIT,
                         0, 0, nullptr, 0, nullptr, 0, nullptr);
    vkCmdFillBuffer(cmd, predicate_.buffer, kPredicateOff, 4, 0);
    vkCmdFillBuffer(cmd, predicate_.buffer, kPredicateOn, 4, 1);
    barrier.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    barrier.dstAccessMask = VK_ACCESS_CONDITIONAL_RENDERING_READ_BIT_EXT;
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_CONDITIONAL_RENDERING_BIT_EXT,
                         0, 0, nullptr, 1, &barrier, 0, nullptr);

    begin_pass(cmd, capture_pass_, capture_framebuffer_, VkExtent2D{1, 1}, {}, VK_SUBPASS_CONTENTS_INLINE);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, capture_pipeline_);
    set_viewport(cmd, VkRect2D{{0, 0}, {1, 1}});
    // The fragment stage never runs (rasterizer discard), but its push constant must be set.
    const float unused[4] = {};
    vkCmdPushConstants(cmd, layout_, VK_SHADER_STAGE_FRAGMENT_BIT, 0, sizeof(unused), unused);
    const VkDeviceSize offset = 0;
    bind_transform_feedback_buffers_(cmd, 0, 1, &captured_.buffer, &offset, nullptr);
    begin_transform_feedback_(cmd, 0, 0, nullptr, nullptr);
    vkCmdDraw(cmd, 3, 1, 0, 0);
    end_transform_feedback_(cmd, 0, 1, &counter_.buffer, &offset);
    vkCmdEndRenderPass(cmd);
}

void EngineMarkers::record_draw(VkCommandBuffer cmd) const {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, draw_pipeline_);
    set_polygon_mode_(cmd, VK_POLYGON_MODE_FILL);
    const VkSampleMask all_samples = ~0u;
    set_sample_mask_(cmd, VK_SAMPLE_COUNT_1_BIT, &all_samples);
    set_alpha_to_coverage_enable_(cmd, VK_FALSE);
    const VkColorComponentFlags rgba = VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_G_BIT |
                                       VK_COLOR_COMPONENT_B_BIT | VK_COLOR_COMPONENT_A_BIT;
    set_color_write_mask_(cmd, 0, 1, &rgba);
    const VkDeviceSize offset = 0;
    vkCmdBindVertexBuffers(cmd, 0, 1, &captured_.buffer, &offset);
    const struct {
        VkDeviceSize predicate;
        float colour[4];
    } draws[2] = {{kPredicateOn, {1.0f, 0.5f, 0.0f, 1.0f}}, {kPredicateOff, {1.0f, 0.0f, 1.0f, 1.0f}}};
    for (const auto &d : draws) {
        vkCmdPushConstants(cmd, layout_, VK_SHADER_STAGE_FRAGMENT_BIT, 0, sizeof(d.colour), d.colour);
        VkConditionalRenderingBeginInfoEXT condition{};
        condition.sType = VK_STRUCTURE_TYPE_CONDITIONAL_RENDERING_BEGIN_INFO_EXT;
        condition.buffer = predicate_.buffer;
        condition.offset = d.predicate;
        begin_conditional_rendering_(cmd, &condition);
        draw_indirect_byte_count_(cmd, 1, 0, counter_.buffer, 0, 0, uint32_t(kVertexBytes));
        end_conditional_rendering_(cmd);
    }
}

} // namespace atrium
