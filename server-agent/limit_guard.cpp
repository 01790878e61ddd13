#include "limit_guard.h"

#include "log.h"
#include "vk_envelope_tables.h"

#include <algorithm>
#include <iterator>

namespace splitvk::agent {
namespace {

bool is_buffer_descriptor(VkDescriptorType type) {
    switch (type) {
    case VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER:
    case VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER_DYNAMIC:
    case VK_DESCRIPTOR_TYPE_STORAGE_BUFFER:
    case VK_DESCRIPTOR_TYPE_STORAGE_BUFFER_DYNAMIC:
        return true;
    default:
        return false;
    }
}

bool is_uniform(VkDescriptorType type) {
    return type == VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER || type == VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER_DYNAMIC;
}

std::string hex(uint64_t v) {
    char text[24];
    std::snprintf(text, sizeof(text), "0x%llx", static_cast<unsigned long long>(v));
    return text;
}

VkFormatFeatureFlags features_for_usage(VkImageUsageFlags usage) {
    VkFormatFeatureFlags needed = 0;
    if (usage & VK_IMAGE_USAGE_SAMPLED_BIT) needed |= VK_FORMAT_FEATURE_SAMPLED_IMAGE_BIT;
    if (usage & VK_IMAGE_USAGE_STORAGE_BIT) needed |= VK_FORMAT_FEATURE_STORAGE_IMAGE_BIT;
    if (usage & VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT) needed |= VK_FORMAT_FEATURE_COLOR_ATTACHMENT_BIT;
    if (usage & VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT)
        needed |= VK_FORMAT_FEATURE_DEPTH_STENCIL_ATTACHMENT_BIT;
    if (usage & VK_IMAGE_USAGE_TRANSFER_SRC_BIT) needed |= VK_FORMAT_FEATURE_TRANSFER_SRC_BIT;
    if (usage & VK_IMAGE_USAGE_TRANSFER_DST_BIT) needed |= VK_FORMAT_FEATURE_TRANSFER_DST_BIT;
    return needed;
}

} // namespace

LimitGuard::LimitGuard(uint64_t session_id, protocol::DeviceDescription device)
    : session_id_(session_id), device_(std::move(device)) {}

void LimitGuard::violation(const std::string &kind, const std::string &detail) {
    if (logged_.insert(kind).second)
        SPLITVK_ERROR("session %llu: %s (this GPU: %s); frames that use it are sent flagged invalid and the "
                      "client shows its periphery there",
                      static_cast<unsigned long long>(session_id_), detail.c_str(), device_.name.c_str());
}

const VkWriteDescriptorSet *LimitGuard::descriptor_writes(uint32_t count, const VkWriteDescriptorSet *writes,
                                                          std::vector<VkWriteDescriptorSet> &rewritten,
                                                          std::vector<VkDescriptorBufferInfo> &storage) {
    const VkPhysicalDeviceLimits &limits = device_.limits;
    rewritten.assign(writes, writes + count);
    size_t infos = 0;
    for (uint32_t i = 0; i < count; ++i)
        if (is_buffer_descriptor(writes[i].descriptorType) && writes[i].pBufferInfo)
            infos += writes[i].descriptorCount;
    storage.clear();
    storage.reserve(infos); // no reallocation: rewritten writes point into it
    for (uint32_t i = 0; i < count; ++i) {
        const VkWriteDescriptorSet &w = writes[i];
        auto &taints = tainted_descriptors_[w.dstSet];
        if (!is_buffer_descriptor(w.descriptorType) || !w.pBufferInfo) {
            for (uint32_t e = 0; e < w.descriptorCount; ++e)
                taints.erase({w.dstBinding, w.dstArrayElement + e});
            continue;
        }
        const bool uniform = is_uniform(w.descriptorType);
        const VkDeviceSize alignment =
            uniform ? limits.minUniformBufferOffsetAlignment : limits.minStorageBufferOffsetAlignment;
        const VkDeviceSize max_range = uniform ? limits.maxUniformBufferRange : limits.maxStorageBufferRange;
        const size_t first = storage.size();
        for (uint32_t e = 0; e < w.descriptorCount; ++e) {
            VkDescriptorBufferInfo info = w.pBufferInfo[e];
            const std::pair<uint32_t, uint32_t> slot{w.dstBinding, w.dstArrayElement + e};
            bool bad = false;
            // A dynamic descriptor's offset is added to the bind's dynamic offset; each must be
            // aligned (VUID-VkWriteDescriptorSet-descriptorType-00327/-00328).
            if (alignment > 1 && info.offset % alignment != 0) {
                violation(uniform ? "uniform offset" : "storage offset",
                          std::string(uniform ? "uniform" : "storage") + " buffer descriptor offset " +
                              hex(info.offset) + " is not a multiple of min" +
                              (uniform ? "Uniform" : "Storage") + "BufferOffsetAlignment " + hex(alignment));
                info.offset -= info.offset % alignment;
                bad = true;
            }
            if (info.range != VK_WHOLE_SIZE && info.range > max_range) {
                violation(uniform ? "uniform range" : "storage range",
                          std::string(uniform ? "uniform" : "storage") + " buffer descriptor range " +
                              std::to_string(info.range) + " is over max" +
                              (uniform ? "Uniform" : "Storage") + "BufferRange " + std::to_string(max_range));
                info.range = max_range;
                bad = true;
            }
            if (bad)
                taints.insert(slot);
            else
                taints.erase(slot);
            storage.push_back(info);
        }
        rewritten[i].pBufferInfo = storage.data() + first;
    }
    return rewritten.data();
}

void LimitGuard::descriptor_copies(uint32_t count, const VkCopyDescriptorSet *copies) {
    for (uint32_t i = 0; i < count; ++i) {
        const VkCopyDescriptorSet &c = copies[i];
        const auto src = tainted_descriptors_.find(c.srcSet);
        auto &dst = tainted_descriptors_[c.dstSet];
        for (uint32_t e = 0; e < c.descriptorCount; ++e) {
            const bool bad = src != tainted_descriptors_.end() &&
                             src->second.count({c.srcBinding, c.srcArrayElement + e}) != 0;
            if (bad)
                dst.insert({c.dstBinding, c.dstArrayElement + e});
            else
                dst.erase({c.dstBinding, c.dstArrayElement + e});
        }
    }
}

void LimitGuard::descriptor_sets_freed(uint32_t count, const VkDescriptorSet *sets) {
    for (uint32_t i = 0; i < count; ++i)
        tainted_descriptors_.erase(sets[i]);
}

void LimitGuard::command_buffer_begun(VkCommandBuffer command_buffer) {
    command_buffers_[command_buffer] = Recorded{};
}

void LimitGuard::untranslatable_address(VkCommandBuffer command_buffer, const std::string &detail) {
    if (logged_.insert("untranslatable address").second)
        SPLITVK_ERROR("session %llu: %s, which the agent cannot translate; it skips the command buffers that "
                      "use it, and sends every frame from now on flagged invalid: the client shows its "
                      "periphery there",
                      static_cast<unsigned long long>(session_id_), detail.c_str());
    Recorded &recorded = command_buffers_[command_buffer];
    recorded.tainted = true;
    recorded.skip = true;
}

bool LimitGuard::must_skip(VkCommandBuffer command_buffer) const {
    const auto it = command_buffers_.find(command_buffer);
    return it != command_buffers_.end() && it->second.skip;
}

void LimitGuard::executed(VkCommandBuffer primary, uint32_t count, const VkCommandBuffer *secondaries) {
    for (uint32_t i = 0; i < count && secondaries; ++i) {
        const auto it = command_buffers_.find(secondaries[i]);
        if (it == command_buffers_.end()) continue;
        const Recorded secondary = it->second; // the primary's entry may rehash the map
        Recorded &recorded = command_buffers_[primary];
        recorded.tainted = recorded.tainted || secondary.tainted;
        recorded.skip = recorded.skip || secondary.skip;
        recorded.sets.insert(recorded.sets.end(), secondary.sets.begin(), secondary.sets.end());
    }
}

void LimitGuard::sets_bound(VkCommandBuffer command_buffer, uint32_t set_count, const VkDescriptorSet *sets,
                            uint32_t dynamic_count, const uint32_t *dynamic_offsets) {
    Recorded &recorded = command_buffers_[command_buffer];
    recorded.sets.insert(recorded.sets.end(), sets, sets + set_count);
    // Without the set layouts the type of each dynamic offset is unknown here, so each is held to
    // the smaller of the two alignments: what no dynamic descriptor of either type can be below.
    const VkDeviceSize alignment = std::min(device_.limits.minUniformBufferOffsetAlignment,
                                            device_.limits.minStorageBufferOffsetAlignment);
    for (uint32_t i = 0; i < dynamic_count && dynamic_offsets; ++i) {
        if (alignment > 1 && dynamic_offsets[i] % alignment != 0) {
            violation("dynamic offset", "dynamic offset " + hex(dynamic_offsets[i]) +
                                            " is not a multiple of the buffer offset alignment " +
                                            hex(alignment));
            recorded.tainted = true;
        }
    }
}

void LimitGuard::image_created(const VkImageCreateInfo &info) {
    const VkPhysicalDeviceLimits &limits = device_.limits;
    uint32_t max_dimension = limits.maxImageDimension2D;
    if (info.imageType == VK_IMAGE_TYPE_1D) max_dimension = limits.maxImageDimension1D;
    if (info.imageType == VK_IMAGE_TYPE_3D) max_dimension = limits.maxImageDimension3D;
    if (info.flags & VK_IMAGE_CREATE_CUBE_COMPATIBLE_BIT)
        max_dimension = std::min(max_dimension, limits.maxImageDimensionCube);
    const uint32_t largest = std::max({info.extent.width, info.extent.height, info.extent.depth});
    if (largest > max_dimension) {
        violation("image extent", "an image of " + std::to_string(info.extent.width) + "x" +
                                      std::to_string(info.extent.height) + "x" +
                                      std::to_string(info.extent.depth) +
                                      " is over the image dimension limit " + std::to_string(max_dimension));
        session_tainted_ = true;
    }
    if (info.arrayLayers > limits.maxImageArrayLayers) {
        violation("image layers", "an image of " + std::to_string(info.arrayLayers) +
                                      " layers is over maxImageArrayLayers " +
                                      std::to_string(limits.maxImageArrayLayers));
        session_tainted_ = true;
    }
    const auto &formats = envelope::kEnvelopeFormats;
    const auto *it = std::find(std::begin(formats), std::end(formats), info.format);
    if (it != std::end(formats)) {
        const VkFormatProperties &properties = device_.formats[static_cast<size_t>(it - std::begin(formats))];
        const VkFormatFeatureFlags have = info.tiling == VK_IMAGE_TILING_LINEAR
                                              ? properties.linearTilingFeatures
                                              : properties.optimalTilingFeatures;
        const VkFormatFeatureFlags need = features_for_usage(info.usage);
        if ((have & need) != need) {
            violation("image format " + std::to_string(info.format),
                      "an image of VkFormat " + std::to_string(info.format) + " with usage " +
                          hex(info.usage) + " needs format features " + hex(need) + ", this GPU has " +
                          hex(have));
            session_tainted_ = true;
        }
    }
}

bool LimitGuard::set_tainted(VkDescriptorSet set) const {
    const auto it = tainted_descriptors_.find(set);
    return it != tainted_descriptors_.end() && !it->second.empty();
}

void LimitGuard::submitted(uint32_t count, const VkCommandBuffer *command_buffers) {
    for (uint32_t i = 0; i < count; ++i)
        if (must_skip(command_buffers[i])) session_tainted_ = true;
    if (session_tainted_) frame_invalid_ = true;
    for (uint32_t i = 0; i < count && !frame_invalid_; ++i) {
        const auto it = command_buffers_.find(command_buffers[i]);
        if (it == command_buffers_.end()) continue;
        if (it->second.tainted || std::any_of(it->second.sets.begin(), it->second.sets.end(),
                                              [&](VkDescriptorSet set) { return set_tainted(set); }))
            frame_invalid_ = true;
    }
}

bool LimitGuard::take_frame_invalid() {
    const bool invalid = frame_invalid_ || session_tainted_;
    frame_invalid_ = false;
    if (invalid) ++invalid_frames_;
    return invalid;
}

} // namespace splitvk::agent
