#include "queued_writes.h"

#include <algorithm>
#include <cstring>

namespace splitvk::agent {

namespace {
constexpr uint64_t kBatchWaitNs = 30'000'000'000; // a batch that long is a lost GPU, not a slow one
} // namespace

QueuedWrites::~QueuedWrites() {
    const VkDevice device = context_.device;
    if (!device) return;
    for (Batch &b : batches_) {
        if (b.in_flight) vkWaitForFences(device, 1, &b.fence, VK_TRUE, kBatchWaitNs);
        if (b.fence) vkDestroyFence(device, b.fence, nullptr);
        context_.destroy(b.staging);
    }
    if (pool_) vkDestroyCommandPool(device, pool_, nullptr); // frees the command buffers
}

bool QueuedWrites::open(std::string *error) {
    const VkDevice device = context_.device;
    Batch &b = batches_[current_];
    if (!pool_) {
        VkCommandPoolCreateInfo pool_info{};
        pool_info.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
        pool_info.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
        pool_info.queueFamilyIndex = context_.queue_family;
        if (const VkResult r = vkCreateCommandPool(device, &pool_info, nullptr, &pool_); r != VK_SUCCESS) {
            *error = std::string("memory upload command pool: ") + vk_result_name(r);
            return false;
        }
    }
    if (!b.command_buffer) {
        VkCommandBufferAllocateInfo alloc{};
        alloc.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
        alloc.commandPool = pool_;
        alloc.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
        alloc.commandBufferCount = 1;
        VkFenceCreateInfo fence_info{};
        fence_info.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
        VkResult r = vkAllocateCommandBuffers(device, &alloc, &b.command_buffer);
        if (r == VK_SUCCESS) r = vkCreateFence(device, &fence_info, nullptr, &b.fence);
        if (r == VK_SUCCESS && !context_.create_upload_buffer(kBatchBytes, &b.staging, error)) return false;
        if (r != VK_SUCCESS) {
            *error = std::string("memory upload batch: ") + vk_result_name(r);
            return false;
        }
    }
    if (b.in_flight) {
        if (vkWaitForFences(device, 1, &b.fence, VK_TRUE, kBatchWaitNs) != VK_SUCCESS) {
            *error = "memory upload: the GPU did not finish an earlier batch";
            return false;
        }
        b.in_flight = false;
    }
    return true;
}

bool QueuedWrites::stage(VkBuffer dst, VkDeviceSize offset, const uint8_t *src, VkDeviceSize n,
                         std::string *error) {
    if (n == 0) return true;
    if (n > kBatchBytes) {
        *error = "memory upload: more than a batch";
        return false;
    }
    if (!fits(n) && !flush(error)) return false; // a full batch goes ahead of this one
    if (copies_.empty() && !open(error)) return false;
    Batch &b = batches_[current_];
    std::memcpy(b.staging.mapped + used_, src, n);
    copies_.push_back({dst, VkBufferCopy{used_, offset, n}});
    // Copy offsets need no alignment; 16 keeps each copy's source on its own cache line pair.
    used_ = std::min(kBatchBytes, (used_ + n + 15) & ~VkDeviceSize{15});
    return true;
}

bool QueuedWrites::flush(std::string *error) {
    if (copies_.empty()) return true;
    Batch &b = batches_[current_];
    const VkCommandBuffer cb = b.command_buffer;
    vkResetCommandBuffer(cb, 0);
    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    vkBeginCommandBuffer(cb, &begin);
    // The earlier work's reads and writes of these buffers end before the copies write them.
    VkMemoryBarrier before{};
    before.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
    before.srcAccessMask = VK_ACCESS_MEMORY_WRITE_BIT;
    before.dstAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    vkCmdPipelineBarrier(cb, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 1,
                         &before, 0, nullptr, 0, nullptr);
    // One vkCmdCopyBuffer per run of copies into the same buffer.
    for (size_t i = 0; i < copies_.size();) {
        size_t j = i;
        std::vector<VkBufferCopy> regions;
        while (j < copies_.size() && copies_[j].dst == copies_[i].dst)
            regions.push_back(copies_[j++].region);
        vkCmdCopyBuffer(cb, b.staging.buffer, copies_[i].dst, static_cast<uint32_t>(regions.size()),
                        regions.data());
        i = j;
    }
    // The copies' writes are visible to everything after, as the host's write was to the client's
    // next submit.
    VkMemoryBarrier after{};
    after.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
    after.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    after.dstAccessMask = VK_ACCESS_MEMORY_READ_BIT | VK_ACCESS_MEMORY_WRITE_BIT;
    vkCmdPipelineBarrier(cb, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, 0, 1, &after,
                         0, nullptr, 0, nullptr);
    vkEndCommandBuffer(cb);
    if (!b.staging.coherent) {
        VkMappedMemoryRange range{};
        range.sType = VK_STRUCTURE_TYPE_MAPPED_MEMORY_RANGE;
        range.memory = b.staging.memory;
        range.size = VK_WHOLE_SIZE;
        vkFlushMappedMemoryRanges(context_.device, 1, &range);
    }
    vkResetFences(context_.device, 1, &b.fence);
    VkSubmitInfo submit{};
    submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
    submit.commandBufferCount = 1;
    submit.pCommandBuffers = &cb;
    const VkResult r = vkQueueSubmit(context_.queue, 1, &submit, b.fence);
    copies_.clear();
    used_ = 0;
    current_ = (current_ + 1) % kBatches;
    if (r != VK_SUCCESS) {
        *error = std::string("memory upload submit: ") + vk_result_name(r);
        return false;
    }
    b.in_flight = true;
    return true;
}

} // namespace splitvk::agent
