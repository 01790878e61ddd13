#pragma once

// The hand-written half of codegen/codec_overrides.py: which members of a structure the
// specification ignores in a given state, so the encoder must not read them. Generated encoders
// call these; see the override table for the specification's text behind each rule.

#include "codec.h"

namespace splitvk::codec {

// Which member of VkWriteDescriptorSet / which members of VkDescriptorImageInfo a descriptor type
// uses.
bool descriptor_uses_image_info(VkDescriptorType type);
bool descriptor_uses_buffer_info(VkDescriptorType type);
bool descriptor_uses_texel_buffer_view(VkDescriptorType type);
bool descriptor_uses_sampler(VkDescriptorType type);
bool descriptor_uses_image_view(VkDescriptorType type);

// Saves the encoder's context and restores it when the scope ends.
class ContextScope {
public:
    explicit ContextScope(Encoder &e) : e_(e), saved_(e.context()) {}
    ~ContextScope() { e_.context() = saved_; }
    ContextScope(const ContextScope &) = delete;
    ContextScope &operator=(const ContextScope &) = delete;

private:
    Encoder &e_;
    EncodeContext saved_;
};

// VkWriteDescriptorSet: its descriptor type (and whether its binding has immutable samplers,
// asked of the layer through EncodeHooks) decide which members of VkDescriptorImageInfo are read.
class DescriptorWriteScope : public ContextScope {
public:
    DescriptorWriteScope(Encoder &e, const VkWriteDescriptorSet &s);
};

// VkGraphicsPipelineCreateInfo: which of its state pointers are read (tessellation stages,
// rasterizer discard, the attachments its subpass or VkPipelineRenderingCreateInfo uses), and
// which viewport state is dynamic.
class GraphicsPipelineScope : public ContextScope {
public:
    GraphicsPipelineScope(Encoder &e, const VkGraphicsPipelineCreateInfo &s);
};

// True if `state` is in the pipeline's dynamic states (null pDynamicState: none is).
bool has_dynamic_state(const VkPipelineDynamicStateCreateInfo *dynamic, VkDynamicState state);

} // namespace splitvk::codec
