#include "memory_rebind.h"

#include "vk_codec.h"

#include <algorithm>
#include <cstdio>
#include <cstring>

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
    resources_[codec::handle_value(buffer)] = r;
}

void MemoryRebind::image_created(VkImage image, const VkImageCreateInfo &info) {
    Resource r;
    r.is_image = true;
    r.tiling = info.tiling;
    resources_[codec::handle_value(image)] = r;
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
        // The client wrote its linear image with ITS subresource layout, which the wire does not
        // carry: bytes are copied 1:1, which is exact when both sides lay the image out alike
        // (same driver); see the header.
        resource.client_size = req.size;
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
    const VkDeviceSize end = begin + std::min(resource.client_size, resource.mapped_size);
    for (auto it = memory.pages.lower_bound(begin / kPageSize); it != memory.pages.end(); ++it) {
        const VkDeviceSize page_begin = it->first * kPageSize;
        if (page_begin >= end) break;
        const VkDeviceSize from = std::max(begin, page_begin);
        const VkDeviceSize to = std::min(end, page_begin + kPageSize);
        std::memcpy(resource.mapped + (from - begin), it->second.get() + (from - page_begin), to - from);
    }
}

bool MemoryRebind::write(uint64_t memory_id, VkDeviceSize offset, std::span<const uint8_t> bytes,
                         std::string *error) {
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
        const VkDeviceSize r_end = r_begin + std::min(r.client_size, r.mapped_size);
        const VkDeviceSize from = std::max(offset, r_begin);
        const VkDeviceSize to = std::min(end, r_end);
        if (from >= to) continue;
        std::memcpy(r.mapped + (from - r_begin), bytes.data() + (from - offset), to - from);
    }
    return true;
}

} // namespace splitvk::agent
