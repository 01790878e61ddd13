// VkBuffer and VkImage: TRANSFER_SRC added down the chain, where they live, and the layout of every
// image subresource, for the snapshot of their contents (resource.h, content_snapshot.h).

#include "capture/resource.h"

#include "capture/capture.h"
#include "capture/fovea_mask.h"
#include "capture/render_pass.h"
#include "capture/screen_space.h"
#include "core/image.h"
#include "core/instance.h"
#include "layer_entry_points.h"
#include "log.h"
#include "vk_format_info.h"

#include <algorithm>
#include <atomic>
#include <cstring>
#include <mutex>
#include <unordered_map>

namespace splitvk {
namespace {

struct BufferState {
    VkDeviceSize size = 0;
    bool readable = false; // created with TRANSFER_SRC
    VkDeviceMemory memory = VK_NULL_HANDLE;
    VkDeviceSize memory_offset = 0;
    VkDeviceAddress address_sent = 0; // what the agent was told vkGetBufferDeviceAddress returned
};

} // namespace

struct ResourceTable {
    std::mutex mutex; // what follows; images have their own table (image.h)
    std::unordered_map<VkBuffer, BufferState> buffers;
    std::unordered_map<VkRenderPass, std::vector<VkImageLayout>> final_layouts; // per attachment
};

std::shared_ptr<ResourceTable> make_resource_table() {
    return std::make_shared<ResourceTable>();
}

namespace {

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

void bind_buffer(DeviceState &dev, VkBuffer buffer, VkDeviceMemory memory, VkDeviceSize offset) {
    ResourceTable &t = *dev.resources;
    std::lock_guard lock(t.mutex);
    if (const auto it = t.buffers.find(buffer); it != t.buffers.end()) {
        it->second.memory = memory;
        it->second.memory_offset = offset;
    }
}

void bind_image(DeviceState &dev, VkImage image) {
    LockedImages images(dev);
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
void note_final_layouts(DeviceState &dev, VkRenderPass render_pass, const RenderPassCreateInfo &info) {
    forget_render_pass(dev, render_pass);
    note_render_pass_depth(dev, render_pass, info);
    std::vector<VkImageLayout> finals;
    for (uint32_t i = 0; i < info.attachmentCount; ++i)
        finals.push_back(info.pAttachments[i].finalLayout);
    std::lock_guard lock(dev.resources->mutex);
    dev.resources->final_layouts[render_pass] = std::move(finals);
}

} // namespace

void note_render_pass_begin(DeviceState &device, VkCommandBuffer command_buffer, VkRenderPass render_pass,
                            std::span<const AttachmentImage> attachments) {
    CommandLayouts *layouts = command_buffer_layouts(command_buffer);
    if (!layouts) return;
    layouts->at_pass_end.clear();
    ResourceTable &t = *device.resources;
    std::lock_guard lock(t.mutex);
    const auto it = t.final_layouts.find(render_pass);
    if (it == t.final_layouts.end()) return;
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

void for_each_readable_buffer(
    const DeviceState &device,
    const std::function<void(VkBuffer, VkDeviceMemory, VkDeviceSize offset, VkDeviceSize size)> &each) {
    ResourceTable &t = *device.resources;
    std::lock_guard lock(t.mutex);
    for (const auto &[buffer, state] : t.buffers)
        if (state.readable && state.memory && state.size != 0)
            each(buffer, state.memory, state.memory_offset, state.size);
}

namespace rewrite {

// The generated entry point captures the application's create info once this succeeded.
VkResult CreateBuffer(DeviceState &dev, PFN_vkCreateBuffer down, VkDevice device,
                      const VkBufferCreateInfo *pCreateInfo, const VkAllocationCallbacks *pAllocator,
                      VkBuffer *pBuffer) {
    // Every buffer usage combination accepts TRANSFER_SRC; the retry is for the exotic case.
    VkBufferCreateInfo info = *pCreateInfo;
    info.usage |= VK_BUFFER_USAGE_TRANSFER_SRC_BIT;
    VkResult result = down(device, &info, pAllocator, pBuffer);
    bool readable = result == VK_SUCCESS;
    if (result != VK_SUCCESS && info.usage != pCreateInfo->usage) {
        result = down(device, pCreateInfo, pAllocator, pBuffer);
        readable = pCreateInfo->usage & VK_BUFFER_USAGE_TRANSFER_SRC_BIT;
    }
    if (result != VK_SUCCESS) return result;
    std::lock_guard lock(dev.resources->mutex);
    dev.resources->buffers[*pBuffer] = BufferState{pCreateInfo->size, readable, VK_NULL_HANDLE, 0};
    return result;
}

} // namespace rewrite

namespace observe {

void DestroyBuffer(DeviceState &dev, VkDevice, VkBuffer buffer, const VkAllocationCallbacks *) {
    std::lock_guard lock(dev.resources->mutex);
    dev.resources->buffers.erase(buffer);
}

void DestroyImage(DeviceState &dev, VkDevice, VkImage image, const VkAllocationCallbacks *) {
    remove_image(dev, image);
}

void BindBufferMemory(DeviceState &dev, VkDevice, VkBuffer buffer, VkDeviceMemory memory,
                      VkDeviceSize offset) {
    bind_buffer(dev, buffer, memory, offset);
}

void BindBufferMemory2(DeviceState &dev, VkDevice, uint32_t count, const VkBindBufferMemoryInfo *infos) {
    for (uint32_t i = 0; i < count; ++i)
        bind_buffer(dev, infos[i].buffer, infos[i].memory, infos[i].memoryOffset);
}

void BindBufferMemory2KHR(DeviceState &dev, VkDevice device, uint32_t count,
                          const VkBindBufferMemoryInfo *infos) {
    BindBufferMemory2(dev, device, count, infos);
}

void BindImageMemory(DeviceState &dev, VkDevice, VkImage image, VkDeviceMemory, VkDeviceSize) {
    bind_image(dev, image);
}

void BindImageMemory2(DeviceState &dev, VkDevice, uint32_t count, const VkBindImageMemoryInfo *infos) {
    for (uint32_t i = 0; i < count; ++i)
        bind_image(dev, infos[i].image);
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

void CreateRenderPass(DeviceState &dev, VkDevice, const VkRenderPassCreateInfo *info,
                      const VkAllocationCallbacks *, VkRenderPass *render_pass) {
    note_final_layouts(dev, *render_pass, *info);
}

void CreateRenderPass2(DeviceState &dev, VkDevice, const VkRenderPassCreateInfo2 *info,
                       const VkAllocationCallbacks *, VkRenderPass *render_pass) {
    note_final_layouts(dev, *render_pass, *info);
}

void CreateRenderPass2KHR(DeviceState &dev, VkDevice device, const VkRenderPassCreateInfo2 *info,
                          const VkAllocationCallbacks *allocator, VkRenderPass *render_pass) {
    CreateRenderPass2(dev, device, info, allocator, render_pass);
}

void DestroyRenderPass(DeviceState &dev, VkDevice, VkRenderPass render_pass, const VkAllocationCallbacks *) {
    forget_render_pass(dev, render_pass);
    forget_render_pass_depth(dev, render_pass);
    std::lock_guard lock(dev.resources->mutex);
    dev.resources->final_layouts.erase(render_pass);
}

} // namespace observe

namespace entry {} // namespace entry

namespace observe {

// The client's address of a buffer means nothing on the agent's GPU: the agent learns it here and
// maps it to its own buffer's (server-agent/buffer_addresses.h), once per buffer (a bound buffer's
// address never changes). Sent before the application can record a command that uses it. The log
// entry dies with the buffer or its memory, after which the address names nothing.
void GetBufferDeviceAddress(DeviceState &dev, VkDeviceAddress address, VkDevice,
                            const VkBufferDeviceAddressInfo *pInfo) {
    if (address == 0) return;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    {
        std::lock_guard lock(dev.resources->mutex);
        const auto it = dev.resources->buffers.find(pInfo->buffer);
        if (it == dev.resources->buffers.end() || it->second.address_sent == address) return;
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
    std::lock_guard lock(dev.resources->mutex);
    if (const auto it = dev.resources->buffers.find(pInfo->buffer); it != dev.resources->buffers.end())
        it->second.address_sent = address;
}

void GetBufferDeviceAddressKHR(DeviceState &dev, VkDeviceAddress address, VkDevice device,
                               const VkBufferDeviceAddressInfo *pInfo) {
    GetBufferDeviceAddress(dev, address, device, pInfo);
}

} // namespace observe

namespace entry {

VKAPI_ATTR VkResult VKAPI_CALL CreateImage(VkDevice device, const VkImageCreateInfo *pCreateInfo,
                                           const VkAllocationCallbacks *pAllocator, VkImage *pImage) {
    DeviceState &dev = device_state(device);
    if (!dev.session) return dev.dispatch.CreateImage(device, pCreateInfo, pAllocator, pImage);
    VkImageCreateInfo info = *pCreateInfo;
    GuardTarget guard;
    const bool screen_space = screen_space_create_info(dev, *pCreateInfo, &info, &guard);
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
        if (guard.kind.screen_space) {
            state.guard_kind = std::move(guard.kind);
            state.guard_screen = guard.screen;
        }
        add_image(dev, *pImage, std::move(state));
    }
    record_global(dev, LiveChange::Created, codec::handle_value(*pImage), [&](codec::Encoder &e) {
        encode_vkCreateImage(e, device, pCreateInfo, pAllocator, pImage);
    });
    if (pCreateInfo->tiling == VK_IMAGE_TILING_LINEAR) send_image_layouts(dev, *pImage, *pCreateInfo);
    return result;
}

} // namespace entry

} // namespace splitvk
