// VkBuffer and VkImage: TRANSFER_SRC added down the chain, where they live, the layout of every
// image subresource, and the snapshot of their contents for a new agent (resource.h).

#include "resource.h"

#include "capture.h"
#include "host_buffer.h"
#include "image.h"
#include "instance.h"
#include "layer_entry_points.h"
#include "log.h"
#include "screen_space.h"
#include "split.h"
#include "vk_format_info.h"
#include "vk_util.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstring>
#include <mutex>
#include <numeric>
#include <unordered_map>

namespace splitvk {
namespace {

struct BufferState {
    DeviceState *device = nullptr;
    VkDeviceSize size = 0;
    bool readable = false; // created with TRANSFER_SRC
    VkDeviceMemory memory = VK_NULL_HANDLE;
    VkDeviceSize memory_offset = 0;
    VkDeviceAddress address_sent = 0; // what the agent was told vkGetBufferDeviceAddress returned
};

std::mutex g_mutex; // g_buffers, g_final_layouts; images have their own table (image.h)
std::unordered_map<VkBuffer, BufferState> g_buffers;
std::unordered_map<VkRenderPass, std::vector<VkImageLayout>> g_final_layouts; // per attachment

void apply(LockedImages &images, const LayoutTransition &t) {
    ImageState *found = images.find(t.image);
    if (!found || !found->created) return; // a swapchain image, or one created before the session
    ImageState &image = *found;
    const uint32_t mip_end = t.range.levelCount == VK_REMAINING_MIP_LEVELS
                                 ? image.mips
                                 : std::min(image.mips, t.range.baseMipLevel + t.range.levelCount);
    const uint32_t layer_end = t.range.layerCount == VK_REMAINING_ARRAY_LAYERS
                                   ? image.layers
                                   : std::min(image.layers, t.range.baseArrayLayer + t.range.layerCount);
    for (uint32_t layer = t.range.baseArrayLayer; layer < layer_end; ++layer)
        for (uint32_t mip = t.range.baseMipLevel; mip < mip_end; ++mip)
            image.layout(mip, layer) = t.layout;
}

void record_barriers(VkCommandBuffer cb, uint32_t count, const VkImageMemoryBarrier *barriers) {
    CommandLayouts *layouts = command_buffer_layouts(cb);
    if (!layouts) return;
    for (uint32_t i = 0; i < count; ++i)
        if (barriers[i].oldLayout != barriers[i].newLayout)
            layouts->transitions.push_back(
                {barriers[i].image, barriers[i].subresourceRange, barriers[i].newLayout});
}

void record_dependency(VkCommandBuffer cb, const VkDependencyInfo &info) {
    CommandLayouts *layouts = command_buffer_layouts(cb);
    if (!layouts) return;
    for (uint32_t i = 0; i < info.imageMemoryBarrierCount; ++i) {
        const VkImageMemoryBarrier2 &b = info.pImageMemoryBarriers[i];
        if (b.oldLayout != b.newLayout)
            layouts->transitions.push_back({b.image, b.subresourceRange, b.newLayout});
    }
}

void bind_buffer(VkBuffer buffer, VkDeviceMemory memory, VkDeviceSize offset) {
    std::lock_guard lock(g_mutex);
    if (const auto it = g_buffers.find(buffer); it != g_buffers.end()) {
        it->second.memory = memory;
        it->second.memory_offset = offset;
    }
}

void bind_image(VkImage image) {
    LockedImages images;
    if (ImageState *state = images.find(image)) state->bound = true;
}

// A linear image: what the host writes into its memory is laid out as this driver says, which the
// agent needs to know to put the bytes where its own driver expects them (ImageLayouts). Formats
// vk.xml describes as single-plane only: a multi-planar image's bytes reach the agent 1:1.
void send_image_layouts(DeviceState &dev, VkImage image, const VkImageCreateInfo &info) {
    const FormatInfo format = format_info(info.format);
    if (format.block_bytes == 0) {
        static std::atomic<bool> logged{false};
        if (!logged.exchange(true))
            SPLITVK_WARN(
                "a linear image of multi-planar VkFormat %d: what the host writes into it reaches the "
                "agent byte for byte, exact only when both drivers lay it out alike",
                static_cast<int>(info.format));
        return;
    }
    protocol::ImageLayouts message;
    message.device_id = dev.session->device_id();
    message.image_id = codec::handle_value(image);
    message.format = static_cast<uint32_t>(info.format);
    message.width = info.extent.width;
    message.height = info.extent.height;
    message.depth = info.extent.depth;
    message.mip_levels = info.mipLevels;
    message.array_layers = info.arrayLayers;
    std::vector<VkImageAspectFlagBits> aspects;
    if (format.depth) aspects.push_back(VK_IMAGE_ASPECT_DEPTH_BIT);
    if (format.stencil) aspects.push_back(VK_IMAGE_ASPECT_STENCIL_BIT);
    if (aspects.empty()) aspects.push_back(VK_IMAGE_ASPECT_COLOR_BIT);
    using namespace protocol;
    if (size_t{info.mipLevels} * info.arrayLayers * aspects.size() > kMaxImageSubresources ||
        info.mipLevels > kMaxImageMipLevels || info.arrayLayers > kMaxImageArrayLayers ||
        std::max({info.extent.width, info.extent.height, info.extent.depth}) > kMaxImageExtent) {
        SPLITVK_WARN("a linear image of %ux%ux%u with %u mip levels and %u layers is larger than splitvk "
                     "describes to the agent; what the host writes into it may differ there",
                     info.extent.width, info.extent.height, info.extent.depth, info.mipLevels,
                     info.arrayLayers);
        return;
    }
    for (const VkImageAspectFlagBits aspect : aspects)
        for (uint32_t mip = 0; mip < info.mipLevels; ++mip)
            for (uint32_t layer = 0; layer < info.arrayLayers; ++layer) {
                const VkImageSubresource sub{static_cast<VkImageAspectFlags>(aspect), mip, layer};
                VkSubresourceLayout layout{};
                dev.dispatch.GetImageSubresourceLayout(dev.handle, image, &sub, &layout);
                message.subresources.push_back({static_cast<uint32_t>(aspect), mip, layer, layout.offset,
                                                layout.size, layout.rowPitch, layout.arrayPitch,
                                                layout.depthPitch});
            }
    const uint64_t id = codec::handle_value(image);
    const uint64_t killers[] = {id};
    dev.session->send_metadata_logged(protocol::MessageType::ImageLayouts, protocol::encode(message), id,
                                      killers);
}

// Whether the implementation accepts the image with TRANSFER_SRC added to its usage.
bool can_add_transfer_src(const DeviceState &dev, const VkImageCreateInfo &info) {
    if (info.usage & (VK_IMAGE_USAGE_TRANSFER_SRC_BIT | VK_IMAGE_USAGE_TRANSIENT_ATTACHMENT_BIT))
        return false;
    if (info.flags & VK_IMAGE_CREATE_SPARSE_BINDING_BIT) return false;
    if (info.tiling != VK_IMAGE_TILING_OPTIMAL && info.tiling != VK_IMAGE_TILING_LINEAR) return false;
    VkImageFormatProperties properties{};
    return dev.instance->dispatch.GetPhysicalDeviceImageFormatProperties(
               dev.physical_device, info.format, info.imageType, info.tiling,
               info.usage | VK_IMAGE_USAGE_TRANSFER_SRC_BIT, info.flags, &properties) == VK_SUCCESS;
}

// vkCreateRenderPass and vkCreateRenderPass2 alike: the attachments' final layouts, which the
// pass's end applies (note_render_pass_end).
template <class RenderPassCreateInfo>
void note_final_layouts(VkRenderPass render_pass, const RenderPassCreateInfo &info) {
    forget_render_pass(render_pass);
    std::vector<VkImageLayout> finals;
    for (uint32_t i = 0; i < info.attachmentCount; ++i)
        finals.push_back(info.pAttachments[i].finalLayout);
    std::lock_guard lock(g_mutex);
    g_final_layouts[render_pass] = std::move(finals);
}

} // namespace

void note_render_pass_begin(VkCommandBuffer command_buffer, VkRenderPass render_pass,
                            std::span<const AttachmentImage> attachments) {
    CommandLayouts *layouts = command_buffer_layouts(command_buffer);
    if (!layouts) return;
    layouts->at_pass_end.clear();
    std::lock_guard lock(g_mutex);
    const auto it = g_final_layouts.find(render_pass);
    if (it == g_final_layouts.end()) return;
    for (size_t i = 0; i < attachments.size() && i < it->second.size(); ++i)
        if (attachments[i].image)
            layouts->at_pass_end.push_back({attachments[i].image, attachments[i].range, it->second[i]});
}

void note_render_pass_end(VkCommandBuffer command_buffer) {
    CommandLayouts *layouts = command_buffer_layouts(command_buffer);
    if (!layouts) return;
    layouts->transitions.insert(layouts->transitions.end(), layouts->at_pass_end.begin(),
                                layouts->at_pass_end.end());
    layouts->at_pass_end.clear();
}

void apply_layouts(LockedImages &images, const CommandLayouts &layouts) {
    for (const LayoutTransition &t : layouts.transitions)
        apply(images, t);
}

void forget_resources(DeviceState &device) {
    std::lock_guard lock(g_mutex);
    std::erase_if(g_buffers, [&](const auto &entry) { return entry.second.device == &device; });
    forget_images(device);
    forget_screen_space(device);
}

namespace observe {

void DestroyBuffer(DeviceState &, VkDevice, VkBuffer buffer, const VkAllocationCallbacks *) {
    std::lock_guard lock(g_mutex);
    g_buffers.erase(buffer);
}

void DestroyImage(DeviceState &, VkDevice, VkImage image, const VkAllocationCallbacks *) {
    remove_image(image);
}

void BindBufferMemory(DeviceState &, VkDevice, VkBuffer buffer, VkDeviceMemory memory, VkDeviceSize offset) {
    bind_buffer(buffer, memory, offset);
}

void BindBufferMemory2(DeviceState &, VkDevice, uint32_t count, const VkBindBufferMemoryInfo *infos) {
    for (uint32_t i = 0; i < count; ++i)
        bind_buffer(infos[i].buffer, infos[i].memory, infos[i].memoryOffset);
}

void BindBufferMemory2KHR(DeviceState &dev, VkDevice device, uint32_t count,
                          const VkBindBufferMemoryInfo *infos) {
    BindBufferMemory2(dev, device, count, infos);
}

void BindImageMemory(DeviceState &, VkDevice, VkImage image, VkDeviceMemory, VkDeviceSize) {
    bind_image(image);
}

void BindImageMemory2(DeviceState &, VkDevice, uint32_t count, const VkBindImageMemoryInfo *infos) {
    for (uint32_t i = 0; i < count; ++i)
        bind_image(infos[i].image);
}

void BindImageMemory2KHR(DeviceState &dev, VkDevice device, uint32_t count,
                         const VkBindImageMemoryInfo *infos) {
    BindImageMemory2(dev, device, count, infos);
}

void CmdPipelineBarrier(DeviceState &, VkCommandBuffer cb, VkPipelineStageFlags, VkPipelineStageFlags,
                        VkDependencyFlags, uint32_t, const VkMemoryBarrier *, uint32_t,
                        const VkBufferMemoryBarrier *, uint32_t image_count,
                        const VkImageMemoryBarrier *images) {
    record_barriers(cb, image_count, images);
}

void CmdPipelineBarrier2(DeviceState &, VkCommandBuffer cb, const VkDependencyInfo *info) {
    record_dependency(cb, *info);
}

void CmdPipelineBarrier2KHR(DeviceState &dev, VkCommandBuffer cb, const VkDependencyInfo *info) {
    CmdPipelineBarrier2(dev, cb, info);
}

void CmdWaitEvents(DeviceState &, VkCommandBuffer cb, uint32_t, const VkEvent *, VkPipelineStageFlags,
                   VkPipelineStageFlags, uint32_t, const VkMemoryBarrier *, uint32_t,
                   const VkBufferMemoryBarrier *, uint32_t image_count, const VkImageMemoryBarrier *images) {
    record_barriers(cb, image_count, images);
}

void CmdWaitEvents2(DeviceState &, VkCommandBuffer cb, uint32_t count, const VkEvent *,
                    const VkDependencyInfo *infos) {
    for (uint32_t i = 0; i < count; ++i)
        record_dependency(cb, infos[i]);
}

void CmdWaitEvents2KHR(DeviceState &dev, VkCommandBuffer cb, uint32_t count, const VkEvent *events,
                       const VkDependencyInfo *infos) {
    CmdWaitEvents2(dev, cb, count, events, infos);
}

void CreateRenderPass(DeviceState &, VkDevice, const VkRenderPassCreateInfo *info,
                      const VkAllocationCallbacks *, VkRenderPass *render_pass) {
    note_final_layouts(*render_pass, *info);
}

void CreateRenderPass2(DeviceState &, VkDevice, const VkRenderPassCreateInfo2 *info,
                       const VkAllocationCallbacks *, VkRenderPass *render_pass) {
    note_final_layouts(*render_pass, *info);
}

void CreateRenderPass2KHR(DeviceState &dev, VkDevice device, const VkRenderPassCreateInfo2 *info,
                          const VkAllocationCallbacks *allocator, VkRenderPass *render_pass) {
    CreateRenderPass2(dev, device, info, allocator, render_pass);
}

void DestroyRenderPass(DeviceState &, VkDevice, VkRenderPass render_pass, const VkAllocationCallbacks *) {
    forget_render_pass(render_pass);
    std::lock_guard lock(g_mutex);
    g_final_layouts.erase(render_pass);
}

} // namespace observe

namespace entry {

VKAPI_ATTR VkResult VKAPI_CALL CreateBuffer(VkDevice device, const VkBufferCreateInfo *pCreateInfo,
                                            const VkAllocationCallbacks *pAllocator, VkBuffer *pBuffer) {
    DeviceState &dev = device_state(device);
    if (!dev.session) return dev.dispatch.CreateBuffer(device, pCreateInfo, pAllocator, pBuffer);
    // Every buffer usage combination accepts TRANSFER_SRC; the retry is for the exotic case.
    VkBufferCreateInfo info = *pCreateInfo;
    info.usage |= VK_BUFFER_USAGE_TRANSFER_SRC_BIT;
    VkResult result = dev.dispatch.CreateBuffer(device, &info, pAllocator, pBuffer);
    bool readable = result == VK_SUCCESS;
    if (result != VK_SUCCESS && info.usage != pCreateInfo->usage) {
        result = dev.dispatch.CreateBuffer(device, pCreateInfo, pAllocator, pBuffer);
        readable = pCreateInfo->usage & VK_BUFFER_USAGE_TRANSFER_SRC_BIT;
    }
    if (result != VK_SUCCESS) return result;
    {
        std::lock_guard lock(g_mutex);
        g_buffers[*pBuffer] = BufferState{&dev, pCreateInfo->size, readable, VK_NULL_HANDLE, 0};
    }
    record_global(dev, LiveChange::Created, codec::handle_value(*pBuffer), [&](codec::Encoder &e) {
        encode_vkCreateBuffer(e, device, pCreateInfo, pAllocator, pBuffer);
    });
    return result;
}

// The client's address of a buffer means nothing on the agent's GPU: the agent learns it here and
// maps it to its own buffer's (server-agent/buffer_addresses.h), once per buffer (a bound buffer's
// address never changes). Sent before the application can record a command that uses it. The log
// entry dies with the buffer or its memory, after which the address names nothing.
static VkDeviceAddress get_buffer_device_address(VkDevice device, const VkBufferDeviceAddressInfo *pInfo,
                                                 PFN_vkGetBufferDeviceAddress next) {
    DeviceState &dev = device_state(device);
    const VkDeviceAddress address = next(device, pInfo);
    if (!dev.session || address == 0) return address;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    {
        std::lock_guard lock(g_mutex);
        const auto it = g_buffers.find(pInfo->buffer);
        if (it == g_buffers.end() || it->second.address_sent == address) return address;
        memory = it->second.memory;
    }
    protocol::BufferAddress message;
    message.device_id = dev.session->device_id();
    message.buffer_id = codec::handle_value(pInfo->buffer);
    message.address = address;
    const uint64_t killers[] = {message.buffer_id, codec::handle_value(memory)};
    dev.session->send_metadata_logged(protocol::MessageType::BufferAddress, protocol::encode(message),
                                      message.buffer_id, std::span(killers, memory ? 2 : 1));
    // Marked sent only now: another thread asking meanwhile sends it again (the agent keeps the
    // last), rather than returning an address whose message could follow that thread's submit.
    std::lock_guard lock(g_mutex);
    if (const auto it = g_buffers.find(pInfo->buffer); it != g_buffers.end())
        it->second.address_sent = address;
    return address;
}

VKAPI_ATTR VkDeviceAddress VKAPI_CALL GetBufferDeviceAddress(VkDevice device,
                                                             const VkBufferDeviceAddressInfo *pInfo) {
    return get_buffer_device_address(device, pInfo, device_dispatch(device).GetBufferDeviceAddress);
}

VKAPI_ATTR VkDeviceAddress VKAPI_CALL GetBufferDeviceAddressKHR(VkDevice device,
                                                                const VkBufferDeviceAddressInfo *pInfo) {
    return get_buffer_device_address(device, pInfo, device_dispatch(device).GetBufferDeviceAddressKHR);
}

VKAPI_ATTR VkResult VKAPI_CALL CreateImage(VkDevice device, const VkImageCreateInfo *pCreateInfo,
                                           const VkAllocationCallbacks *pAllocator, VkImage *pImage) {
    DeviceState &dev = device_state(device);
    if (!dev.session) return dev.dispatch.CreateImage(device, pCreateInfo, pAllocator, pImage);
    VkImageCreateInfo info = *pCreateInfo;
    const bool screen_space = screen_space_create_info(dev, *pCreateInfo, &info);
    const bool add = can_add_transfer_src(dev, info);
    if (add) info.usage |= VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
    VkResult result = dev.dispatch.CreateImage(device, &info, pAllocator, pImage);
    if (result != VK_SUCCESS && add) {
        info.usage = pCreateInfo->usage;
        result = dev.dispatch.CreateImage(device, &info, pAllocator, pImage);
    }
    if (result != VK_SUCCESS) return result;
    {
        ImageState state;
        state.device = &dev;
        state.created = true;
        state.type = info.imageType;
        state.format = info.format;
        state.extent = info.extent;
        state.mips = std::max(info.mipLevels, 1u);
        state.layers = std::max(info.arrayLayers, 1u);
        state.samples = info.samples;
        state.readable = info.usage & VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
        state.layouts.assign(size_t{state.mips} * state.layers, info.initialLayout);
        // Rendered scaled on the client: its contents are not the agent's image's, and every frame
        // rewrites them, so a snapshot leaves them out.
        state.screen_space = screen_space;
        state.full = {pCreateInfo->extent.width, pCreateInfo->extent.height};
        add_image(*pImage, std::move(state));
    }
    record_global(dev, LiveChange::Created, codec::handle_value(*pImage), [&](codec::Encoder &e) {
        encode_vkCreateImage(e, device, pCreateInfo, pAllocator, pImage);
    });
    if (pCreateInfo->tiling == VK_IMAGE_TILING_LINEAR) send_image_layouts(dev, *pImage, *pCreateInfo);
    return result;
}

} // namespace entry

// --- the snapshot of contents ---------------------------------------------------------------

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
    {
        std::lock_guard lock(g_mutex);
        for (const auto &[buffer, state] : g_buffers) {
            if (state.device != &dev || !state.readable || !state.memory || state.size == 0) continue;
            total = align_up(total, 16);
            buffers.push_back({buffer, state.memory, state.memory_offset, state.size, total});
            total += state.size;
        }
    }
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
