#pragma once

// A buffer in host-visible memory, mapped for its whole life: the layer's own staging for what it
// reads back (verification, snapshots) and what it uploads (fovea tiles).

#include "core/device.h"

#include <cstddef>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

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
bool create_host_buffer(const DeviceState &device, VkDeviceSize size, VkBufferUsageFlags usage,
                        HostAccess access, HostBuffer *out, std::string *error);
void destroy_host_buffer(const DeviceState &device, HostBuffer &buffer);
// Non-coherent memory: makes the device's writes visible to the host, or the host's to the device.
void invalidate_host_buffer(const DeviceState &device, const HostBuffer &buffer);
void flush_host_buffer(const DeviceState &device, const HostBuffer &buffer);

// Upload memory that the fovea tiles are decoded straight into: a decoder thread takes
// a buffer, writes the tile's pixels into its mapping and flushes it; the composite copies the
// tile's rect from it into the swapchain image on the GPU, and holds it until that copy's fence
// has signalled. A buffer goes back to the pool when its last holder lets go, so a stream of
// same-sized tiles reuses a handful of buffers instead of allocating per frame. Thread-safe.
class UploadPool {
public:
    explicit UploadPool(const DeviceState &device);
    ~UploadPool(); // close()
    UploadPool(const UploadPool &) = delete;
    UploadPool &operator=(const UploadPool &) = delete;

    // A mapped buffer (TRANSFER_SRC) of at least `bytes`; nullptr and *error when none can be
    // allocated.
    std::shared_ptr<const HostBuffer> take(VkDeviceSize bytes, std::string *error);
    // After the host wrote a buffer: makes the writes visible to the device (non-coherent memory).
    void flush(const HostBuffer &buffer) const;
    // Before vkDestroyDevice, once every holder has let go (the tile stream, the present thread
    // and the compositors are gone): frees the pool's buffers. A buffer returned later is leaked
    // rather than freed on a device that may no longer exist.
    void close();

private:
    struct State {
        const DeviceState *device = nullptr;
        std::mutex mutex;
        std::vector<HostBuffer> free; // under mutex
        size_t taken = 0;             // buffers out, under mutex
        bool closed = false;          // under mutex
    };
    std::shared_ptr<State> state_;
};

} // namespace splitvk
