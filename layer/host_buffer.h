#pragma once

// A buffer in host-visible memory, mapped for its whole life: the layer's own staging for what it
// reads back (verification, snapshots) and what it uploads (fovea tiles).

#include "device.h"

#include <string>

namespace splitvk {

struct HostBuffer {
    VkBuffer buffer = VK_NULL_HANDLE;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    uint8_t *mapped = nullptr;
    VkDeviceSize size = 0;
    bool coherent = true;
};

// Which memory suits the buffer: one the host reads every byte of prefers HOST_CACHED (uncached
// reads are slow on discrete GPUs), one it only writes prefers HOST_COHERENT (no flush).
enum class HostAccess { Read, Write };

// False with one line in `error`; whatever was created is destroyed again.
bool create_host_buffer(DeviceState &device, VkDeviceSize size, VkBufferUsageFlags usage, HostAccess access,
                        HostBuffer *out, std::string *error);
void destroy_host_buffer(DeviceState &device, HostBuffer &buffer);
// Non-coherent memory: makes the device's writes visible to the host, or the host's to the device.
void invalidate_host_buffer(DeviceState &device, const HostBuffer &buffer);
void flush_host_buffer(DeviceState &device, const HostBuffer &buffer);

} // namespace splitvk
