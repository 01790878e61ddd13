#include "descriptor_template.h"

#include "rules.h"

#include <algorithm>
#include <string>

namespace splitvk::codec {

namespace {

enum class Kind { Image, Buffer, TexelBuffer, InlineUniformBlock, Unsupported };

Kind kind_of(VkDescriptorType type) {
    if (descriptor_uses_image_info(type)) return Kind::Image;
    if (descriptor_uses_buffer_info(type)) return Kind::Buffer;
    if (descriptor_uses_texel_buffer_view(type)) return Kind::TexelBuffer;
    if (type == VK_DESCRIPTOR_TYPE_INLINE_UNIFORM_BLOCK) return Kind::InlineUniformBlock;
    return Kind::Unsupported;
}

// Minimum wire bytes of one descriptor (see the header's layout).
size_t wire_size(Kind kind) {
    switch (kind) {
    case Kind::Image:
        return 8 + 8 + 4;
    case Kind::Buffer:
        return 8 + 8 + 8;
    case Kind::TexelBuffer:
        return 8;
    case Kind::InlineUniformBlock:
        return 1;
    case Kind::Unsupported:
        break;
    }
    return 0;
}

template <class T>
T load(const uint8_t *p) {
    T v;
    std::memcpy(&v, p, sizeof(T)); // pData need not be aligned
    return v;
}

} // namespace

DescriptorTemplateLayout DescriptorTemplateLayout::from(const VkDescriptorUpdateTemplateCreateInfo &info) {
    DescriptorTemplateLayout layout;
    if (info.pDescriptorUpdateEntries)
        layout.entries.assign(info.pDescriptorUpdateEntries,
                              info.pDescriptorUpdateEntries + info.descriptorUpdateEntryCount);
    return layout;
}

size_t template_descriptor_size(VkDescriptorType type) {
    switch (kind_of(type)) {
    case Kind::Image:
        return sizeof(VkDescriptorImageInfo);
    case Kind::Buffer:
        return sizeof(VkDescriptorBufferInfo);
    case Kind::TexelBuffer:
        return sizeof(VkBufferView);
    case Kind::InlineUniformBlock:
        return 1;
    case Kind::Unsupported:
        break;
    }
    return 0;
}

size_t canonical_template_layout(std::span<VkDescriptorUpdateTemplateEntry> entries) {
    size_t offset = 0;
    for (VkDescriptorUpdateTemplateEntry &entry : entries) {
        const size_t size = template_descriptor_size(entry.descriptorType);
        offset = (offset + 7) & ~size_t{7};
        entry.offset = offset;
        entry.stride = size;
        offset += size * entry.descriptorCount;
    }
    return offset;
}

void canonicalize_template_entries(VkDescriptorUpdateTemplateCreateInfo &info) {
    if (!info.pDescriptorUpdateEntries) return;
    // The decoder allocated these entries in its arena: they are not really const.
    auto *entries = const_cast<VkDescriptorUpdateTemplateEntry *>(info.pDescriptorUpdateEntries);
    canonical_template_layout(
        std::span<VkDescriptorUpdateTemplateEntry>(entries, info.descriptorUpdateEntryCount));
}

void encode_template_data(Encoder &e, const DescriptorTemplateLayout &layout, const void *pData,
                          VkDescriptorSet set) {
    const auto *data = static_cast<const uint8_t *>(pData);
    e.u32(static_cast<uint32_t>(layout.entries.size()));
    for (const VkDescriptorUpdateTemplateEntry &entry : layout.entries) {
        const Kind kind = kind_of(entry.descriptorType);
        const uint32_t count = (kind == Kind::Unsupported || !data) ? 0 : entry.descriptorCount;
        if (kind == Kind::Unsupported && entry.descriptorCount > 0)
            e.skipped_structure(static_cast<VkStructureType>(entry.descriptorType),
                                "VkDescriptorUpdateTemplateEntry");
        e.u32(entry.dstBinding);
        e.u32(entry.dstArrayElement);
        e.u32(count);
        e.enum32(entry.descriptorType);
        if (count == 0) continue;
        if (kind == Kind::InlineUniformBlock) {
            // descriptorCount bytes at offset; stride is ignored.
            e.bytes(data + entry.offset, count);
            continue;
        }
        // The sampler is ignored by types without one and by bindings with immutable samplers.
        bool sampler = descriptor_uses_sampler(entry.descriptorType);
        if (sampler && set != VK_NULL_HANDLE && e.hooks() &&
            e.hooks()->has_immutable_samplers(set, entry.dstBinding))
            sampler = false;
        const bool view = descriptor_uses_image_view(entry.descriptorType);
        for (uint32_t i = 0; i < count; ++i) {
            const uint8_t *p = data + entry.offset + size_t{i} * entry.stride;
            switch (kind) {
            case Kind::Image: {
                const auto info = load<VkDescriptorImageInfo>(p);
                e.handle(sampler ? info.sampler : VkSampler{});
                e.handle(view ? info.imageView : VkImageView{});
                e.enum32(info.imageLayout);
                break;
            }
            case Kind::Buffer: {
                const auto info = load<VkDescriptorBufferInfo>(p);
                e.handle(info.buffer);
                e.u64(info.offset);
                e.u64(info.range);
                break;
            }
            case Kind::TexelBuffer:
                e.handle(load<VkBufferView>(p));
                break;
            case Kind::InlineUniformBlock:
            case Kind::Unsupported:
                break;
            }
        }
    }
}

bool decode_template_data(Decoder &d, DecodedTemplateData &out) {
    out = {};
    // Each entry takes at least 16 bytes on the wire.
    const uint32_t count = d.u32("entryCount");
    auto *entries = d.array<DecodedTemplateEntry>(count, 16, "template entries");
    if (!d.ok()) return false;
    // The canonical layout of the same entries gives pData's offsets.
    auto *layout = d.array<VkDescriptorUpdateTemplateEntry>(count, 0, "template entries");
    if (!d.ok()) return false;
    for (uint32_t i = 0; i < count && d.ok(); ++i) {
        DecodedTemplateEntry &entry = entries[i];
        entry.dstBinding = d.u32("dstBinding");
        entry.dstArrayElement = d.u32("dstArrayElement");
        entry.descriptorCount = d.u32("descriptorCount");
        entry.descriptorType = d.enum32<VkDescriptorType>("descriptorType");
        if (!d.ok()) return false;
        const Kind kind = kind_of(entry.descriptorType);
        if (kind == Kind::Unsupported && entry.descriptorCount > 0) {
            d.fail("descriptor type " + std::to_string(entry.descriptorType) + " in a template update");
            return false;
        }
        layout[i].dstBinding = entry.dstBinding;
        layout[i].dstArrayElement = entry.dstArrayElement;
        layout[i].descriptorCount = entry.descriptorCount;
        layout[i].descriptorType = entry.descriptorType;
        const uint32_t n = entry.descriptorCount;
        if (n == 0) continue;
        switch (kind) {
        case Kind::Image: {
            auto *infos = d.array<VkDescriptorImageInfo>(n, wire_size(kind), "pImageInfo");
            for (uint32_t j = 0; infos && j < n && d.ok(); ++j) {
                infos[j].sampler = d.handle<VkSampler>(VK_OBJECT_TYPE_SAMPLER, true, "sampler");
                infos[j].imageView = d.handle<VkImageView>(VK_OBJECT_TYPE_IMAGE_VIEW, true, "imageView");
                infos[j].imageLayout = d.enum32<VkImageLayout>("imageLayout");
            }
            entry.pImageInfo = infos;
            break;
        }
        case Kind::Buffer: {
            auto *infos = d.array<VkDescriptorBufferInfo>(n, wire_size(kind), "pBufferInfo");
            for (uint32_t j = 0; infos && j < n && d.ok(); ++j) {
                infos[j].buffer = d.handle<VkBuffer>(VK_OBJECT_TYPE_BUFFER, true, "buffer");
                infos[j].offset = d.u64("offset");
                infos[j].range = d.u64("range");
            }
            entry.pBufferInfo = infos;
            break;
        }
        case Kind::TexelBuffer: {
            auto *views = d.array<VkBufferView>(n, wire_size(kind), "pTexelBufferView");
            for (uint32_t j = 0; views && j < n && d.ok(); ++j)
                views[j] = d.handle<VkBufferView>(VK_OBJECT_TYPE_BUFFER_VIEW, true, "bufferView");
            entry.pTexelBufferView = views;
            break;
        }
        case Kind::InlineUniformBlock:
            entry.pInlineData = d.bytes(n, "inline uniform block data");
            break;
        case Kind::Unsupported:
            break;
        }
    }
    if (!d.ok()) return false;
    out.entryCount = count;
    out.pEntries = entries;
    out.dataSize = canonical_template_layout(std::span<VkDescriptorUpdateTemplateEntry>(layout, count));
    const void *pData = nullptr;
    std::string error;
    if (!layout_template_data(out, std::span<const VkDescriptorUpdateTemplateEntry>(layout, count), d.arena(),
                              pData, &error)) {
        d.fail(error);
        return false;
    }
    out.pData = pData;
    return true;
}

bool layout_template_data(const DecodedTemplateData &data,
                          std::span<const VkDescriptorUpdateTemplateEntry> entries, Arena &arena,
                          const void *&pData, std::string *error) {
    pData = nullptr;
    if (entries.size() != data.entryCount) {
        if (error)
            *error = "template update has " + std::to_string(data.entryCount) + " entries, the template " +
                     std::to_string(entries.size());
        return false;
    }
    size_t size = 8; // never empty: drivers may read a non-null pData
    for (uint32_t i = 0; i < data.entryCount; ++i) {
        const DecodedTemplateEntry &d = data.pEntries[i];
        const VkDescriptorUpdateTemplateEntry &t = entries[i];
        if (d.dstBinding != t.dstBinding || d.dstArrayElement != t.dstArrayElement ||
            d.descriptorCount != t.descriptorCount || d.descriptorType != t.descriptorType) {
            if (error) *error = "template update entry " + std::to_string(i) + " does not match the template";
            return false;
        }
        if (d.descriptorCount == 0) continue;
        const size_t element = template_descriptor_size(t.descriptorType);
        const size_t stride = t.descriptorType == VK_DESCRIPTOR_TYPE_INLINE_UNIFORM_BLOCK ? 1 : t.stride;
        if (stride < element && d.descriptorCount > 1) {
            if (error)
                *error = "template entry " + std::to_string(i) + " has a stride below its descriptor size";
            return false;
        }
        size = std::max(size, t.offset + stride * (d.descriptorCount - 1) + element);
    }
    auto *out = static_cast<uint8_t *>(arena.allocate(size, 8));
    if (!out) {
        if (error) *error = "template data of " + std::to_string(size) + " bytes exceeds the arena limit";
        return false;
    }
    for (uint32_t i = 0; i < data.entryCount; ++i) {
        const DecodedTemplateEntry &d = data.pEntries[i];
        const VkDescriptorUpdateTemplateEntry &t = entries[i];
        if (d.descriptorCount == 0) continue;
        if (d.pInlineData) {
            std::memcpy(out + t.offset, d.pInlineData, d.descriptorCount);
            continue;
        }
        for (uint32_t j = 0; j < d.descriptorCount; ++j) {
            uint8_t *p = out + t.offset + size_t{j} * t.stride;
            if (d.pImageInfo) std::memcpy(p, &d.pImageInfo[j], sizeof(VkDescriptorImageInfo));
            if (d.pBufferInfo) std::memcpy(p, &d.pBufferInfo[j], sizeof(VkDescriptorBufferInfo));
            if (d.pTexelBufferView) std::memcpy(p, &d.pTexelBufferView[j], sizeof(VkBufferView));
        }
    }
    pData = out;
    return true;
}

} // namespace splitvk::codec
