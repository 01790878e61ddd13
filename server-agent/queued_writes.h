#pragma once

// MemoryData without idling the queue. What the client's host wrote arrives as
// MemoryData between submits, and must reach the agent's resources after the work submitted before
// it has stopped using them and before the work submitted after it starts. Waiting for the queue
// to go idle does that, but stalls the replay on every memory update (a frame's uniforms). Instead,
// bytes for buffers are put in a staging buffer of this class's and copied by the GPU into the
// buffer, in a batch submitted on the replay queue before the next thing that uses the queue: the
// queue orders it after the earlier work and before the later, as the client's host write was.
// Barriers around the copies: everything before (reads and writes of any stage) -> the copies'
// writes -> everything after. Linear images (re-laid row by row, memory_rebind.h) and MemoryData
// larger than a batch still wait for the queue and are written by the host.
//
// Batches are used in turn, each with its own staging buffer, command buffer and fence, so staging a
// batch never overwrites bytes a previous batch's copies still read (a batch is waited for, bounded,
// before its reuse).

#include "vulkan_context.h"

#include <array>
#include <string>
#include <vector>

namespace splitvk::agent {

class QueuedWrites {
public:
    static constexpr VkDeviceSize kBatchBytes = VkDeviceSize{8} << 20;

    explicit QueuedWrites(VulkanContext &context) : context_(context) {}
    ~QueuedWrites(); // the queue is idle by then (the replayer waits for it)
    QueuedWrites(const QueuedWrites &) = delete;
    QueuedWrites &operator=(const QueuedWrites &) = delete;

    // Whether `bytes` more fit into the open batch.
    bool fits(VkDeviceSize bytes) const { return used_ + bytes <= kBatchBytes; }
    // Copies `n` bytes (at most kBatchBytes) at `src` into the open batch, for `dst` at `offset`,
    // submitting the open batch first when they do not fit. False with one line in `error` (the
    // staging buffer could not be made, or a batch's previous copies never finished).
    bool stage(VkBuffer dst, VkDeviceSize offset, const uint8_t *src, VkDeviceSize n, std::string *error);
    // Submits the open batch, if any, on the replay queue. False with one line in `error`.
    bool flush(std::string *error);
    bool pending() const { return !copies_.empty(); }

private:
    static constexpr size_t kBatches = 4;
    struct Batch {
        HostBuffer staging;
        VkCommandBuffer command_buffer = VK_NULL_HANDLE;
        VkFence fence = VK_NULL_HANDLE;
        bool in_flight = false;
    };
    struct Copy {
        VkBuffer dst = VK_NULL_HANDLE;
        VkBufferCopy region{};
    };
    bool open(std::string *error); // makes or waits for batches_[current_]

    VulkanContext &context_;
    VkCommandPool pool_ = VK_NULL_HANDLE;
    std::array<Batch, kBatches> batches_{};
    size_t current_ = 0;
    VkDeviceSize used_ = 0;
    std::vector<Copy> copies_; // of the open batch
};

} // namespace splitvk::agent
