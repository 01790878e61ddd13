#include "memory_rebind.h"

#include "queued_writes.h"
#include "vk_codec.h"
#include "vk_format_info.h"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <map>
#include <tuple>

namespace splitvk::agent {

namespace {

std::string hex(uint64_t v) {
    char text[24];
    std::snprintf(text, sizeof(text), "0x%llx", static_cast<unsigned long long>(v));
    return text;
}

// "over --max-gpu-memory (8589934592 bytes)": the line names the flag that raises the cap.
std::string over(const char *flag, uint64_t limit) {
    return std::string("over ") + flag + " (" + std::to_string(limit) + " bytes)";
}

} // namespace

MemoryRebind::~MemoryRebind() {
    for (auto &[handle, resource] : resources_)
        release(resource);
}

bool MemoryRebind::allocate(uint64_t memory_id, VkDeviceSize size, std::string *error) {
    if (size == 0) {
        *error = "allocation size 0";
        return false;
    }
    auto existing = memories_.find(memory_id);
    const uint64_t replaced = existing == memories_.end() ? 0 : existing->second.size;
    const uint64_t total = client_gpu_bytes_ - replaced;
    if (size > limits_.gpu_bytes || total > limits_.gpu_bytes - size) {
        *error = std::to_string(size) + " bytes would take the session's device memory to " +
                 std::to_string(total + std::min<uint64_t>(size, UINT64_MAX - total)) + " bytes, " +
                 over("--max-gpu-memory", limits_.gpu_bytes);
        return false;
    }
    client_gpu_bytes_ = total + size;
    memories_[memory_id].size = size;
    return true;
}

void MemoryRebind::free(uint64_t memory_id) {
    auto it = memories_.find(memory_id);
    if (it == memories_.end()) return;
    // Resources still bound keep their own allocation (and their contents) until destroyed.
    for (uint64_t handle : it->second.bound) {
        auto r = resources_.find(handle);
        if (r != resources_.end()) r->second.memory_id = 0;
    }
    client_gpu_bytes_ -= it->second.size;
    host_bytes_ -= it->second.pages.size() * kPageSize;
    memories_.erase(it);
}

void MemoryRebind::buffer_created(VkBuffer buffer, const VkBufferCreateInfo &info) {
    Resource r;
    r.client_size = info.size;
    r.device_address = (info.usage & VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT) != 0;
    resources_[codec::handle_value(buffer)] = r;
}

std::optional<VkDeviceSize> MemoryRebind::bound_buffer_size(VkBuffer buffer) const {
    const auto it = resources_.find(codec::handle_value(buffer));
    if (it == resources_.end() || it->second.is_image || !it->second.memory) return std::nullopt;
    return it->second.client_size;
}

void MemoryRebind::image_created(VkImage image, const VkImageCreateInfo &info) {
    Resource r;
    r.is_image = true;
    r.tiling = info.tiling;
    r.image_type = info.imageType;
    r.format = info.format;
    r.extent = info.extent;
    r.mip_levels = info.mipLevels;
    r.array_layers = info.arrayLayers;
    resources_[codec::handle_value(image)] = r;
}

namespace {

// Bytes of the client's range that reach the agent's allocation: copied 1:1, no more than it
// holds; re-laid, every byte of the client's image (place() keeps to the agent's rows).
template <class Resource>
VkDeviceSize covered(const Resource &r) {
    return r.relayout.empty() ? std::min(r.client_size, r.mapped_size) : r.client_size;
}

} // namespace

bool MemoryRebind::image_layouts(VkImage image, const protocol::ImageLayouts &layouts, std::string *error,
                                 std::string *warning) {
    auto it = resources_.find(codec::handle_value(image));
    if (it == resources_.end() || !it->second.is_image) {
        *error = "image " + hex(codec::handle_value(image)) + " was not created through the stream";
        return false;
    }
    Resource &r = it->second;
    if (r.tiling != VK_IMAGE_TILING_LINEAR) {
        *error = "the image's tiling is not VK_IMAGE_TILING_LINEAR";
        return false;
    }
    if (r.has_layouts) {
        *error = "the image's layouts came already";
        return false;
    }
    if (layouts.format != static_cast<uint32_t>(r.format) || layouts.width != r.extent.width ||
        layouts.height != r.extent.height || layouts.depth != r.extent.depth ||
        layouts.mip_levels != r.mip_levels || layouts.array_layers != r.array_layers) {
        *error = "format, extent, mip levels or array layers differ from the image's vkCreateImage";
        return false;
    }
    r.has_layouts = true;
    const FormatInfo format = format_info(r.format);
    if (format.block_bytes == 0 || (format.depth && format.stencil)) {
        *warning = "linear image of VkFormat " + std::to_string(r.format) +
                   " (multi-planar or depth/stencil): its bytes are copied 1:1, exact only when the "
                   "client's driver lays it out as the agent's does";
        r.has_layouts = false;
        return true;
    }
    const VkImageAspectFlagBits aspect = format.depth     ? VK_IMAGE_ASPECT_DEPTH_BIT
                                         : format.stencil ? VK_IMAGE_ASPECT_STENCIL_BIT
                                                          : VK_IMAGE_ASPECT_COLOR_BIT;
    VkMemoryRequirements req{};
    vkGetImageMemoryRequirements(context_.device, image, &req);
    const bool is_3d = r.image_type == VK_IMAGE_TYPE_3D;
    std::map<std::tuple<uint32_t, uint32_t>, const protocol::SubresourceLayout *> by_subresource;
    for (const protocol::SubresourceLayout &sub : layouts.subresources)
        if (sub.aspect == static_cast<uint32_t>(aspect))
            by_subresource[{sub.mip_level, sub.array_layer}] = &sub;
    std::vector<Relayout> relayout;
    bool same = true;
    VkDeviceSize client_end = 0;
    for (uint32_t mip = 0; mip < r.mip_levels; ++mip) {
        const auto at_mip = [mip](uint32_t v) { return std::max(v >> mip, 1u); };
        RowShape shape;
        shape.row_bytes =
            VkDeviceSize{(at_mip(r.extent.width) + format.block_width - 1) / format.block_width} *
            format.block_bytes;
        shape.rows = (at_mip(r.extent.height) + format.block_height - 1) / format.block_height;
        shape.slices = is_3d ? at_mip(r.extent.depth) : 1;
        for (uint32_t layer = 0; layer < r.array_layers; ++layer) {
            const std::string which = "mip " + std::to_string(mip) + ", layer " + std::to_string(layer);
            const auto found = by_subresource.find({mip, layer});
            if (found == by_subresource.end()) {
                *error = "no layout for " + which;
                return false;
            }
            const protocol::SubresourceLayout *client = found->second;
            Relayout l;
            l.shape = shape;
            l.client = {client->offset, client->row_pitch, client->depth_pitch};
            uint64_t client_span = 0;
            if (!row_span(shape, l.client, &client_span) || client_span > client->size) {
                *error = "the layout of " + which + " (row pitch " + std::to_string(client->row_pitch) +
                         ", depth pitch " + std::to_string(client->depth_pitch) + ", size " +
                         std::to_string(client->size) + ") cannot hold " + std::to_string(shape.rows) +
                         " rows of " + std::to_string(shape.row_bytes) + " bytes";
                return false;
            }
            const VkImageSubresource sub{static_cast<VkImageAspectFlags>(aspect), mip, layer};
            VkSubresourceLayout agent{};
            vkGetImageSubresourceLayout(context_.device, image, &sub, &agent);
            l.agent = {agent.offset, agent.rowPitch, agent.depthPitch};
            uint64_t agent_span = 0;
            if (!row_span(shape, l.agent, &agent_span) || agent.offset > req.size ||
                agent_span > req.size - agent.offset) {
                *error = "the agent's own layout of " + which + " does not fit its memory requirements";
                return false;
            }
            client_end = std::max(client_end, client->offset + client_span);
            // Pitches that nothing steps over need not agree.
            same = same && l.client.offset == l.agent.offset &&
                   (shape.rows == 1 || l.client.row_pitch == l.agent.row_pitch) &&
                   (shape.slices == 1 || l.client.depth_pitch == l.agent.depth_pitch);
            relayout.push_back(l);
        }
    }
    if (!same) r.relayout = std::move(relayout);
    r.client_image_bytes = client_end;
    if (r.memory) { // bound before its layouts came: lay the shadow out again
        auto m = memories_.find(r.memory_id);
        if (r.mapped) std::memset(r.mapped, 0, r.mapped_size);
        if (m != memories_.end()) {
            r.client_size = std::min(r.client_image_bytes, m->second.size - r.client_offset);
            copy_shadow(m->second, r);
        }
    }
    return true;
}

void MemoryRebind::place(const Resource &r, VkDeviceSize at, const uint8_t *src, VkDeviceSize n) {
    if (r.relayout.empty()) {
        std::memcpy(r.mapped + at, src, n);
        return;
    }
    for (const Relayout &l : r.relayout)
        relay_rows(l, r.mapped, at, src, n);
}

void MemoryRebind::release(Resource &resource) {
    if (resource.memory) {
        if (resource.mapped) vkUnmapMemory(context_.device, resource.memory);
        vkFreeMemory(context_.device, resource.memory, nullptr);
    }
    agent_gpu_bytes_ -= resource.allocated;
    resource = {};
}

void MemoryRebind::buffer_destroyed(VkBuffer buffer) {
    auto it = resources_.find(codec::handle_value(buffer));
    if (it == resources_.end()) return;
    if (it->second.memory_id) {
        auto m = memories_.find(it->second.memory_id);
        if (m != memories_.end()) m->second.bound.erase(it->first);
        it->second.memory_id = 0;
    }
    release(it->second);
    resources_.erase(it);
}

void MemoryRebind::image_destroyed(VkImage image) {
    buffer_destroyed(codec::to_handle<VkBuffer>(codec::handle_value(image)));
}

bool MemoryRebind::bind_buffer(VkBuffer buffer, uint64_t memory_id, VkDeviceSize offset, std::string *error) {
    VkMemoryRequirements req{};
    vkGetBufferMemoryRequirements(context_.device, buffer, &req);
    return bind(codec::handle_value(buffer), memory_id, offset, req, error);
}

bool MemoryRebind::bind_image(VkImage image, uint64_t memory_id, VkDeviceSize offset, std::string *error) {
    VkMemoryRequirements req{};
    vkGetImageMemoryRequirements(context_.device, image, &req);
    return bind(codec::handle_value(image), memory_id, offset, req, error);
}

bool MemoryRebind::bind(uint64_t handle, uint64_t memory_id, VkDeviceSize offset,
                        const VkMemoryRequirements &req, std::string *error) {
    auto r = resources_.find(handle);
    if (r == resources_.end()) {
        *error = "resource " + hex(handle) + " was not created through the stream";
        return false;
    }
    Resource &resource = r->second;
    if (resource.memory) {
        *error = "resource is already bound";
        return false;
    }
    auto m = memories_.find(memory_id);
    if (m == memories_.end()) {
        *error = "unknown VkDeviceMemory id " + hex(memory_id);
        return false;
    }
    if (offset >= m->second.size) {
        *error = "memoryOffset " + std::to_string(offset) + " is beyond the allocation's " +
                 std::to_string(m->second.size) + " bytes";
        return false;
    }
    // Buffers (and linear images) are host-visible + coherent where possible, so MemoryData is
    // written directly; optimal-tiling images are device-local and only receive GPU copies.
    const bool host = !resource.is_image || resource.tiling == VK_IMAGE_TILING_LINEAR;
    int32_t type = -1;
    if (host) {
        type = context_.find_memory_type(req.memoryTypeBits, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT |
                                                                 VK_MEMORY_PROPERTY_HOST_COHERENT_BIT);
        if (type < 0 && !resource.is_image) {
            *error = "no host-visible coherent memory type for this buffer on " + context_.gpu_name;
            return false;
        }
    }
    if (type < 0)
        type = context_.find_memory_type(req.memoryTypeBits, 0, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
    if (type < 0) {
        *error = "no compatible memory type";
        return false;
    }
    if (req.size > limits_.gpu_bytes || agent_gpu_bytes_ > limits_.gpu_bytes - req.size) {
        *error =
            "the resource's own " + std::to_string(req.size) +
            " bytes would take the agent's allocations for this session to " +
            std::to_string(agent_gpu_bytes_ + std::min<uint64_t>(req.size, UINT64_MAX - agent_gpu_bytes_)) +
            " bytes, " + over("--max-gpu-memory", limits_.gpu_bytes);
        return false;
    }
    VkMemoryAllocateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
    info.allocationSize = req.size;
    info.memoryTypeIndex = static_cast<uint32_t>(type);
    // The client allocated with VK_MEMORY_ALLOCATE_DEVICE_ADDRESS_BIT for such a buffer; the agent's
    // own allocation must allow the agent's vkGetBufferDeviceAddress too (buffer_addresses.h).
    VkMemoryAllocateFlagsInfo flags_info{};
    flags_info.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_FLAGS_INFO;
    flags_info.flags = VK_MEMORY_ALLOCATE_DEVICE_ADDRESS_BIT;
    if (resource.device_address) info.pNext = &flags_info;
    VkResult result = vkAllocateMemory(context_.device, &info, nullptr, &resource.memory);
    if (result != VK_SUCCESS) {
        resource.memory = VK_NULL_HANDLE;
        *error = std::string("vkAllocateMemory (") + std::to_string(req.size) +
                 " bytes) failed: " + vk_result_name(result);
        return false;
    }
    resource.allocated = req.size;
    agent_gpu_bytes_ += req.size;
    result =
        resource.is_image
            ? vkBindImageMemory(context_.device, codec::to_handle<VkImage>(handle), resource.memory, 0)
            : vkBindBufferMemory(context_.device, codec::to_handle<VkBuffer>(handle), resource.memory, 0);
    if (result != VK_SUCCESS) {
        *error = std::string("binding the agent's own allocation failed: ") + vk_result_name(result);
        release(resource);
        return false;
    }
    resource.memory_id = memory_id;
    resource.client_offset = offset;
    m->second.bound.insert(handle);
    const auto flags = context_.memory_properties.memoryTypes[type].propertyFlags;
    if (flags & VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT) {
        void *p = nullptr;
        if (vkMapMemory(context_.device, resource.memory, 0, VK_WHOLE_SIZE, 0, &p) == VK_SUCCESS) {
            resource.mapped = static_cast<uint8_t *>(p);
            resource.mapped_size = req.size;
            std::memset(resource.mapped, 0, req.size); // the client's memory diffing assumes zeroes
        }
    }
    if (resource.is_image && resource.tiling == VK_IMAGE_TILING_LINEAR) {
        // The client's image ends where its layouts say; without them (copied 1:1), where the
        // agent's does.
        resource.client_size = resource.has_layouts ? resource.client_image_bytes : req.size;
    }
    if (!resource.is_image || resource.tiling == VK_IMAGE_TILING_LINEAR) {
        resource.client_size = std::min(resource.client_size, m->second.size - offset);
        copy_shadow(m->second, resource);
    }
    return true;
}

void MemoryRebind::copy_shadow(const ClientMemory &memory, Resource &resource) {
    if (!resource.mapped) return;
    const VkDeviceSize begin = resource.client_offset;
    const VkDeviceSize end = begin + covered(resource);
    for (auto it = memory.pages.lower_bound(begin / kPageSize); it != memory.pages.end(); ++it) {
        const VkDeviceSize page_begin = it->first * kPageSize;
        if (page_begin >= end) break;
        const VkDeviceSize from = std::max(begin, page_begin);
        const VkDeviceSize to = std::min(end, page_begin + kPageSize);
        place(resource, from - begin, it->second.get() + (from - page_begin), to - from);
    }
}

MemoryRebind::WritePlan MemoryRebind::plan_write(uint64_t memory_id, VkDeviceSize offset,
                                                 VkDeviceSize size) const {
    WritePlan plan;
    const auto m = memories_.find(memory_id);
    if (m == memories_.end()) return plan;
    for (uint64_t handle : m->second.bound) {
        const Resource &r = resources_.at(handle);
        if (!r.mapped || (r.is_image && r.tiling != VK_IMAGE_TILING_LINEAR)) continue;
        const VkDeviceSize from = std::max(offset, r.client_offset);
        const VkDeviceSize to = std::min(offset + size, r.client_offset + covered(r));
        if (from >= to) continue;
        if (r.is_image)
            plan.linear_images = true;
        else
            plan.buffer_bytes += to - from;
    }
    return plan;
}

bool MemoryRebind::write(uint64_t memory_id, VkDeviceSize offset, std::span<const uint8_t> bytes,
                         std::string *error, QueuedWrites *queued) {
    auto m = memories_.find(memory_id);
    if (m == memories_.end()) {
        *error = "unknown VkDeviceMemory id " + hex(memory_id);
        return false;
    }
    ClientMemory &memory = m->second;
    if (offset > memory.size || bytes.size() > memory.size - offset) {
        *error = std::to_string(bytes.size()) + " bytes at offset " + std::to_string(offset) +
                 " exceed the allocation's " + std::to_string(memory.size) + " bytes";
        return false;
    }
    const VkDeviceSize end = offset + bytes.size();
    for (VkDeviceSize pos = offset; pos < end;) {
        const VkDeviceSize page = pos / kPageSize;
        const VkDeviceSize in_page = pos - page * kPageSize;
        const VkDeviceSize n = std::min(end - pos, kPageSize - in_page);
        auto &slot = memory.pages[page];
        if (!slot) {
            if (host_bytes_ + kPageSize > limits_.host_bytes) {
                memory.pages.erase(page);
                *error = "keeping these bytes would take the session's host memory to " +
                         std::to_string(host_bytes_ + kPageSize) + " bytes, " +
                         over("--max-host-memory", limits_.host_bytes);
                return false;
            }
            slot = std::make_unique<uint8_t[]>(kPageSize); // value-initialised: zeroes
            host_bytes_ += kPageSize;
        }
        std::memcpy(slot.get() + in_page, bytes.data() + (pos - offset), n);
        pos += n;
    }
    for (uint64_t handle : memory.bound) {
        const Resource &r = resources_.at(handle);
        if (!r.mapped || (r.is_image && r.tiling != VK_IMAGE_TILING_LINEAR)) continue;
        const VkDeviceSize r_begin = r.client_offset;
        const VkDeviceSize r_end = r_begin + covered(r);
        const VkDeviceSize from = std::max(offset, r_begin);
        const VkDeviceSize to = std::min(end, r_end);
        if (from >= to) continue;
        if (queued && !r.is_image) {
            if (!queued->stage(codec::to_handle<VkBuffer>(handle), from - r_begin,
                               bytes.data() + (from - offset), to - from, error))
                return false;
            continue;
        }
        place(r, from - r_begin, bytes.data() + (from - offset), to - from);
    }
    return true;
}

} // namespace splitvk::agent
