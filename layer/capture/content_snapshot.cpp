// The snapshot of buffer and image contents that brings a new agent in (content_snapshot.h): read
// back on the client with one copy, given to the agent as MemoryData and upload commands.

#include "capture/content_snapshot.h"

#include "capture/resource.h"
#include "core/host_buffer.h"
#include "core/image.h"
#include "core/vk_util.h"
#include "vk_format_info.h"

#include <algorithm>
#include <numeric>
#include <string>
#include <vector>

namespace splitvk {

namespace {

constexpr VkDeviceSize kMaxSnapshotBytes = VkDeviceSize{2} << 30;
constexpr size_t kMaxMemoryDataBytes = size_t{8} << 20; // per MemoryData, as memory.cpp sends them
constexpr uint64_t kFenceWaitNs = 30'000'000'000;
// Handles of the objects a snapshot creates on the agent for its own copies. The agent knows
// objects by the client's 64-bit values, which are pointers or driver handles: values this high
// are neither.
constexpr uint64_t kFirstSnapshotId = 0xfffffff000000000ull;

struct BufferCopy {
    VkBuffer buffer = VK_NULL_HANDLE;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    VkDeviceSize memory_offset = 0;
    VkDeviceSize size = 0;
    VkDeviceSize staging_offset = 0;
};

struct MipCopy {
    uint32_t mip = 0;
    VkExtent3D extent{};
    VkDeviceSize offset = 0; // from the image's first byte in staging
    VkDeviceSize size = 0;   // all layers
};

struct ImageCopy {
    VkImage image = VK_NULL_HANDLE;
    ImageState state;
    std::vector<MipCopy> mips;
    VkDeviceSize staging_offset = 0;
    VkDeviceSize size = 0;
};

VkDeviceSize align_up(VkDeviceSize v, VkDeviceSize a) {
    return (v + a - 1) / a * a;
}

// The mips of `state` a snapshot can copy (every layer in a defined layout), laid out in order.
std::vector<MipCopy> copyable_mips(const ImageState &state, const FormatInfo &format, VkDeviceSize *size) {
    std::vector<MipCopy> mips;
    const VkDeviceSize alignment = std::lcm(VkDeviceSize{format.block_bytes}, VkDeviceSize{16});
    VkDeviceSize offset = 0;
    for (uint32_t mip = 0; mip < state.mips; ++mip) {
        bool defined = true;
        for (uint32_t layer = 0; layer < state.layers && defined; ++layer) {
            const VkImageLayout layout = state.layout(mip, layer);
            defined = layout != VK_IMAGE_LAYOUT_UNDEFINED && layout != VK_IMAGE_LAYOUT_PREINITIALIZED;
        }
        if (!defined) continue;
        MipCopy copy;
        copy.mip = mip;
        copy.extent = {std::max(state.extent.width >> mip, 1u), std::max(state.extent.height >> mip, 1u),
                       std::max(state.extent.depth >> mip, 1u)};
        const VkDeviceSize blocks_x = (copy.extent.width + format.block_width - 1) / format.block_width;
        const VkDeviceSize blocks_y = (copy.extent.height + format.block_height - 1) / format.block_height;
        copy.size = blocks_x * blocks_y * copy.extent.depth * format.block_bytes * state.layers;
        offset = align_up(offset, alignment);
        copy.offset = offset;
        offset += copy.size;
        mips.push_back(copy);
    }
    *size = offset;
    return mips;
}

VkBufferImageCopy image_region(const MipCopy &mip, uint32_t layers, VkDeviceSize base) {
    VkBufferImageCopy region{};
    region.bufferOffset = base + mip.offset; // rows tightly packed (bufferRowLength 0)
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, mip.mip, 0, layers};
    region.imageExtent = mip.extent;
    return region;
}

// The layer's own Vulkan objects for one readback, freed however it ends.
struct Readback {
    DeviceState &dev;
    HostBuffer staging;
    VkCommandPool pool = VK_NULL_HANDLE;
    VkCommandBuffer cb = VK_NULL_HANDLE;
    VkFence fence = VK_NULL_HANDLE;

    explicit Readback(DeviceState &d) : dev(d) {}
    ~Readback() {
        const VkDevice d = dev.handle;
        if (fence) dev.dispatch.DestroyFence(d, fence, nullptr);
        if (pool) dev.dispatch.DestroyCommandPool(d, pool, nullptr);
        destroy_host_buffer(dev, staging);
    }

    bool create(VkDeviceSize size, uint32_t family, std::string *error) {
        if (!create_host_buffer(dev, size, VK_BUFFER_USAGE_TRANSFER_DST_BIT, HostAccess::Read, &staging,
                                error))
            return false;
        if (create_command_pool(dev, family, VK_COMMAND_POOL_CREATE_TRANSIENT_BIT, &pool) != VK_SUCCESS ||
            allocate_primary_command_buffer(dev, pool, &cb) != VK_SUCCESS ||
            create_fence(dev, &fence) != VK_SUCCESS) {
            *error = "cannot create a command buffer for the readback";
            return false;
        }
        return true;
    }
};

void record_readback(DeviceState &dev, VkCommandBuffer cb, VkBuffer staging,
                     const std::vector<BufferCopy> &buffers, const std::vector<ImageCopy> &images) {
    const auto &k = dev.dispatch;
    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    k.BeginCommandBuffer(cb, &begin);
    // The app's submits before this one wrote what is copied: make those writes visible.
    VkMemoryBarrier all{};
    all.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
    all.srcAccessMask = VK_ACCESS_MEMORY_WRITE_BIT;
    all.dstAccessMask = VK_ACCESS_TRANSFER_READ_BIT;
    k.CmdPipelineBarrier(cb, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 1, &all,
                         0, nullptr, 0, nullptr);
    for (const BufferCopy &b : buffers) {
        const VkBufferCopy region{0, b.staging_offset, b.size};
        k.CmdCopyBuffer(cb, b.buffer, staging, 1, &region);
    }
    for (const ImageCopy &image : images) {
        ImageState state = image.state;
        std::vector<VkImageMemoryBarrier> to_src, back;
        std::vector<VkBufferImageCopy> regions;
        for (const MipCopy &mip : image.mips) {
            for (uint32_t layer = 0; layer < state.layers; ++layer) {
                const VkImageLayout layout = state.layout(mip.mip, layer);
                if (layout == VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL) continue;
                to_src.push_back(colour_image_barrier(image.image, VK_ACCESS_MEMORY_WRITE_BIT,
                                                      VK_ACCESS_TRANSFER_READ_BIT, layout,
                                                      VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, mip.mip, layer));
                // Back to where the app left it, before anything the app submits later.
                back.push_back(colour_image_barrier(
                    image.image, 0, VK_ACCESS_MEMORY_READ_BIT | VK_ACCESS_MEMORY_WRITE_BIT,
                    VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, layout, mip.mip, layer));
            }
            regions.push_back(image_region(mip, state.layers, image.staging_offset));
        }
        if (!to_src.empty())
            k.CmdPipelineBarrier(cb, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0,
                                 nullptr, 0, nullptr, static_cast<uint32_t>(to_src.size()), to_src.data());
        k.CmdCopyImageToBuffer(cb, image.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, staging,
                               static_cast<uint32_t>(regions.size()), regions.data());
        if (!back.empty())
            k.CmdPipelineBarrier(cb, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, 0, 0,
                                 nullptr, 0, nullptr, static_cast<uint32_t>(back.size()), back.data());
    }
    VkBufferMemoryBarrier host{};
    host.sType = VK_STRUCTURE_TYPE_BUFFER_MEMORY_BARRIER;
    host.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    host.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
    host.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    host.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    host.buffer = staging;
    host.size = VK_WHOLE_SIZE;
    k.CmdPipelineBarrier(cb, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_HOST_BIT, 0, 0, nullptr, 1,
                         &host, 0, nullptr);
    k.EndCommandBuffer(cb);
}

template <class Handle>
Handle snapshot_handle(uint64_t &next) {
    return reinterpret_cast<Handle>(static_cast<uintptr_t>(next++));
}

void push_memory_data(ContentSnapshot &out, uint64_t device_id, uint64_t memory_id, VkDeviceSize offset,
                      const uint8_t *bytes, VkDeviceSize size) {
    for (VkDeviceSize done = 0; done < size; done += kMaxMemoryDataBytes) {
        protocol::MemoryData data;
        data.device_id = device_id;
        data.memory_id = memory_id;
        data.offset = offset + done;
        data.bytes.assign(bytes + done,
                          bytes + done + std::min<VkDeviceSize>(kMaxMemoryDataBytes, size - done));
        out.messages.push_back({protocol::MessageType::MemoryData, protocol::encode(data)});
    }
}

// Gives the agent the images' bytes: one staging buffer per image holding them (MemoryData), and
// one command buffer that copies them in and leaves every subresource in its tracked layout. All
// of it is made of ordinary commands and MemoryData, which the agent replays as it would an app's.
void push_image_uploads(DeviceState &dev, VkQueue queue, uint32_t family,
                        const std::vector<ImageCopy> &images, const uint8_t *staging, ContentSnapshot &out) {
    if (images.empty()) return;
    Session &session = *dev.session;
    const VkDevice device = dev.handle;
    uint64_t next = kFirstSnapshotId;
    codec::Encoder e;
    e.set_hooks(session.hooks());
    std::vector<std::pair<VkBuffer, VkDeviceMemory>> uploads;
    for (const ImageCopy &image : images) {
        VkBufferCreateInfo buffer_info{};
        buffer_info.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
        buffer_info.size = image.size;
        buffer_info.usage = VK_BUFFER_USAGE_TRANSFER_SRC_BIT;
        VkBuffer buffer = snapshot_handle<VkBuffer>(next);
        encode_vkCreateBuffer(e, device, &buffer_info, nullptr, &buffer);
        VkMemoryAllocateInfo memory_info{};
        memory_info.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
        memory_info.allocationSize = image.size; // the agent chooses its own memory types
        VkDeviceMemory memory = snapshot_handle<VkDeviceMemory>(next);
        encode_vkAllocateMemory(e, device, &memory_info, nullptr, &memory);
        encode_vkBindBufferMemory(e, device, buffer, memory, 0);
        out.messages.push_back({protocol::MessageType::Commands, e.take()});
        push_memory_data(out, session.device_id(), codec::handle_value(memory), 0,
                         staging + image.staging_offset, image.size);
        uploads.emplace_back(buffer, memory);
    }

    VkCommandPoolCreateInfo pool_info{};
    pool_info.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
    pool_info.flags = VK_COMMAND_POOL_CREATE_TRANSIENT_BIT;
    pool_info.queueFamilyIndex = family;
    VkCommandPool pool = snapshot_handle<VkCommandPool>(next);
    encode_vkCreateCommandPool(e, device, &pool_info, nullptr, &pool);
    VkCommandBufferAllocateInfo cb_info{};
    cb_info.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
    cb_info.commandPool = pool;
    cb_info.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    cb_info.commandBufferCount = 1;
    VkCommandBuffer cb = snapshot_handle<VkCommandBuffer>(next);
    encode_vkAllocateCommandBuffers(e, device, &cb_info, &cb);
    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    encode_vkBeginCommandBuffer(e, cb, &begin, VK_COMMAND_BUFFER_LEVEL_PRIMARY);
    for (size_t i = 0; i < images.size(); ++i) {
        const ImageCopy &image = images[i];
        ImageState state = image.state;
        std::vector<VkImageMemoryBarrier> to_dst, to_layout;
        std::vector<VkBufferImageCopy> regions;
        for (const MipCopy &mip : image.mips) {
            for (uint32_t layer = 0; layer < state.layers; ++layer) {
                // The agent's image holds nothing yet: its old contents can be discarded.
                to_dst.push_back(colour_image_barrier(image.image, 0, VK_ACCESS_TRANSFER_WRITE_BIT,
                                                      VK_IMAGE_LAYOUT_UNDEFINED,
                                                      VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, mip.mip, layer));
                to_layout.push_back(colour_image_barrier(
                    image.image, VK_ACCESS_TRANSFER_WRITE_BIT,
                    VK_ACCESS_MEMORY_READ_BIT | VK_ACCESS_MEMORY_WRITE_BIT,
                    VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, state.layout(mip.mip, layer), mip.mip, layer));
            }
            regions.push_back(image_region(mip, state.layers, 0));
        }
        encode_vkCmdPipelineBarrier(e, cb, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT,
                                    0, 0, nullptr, 0, nullptr, static_cast<uint32_t>(to_dst.size()),
                                    to_dst.data());
        encode_vkCmdCopyBufferToImage(e, cb, uploads[i].first, image.image,
                                      VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                                      static_cast<uint32_t>(regions.size()), regions.data());
        encode_vkCmdPipelineBarrier(e, cb, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT,
                                    0, 0, nullptr, 0, nullptr, static_cast<uint32_t>(to_layout.size()),
                                    to_layout.data());
    }
    encode_vkEndCommandBuffer(e, cb);
    const VkSubmitInfo submit = submit_info(&cb);
    encode_vkQueueSubmit(e, queue, 1, &submit, VK_NULL_HANDLE);
    // The agent waits for its queue before a destroy or a free, so the copies are done by then.
    encode_vkDestroyCommandPool(e, device, pool, nullptr);
    for (const auto &[buffer, memory] : uploads) {
        encode_vkDestroyBuffer(e, device, buffer, nullptr);
        encode_vkFreeMemory(e, device, memory, nullptr);
    }
    out.messages.push_back({protocol::MessageType::Commands, e.take()});
}

} // namespace

bool snapshot_contents(DeviceState &dev, VkQueue queue, uint32_t family, ContentSnapshot *out,
                       std::string *error) {
    if (family == UINT32_MAX) {
        *error = "the present queue's family is unknown";
        return false;
    }
    std::vector<BufferCopy> buffers;
    std::vector<ImageCopy> images;
    VkDeviceSize total = 0;
    for_each_readable_buffer(
        dev, [&](VkBuffer buffer, VkDeviceMemory memory, VkDeviceSize offset, VkDeviceSize size) {
            total = align_up(total, 16);
            buffers.push_back({buffer, memory, offset, size, total});
            total += size;
        });
    for_each_image(dev, [&](VkImage image, const ImageState &state) {
        if (!state.created || !state.bound) return;
        if (state.screen_space) {
            ++out->screen_space_images;
            return;
        }
        const FormatInfo format = format_info(state.format);
        if (!state.readable || state.samples != VK_SAMPLE_COUNT_1_BIT || format.block_bytes == 0 ||
            format.depth || format.stencil) {
            ++out->skipped_images;
            return;
        }
        ImageCopy copy;
        copy.image = image;
        copy.state = state;
        copy.mips = copyable_mips(state, format, &copy.size);
        if (copy.mips.empty()) return; // never written: nothing to give
        total = align_up(total, std::lcm(VkDeviceSize{format.block_bytes}, VkDeviceSize{16}));
        copy.staging_offset = total;
        total += copy.size;
        images.push_back(std::move(copy));
    });
    if (total == 0) return true;
    if (total > kMaxSnapshotBytes) {
        *error = "buffer and image contents of " + std::to_string(total >> 20) +
                 " MiB exceed the snapshot's " + std::to_string(kMaxSnapshotBytes >> 20) + " MiB";
        return false;
    }

    Readback readback(dev);
    if (!readback.create(total, family, error)) return false;
    record_readback(dev, readback.cb, readback.staging.buffer, buffers, images);
    const VkSubmitInfo submit = submit_info(&readback.cb);
    VkResult r = dev.dispatch.QueueSubmit(queue, 1, &submit, readback.fence);
    if (r == VK_SUCCESS)
        r = dev.dispatch.WaitForFences(dev.handle, 1, &readback.fence, VK_TRUE, kFenceWaitNs);
    if (r != VK_SUCCESS) {
        *error = "the readback did not complete (VkResult " + std::to_string(r) + ")";
        // The fence may still be pending: wait before the Readback's destructor frees what it uses.
        dev.dispatch.QueueWaitIdle(queue);
        return false;
    }
    invalidate_host_buffer(dev, readback.staging);
    const uint8_t *staging = readback.staging.mapped;
    for (const BufferCopy &b : buffers)
        push_memory_data(*out, dev.session->device_id(), codec::handle_value(b.memory), b.memory_offset,
                         staging + b.staging_offset, b.size);
    push_image_uploads(dev, queue, family, images, staging, *out);
    out->buffers = buffers.size();
    out->images = images.size();
    out->bytes = total;
    return true;
}

} // namespace splitvk
