#include "rules.h"

namespace splitvk::codec {

bool descriptor_uses_image_info(VkDescriptorType type) {
    switch (type) {
    case VK_DESCRIPTOR_TYPE_SAMPLER:
    case VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER:
    case VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE:
    case VK_DESCRIPTOR_TYPE_STORAGE_IMAGE:
    case VK_DESCRIPTOR_TYPE_INPUT_ATTACHMENT:
        return true;
    default:
        return false;
    }
}

bool descriptor_uses_buffer_info(VkDescriptorType type) {
    switch (type) {
    case VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER:
    case VK_DESCRIPTOR_TYPE_STORAGE_BUFFER:
    case VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER_DYNAMIC:
    case VK_DESCRIPTOR_TYPE_STORAGE_BUFFER_DYNAMIC:
        return true;
    default:
        return false;
    }
}

bool descriptor_uses_texel_buffer_view(VkDescriptorType type) {
    return type == VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER || type == VK_DESCRIPTOR_TYPE_STORAGE_TEXEL_BUFFER;
}

bool descriptor_uses_sampler(VkDescriptorType type) {
    return type == VK_DESCRIPTOR_TYPE_SAMPLER || type == VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
}

bool descriptor_uses_image_view(VkDescriptorType type) {
    switch (type) {
    case VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER:
    case VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE:
    case VK_DESCRIPTOR_TYPE_STORAGE_IMAGE:
    case VK_DESCRIPTOR_TYPE_INPUT_ATTACHMENT:
        return true;
    default:
        return false;
    }
}

DescriptorWriteScope::DescriptorWriteScope(Encoder &e, const VkWriteDescriptorSet &s) : ContextScope(e) {
    EncodeContext &c = e.context();
    c.descriptor_type = s.descriptorType;
    c.immutable_samplers = false;
    // Push descriptors have no set to ask about (dstSet is ignored).
    if (descriptor_uses_sampler(s.descriptorType) && !c.push_descriptor && e.hooks())
        c.immutable_samplers = e.hooks()->has_immutable_samplers(s.dstSet, s.dstBinding);
}

bool has_dynamic_state(const VkPipelineDynamicStateCreateInfo *dynamic, VkDynamicState state) {
    if (!dynamic || !dynamic->pDynamicStates) return false;
    for (uint32_t i = 0; i < dynamic->dynamicStateCount; ++i)
        if (dynamic->pDynamicStates[i] == state) return true;
    return false;
}

namespace {

const VkPipelineRenderingCreateInfo *find_rendering_info(const void *next) {
    // Bounded like the encoder's own walk, in case the chain loops.
    for (uint32_t n = 0; next && n < Encoder::kMaxChainLength; ++n) {
        const auto *base = static_cast<const VkBaseInStructure *>(next);
        if (base->sType == VK_STRUCTURE_TYPE_PIPELINE_RENDERING_CREATE_INFO)
            return static_cast<const VkPipelineRenderingCreateInfo *>(next);
        next = base->pNext;
    }
    return nullptr;
}

} // namespace

GraphicsPipelineScope::GraphicsPipelineScope(Encoder &e, const VkGraphicsPipelineCreateInfo &s)
    : ContextScope(e) {
    EncodeContext &c = e.context();
    const VkPipelineDynamicStateCreateInfo *dynamic = s.pDynamicState;

    // Tessellation state: only with both tessellation stages.
    VkShaderStageFlags stages = 0;
    if (s.pStages)
        for (uint32_t i = 0; i < s.stageCount; ++i)
            stages |= s.pStages[i].stage;
    c.pipeline_tessellation = (stages & VK_SHADER_STAGE_TESSELLATION_CONTROL_BIT) != 0 &&
                              (stages & VK_SHADER_STAGE_TESSELLATION_EVALUATION_BIT) != 0;

    // Rasterization is disabled when rasterizerDiscardEnable is statically VK_TRUE.
    const bool discard = s.pRasterizationState && s.pRasterizationState->rasterizerDiscardEnable == VK_TRUE &&
                         !has_dynamic_state(dynamic, VK_DYNAMIC_STATE_RASTERIZER_DISCARD_ENABLE);
    c.pipeline_rasterization = !discard;

    // Attachments: from the subpass (asked of the layer) or from VkPipelineRenderingCreateInfo.
    c.rendering_info_applies = s.renderPass == VK_NULL_HANDLE;
    if (s.renderPass != VK_NULL_HANDLE) {
        EncodeHooks::SubpassUse use;
        if (e.hooks()) use = e.hooks()->subpass_use(s.renderPass, s.subpass);
        c.pipeline_color = use.color;
        c.pipeline_depth_stencil = use.depth_stencil;
    } else {
        // Without the structure, dynamic rendering uses no attachments (all counts and formats 0).
        const VkPipelineRenderingCreateInfo *rendering = find_rendering_info(s.pNext);
        c.pipeline_color = rendering && rendering->colorAttachmentCount > 0;
        c.pipeline_depth_stencil = rendering && (rendering->depthAttachmentFormat != VK_FORMAT_UNDEFINED ||
                                                 rendering->stencilAttachmentFormat != VK_FORMAT_UNDEFINED);
    }

    c.dynamic_viewport = has_dynamic_state(dynamic, VK_DYNAMIC_STATE_VIEWPORT) ||
                         has_dynamic_state(dynamic, VK_DYNAMIC_STATE_VIEWPORT_WITH_COUNT);
    c.dynamic_scissor = has_dynamic_state(dynamic, VK_DYNAMIC_STATE_SCISSOR) ||
                        has_dynamic_state(dynamic, VK_DYNAMIC_STATE_SCISSOR_WITH_COUNT);
    c.dynamic_vertex_input = has_dynamic_state(dynamic, VK_DYNAMIC_STATE_VERTEX_INPUT_EXT);
    // The attachments' blend state is ignored only when all three of its parts are dynamic
    // (advanced blending, the fourth part, is not forwarded).
    c.dynamic_color_blend_attachments =
        has_dynamic_state(dynamic, VK_DYNAMIC_STATE_COLOR_BLEND_ENABLE_EXT) &&
        has_dynamic_state(dynamic, VK_DYNAMIC_STATE_COLOR_BLEND_EQUATION_EXT) &&
        has_dynamic_state(dynamic, VK_DYNAMIC_STATE_COLOR_WRITE_MASK_EXT);
}

} // namespace splitvk::codec
