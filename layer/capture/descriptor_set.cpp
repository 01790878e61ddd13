// VkDescriptorSetLayout / VkDescriptorSet: which bindings of a set have immutable samplers. For
// those, VkDescriptorImageInfo::sampler is ignored by the specification and may hold anything, so
// the encoder must not send it (EncodeHooks::has_immutable_samplers). Kept only while a session
// exists: layouts by handle, sets by handle with their layout (shared, since a layout may be
// destroyed while sets allocated from it live on) and their pool.
//
// Each set also keeps its part of the live-state log (session.h): the latest descriptor per
// (binding, array element), from vkUpdateDescriptorSets writes (split per element, rolling over
// into the next binding as the specification says), copies (the source's content at copy time)
// and template updates (VkDescriptorUpdateTemplate, below). snapshot_descriptor_contents() re-encodes them.

#include "capture/descriptor_set.h"

#include "capture/capture.h"
#include "capture/screen_space.h"
#include "capture/split.h"
#include "core/object_map.h"
#include "core/vk_util.h"
#include "descriptor_template.h"
#include "layer_entry_points.h"

#include <cstring>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <shared_mutex>
#include <unordered_map>
#include <unordered_set>

namespace splitvk {
namespace {

struct LayoutInfo {
    std::unordered_set<uint32_t> immutable_sampler_bindings;
    std::map<uint32_t, uint32_t> counts; // binding -> descriptorCount
};

// One descriptor's content (inline uniform blocks: one write's bytes, keyed by its offset).
struct Descriptor {
    VkDescriptorType type = VK_DESCRIPTOR_TYPE_SAMPLER;
    VkDescriptorImageInfo image{};
    VkDescriptorBufferInfo buffer{};
    VkBufferView texel_view = VK_NULL_HANDLE;
    std::vector<uint8_t> inline_bytes;
};

struct SetInfo {
    std::shared_ptr<const LayoutInfo> layout;
    VkDescriptorPool pool = VK_NULL_HANDLE;
    std::map<std::pair<uint32_t, uint32_t>, Descriptor> contents; // (binding, element)
};

std::shared_mutex g_mutex;
std::unordered_map<VkDescriptorSetLayout, std::shared_ptr<const LayoutInfo>> g_layouts;
std::unordered_map<VkDescriptorSet, SetInfo> g_sets;
std::unordered_map<VkDescriptorPool, std::unordered_set<VkDescriptorSet>> g_pool_sets;

// Returns the ids of the sets forgotten (they let go of their live-state log entries).
std::vector<uint64_t> forget_pool_sets_locked(VkDescriptorPool pool) {
    std::vector<uint64_t> ids;
    const auto it = g_pool_sets.find(pool);
    if (it == g_pool_sets.end()) return ids;
    for (VkDescriptorSet set : it->second) {
        g_sets.erase(set);
        ids.push_back(codec::handle_value(set));
    }
    g_pool_sets.erase(it);
    return ids;
}

bool is_image_type(VkDescriptorType type) {
    return type == VK_DESCRIPTOR_TYPE_SAMPLER || type == VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER ||
           type == VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE || type == VK_DESCRIPTOR_TYPE_STORAGE_IMAGE ||
           type == VK_DESCRIPTOR_TYPE_INPUT_ATTACHMENT;
}

bool is_buffer_type(VkDescriptorType type) {
    return type == VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER || type == VK_DESCRIPTOR_TYPE_STORAGE_BUFFER ||
           type == VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER_DYNAMIC ||
           type == VK_DESCRIPTOR_TYPE_STORAGE_BUFFER_DYNAMIC;
}

bool is_texel_type(VkDescriptorType type) {
    return type == VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER || type == VK_DESCRIPTOR_TYPE_STORAGE_TEXEL_BUFFER;
}

// The (binding, element) `index` descriptors after (binding, element), rolling over into the next
// bindings of the layout (consecutive binding updates); without a layout, within the binding.
std::pair<uint32_t, uint32_t> advance(const LayoutInfo *layout, uint32_t binding, uint32_t element) {
    if (!layout) return {binding, element};
    auto it = layout->counts.find(binding);
    while (it != layout->counts.end() && element >= it->second) {
        element -= it->second;
        ++it;
        while (it != layout->counts.end() && it->second == 0)
            ++it;
        if (it == layout->counts.end()) break;
        binding = it->first;
    }
    return {binding, element};
}

// Stores `count` descriptors of `type` from (binding, element); `at(i)` fills the i-th. Under g_mutex.
template <class F>
void store_locked(SetInfo &set, uint32_t binding, uint32_t element, uint32_t count, VkDescriptorType type,
                  F &&at) {
    for (uint32_t i = 0; i < count; ++i) {
        Descriptor d;
        d.type = type;
        at(i, d);
        set.contents[advance(set.layout.get(), binding, element + i)] = std::move(d);
    }
}

void store_inline_locked(SetInfo &set, uint32_t binding, uint32_t offset, uint32_t size, const void *data) {
    Descriptor d;
    d.type = VK_DESCRIPTOR_TYPE_INLINE_UNIFORM_BLOCK;
    const auto *bytes = static_cast<const uint8_t *>(data);
    d.inline_bytes.assign(bytes, bytes + size);
    set.contents[{binding, offset}] = std::move(d);
}

} // namespace

bool set_binding_has_immutable_samplers(VkDescriptorSet set, uint32_t binding) {
    std::shared_lock lock(g_mutex);
    const auto it = g_sets.find(set);
    return it != g_sets.end() && it->second.layout &&
           it->second.layout->immutable_sampler_bindings.count(binding);
}

void note_descriptor_updates(uint32_t write_count, const VkWriteDescriptorSet *writes, uint32_t copy_count,
                             const VkCopyDescriptorSet *copies) {
    std::unique_lock lock(g_mutex);
    for (uint32_t w = 0; w < write_count; ++w) {
        const VkWriteDescriptorSet &write = writes[w];
        const auto set = g_sets.find(write.dstSet);
        if (set == g_sets.end()) continue;
        const VkDescriptorType type = write.descriptorType;
        if (is_image_type(type) && write.pImageInfo) {
            store_locked(set->second, write.dstBinding, write.dstArrayElement, write.descriptorCount, type,
                         [&](uint32_t i, Descriptor &d) { d.image = write.pImageInfo[i]; });
        } else if (is_buffer_type(type) && write.pBufferInfo) {
            store_locked(set->second, write.dstBinding, write.dstArrayElement, write.descriptorCount, type,
                         [&](uint32_t i, Descriptor &d) { d.buffer = write.pBufferInfo[i]; });
        } else if (is_texel_type(type) && write.pTexelBufferView) {
            store_locked(set->second, write.dstBinding, write.dstArrayElement, write.descriptorCount, type,
                         [&](uint32_t i, Descriptor &d) { d.texel_view = write.pTexelBufferView[i]; });
        } else if (type == VK_DESCRIPTOR_TYPE_INLINE_UNIFORM_BLOCK) {
            if (const auto *block = find_in_chain<VkWriteDescriptorSetInlineUniformBlock>(
                    write.pNext, VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET_INLINE_UNIFORM_BLOCK))
                store_inline_locked(set->second, write.dstBinding, write.dstArrayElement, block->dataSize,
                                    block->pData);
        }
    }
    for (uint32_t c = 0; c < copy_count; ++c) {
        const VkCopyDescriptorSet &copy = copies[c];
        const auto src = g_sets.find(copy.srcSet);
        const auto dst = g_sets.find(copy.dstSet);
        if (src == g_sets.end() || dst == g_sets.end()) continue;
        // Resolved now: later writes to the source do not change the destination.
        std::vector<std::pair<std::pair<uint32_t, uint32_t>, std::optional<Descriptor>>> moved;
        for (uint32_t i = 0; i < copy.descriptorCount; ++i) {
            const auto from = src->second.contents.find(
                advance(src->second.layout.get(), copy.srcBinding, copy.srcArrayElement + i));
            std::optional<Descriptor> content;
            if (from != src->second.contents.end()) content = from->second;
            moved.emplace_back(advance(dst->second.layout.get(), copy.dstBinding, copy.dstArrayElement + i),
                               std::move(content));
        }
        for (auto &[key, content] : moved) {
            if (content)
                dst->second.contents[key] = std::move(*content);
            else
                dst->second.contents.erase(key);
        }
    }
}

void note_descriptor_template_update(VkDescriptorSet set, const codec::DescriptorTemplateLayout &layout,
                                     const void *data) {
    std::unique_lock lock(g_mutex);
    const auto it = g_sets.find(set);
    if (it == g_sets.end() || !data) return;
    const auto *base = static_cast<const uint8_t *>(data);
    for (const VkDescriptorUpdateTemplateEntry &entry : layout.entries) {
        const uint8_t *at = base + entry.offset;
        const VkDescriptorType type = entry.descriptorType;
        const auto read = [&](uint32_t i, auto &out) {
            std::memcpy(&out, at + size_t{i} * entry.stride, sizeof(out));
        };
        if (is_image_type(type))
            store_locked(it->second, entry.dstBinding, entry.dstArrayElement, entry.descriptorCount, type,
                         [&](uint32_t i, Descriptor &d) { read(i, d.image); });
        else if (is_buffer_type(type))
            store_locked(it->second, entry.dstBinding, entry.dstArrayElement, entry.descriptorCount, type,
                         [&](uint32_t i, Descriptor &d) { read(i, d.buffer); });
        else if (is_texel_type(type))
            store_locked(it->second, entry.dstBinding, entry.dstArrayElement, entry.descriptorCount, type,
                         [&](uint32_t i, Descriptor &d) { read(i, d.texel_view); });
        else if (type == VK_DESCRIPTOR_TYPE_INLINE_UNIFORM_BLOCK)
            store_inline_locked(it->second, entry.dstBinding, entry.dstArrayElement, entry.descriptorCount,
                                at);
    }
}

bool set_writes_screen_space(VkDescriptorSet set) {
    std::vector<VkImageView> views;
    {
        std::shared_lock lock(g_mutex);
        const auto it = g_sets.find(set);
        if (it == g_sets.end()) return false;
        for (const auto &[key, d] : it->second.contents)
            if (d.type == VK_DESCRIPTOR_TYPE_STORAGE_IMAGE && d.image.imageView)
                views.push_back(d.image.imageView);
    }
    for (VkImageView view : views)
        if (is_screen_space(image_of_view(view))) return true;
    return false;
}

void snapshot_descriptor_contents(DeviceState &device, const std::unordered_set<uint64_t> &live,
                                  codec::Encoder &out, size_t *set_count) {
    // Copied out first: encoding asks has_immutable_samplers(), which takes g_mutex.
    std::vector<std::pair<VkDescriptorSet, SetInfo>> sets;
    {
        std::shared_lock lock(g_mutex);
        for (const auto &[set, info] : g_sets)
            if (!info.contents.empty() && live.count(codec::handle_value(set))) sets.emplace_back(set, info);
    }
    const auto named = [&live](auto handle) {
        return handle == VK_NULL_HANDLE || live.count(codec::handle_value(handle));
    };
    size_t count = 0;
    for (const auto &[set, info] : sets) {
        std::vector<VkWriteDescriptorSet> writes;
        std::vector<VkWriteDescriptorSetInlineUniformBlock> blocks;
        writes.reserve(info.contents.size());
        blocks.reserve(info.contents.size());
        for (const auto &[key, d] : info.contents) {
            VkWriteDescriptorSet w{};
            w.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
            w.dstSet = set;
            w.dstBinding = key.first;
            w.dstArrayElement = key.second;
            w.descriptorCount = 1;
            w.descriptorType = d.type;
            const bool immutable = info.layout && info.layout->immutable_sampler_bindings.count(key.first);
            if (is_image_type(d.type)) {
                // A descriptor naming a destroyed object cannot be replayed (nor used by the app).
                const bool has_sampler = d.type == VK_DESCRIPTOR_TYPE_SAMPLER ||
                                         d.type == VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
                const bool has_view = d.type != VK_DESCRIPTOR_TYPE_SAMPLER;
                if ((has_view && !named(d.image.imageView)) ||
                    (has_sampler && !immutable && !named(d.image.sampler)))
                    continue;
                w.pImageInfo = &d.image;
            } else if (is_buffer_type(d.type)) {
                if (!named(d.buffer.buffer)) continue;
                w.pBufferInfo = &d.buffer;
            } else if (is_texel_type(d.type)) {
                if (!named(d.texel_view)) continue;
                w.pTexelBufferView = &d.texel_view;
            } else if (d.type == VK_DESCRIPTOR_TYPE_INLINE_UNIFORM_BLOCK) {
                blocks.push_back({VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET_INLINE_UNIFORM_BLOCK, nullptr,
                                  static_cast<uint32_t>(d.inline_bytes.size()), d.inline_bytes.data()});
                w.pNext = &blocks.back();
                w.descriptorCount = static_cast<uint32_t>(d.inline_bytes.size());
            } else {
                continue;
            }
            writes.push_back(w);
        }
        if (writes.empty()) continue;
        encode_vkUpdateDescriptorSets(out, device.handle, static_cast<uint32_t>(writes.size()), writes.data(),
                                      0, nullptr);
        ++count;
    }
    if (set_count) *set_count = count;
}

namespace entry {

VKAPI_ATTR VkResult VKAPI_CALL CreateDescriptorSetLayout(VkDevice device,
                                                         const VkDescriptorSetLayoutCreateInfo *pCreateInfo,
                                                         const VkAllocationCallbacks *pAllocator,
                                                         VkDescriptorSetLayout *pSetLayout) {
    DeviceState &dev = device_state(device);
    const VkResult result =
        dev.dispatch.CreateDescriptorSetLayout(device, pCreateInfo, pAllocator, pSetLayout);
    if (result != VK_SUCCESS || !capturing(dev)) return result;
    auto info = std::make_shared<LayoutInfo>();
    for (uint32_t i = 0; i < pCreateInfo->bindingCount; ++i) {
        const VkDescriptorSetLayoutBinding &b = pCreateInfo->pBindings[i];
        info->counts[b.binding] = b.descriptorCount;
        if ((b.descriptorType == VK_DESCRIPTOR_TYPE_SAMPLER ||
             b.descriptorType == VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER) &&
            b.pImmutableSamplers && b.descriptorCount > 0)
            info->immutable_sampler_bindings.insert(b.binding);
    }
    {
        std::unique_lock lock(g_mutex);
        g_layouts[*pSetLayout] = std::move(info);
    }
    record_global(dev, LiveChange::Created, codec::handle_value(*pSetLayout), [&](codec::Encoder &e) {
        encode_vkCreateDescriptorSetLayout(e, device, pCreateInfo, pAllocator, pSetLayout);
    });
    return result;
}

VKAPI_ATTR void VKAPI_CALL DestroyDescriptorSetLayout(VkDevice device,
                                                      VkDescriptorSetLayout descriptorSetLayout,
                                                      const VkAllocationCallbacks *pAllocator) {
    DeviceState &dev = device_state(device);
    // Forgotten and recorded before the driver may hand the value to a layout another thread creates
    // (as every destroy: codegen/emit_layer.py): the new layout keeps its counts, and the agent and
    // the live state keep the new layout.
    if (dev.session && descriptorSetLayout != VK_NULL_HANDLE) {
        {
            std::unique_lock lock(g_mutex);
            g_layouts.erase(descriptorSetLayout);
        }
        if (capturing(dev))
            record_global(dev, LiveChange::Retired, codec::handle_value(descriptorSetLayout),
                          [&](codec::Encoder &e) {
                              encode_vkDestroyDescriptorSetLayout(e, device, descriptorSetLayout, pAllocator);
                          });
    }
    dev.dispatch.DestroyDescriptorSetLayout(device, descriptorSetLayout, pAllocator);
}

VKAPI_ATTR VkResult VKAPI_CALL AllocateDescriptorSets(VkDevice device,
                                                      const VkDescriptorSetAllocateInfo *pAllocateInfo,
                                                      VkDescriptorSet *pDescriptorSets) {
    DeviceState &dev = device_state(device);
    const VkResult result = dev.dispatch.AllocateDescriptorSets(device, pAllocateInfo, pDescriptorSets);
    if (result != VK_SUCCESS || !capturing(dev)) return result;
    {
        std::unique_lock lock(g_mutex);
        for (uint32_t i = 0; i < pAllocateInfo->descriptorSetCount; ++i) {
            const auto layout = g_layouts.find(pAllocateInfo->pSetLayouts[i]);
            g_sets[pDescriptorSets[i]] = {
                layout == g_layouts.end() ? nullptr : layout->second, pAllocateInfo->descriptorPool, {}};
            g_pool_sets[pAllocateInfo->descriptorPool].insert(pDescriptorSets[i]);
        }
    }
    record_logged(dev, handle_ids(pDescriptorSets, pAllocateInfo->descriptorSetCount), {},
                  [&](codec::Encoder &e) {
                      encode_vkAllocateDescriptorSets(e, device, pAllocateInfo, pDescriptorSets);
                  });
    return result;
}

VKAPI_ATTR VkResult VKAPI_CALL FreeDescriptorSets(VkDevice device, VkDescriptorPool descriptorPool,
                                                  uint32_t descriptorSetCount,
                                                  const VkDescriptorSet *pDescriptorSets) {
    DeviceState &dev = device_state(device);
    // Forgotten and recorded before the driver may hand a freed set's value to a set another thread
    // allocates (as every destroy: codegen/emit_layer.py). Recording first needs no result: the
    // command's only result is VK_SUCCESS.
    if (dev.session) {
        std::vector<uint64_t> ids;
        {
            std::unique_lock lock(g_mutex);
            const auto pool = g_pool_sets.find(descriptorPool);
            for (uint32_t i = 0; i < descriptorSetCount; ++i) {
                if (pDescriptorSets[i] == VK_NULL_HANDLE) continue;
                g_sets.erase(pDescriptorSets[i]);
                if (pool != g_pool_sets.end()) pool->second.erase(pDescriptorSets[i]);
                ids.push_back(codec::handle_value(pDescriptorSets[i]));
            }
        }
        dev.session->forget(ids);
        if (capturing(dev))
            record_global(dev, LiveChange::Unchanged, 0, [&](codec::Encoder &e) {
                encode_vkFreeDescriptorSets(e, device, descriptorPool, descriptorSetCount, pDescriptorSets);
            });
    }
    return dev.dispatch.FreeDescriptorSets(device, descriptorPool, descriptorSetCount, pDescriptorSets);
}

VKAPI_ATTR VkResult VKAPI_CALL ResetDescriptorPool(VkDevice device, VkDescriptorPool descriptorPool,
                                                   VkDescriptorPoolResetFlags flags) {
    DeviceState &dev = device_state(device);
    // As FreeDescriptorSets: the pool's sets are forgotten and the reset recorded before the driver
    // may hand their values to sets another thread allocates; VK_SUCCESS is the only result.
    if (dev.session) {
        std::vector<uint64_t> ids;
        {
            std::unique_lock lock(g_mutex);
            ids = forget_pool_sets_locked(descriptorPool);
        }
        dev.session->forget(ids);
        if (capturing(dev))
            record_global(dev, LiveChange::Unchanged, 0, [&](codec::Encoder &e) {
                encode_vkResetDescriptorPool(e, device, descriptorPool, flags);
            });
    }
    return dev.dispatch.ResetDescriptorPool(device, descriptorPool, flags);
}

VKAPI_ATTR void VKAPI_CALL DestroyDescriptorPool(VkDevice device, VkDescriptorPool descriptorPool,
                                                 const VkAllocationCallbacks *pAllocator) {
    DeviceState &dev = device_state(device);
    // Forgotten and recorded before the driver may hand the pool's value, or its sets', to objects
    // another thread creates (as every destroy: codegen/emit_layer.py).
    if (dev.session && descriptorPool != VK_NULL_HANDLE) {
        std::vector<uint64_t> ids;
        {
            std::unique_lock lock(g_mutex);
            ids = forget_pool_sets_locked(descriptorPool);
        }
        dev.session->forget(ids);
        if (capturing(dev))
            record_global(dev, LiveChange::Destroyed, codec::handle_value(descriptorPool),
                          [&](codec::Encoder &e) {
                              encode_vkDestroyDescriptorPool(e, device, descriptorPool, pAllocator);
                          });
    }
    dev.dispatch.DestroyDescriptorPool(device, descriptorPool, pAllocator);
}

} // namespace entry
} // namespace splitvk

// VkDescriptorUpdateTemplate: the layout pData is encoded with (docs/architecture.md §8, GFXReconstruct:
// update templates need the template's entries to encode pData). Kept only while a session exists.

namespace splitvk {
namespace {

ObjectMap<VkDescriptorUpdateTemplate, codec::DescriptorTemplateLayout> g_templates;

VkResult create_template(PFN_vkCreateDescriptorUpdateTemplate next, VkDevice device,
                         const VkDescriptorUpdateTemplateCreateInfo *pCreateInfo,
                         const VkAllocationCallbacks *pAllocator, VkDescriptorUpdateTemplate *pTemplate) {
    DeviceState &dev = device_state(device);
    const VkResult result = next(device, pCreateInfo, pAllocator, pTemplate);
    if (result != VK_SUCCESS || !capturing(dev)) return result;
    g_templates.insert(*pTemplate, std::make_unique<codec::DescriptorTemplateLayout>(
                                       codec::DescriptorTemplateLayout::from(*pCreateInfo)));
    record_global(dev, LiveChange::Created, codec::handle_value(*pTemplate), [&](codec::Encoder &e) {
        encode_vkCreateDescriptorUpdateTemplate(e, device, pCreateInfo, pAllocator, pTemplate);
    });
    return result;
}

void destroy_template(PFN_vkDestroyDescriptorUpdateTemplate next, VkDevice device,
                      VkDescriptorUpdateTemplate descriptorUpdateTemplate,
                      const VkAllocationCallbacks *pAllocator) {
    DeviceState &dev = device_state(device);
    // Forgotten and recorded before the driver may hand the value to a template another thread
    // creates (as every destroy: codegen/emit_layer.py): the new template keeps its layout, and the
    // agent and the live state keep the new template.
    if (dev.session && descriptorUpdateTemplate != VK_NULL_HANDLE) {
        g_templates.remove(descriptorUpdateTemplate);
        if (capturing(dev))
            record_global(dev, LiveChange::Destroyed, codec::handle_value(descriptorUpdateTemplate),
                          [&](codec::Encoder &e) {
                              encode_vkDestroyDescriptorUpdateTemplate(e, device, descriptorUpdateTemplate,
                                                                       pAllocator);
                          });
    }
    next(device, descriptorUpdateTemplate, pAllocator);
}

void update_with_template(PFN_vkUpdateDescriptorSetWithTemplate next, VkDevice device, VkDescriptorSet set,
                          VkDescriptorUpdateTemplate descriptorUpdateTemplate, const void *pData) {
    DeviceState &dev = device_state(device);
    next(device, set, descriptorUpdateTemplate, pData);
    if (!capturing(dev)) return;
    const codec::DescriptorTemplateLayout *layout = g_templates.find(descriptorUpdateTemplate);
    if (!layout) return;
    record_global(dev, LiveChange::Unchanged, 0, [&](codec::Encoder &e) {
        encode_vkUpdateDescriptorSetWithTemplate(e, device, set, descriptorUpdateTemplate, pData, *layout);
    });
    note_descriptor_template_update(set, *layout, pData);
}

} // namespace

namespace entry {

VKAPI_ATTR VkResult VKAPI_CALL CreateDescriptorUpdateTemplate(
    VkDevice device, const VkDescriptorUpdateTemplateCreateInfo *pCreateInfo,
    const VkAllocationCallbacks *pAllocator, VkDescriptorUpdateTemplate *pDescriptorUpdateTemplate) {
    return create_template(device_dispatch(device).CreateDescriptorUpdateTemplate, device, pCreateInfo,
                           pAllocator, pDescriptorUpdateTemplate);
}

VKAPI_ATTR VkResult VKAPI_CALL CreateDescriptorUpdateTemplateKHR(
    VkDevice device, const VkDescriptorUpdateTemplateCreateInfo *pCreateInfo,
    const VkAllocationCallbacks *pAllocator, VkDescriptorUpdateTemplate *pDescriptorUpdateTemplate) {
    return create_template(device_dispatch(device).CreateDescriptorUpdateTemplateKHR, device, pCreateInfo,
                           pAllocator, pDescriptorUpdateTemplate);
}

VKAPI_ATTR void VKAPI_CALL
DestroyDescriptorUpdateTemplate(VkDevice device, VkDescriptorUpdateTemplate descriptorUpdateTemplate,
                                const VkAllocationCallbacks *pAllocator) {
    destroy_template(device_dispatch(device).DestroyDescriptorUpdateTemplate, device,
                     descriptorUpdateTemplate, pAllocator);
}

VKAPI_ATTR void VKAPI_CALL
DestroyDescriptorUpdateTemplateKHR(VkDevice device, VkDescriptorUpdateTemplate descriptorUpdateTemplate,
                                   const VkAllocationCallbacks *pAllocator) {
    destroy_template(device_dispatch(device).DestroyDescriptorUpdateTemplateKHR, device,
                     descriptorUpdateTemplate, pAllocator);
}

VKAPI_ATTR void VKAPI_CALL
UpdateDescriptorSetWithTemplate(VkDevice device, VkDescriptorSet descriptorSet,
                                VkDescriptorUpdateTemplate descriptorUpdateTemplate, const void *pData) {
    update_with_template(device_dispatch(device).UpdateDescriptorSetWithTemplate, device, descriptorSet,
                         descriptorUpdateTemplate, pData);
}

VKAPI_ATTR void VKAPI_CALL
UpdateDescriptorSetWithTemplateKHR(VkDevice device, VkDescriptorSet descriptorSet,
                                   VkDescriptorUpdateTemplate descriptorUpdateTemplate, const void *pData) {
    update_with_template(device_dispatch(device).UpdateDescriptorSetWithTemplateKHR, device, descriptorSet,
                         descriptorUpdateTemplate, pData);
}

VKAPI_ATTR void VKAPI_CALL CmdPushDescriptorSetWithTemplateKHR(
    VkCommandBuffer commandBuffer, VkDescriptorUpdateTemplate descriptorUpdateTemplate,
    VkPipelineLayout layout, uint32_t set, const void *pData) {
    DeviceState &dev = device_state(commandBuffer);
    dev.dispatch.CmdPushDescriptorSetWithTemplateKHR(commandBuffer, descriptorUpdateTemplate, layout, set,
                                                     pData);
    if (!capturing(dev)) return;
    const codec::DescriptorTemplateLayout *template_layout = g_templates.find(descriptorUpdateTemplate);
    codec::Encoder *e = command_buffer_encoder(commandBuffer);
    if (template_layout && e)
        encode_vkCmdPushDescriptorSetWithTemplateKHR(*e, commandBuffer, descriptorUpdateTemplate, layout, set,
                                                     pData, *template_layout);
}

} // namespace entry
} // namespace splitvk
