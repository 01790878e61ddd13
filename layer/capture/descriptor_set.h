#pragma once

// Descriptor set layouts and sets (descriptor_set.cpp): which bindings have immutable samplers, and
// each set's descriptor contents for the live-state log (session.h). Kept only while a session exists.

#include "core/device.h"
#include "descriptor_template.h"
#include "vk_codec.h"

#include <cstddef>
#include <cstdint>
#include <unordered_set>

namespace splitvk {

// Whether `binding` of `set` has immutable samplers, whose VkDescriptorImageInfo::sampler the
// encoder must not send (EncodeHooks::has_immutable_samplers).
bool set_binding_has_immutable_samplers(const DeviceState &device, VkDescriptorSet set, uint32_t binding);

// vkUpdateDescriptorSets: the descriptor contents part of the live-state log.
void note_descriptor_updates(DeviceState &device, uint32_t write_count, const VkWriteDescriptorSet *writes,
                             uint32_t copy_count, const VkCopyDescriptorSet *copies);

// The layout of a descriptor update template of `device` created while it had a session
// (below, in descriptor_set.cpp), which the captures of the template updates encode pData with; nullptr
// for any other template.
const codec::DescriptorTemplateLayout *descriptor_template_layout(const DeviceState &device,
                                                                  VkDescriptorUpdateTemplate update_template);

// vkUpdateDescriptorSetWithTemplate: the same, through a template's layout.
void note_descriptor_template_update(DeviceState &device, VkDescriptorSet set,
                                     const codec::DescriptorTemplateLayout &layout, const void *data);

// Whether a storage image the set holds is a view of a screen-space image (screen_space.h): a
// dispatch with it bound writes a split target.
bool set_writes_screen_space(const DeviceState &device, VkDescriptorSet set);

// Snapshot part (session.h: build_live_snapshot), naming only ids in `live`: one
// vkUpdateDescriptorSets per set with contents.
void snapshot_descriptor_contents(DeviceState &device, const std::unordered_set<uint64_t> &live,
                                  codec::Encoder &out, size_t *set_count);

} // namespace splitvk
