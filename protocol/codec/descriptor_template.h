#pragma once

// Descriptor update templates (vkUpdateDescriptorSetWithTemplate, vkCmdPushDescriptorSetWithTemplateKHR).
//
// Their pData is an opaque block laid out by the template's entries (offset, stride), which only the
// creator of the template knows (GFXReconstruct: "descriptor update templates need the template layout
// to encode pData"). So the layer keeps each template's DescriptorTemplateLayout, and the encoder turns
// pData into a structured list of descriptor writes on the wire:
//
//   u32 entry count, then per entry: u32 dstBinding, u32 dstArrayElement, u32 descriptorCount,
//   u32 descriptorType, and descriptorCount descriptors:
//     image types   u64 sampler id (0 unless the type uses it), u64 image view id (idem), u32 layout
//     buffer types  u64 buffer id, u64 offset, u64 range
//     texel buffers u64 buffer view id
//     inline uniform block: descriptorCount bytes
//
// The agent creates its templates with canonical offsets and strides (the generated decoder of
// VkDescriptorUpdateTemplateCreateInfo rewrites them with canonicalize_template_entries), and the
// decoder lays pData out for exactly that layout, with the agent's handles.

#include "codec.h"

#include <span>
#include <vector>

namespace splitvk::codec {

// The entries of one template as its creator gave them (client side).
struct DescriptorTemplateLayout {
    std::vector<VkDescriptorUpdateTemplateEntry> entries;

    static DescriptorTemplateLayout from(const VkDescriptorUpdateTemplateCreateInfo &info);
};

// One decoded entry; exactly one of the arrays is set, by descriptorType.
struct DecodedTemplateEntry {
    uint32_t dstBinding = 0;
    uint32_t dstArrayElement = 0;
    uint32_t descriptorCount = 0;
    VkDescriptorType descriptorType = VK_DESCRIPTOR_TYPE_SAMPLER;
    const VkDescriptorImageInfo *pImageInfo = nullptr;
    const VkDescriptorBufferInfo *pBufferInfo = nullptr;
    const VkBufferView *pTexelBufferView = nullptr;
    const void *pInlineData = nullptr; // VK_DESCRIPTOR_TYPE_INLINE_UNIFORM_BLOCK: descriptorCount bytes
};

struct DecodedTemplateData {
    uint32_t entryCount = 0;
    const DecodedTemplateEntry *pEntries = nullptr;
    const void *pData = nullptr; // laid out for the canonical template (agent's handles)
    size_t dataSize = 0;
};

// Size of one descriptor of `type` in pData (inline uniform blocks: 1, a byte), 0 if the codec
// does not forward the type.
size_t template_descriptor_size(VkDescriptorType type);

// Assigns canonical offsets and strides (entries packed in order, each 8-byte aligned, stride the
// size of one descriptor) and returns the size of pData they describe.
size_t canonical_template_layout(std::span<VkDescriptorUpdateTemplateEntry> entries);
// The decode epilogue of VkDescriptorUpdateTemplateCreateInfo (its entries live in the arena).
void canonicalize_template_entries(VkDescriptorUpdateTemplateCreateInfo &info);

// Encodes pData as structured writes. `set` is the descriptor set being updated (VK_NULL_HANDLE for
// push descriptors); it lets EncodeHooks::has_immutable_samplers be asked. Entries of a type the codec
// cannot forward are reported (EncodeHooks::skipped_structure with the descriptor type as value) and
// sent with no descriptors.
void encode_template_data(Encoder &e, const DescriptorTemplateLayout &layout, const void *pData,
                          VkDescriptorSet set);
bool decode_template_data(Decoder &d, DecodedTemplateData &out);

// Lays decoded data out for any layout with the same entries (binding, element, count, type in the
// same order), for an agent that keeps the client's offsets. nullptr (and false) on a mismatch.
bool layout_template_data(const DecodedTemplateData &data,
                          std::span<const VkDescriptorUpdateTemplateEntry> entries, Arena &arena,
                          const void *&pData, std::string *error = nullptr);

} // namespace splitvk::codec
