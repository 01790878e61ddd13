#include "core/host_buffer.h"

#include "core/vk_util.h"
#include "log.h"

#include <algorithm>

namespace splitvk {
namespace {

VkMappedMemoryRange whole(const HostBuffer &buffer) {
    VkMappedMemoryRange range{};
    range.sType = VK_STRUCTURE_TYPE_MAPPED_MEMORY_RANGE;
    range.memory = buffer.memory;
    range.size = VK_WHOLE_SIZE;
    return range;
}

} // namespace

bool create_host_buffer(const DeviceState &dev, VkDeviceSize size, VkBufferUsageFlags usage,
                        HostAccess access, HostBuffer *out, std::string *error) {
    const VkDevice d = dev.handle;
    const auto &k = dev.dispatch;
    HostBuffer b;
    VkBufferCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
    info.size = size;
    info.usage = usage;
    if (k.CreateBuffer(d, &info, nullptr, &b.buffer) != VK_SUCCESS) {
        *error = "cannot create a staging buffer of " + std::to_string(size) + " bytes";
        return false;
    }
    VkMemoryRequirements req{};
    k.GetBufferMemoryRequirements(d, b.buffer, &req);
    const VkMemoryPropertyFlags preferred = access == HostAccess::Read ? VK_MEMORY_PROPERTY_HOST_CACHED_BIT
                                                                       : VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
    uint32_t type =
        find_memory_type(dev, req.memoryTypeBits, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | preferred);
    if (type == UINT32_MAX)
        type = find_memory_type(dev, req.memoryTypeBits, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT);
    VkMemoryAllocateInfo alloc{};
    alloc.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
    alloc.allocationSize = req.size;
    alloc.memoryTypeIndex = type;
    void *mapped = nullptr;
    if (type == UINT32_MAX || k.AllocateMemory(d, &alloc, nullptr, &b.memory) != VK_SUCCESS ||
        k.BindBufferMemory(d, b.buffer, b.memory, 0) != VK_SUCCESS ||
        k.MapMemory(d, b.memory, 0, VK_WHOLE_SIZE, 0, &mapped) != VK_SUCCESS) {
        *error = "cannot allocate " + std::to_string(size) + " bytes of host-visible memory";
        destroy_host_buffer(dev, b);
        return false;
    }
    b.mapped = static_cast<uint8_t *>(mapped);
    b.size = size;
    b.coherent = dev.memory_properties.memoryTypes[type].propertyFlags & VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
    *out = b;
    return true;
}

void destroy_host_buffer(const DeviceState &dev, HostBuffer &b) {
    if (b.buffer) dev.dispatch.DestroyBuffer(dev.handle, b.buffer, nullptr);
    if (b.memory) dev.dispatch.FreeMemory(dev.handle, b.memory, nullptr); // unmaps
    b = HostBuffer{};
}

void invalidate_host_buffer(const DeviceState &dev, const HostBuffer &b) {
    if (b.coherent || !b.memory) return;
    const VkMappedMemoryRange range = whole(b);
    dev.dispatch.InvalidateMappedMemoryRanges(dev.handle, 1, &range);
}

void flush_host_buffer(const DeviceState &dev, const HostBuffer &b) {
    if (b.coherent || !b.memory) return;
    const VkMappedMemoryRange range = whole(b);
    dev.dispatch.FlushMappedMemoryRanges(dev.handle, 1, &range);
}

// ---------------------------------------------------------------------------- upload pool

namespace {
// Buffers kept for reuse beyond those in use: two eyes times the frames that can be in flight at
// once (decoded ahead, in the present thread, in the compositor's slots) is well below this.
constexpr size_t kMaxFreeUploads = 32;
} // namespace

UploadPool::UploadPool(const DeviceState &device) : state_(std::make_shared<State>()) {
    state_->device = &device;
}

UploadPool::~UploadPool() {
    close();
}

std::shared_ptr<const HostBuffer> UploadPool::take(VkDeviceSize bytes, std::string *error) {
    HostBuffer buffer;
    {
        std::lock_guard lock(state_->mutex);
        if (state_->closed) {
            *error = "the device is being destroyed";
            return nullptr;
        }
        auto &free = state_->free;
        const auto fits =
            std::find_if(free.begin(), free.end(), [&](const HostBuffer &b) { return b.size >= bytes; });
        if (fits != free.end()) {
            buffer = *fits;
            free.erase(fits);
        }
        ++state_->taken;
    }
    // The decoders only write here, whole rows in order, and sum the pixels before they store them
    // (tile_codec.h): memory the host writes, uncached where that is what the device has.
    if (!buffer.buffer && !create_host_buffer(*state_->device, bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                                              HostAccess::Write, &buffer, error)) {
        std::lock_guard lock(state_->mutex);
        --state_->taken;
        return nullptr;
    }
    std::shared_ptr<State> state = state_;
    return std::shared_ptr<const HostBuffer>(new HostBuffer(buffer), [state](const HostBuffer *b) {
        HostBuffer back = *b;
        delete b;
        std::lock_guard lock(state->mutex);
        --state->taken;
        if (state->closed) {
            SPLITVK_DEBUG("upload pool: a tile buffer returned after the pool closed is leaked");
        } else if (state->free.size() < kMaxFreeUploads) {
            state->free.push_back(back);
        } else {
            destroy_host_buffer(*state->device, back);
        }
    });
}

void UploadPool::flush(const HostBuffer &buffer) const {
    flush_host_buffer(*state_->device, buffer);
}

void UploadPool::close() {
    std::lock_guard lock(state_->mutex);
    if (state_->closed) return;
    state_->closed = true;
    if (state_->taken) SPLITVK_DEBUG("upload pool: %zu tile buffers still held at close", state_->taken);
    for (HostBuffer &b : state_->free)
        destroy_host_buffer(*state_->device, b);
    state_->free.clear();
}

} // namespace splitvk
