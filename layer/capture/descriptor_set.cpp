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

} // namespace

struct DescriptorTable {
    std::shared_mutex mutex; // the maps and every SetInfo in them
    std::unordered_map<VkDescriptorSetLayout, std::shared_ptr<const LayoutInfo>> layouts;
    std::unordered_map<VkDescriptorSet, SetInfo> sets;
    std::unordered_map<VkDescriptorPool, std::unordered_set<VkDescriptorSet>> pool_sets;
};

std::shared_ptr<DescriptorTable> make_descriptor_table() {
    return std::make_shared<DescriptorTable>();
}

namespace {

// Under t.mutex (exclusive). Returns the ids of the sets forgotten (they let go of their
// live-state log entries).
std::vector<uint64_t> forget_pool_sets_locked(DescriptorTable &t, VkDescriptorPool pool) {
    std::vector<uint64_t> ids;
    const auto it = t.pool_sets.find(pool);
    if (it == t.pool_sets.end()) return ids;
    for (VkDescriptorSet set : it->second) {
        t.sets.erase(set);
        ids.push_back(codec::handle_value(set));
    }
    t.pool_sets.erase(it);
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

// Stores `count` descriptors of `type` from (binding, element); `at(i)` fills the i-th. Under the
// table's lock.
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

bool set_binding_has_immutable_samplers(const DeviceState &device, VkDescriptorSet set, uint32_t binding) {
    DescriptorTable &t = *device.descriptors;
    std::shared_lock lock(t.mutex);
    const auto it = t.sets.find(set);
    return it != t.sets.end() && it->second.layout &&
           it->second.layout->immutable_sampler_bindings.count(binding);
}

void note_descriptor_updates(DeviceState &device, uint32_t write_count, const VkWriteDescriptorSet *writes,
                             uint32_t copy_count, const VkCopyDescriptorSet *copies) {
    DescriptorTable &t = *device.descriptors;
    std::unique_lock lock(t.mutex);
    for (uint32_t w = 0; w < write_count; ++w) {
        const VkWriteDescriptorSet &write = writes[w];
        const auto set = t.sets.find(write.dstSet);
        if (set == t.sets.end()) continue;
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
        const auto src = t.sets.find(copy.srcSet);
        const auto dst = t.sets.find(copy.dstSet);
        if (src == t.sets.end() || dst == t.sets.end()) continue;
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

void note_descriptor_template_update(DeviceState &device, VkDescriptorSet set,
                                     const codec::DescriptorTemplateLayout &layout, const void *data) {
    DescriptorTable &t = *device.descriptors;
    std::unique_lock lock(t.mutex);
    const auto it = t.sets.find(set);
    if (it == t.sets.end() || !data) return;
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

bool set_writes_screen_space(const DeviceState &device, VkDescriptorSet set) {
    std::vector<VkImageView> views;
    {
        DescriptorTable &t = *device.descriptors;
        std::shared_lock lock(t.mutex);
        const auto it = t.sets.find(set);
        if (it == t.sets.end()) return false;
        for (const auto &[key, d] : it->second.contents)
            if (d.type == VK_DESCRIPTOR_TYPE_STORAGE_IMAGE && d.image.imageView)
                views.push_back(d.image.imageView);
    }
    for (VkImageView view : views)
        if (is_screen_space(device, image_of_view(device, view))) return true;
    return false;
}

void snapshot_descriptor_contents(DeviceState &device, const std::unordered_set<uint64_t> &live,
                                  codec::Encoder &out, size_t *set_count) {
    // Copied out first: encoding asks has_immutable_samplers(), which takes the table's lock.
    std::vector<std::pair<VkDescriptorSet, SetInfo>> sets;
    {
        DescriptorTable &t = *device.descriptors;
        std::shared_lock lock(t.mutex);
        for (const auto &[set, info] : t.sets)
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

namespace observe {

void CreateDescriptorSetLayout(DeviceState &dev, VkDevice, const VkDescriptorSetLayoutCreateInfo *pCreateInfo,
                               const VkAllocationCallbacks *, VkDescriptorSetLayout *pSetLayout) {
    auto info = std::make_shared<LayoutInfo>();
    for (uint32_t i = 0; i < pCreateInfo->bindingCount; ++i) {
        const VkDescriptorSetLayoutBinding &b = pCreateInfo->pBindings[i];
        info->counts[b.binding] = b.descriptorCount;
        if ((b.descriptorType == VK_DESCRIPTOR_TYPE_SAMPLER ||
             b.descriptorType == VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER) &&
            b.pImmutableSamplers && b.descriptorCount > 0)
            info->immutable_sampler_bindings.insert(b.binding);
    }
    std::unique_lock lock(dev.descriptors->mutex);
    dev.descriptors->layouts[*pSetLayout] = std::move(info);
}

// Before the driver may hand the value to a layout another thread creates (as every destroy's
// observer): the new layout keeps its counts.
void DestroyDescriptorSetLayout(DeviceState &dev, VkDevice, VkDescriptorSetLayout descriptorSetLayout,
                                const VkAllocationCallbacks *) {
    if (descriptorSetLayout == VK_NULL_HANDLE) return;
    std::unique_lock lock(dev.descriptors->mutex);
    dev.descriptors->layouts.erase(descriptorSetLayout);
}

void AllocateDescriptorSets(DeviceState &dev, VkDevice, const VkDescriptorSetAllocateInfo *pAllocateInfo,
                            VkDescriptorSet *pDescriptorSets) {
    std::unique_lock lock(dev.descriptors->mutex);
    for (uint32_t i = 0; i < pAllocateInfo->descriptorSetCount; ++i) {
        const auto layout = dev.descriptors->layouts.find(pAllocateInfo->pSetLayouts[i]);
        dev.descriptors->sets[pDescriptorSets[i]] = {
            layout == dev.descriptors->layouts.end() ? nullptr : layout->second,
            pAllocateInfo->descriptorPool,
            {}};
        dev.descriptors->pool_sets[pAllocateInfo->descriptorPool].insert(pDescriptorSets[i]);
    }
}

// Before the driver may hand a freed set's value to a set another thread allocates (as every
// destroy's observer); the freed sets let go of their live-state log entries.
void FreeDescriptorSets(DeviceState &dev, VkDevice, VkDescriptorPool descriptorPool,
                        uint32_t descriptorSetCount, const VkDescriptorSet *pDescriptorSets) {
    std::vector<uint64_t> ids;
    {
        std::unique_lock lock(dev.descriptors->mutex);
        const auto pool = dev.descriptors->pool_sets.find(descriptorPool);
        for (uint32_t i = 0; i < descriptorSetCount; ++i) {
            if (pDescriptorSets[i] == VK_NULL_HANDLE) continue;
            dev.descriptors->sets.erase(pDescriptorSets[i]);
            if (pool != dev.descriptors->pool_sets.end()) pool->second.erase(pDescriptorSets[i]);
            ids.push_back(codec::handle_value(pDescriptorSets[i]));
        }
    }
    dev.session->forget(ids);
}

// As FreeDescriptorSets, for every set of the pool.
void ResetDescriptorPool(DeviceState &dev, VkDevice, VkDescriptorPool descriptorPool,
                         VkDescriptorPoolResetFlags) {
    std::vector<uint64_t> ids;
    {
        std::unique_lock lock(dev.descriptors->mutex);
        ids = forget_pool_sets_locked(*dev.descriptors, descriptorPool);
    }
    dev.session->forget(ids);
}

void DestroyDescriptorPool(DeviceState &dev, VkDevice, VkDescriptorPool descriptorPool,
                           const VkAllocationCallbacks *) {
    if (descriptorPool == VK_NULL_HANDLE) return;
    std::vector<uint64_t> ids;
    {
        std::unique_lock lock(dev.descriptors->mutex);
        ids = forget_pool_sets_locked(*dev.descriptors, descriptorPool);
    }
    dev.session->forget(ids);
}

} // namespace observe
} // namespace splitvk

// VkDescriptorUpdateTemplate: the layout pData is encoded with (docs/architecture.md §8, GFXReconstruct:
// update templates need the template's entries to encode pData). Kept only while a session exists,
// by the observers of the generated create and destroy; the generated updates' captures look it up.

namespace splitvk {

struct DescriptorTemplateTable {
    ObjectMap<VkDescriptorUpdateTemplate, codec::DescriptorTemplateLayout> templates;
};

std::shared_ptr<DescriptorTemplateTable> make_descriptor_template_table() {
    return std::make_shared<DescriptorTemplateTable>();
}

const codec::DescriptorTemplateLayout *
descriptor_template_layout(const DeviceState &dev, VkDescriptorUpdateTemplate update_template) {
    return dev.descriptor_templates->templates.find(update_template);
}

namespace observe {

void CreateDescriptorUpdateTemplate(DeviceState &dev, VkDevice,
                                    const VkDescriptorUpdateTemplateCreateInfo *pCreateInfo,
                                    const VkAllocationCallbacks *, VkDescriptorUpdateTemplate *pTemplate) {
    dev.descriptor_templates->templates.insert(*pTemplate,
                                               std::make_unique<codec::DescriptorTemplateLayout>(
                                                   codec::DescriptorTemplateLayout::from(*pCreateInfo)));
}

void CreateDescriptorUpdateTemplateKHR(DeviceState &dev, VkDevice device,
                                       const VkDescriptorUpdateTemplateCreateInfo *pCreateInfo,
                                       const VkAllocationCallbacks *pAllocator,
                                       VkDescriptorUpdateTemplate *pTemplate) {
    CreateDescriptorUpdateTemplate(dev, device, pCreateInfo, pAllocator, pTemplate);
}

// Before the driver may hand the value to a template another thread creates (as every destroy's
// observer): the new template keeps its layout.
void DestroyDescriptorUpdateTemplate(DeviceState &dev, VkDevice,
                                     VkDescriptorUpdateTemplate descriptorUpdateTemplate,
                                     const VkAllocationCallbacks *) {
    if (descriptorUpdateTemplate != VK_NULL_HANDLE)
        dev.descriptor_templates->templates.remove(descriptorUpdateTemplate);
}

void DestroyDescriptorUpdateTemplateKHR(DeviceState &dev, VkDevice device,
                                        VkDescriptorUpdateTemplate descriptorUpdateTemplate,
                                        const VkAllocationCallbacks *pAllocator) {
    DestroyDescriptorUpdateTemplate(dev, device, descriptorUpdateTemplate, pAllocator);
}

} // namespace observe
} // namespace splitvk
