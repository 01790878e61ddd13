// Composition before present (docs/architecture.md §4); see compositor.h for the contract.
//
// One submit per present, on the present queue, in this order:
//   1. wait on the application's present semaphores (at the transfer stage, the first use);
//   2. copy the top-left periphery of the swapchain image into the slot's periphery image (an
//      image of the swapchain's format and the periphery's size: neither the blit nor the draw
//      below may read the region it writes);
//   3. by default (UpsampleFilter::BilinearBlit), blit the periphery image into the swapchain
//      image with a linear filter, around the tiles where the scale allows (blit_regions); sRGB
//      is decoded before filtering and encoded after. Otherwise draw a full-screen triangle into
//      the swapchain image (a render pass on a view in its own format) that samples the
//      periphery image, once per band around the tiles (scissored: periphery_bands), so no
//      fragment is shaded where a tile goes: for sRGB formats the sampler decodes and the
//      attachment encodes, so the filter blends linear values;
//   4. copy the fovea tiles' rects from the host-visible buffers they were decoded into
//      (UploadPool) into the image with vkCmdCopyBufferToImage, one command per tile: bytes move
//      unchanged, so the fovea is bit-exact in any format (a shader or a view of another format
//      would re-encode sRGB), and the CPU copies nothing;
//   5. leave the image in the present layout and signal the slot's semaphore, which the present
//      waits on instead of the application's.
//
// The swapped split's composite_periphery() turns it around: the client's foveae are copied out
// of the image into a slot's buffer, the agent's decoded periphery parts into the compositor's
// latest periphery image, which is upsampled over the image as in 3 (the blit straight from it,
// the draw from a copy in the slot's periphery image), and the foveae are copied back as in 4.
// With a feathered seam (SPLITVK_SEAM), each fovea's seam rectangle (the fovea grown by the
// feather, which the client rendered too) is also copied out, into the slot's seam image, before the
// upsample; after it, a blending draw mixes those pixels back in across the band around each fovea;
// only then are the foveae copied back.

#include "present/compositor.h"

#include "capture/session.h"
#include "core/gpu_timing.h"
#include "core/host_buffer.h"
#include "core/instance.h"
#include "core/swapchain.h"
#include "core/vk_util.h"
#include "log.h"
#include "split_geometry.h"
#include "tile_format.h"
#include "upsample_shaders.h"

#include <algorithm>
#include <cstring>
#include <numeric>
#include <unordered_map>

namespace splitvk {
namespace {

constexpr uint64_t kSlotWaitNs = 1'000'000'000;    // a slot's previous submit, before reuse
constexpr uint64_t kDestroyWaitNs = 5'000'000'000; // at destroy, per slot

// shaders/upsample.frag's.
struct PushConstants {
    float scale[2];
    float texel_size[2];
    float max_centre[2];
    int32_t layer; // of the periphery image, the one the pass's framebuffer draws
};

// shaders/feather.frag's.
struct FeatherPushConstants {
    int32_t seam_origin[2];
    int32_t client_origin[2];
    float fovea_min[2];
    float fovea_max[2];
    float feather;
};

constexpr VkFormatFeatureFlags kSwapchainFeatures = VK_FORMAT_FEATURE_TRANSFER_SRC_BIT |
                                                    VK_FORMAT_FEATURE_TRANSFER_DST_BIT |
                                                    VK_FORMAT_FEATURE_COLOR_ATTACHMENT_BIT;
constexpr VkFormatFeatureFlags kBlitFeatures = VK_FORMAT_FEATURE_BLIT_SRC_BIT |
                                               VK_FORMAT_FEATURE_BLIT_DST_BIT |
                                               VK_FORMAT_FEATURE_SAMPLED_IMAGE_FILTER_LINEAR_BIT;
constexpr VkFormatFeatureFlags kPeripheryFeatures = VK_FORMAT_FEATURE_TRANSFER_DST_BIT |
                                                    VK_FORMAT_FEATURE_SAMPLED_IMAGE_BIT |
                                                    VK_FORMAT_FEATURE_SAMPLED_IMAGE_FILTER_LINEAR_BIT;

// A tile (or a fovea to keep) clipped to the image.
struct ClippedTile {
    const FoveaTile *tile = nullptr;
    uint32_t layer = 0;
    VkOffset2D offset{};  // in the image
    VkExtent2D extent{};  // copied
    VkOffset2D skipped{}; // tile pixels left of / above the image
};

bool clip(const VkRect2D &rect, VkExtent2D image, ClippedTile *out) {
    const int64_t x0 = std::max<int64_t>(rect.offset.x, 0);
    const int64_t y0 = std::max<int64_t>(rect.offset.y, 0);
    const int64_t x1 = std::min<int64_t>(int64_t{rect.offset.x} + rect.extent.width, image.width);
    const int64_t y1 = std::min<int64_t>(int64_t{rect.offset.y} + rect.extent.height, image.height);
    if (x1 <= x0 || y1 <= y0) return false;
    out->offset = {static_cast<int32_t>(x0), static_cast<int32_t>(y0)};
    out->extent = {static_cast<uint32_t>(x1 - x0), static_cast<uint32_t>(y1 - y0)};
    out->skipped = {static_cast<int32_t>(x0 - rect.offset.x), static_cast<int32_t>(y0 - rect.offset.y)};
    return true;
}

bool clip(const FoveaTile &t, VkExtent2D image, uint32_t layers, uint32_t texel_bytes, ClippedTile *out) {
    if (t.layer >= layers || !t.buffer || t.texel_bytes != texel_bytes || !clip(t.rect, image, out))
        return false;
    out->tile = &t;
    out->layer = t.layer;
    return true;
}

bool overlaps(const ClippedTile &a, const ClippedTile &b) {
    return a.layer == b.layer && a.offset.x < b.offset.x + int32_t(b.extent.width) &&
           b.offset.x < a.offset.x + int32_t(a.extent.width) &&
           a.offset.y < b.offset.y + int32_t(b.extent.height) &&
           b.offset.y < a.offset.y + int32_t(a.extent.height);
}

// Memory for `req`, device-local where a type is (any type otherwise); false with nothing allocated.
bool allocate_device_local(const DeviceState &device, const VkMemoryRequirements &req, VkDeviceMemory *out) {
    uint32_t type = find_memory_type(device, req.memoryTypeBits, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
    if (type == UINT32_MAX) type = find_memory_type(device, req.memoryTypeBits, 0);
    if (type == UINT32_MAX) return false;
    VkMemoryAllocateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
    info.allocationSize = req.size;
    info.memoryTypeIndex = type;
    return device.dispatch.AllocateMemory(device.handle, &info, nullptr, out) == VK_SUCCESS;
}

void destroy_compositor_image(const DeviceState &device, CompositorImage &owned) {
    const VkDevice d = device.handle;
    const auto &k = device.dispatch;
    if (owned.view) k.DestroyImageView(d, owned.view, nullptr);
    if (owned.image) k.DestroyImage(d, owned.image, nullptr);
    if (owned.memory) k.FreeMemory(d, owned.memory, nullptr);
    owned = {};
}

// `owned` (which nothing in flight reads any more) replaced by an `extent` image of `format` with
// `layers` array layers, optimal tiling, in device-local memory, with a view when `with_view`: of
// every layer (2D array: the upsample draw samples the layer it draws) when `array_view`, else of the
// first (2D). False with one line in `error`
// about `what` the image is, `owned` left empty.
bool create_compositor_image(const DeviceState &device, VkFormat format, VkExtent2D extent, uint32_t layers,
                             VkImageUsageFlags usage, bool with_view, const char *what,
                             CompositorImage &owned, std::string *error, bool array_view = false) {
    destroy_compositor_image(device, owned);
    const VkDevice d = device.handle;
    const auto &k = device.dispatch;
    const auto fail = [&](const char *line) {
        destroy_compositor_image(device, owned);
        *error = std::string(line) + what;
        return false;
    };
    VkImageCreateInfo image_info{};
    image_info.sType = VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO;
    image_info.imageType = VK_IMAGE_TYPE_2D;
    image_info.format = format;
    image_info.extent = {extent.width, extent.height, 1};
    image_info.mipLevels = 1;
    image_info.arrayLayers = layers;
    image_info.samples = VK_SAMPLE_COUNT_1_BIT;
    image_info.tiling = VK_IMAGE_TILING_OPTIMAL;
    image_info.usage = usage;
    image_info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
    image_info.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    if (k.CreateImage(d, &image_info, nullptr, &owned.image) != VK_SUCCESS) {
        owned.image = VK_NULL_HANDLE;
        return fail("cannot create ");
    }
    VkMemoryRequirements req{};
    k.GetImageMemoryRequirements(d, owned.image, &req);
    if (!allocate_device_local(device, req, &owned.memory)) {
        owned.memory = VK_NULL_HANDLE;
        return fail("cannot allocate the memory of ");
    }
    if (k.BindImageMemory(d, owned.image, owned.memory, 0) != VK_SUCCESS)
        return fail("cannot allocate the memory of ");
    if (with_view) {
        VkImageViewCreateInfo view_info{};
        view_info.sType = VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO;
        view_info.image = owned.image;
        view_info.viewType = array_view ? VK_IMAGE_VIEW_TYPE_2D_ARRAY : VK_IMAGE_VIEW_TYPE_2D;
        view_info.format = format;
        view_info.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, array_view ? layers : 1};
        if (k.CreateImageView(d, &view_info, nullptr, &owned.view) != VK_SUCCESS) {
            owned.view = VK_NULL_HANDLE;
            return fail("cannot create the view of ");
        }
    }
    owned.extent = extent;
    return true;
}

// The layout of a draw that samples one set of `set_layout` and takes `push_size` bytes of push
// constants in its fragment shader; false with `out` null.
bool create_draw_layout(const DeviceState &device, VkDescriptorSetLayout set_layout, uint32_t push_size,
                        VkPipelineLayout *out) {
    VkPushConstantRange push{VK_SHADER_STAGE_FRAGMENT_BIT, 0, push_size};
    VkPipelineLayoutCreateInfo layout_info{};
    layout_info.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
    layout_info.setLayoutCount = 1;
    layout_info.pSetLayouts = &set_layout;
    layout_info.pushConstantRangeCount = 1;
    layout_info.pPushConstantRanges = &push;
    if (device.dispatch.CreatePipelineLayout(device.handle, &layout_info, nullptr, out) == VK_SUCCESS)
        return true;
    *out = VK_NULL_HANDLE;
    return false;
}

// `view` as what a set of set_layout_ samples (its one binding, the sampler immutable), read in
// SHADER_READ_ONLY_OPTIMAL.
void write_sampled_view(const DeviceState &device, VkDescriptorSet set, VkImageView view) {
    VkDescriptorImageInfo image{VK_NULL_HANDLE, view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
    VkWriteDescriptorSet write{};
    write.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
    write.dstSet = set;
    write.dstBinding = 0;
    write.descriptorCount = 1;
    write.descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
    write.pImageInfo = &image;
    device.dispatch.UpdateDescriptorSets(device.handle, 1, &write, 0, nullptr);
}

} // namespace

std::vector<VkRect2D> periphery_bands(VkExtent2D image, std::span<const VkBufferImageCopy> tiles) {
    // Horizontal bands between the tiles' top and bottom edges: within one, every tile covers
    // either all of it or none of it, so the gaps between the tiles it holds are whole rects.
    std::vector<uint32_t> edges = {0, image.height};
    for (const VkBufferImageCopy &t : tiles) {
        edges.push_back(std::min<uint32_t>(uint32_t(t.imageOffset.y), image.height));
        edges.push_back(std::min<uint32_t>(uint32_t(t.imageOffset.y) + t.imageExtent.height, image.height));
    }
    std::sort(edges.begin(), edges.end());
    edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
    std::vector<VkRect2D> bands;
    std::vector<std::pair<uint32_t, uint32_t>> covered; // x ranges of the tiles in a band
    for (size_t i = 0; i + 1 < edges.size(); ++i) {
        const uint32_t top = edges[i], bottom = edges[i + 1];
        covered.clear();
        for (const VkBufferImageCopy &t : tiles)
            if (uint32_t(t.imageOffset.y) <= top &&
                uint32_t(t.imageOffset.y) + t.imageExtent.height >= bottom)
                covered.emplace_back(
                    uint32_t(t.imageOffset.x),
                    std::min<uint32_t>(uint32_t(t.imageOffset.x) + t.imageExtent.width, image.width));
        std::sort(covered.begin(), covered.end());
        uint32_t x = 0;
        const auto gap = [&](uint32_t to) {
            if (to > x) bands.push_back({{int32_t(x), int32_t(top)}, {to - x, bottom - top}});
        };
        for (const auto &[from, to] : covered) {
            gap(from);
            x = std::max(x, to);
        }
        gap(image.width);
    }
    return bands;
}

std::vector<VkImageBlit> blit_regions(VkExtent2D image, VkExtent2D periphery,
                                      std::span<const VkBufferImageCopy> tiles) {
    // A blit region maps integer rects onto integer rects, so a band's edges must be multiples of
    // the period after which image and periphery pixels line up again (5 for a scale of 0.6);
    // each tile shrinks to the largest such rect inside it, and the blit covers the rest of the
    // tile too, which its copy then overwrites. A long period skips nothing.
    constexpr uint32_t kMaxPeriod = 64;
    const uint32_t px = image.width / std::gcd(image.width, periphery.width);
    const uint32_t py = image.height / std::gcd(image.height, periphery.height);
    std::vector<VkBufferImageCopy> inner;
    if (px <= kMaxPeriod && py <= kMaxPeriod) {
        for (const VkBufferImageCopy &t : tiles) {
            const uint32_t x0 = (uint32_t(t.imageOffset.x) + px - 1) / px * px;
            const uint32_t y0 = (uint32_t(t.imageOffset.y) + py - 1) / py * py;
            const uint32_t x1 = (uint32_t(t.imageOffset.x) + t.imageExtent.width) / px * px;
            const uint32_t y1 = (uint32_t(t.imageOffset.y) + t.imageExtent.height) / py * py;
            if (x1 <= x0 || y1 <= y0) continue;
            VkBufferImageCopy c{};
            c.imageOffset = {int32_t(x0), int32_t(y0), 0};
            c.imageExtent = {x1 - x0, y1 - y0, 1};
            inner.push_back(c);
        }
    }
    std::vector<VkImageBlit> regions;
    for (const VkRect2D &band : periphery_bands(image, inner)) {
        const auto src = [](uint32_t v, uint32_t from, uint32_t to) {
            return int32_t(uint64_t{v} * to / from); // exact: v is a multiple of the period
        };
        const uint32_t x1 = uint32_t(band.offset.x) + band.extent.width;
        const uint32_t y1 = uint32_t(band.offset.y) + band.extent.height;
        VkImageBlit r{};
        r.srcSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
        r.srcOffsets[0] = {src(uint32_t(band.offset.x), image.width, periphery.width),
                           src(uint32_t(band.offset.y), image.height, periphery.height), 0};
        r.srcOffsets[1] = {src(x1, image.width, periphery.width), src(y1, image.height, periphery.height), 1};
        r.dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
        r.dstOffsets[0] = {band.offset.x, band.offset.y, 0};
        r.dstOffsets[1] = {int32_t(x1), int32_t(y1), 1};
        regions.push_back(r);
    }
    return regions;
}

struct Compositor::Slot {
    VkCommandBuffer command_buffer = VK_NULL_HANDLE;
    VkFence fence = VK_NULL_HANDLE;
    VkSemaphore semaphore = VK_NULL_HANDLE;
    bool in_flight = false;
    // Per array layer of the swapchain image: a view of that layer as the draw's attachment, and its
    // framebuffer (the feather draws into layer 0's: it serves single-layer images only).
    std::vector<VkImageView> target_views;
    std::vector<VkFramebuffer> framebuffers;
    VkDescriptorSet set = VK_NULL_HANDLE;
    // The copy of the periphery the draw samples; at least as large as the periphery.
    CompositorImage periphery;
    // The buffers of the tiles the slot's submit copies from: held until its fence has signalled.
    std::vector<std::shared_ptr<const void>> tiles_in_use;
    // composite_periphery(): the client's foveae, copied out of the image before the periphery is
    // blitted over it and back after (device-local, TRANSFER_SRC|DST).
    VkBuffer saved = VK_NULL_HANDLE;
    VkDeviceMemory saved_memory = VK_NULL_HANDLE;
    VkDeviceSize saved_size = 0;
    // composite_periphery() with a feather: the client's seam rectangles side by side (sampled by
    // the feather draw; TRANSFER_DST|SAMPLED, the swapchain's format), and the set that names it.
    CompositorImage seam;
    VkDescriptorSet seam_set = VK_NULL_HANDLE;
    // Timed: the composite's two timestamps, copied by the GPU (gpu_timing.h).
    HostBuffer timing;
    CommandTiming timestamps;     // the query pair of the recording (begin_recording())
    bool timing_recorded = false; // by end_recording()
    bool timing_pending = false;  // submitted, not read yet
    // take_waits(): the empty submit that stands in for the application's semaphores.
    VkSemaphore taken = VK_NULL_HANDLE;
    VkFence taken_fence = VK_NULL_HANDLE;
    bool taken_in_flight = false;
};

bool Compositor::supports(DeviceState &device, VkFormat format, std::string *why, uint32_t layers) {
    if (tile_texel_bytes(format) == 0) {
        *why = std::string(format_name(format)) + " is not a colour format of 4 or 8 bytes a texel";
        return false;
    }
    VkFormatProperties props{};
    device.instance->dispatch.GetPhysicalDeviceFormatProperties(device.physical_device, format, &props);
    if ((props.optimalTilingFeatures & kSwapchainFeatures) != kSwapchainFeatures ||
        (props.optimalTilingFeatures & kPeripheryFeatures) != kPeripheryFeatures) {
        *why = std::string(format_name(format)) + " lacks transfer, colour attachment or linear sampling";
        return false;
    }
    if (layers > 1 && (props.optimalTilingFeatures & kBlitFeatures) != kBlitFeatures) {
        *why = std::string(format_name(format)) + " of a layered image does not blit with a linear filter";
        return false;
    }
    return true;
}

Compositor::Compositor(DeviceState &device, const SwapchainState &swapchain, uint32_t queue_family,
                       UpsampleFilter filter, bool timed)
    : device_(device), swapchain_(swapchain.handle), extent_(swapchain.extent), format_(swapchain.format),
      texel_bytes_(tile_texel_bytes(swapchain.format)), layers_(std::max(swapchain.array_layers, 1u)),
      present_layout_(swapchain.present_layout), images_(swapchain.images), queue_family_(queue_family),
      filter_(filter), blit_(filter == UpsampleFilter::BilinearBlit), timed_(timed) {
    if (swapchain.runtime) {
        // An OpenXR runtime's image (runtime_swapchain.h): no semaphore orders the application's
        // rendering before the composite, nor the composite before the runtime's release barrier;
        // submission order on the queue does, so the barriers' outer scopes must name every stage.
        ready_stages_ = VK_PIPELINE_STAGE_ALL_COMMANDS_BIT;
        ready_access_ = VK_ACCESS_MEMORY_WRITE_BIT;
        done_stages_ = VK_PIPELINE_STAGE_ALL_COMMANDS_BIT;
        done_access_ = VK_ACCESS_MEMORY_READ_BIT | VK_ACCESS_MEMORY_WRITE_BIT;
    }
}

std::unique_ptr<Compositor> Compositor::create(DeviceState &device, const SwapchainState &swapchain,
                                               uint32_t queue_family, std::string *error,
                                               UpsampleFilter filter, bool timed) {
    if (!swapchain.composable) {
        *error = "the swapchain was created without the usage composition needs";
        return nullptr;
    }
    uint32_t family_count = 0;
    device.instance->dispatch.GetPhysicalDeviceQueueFamilyProperties(device.physical_device, &family_count,
                                                                     nullptr);
    std::vector<VkQueueFamilyProperties> families(family_count);
    device.instance->dispatch.GetPhysicalDeviceQueueFamilyProperties(device.physical_device, &family_count,
                                                                     families.data());
    if (queue_family >= family_count || !(families[queue_family].queueFlags & VK_QUEUE_GRAPHICS_BIT)) {
        *error = "the present queue's family " + std::to_string(queue_family) + " cannot draw";
        return nullptr;
    }
    if (!supports(device, swapchain.format, error, swapchain.array_layers)) return nullptr;
    if (filter == UpsampleFilter::BilinearBlit) {
        VkFormatProperties props{};
        device.instance->dispatch.GetPhysicalDeviceFormatProperties(device.physical_device, swapchain.format,
                                                                    &props);
        if ((props.optimalTilingFeatures & kBlitFeatures) != kBlitFeatures) filter = UpsampleFilter::Bilinear;
    }
    std::unique_ptr<Compositor> c(new Compositor(device, swapchain, queue_family, filter, timed));
    if (!c->init(error)) return nullptr;
    return c;
}

bool Compositor::init(std::string *error) {
    const VkDevice d = device_.handle;
    const auto &k = device_.dispatch;
    const auto fail = [&](const char *what) {
        *error = std::string("cannot create the compositor's ") + what;
        return false;
    };

    if (create_command_pool(device_, queue_family_, VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT,
                            &pool_) != VK_SUCCESS)
        return fail("command pool");

    // Clamp to edge and the clamp in the shader keep taps inside the periphery; one mip level.
    VkSamplerCreateInfo sampler_info{};
    sampler_info.sType = VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO;
    sampler_info.magFilter = VK_FILTER_LINEAR;
    sampler_info.minFilter = VK_FILTER_LINEAR;
    sampler_info.mipmapMode = VK_SAMPLER_MIPMAP_MODE_NEAREST;
    sampler_info.addressModeU = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
    sampler_info.addressModeV = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
    sampler_info.addressModeW = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
    sampler_info.maxLod = 0.0f;
    if (k.CreateSampler(d, &sampler_info, nullptr, &sampler_) != VK_SUCCESS) return fail("sampler");

    VkDescriptorSetLayoutBinding binding{};
    binding.binding = 0;
    binding.descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
    binding.descriptorCount = 1;
    binding.stageFlags = VK_SHADER_STAGE_FRAGMENT_BIT;
    binding.pImmutableSamplers = &sampler_;
    VkDescriptorSetLayoutCreateInfo set_layout_info{};
    set_layout_info.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO;
    set_layout_info.bindingCount = 1;
    set_layout_info.pBindings = &binding;
    if (k.CreateDescriptorSetLayout(d, &set_layout_info, nullptr, &set_layout_) != VK_SUCCESS)
        return fail("descriptor set layout");

    // Two sets per slot: the upsample draw's periphery and the feather draw's seam image.
    const uint32_t count = 2 * std::max<uint32_t>(1, static_cast<uint32_t>(images_.size()));
    VkDescriptorPoolSize pool_size{VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, count};
    VkDescriptorPoolCreateInfo descriptor_pool_info{};
    descriptor_pool_info.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
    descriptor_pool_info.maxSets = count;
    descriptor_pool_info.poolSizeCount = 1;
    descriptor_pool_info.pPoolSizes = &pool_size;
    if (k.CreateDescriptorPool(d, &descriptor_pool_info, nullptr, &descriptor_pool_) != VK_SUCCESS)
        return fail("descriptor pool");

    if (!create_draw_layout(device_, set_layout_, sizeof(PushConstants), &pipeline_layout_))
        return fail("pipeline layout");

    // The draw overwrites every pixel, so the old contents need not be loaded. The layout stays
    // COLOR_ATTACHMENT_OPTIMAL throughout: record() transitions around the pass with barriers,
    // whose stages and accesses these two dependencies repeat.
    VkAttachmentDescription attachment{};
    attachment.format = format_;
    attachment.samples = VK_SAMPLE_COUNT_1_BIT;
    attachment.loadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
    attachment.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    attachment.stencilLoadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
    attachment.stencilStoreOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
    attachment.initialLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
    attachment.finalLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
    VkAttachmentReference reference{0, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
    VkSubpassDescription subpass{};
    subpass.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
    subpass.colorAttachmentCount = 1;
    subpass.pColorAttachments = &reference;
    VkSubpassDependency dependencies[2]{};
    dependencies[0].srcSubpass = VK_SUBPASS_EXTERNAL;
    dependencies[0].dstSubpass = 0;
    dependencies[0].srcStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
    dependencies[0].dstStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
    dependencies[0].srcAccessMask = 0;
    // READ too for the feather's pass (create_feather_pipeline), which loads the attachment and must
    // have the same dependencies to share the framebuffers.
    dependencies[0].dstAccessMask =
        VK_ACCESS_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
    dependencies[1].srcSubpass = 0;
    dependencies[1].dstSubpass = VK_SUBPASS_EXTERNAL;
    dependencies[1].srcStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
    dependencies[1].dstStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
    dependencies[1].srcAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
    dependencies[1].dstAccessMask = 0;
    VkRenderPassCreateInfo render_pass_info{};
    render_pass_info.sType = VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO;
    render_pass_info.attachmentCount = 1;
    render_pass_info.pAttachments = &attachment;
    render_pass_info.subpassCount = 1;
    render_pass_info.pSubpasses = &subpass;
    render_pass_info.dependencyCount = 2;
    render_pass_info.pDependencies = dependencies;
    if (k.CreateRenderPass(d, &render_pass_info, nullptr, &render_pass_) != VK_SUCCESS)
        return fail("render pass");

    VkShaderModule vert = VK_NULL_HANDLE, frag = VK_NULL_HANDLE;
    VkShaderModuleCreateInfo module_info{};
    module_info.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO;
    module_info.codeSize = sizeof(shaders::composite_vert);
    module_info.pCode = shaders::composite_vert;
    const bool have_vert = k.CreateShaderModule(d, &module_info, nullptr, &vert) == VK_SUCCESS;
    module_info.codeSize = sizeof(shaders::upsample_frag);
    module_info.pCode = shaders::upsample_frag;
    const bool have_frag = k.CreateShaderModule(d, &module_info, nullptr, &frag) == VK_SUCCESS;

    const int32_t filter = static_cast<int32_t>(filter_);
    VkSpecializationMapEntry entry{0, 0, sizeof(filter)};
    VkSpecializationInfo specialization{1, &entry, sizeof(filter), &filter};
    VkPipelineShaderStageCreateInfo stages[2]{};
    stages[0].sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
    stages[0].stage = VK_SHADER_STAGE_VERTEX_BIT;
    stages[0].module = vert;
    stages[0].pName = "main";
    stages[1].sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
    stages[1].stage = VK_SHADER_STAGE_FRAGMENT_BIT;
    stages[1].module = frag;
    stages[1].pName = "main";
    stages[1].pSpecializationInfo = &specialization;
    VkPipelineVertexInputStateCreateInfo vertex_input{};
    vertex_input.sType = VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO;
    VkPipelineInputAssemblyStateCreateInfo input_assembly{};
    input_assembly.sType = VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO;
    input_assembly.topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
    VkPipelineViewportStateCreateInfo viewport{};
    viewport.sType = VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO;
    viewport.viewportCount = 1;
    viewport.scissorCount = 1;
    VkPipelineRasterizationStateCreateInfo raster{};
    raster.sType = VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO;
    raster.polygonMode = VK_POLYGON_MODE_FILL;
    raster.cullMode = VK_CULL_MODE_NONE;
    raster.frontFace = VK_FRONT_FACE_COUNTER_CLOCKWISE;
    raster.lineWidth = 1.0f;
    VkPipelineMultisampleStateCreateInfo multisample{};
    multisample.sType = VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO;
    multisample.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;
    VkPipelineColorBlendAttachmentState blend_attachment{};
    blend_attachment.colorWriteMask = VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_G_BIT |
                                      VK_COLOR_COMPONENT_B_BIT | VK_COLOR_COMPONENT_A_BIT;
    VkPipelineColorBlendStateCreateInfo blend{};
    blend.sType = VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO;
    blend.attachmentCount = 1;
    blend.pAttachments = &blend_attachment;
    const VkDynamicState dynamic_states[] = {VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR};
    VkPipelineDynamicStateCreateInfo dynamic{};
    dynamic.sType = VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO;
    dynamic.dynamicStateCount = 2;
    dynamic.pDynamicStates = dynamic_states;
    VkGraphicsPipelineCreateInfo pipeline_info{};
    pipeline_info.sType = VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO;
    pipeline_info.stageCount = 2;
    pipeline_info.pStages = stages;
    pipeline_info.pVertexInputState = &vertex_input;
    pipeline_info.pInputAssemblyState = &input_assembly;
    pipeline_info.pViewportState = &viewport;
    pipeline_info.pRasterizationState = &raster;
    pipeline_info.pMultisampleState = &multisample;
    pipeline_info.pColorBlendState = &blend;
    pipeline_info.pDynamicState = &dynamic;
    pipeline_info.layout = pipeline_layout_;
    pipeline_info.renderPass = render_pass_;
    pipeline_info.subpass = 0;
    const bool have_pipeline =
        have_vert && have_frag &&
        k.CreateGraphicsPipelines(d, VK_NULL_HANDLE, 1, &pipeline_info, nullptr, &pipeline_) == VK_SUCCESS;
    if (frag) k.DestroyShaderModule(d, frag, nullptr);
    if (!have_pipeline) {
        if (vert) k.DestroyShaderModule(d, vert, nullptr);
        return fail("pipeline");
    }
    create_feather_pipeline(vert, render_pass_info, pipeline_info);
    if (vert) k.DestroyShaderModule(d, vert, nullptr);

    slots_.resize(images_.size());
    return true;
}

void Compositor::create_feather_pipeline(VkShaderModule vert, VkRenderPassCreateInfo render_pass_info,
                                         VkGraphicsPipelineCreateInfo pipeline_info) {
    const VkDevice d = device_.handle;
    const auto &k = device_.dispatch;
    VkFormatProperties props{};
    device_.instance->dispatch.GetPhysicalDeviceFormatProperties(device_.physical_device, format_, &props);
    if (!(props.optimalTilingFeatures & VK_FORMAT_FEATURE_COLOR_ATTACHMENT_BLEND_BIT)) return;

    if (!create_draw_layout(device_, set_layout_, sizeof(FeatherPushConstants), &feather_layout_)) return;
    // The feather blends into what the upsample left: loaded. Otherwise the upsample's pass (its
    // dependencies name the load's read), so that the two are compatible and the slots' framebuffers
    // serve both. Around the pass, record_seams() transitions with barriers that the dependencies repeat.
    VkAttachmentDescription attachment = render_pass_info.pAttachments[0];
    attachment.loadOp = VK_ATTACHMENT_LOAD_OP_LOAD;
    render_pass_info.pAttachments = &attachment;
    if (k.CreateRenderPass(d, &render_pass_info, nullptr, &seam_pass_) != VK_SUCCESS) {
        seam_pass_ = VK_NULL_HANDLE;
        return;
    }

    VkShaderModule frag = VK_NULL_HANDLE;
    VkShaderModuleCreateInfo module_info{};
    module_info.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO;
    module_info.codeSize = sizeof(shaders::feather_frag);
    module_info.pCode = shaders::feather_frag;
    if (!vert || k.CreateShaderModule(d, &module_info, nullptr, &frag) != VK_SUCCESS) return;
    VkPipelineShaderStageCreateInfo stages[2]{};
    stages[0] = pipeline_info.pStages[0];
    stages[1].sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
    stages[1].stage = VK_SHADER_STAGE_FRAGMENT_BIT;
    stages[1].module = frag;
    stages[1].pName = "main";
    // out = client * w + periphery * (1 - w), w in the source's alpha; the alpha channel keeps the
    // periphery's (a second weight would need dual-source blending, which not every device has).
    VkPipelineColorBlendAttachmentState blend_attachment{};
    blend_attachment.blendEnable = VK_TRUE;
    blend_attachment.srcColorBlendFactor = VK_BLEND_FACTOR_SRC_ALPHA;
    blend_attachment.dstColorBlendFactor = VK_BLEND_FACTOR_ONE_MINUS_SRC_ALPHA;
    blend_attachment.colorBlendOp = VK_BLEND_OP_ADD;
    blend_attachment.srcAlphaBlendFactor = VK_BLEND_FACTOR_ZERO;
    blend_attachment.dstAlphaBlendFactor = VK_BLEND_FACTOR_ONE;
    blend_attachment.alphaBlendOp = VK_BLEND_OP_ADD;
    blend_attachment.colorWriteMask = VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_G_BIT |
                                      VK_COLOR_COMPONENT_B_BIT | VK_COLOR_COMPONENT_A_BIT;
    VkPipelineColorBlendStateCreateInfo blend{};
    blend.sType = VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO;
    blend.attachmentCount = 1;
    blend.pAttachments = &blend_attachment;
    pipeline_info.pStages = stages;
    pipeline_info.pColorBlendState = &blend;
    pipeline_info.layout = feather_layout_;
    pipeline_info.renderPass = seam_pass_;
    if (k.CreateGraphicsPipelines(d, VK_NULL_HANDLE, 1, &pipeline_info, nullptr, &feather_pipeline_) !=
        VK_SUCCESS)
        feather_pipeline_ = VK_NULL_HANDLE;
    k.DestroyShaderModule(d, frag, nullptr);
}

bool Compositor::init_slot(Slot &s, uint32_t image_index, std::string *error) {
    const VkDevice d = device_.handle;
    const auto &k = device_.dispatch;
    const auto fail = [&](const char *what) {
        *error = std::string("cannot create the compositor's ") + what + " for image " +
                 std::to_string(image_index);
        return false;
    };
    if (allocate_primary_command_buffer(device_, pool_, &s.command_buffer) != VK_SUCCESS)
        return fail("command buffer");

    if (create_fence(device_, &s.fence) != VK_SUCCESS) return fail("fence");
    if (create_semaphore(device_, &s.semaphore) != VK_SUCCESS) return fail("semaphore");
    if (create_fence(device_, &s.taken_fence) != VK_SUCCESS) return fail("fence");
    if (create_semaphore(device_, &s.taken) != VK_SUCCESS) return fail("semaphore");
    std::string untimed; // without this buffer the slot's composites are not timed
    if (timed_)
        create_host_buffer(device_, 2 * sizeof(uint64_t), VK_BUFFER_USAGE_TRANSFER_DST_BIT, HostAccess::Read,
                           &s.timing, &untimed);

    // A view of each layer of the swapchain image in its own format (never another: the fovea goes
    // in by copy), and a framebuffer on it: the draw upsamples a layered image layer by layer.
    for (uint32_t layer = 0; layer < layers_; ++layer) {
        VkImageViewCreateInfo view_info{};
        view_info.sType = VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO;
        view_info.image = images_[image_index];
        view_info.viewType = VK_IMAGE_VIEW_TYPE_2D;
        view_info.format = format_;
        view_info.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, layer, 1};
        VkImageView view = VK_NULL_HANDLE;
        if (k.CreateImageView(d, &view_info, nullptr, &view) != VK_SUCCESS) return fail("image view");
        s.target_views.push_back(view);
        VkFramebufferCreateInfo framebuffer_info{};
        framebuffer_info.sType = VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO;
        framebuffer_info.renderPass = render_pass_;
        framebuffer_info.attachmentCount = 1;
        framebuffer_info.pAttachments = &view;
        framebuffer_info.width = extent_.width;
        framebuffer_info.height = extent_.height;
        framebuffer_info.layers = 1;
        VkFramebuffer framebuffer = VK_NULL_HANDLE;
        if (k.CreateFramebuffer(d, &framebuffer_info, nullptr, &framebuffer) != VK_SUCCESS)
            return fail("framebuffer");
        s.framebuffers.push_back(framebuffer);
    }

    VkDescriptorSetAllocateInfo set_info{};
    set_info.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
    set_info.descriptorPool = descriptor_pool_;
    set_info.descriptorSetCount = 1;
    set_info.pSetLayouts = &set_layout_;
    if (k.AllocateDescriptorSets(d, &set_info, &s.set) != VK_SUCCESS) return fail("descriptor set");
    if (k.AllocateDescriptorSets(d, &set_info, &s.seam_set) != VK_SUCCESS) return fail("descriptor set");
    return true;
}

// Called only while the slot is idle (its fence waited for), so the old image can go.
bool Compositor::ensure_periphery_image(Slot &s, VkExtent2D periphery, std::string *error) {
    // Exactly the periphery's size: the blit clamps its filter to the image's edge.
    if (s.periphery.image && s.periphery.extent.width == periphery.width &&
        s.periphery.extent.height == periphery.height)
        return true;
    // The swapchain's format: the copy moves bytes, and sampling an sRGB image decodes them.
    if (!create_compositor_image(device_, format_, periphery, layers_,
                                 VK_IMAGE_USAGE_TRANSFER_DST_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT |
                                     VK_IMAGE_USAGE_SAMPLED_BIT,
                                 /*with_view=*/true, "the periphery image", s.periphery, error,
                                 /*array_view=*/true))
        return false;
    write_sampled_view(device_, s.set, s.periphery.view);
    return true;
}

void Compositor::destroy_slot(Slot &s) {
    const VkDevice d = device_.handle;
    const auto &k = device_.dispatch;
    if (s.in_flight) k.WaitForFences(d, 1, &s.fence, VK_TRUE, kDestroyWaitNs);
    s.tiles_in_use.clear();
    destroy_host_buffer(device_, s.timing);
    destroy_compositor_image(device_, s.periphery);
    if (s.saved) k.DestroyBuffer(d, s.saved, nullptr);
    if (s.saved_memory) k.FreeMemory(d, s.saved_memory, nullptr);
    destroy_compositor_image(device_, s.seam);
    for (VkFramebuffer framebuffer : s.framebuffers)
        k.DestroyFramebuffer(d, framebuffer, nullptr);
    for (VkImageView view : s.target_views)
        k.DestroyImageView(d, view, nullptr);
    if (s.semaphore) k.DestroySemaphore(d, s.semaphore, nullptr);
    if (s.fence) k.DestroyFence(d, s.fence, nullptr);
    if (s.taken_in_flight) k.WaitForFences(d, 1, &s.taken_fence, VK_TRUE, kDestroyWaitNs);
    if (s.taken) k.DestroySemaphore(d, s.taken, nullptr);
    if (s.taken_fence) k.DestroyFence(d, s.taken_fence, nullptr);
    // The descriptor set and command buffer go with their pools.
    s = Slot{};
}

Compositor::~Compositor() {
    const VkDevice d = device_.handle;
    const auto &k = device_.dispatch;
    std::lock_guard lock(mutex_);
    for (auto &slot : slots_)
        if (slot) destroy_slot(*slot);
    destroy_latest_periphery();
    if (pipeline_) k.DestroyPipeline(d, pipeline_, nullptr);
    if (feather_pipeline_) k.DestroyPipeline(d, feather_pipeline_, nullptr);
    if (seam_pass_) k.DestroyRenderPass(d, seam_pass_, nullptr);
    if (feather_layout_) k.DestroyPipelineLayout(d, feather_layout_, nullptr);
    if (render_pass_) k.DestroyRenderPass(d, render_pass_, nullptr);
    if (pipeline_layout_) k.DestroyPipelineLayout(d, pipeline_layout_, nullptr);
    if (descriptor_pool_) k.DestroyDescriptorPool(d, descriptor_pool_, nullptr);
    if (set_layout_) k.DestroyDescriptorSetLayout(d, set_layout_, nullptr);
    if (sampler_) k.DestroySampler(d, sampler_, nullptr);
    if (pool_) k.DestroyCommandPool(d, pool_, nullptr);
}

VkImageMemoryBarrier Compositor::layered_barrier(VkImage image, VkAccessFlags src, VkAccessFlags dst,
                                                 VkImageLayout from, VkImageLayout to) const {
    return colour_image_barrier(image, src, dst, from, to, 0, 0, layers_);
}

void Compositor::begin_recording(Slot &s) {
    const auto &k = device_.dispatch;
    const VkCommandBuffer cb = s.command_buffer;
    k.ResetCommandBuffer(cb, 0);
    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    k.BeginCommandBuffer(cb, &begin);
    s.timing_recorded = false;
    s.timestamps = {};
    if (timed_ && s.timing.buffer) time_composite_begin(device_, cb, s.timestamps);
}

void Compositor::end_recording(Slot &s) {
    const VkCommandBuffer cb = s.command_buffer;
    const auto &k = device_.dispatch;
    if (timed_ && s.timing.buffer)
        s.timing_recorded = time_composite_end(device_, cb, s.timestamps, s.timing.buffer);
    k.EndCommandBuffer(cb);
}

void Compositor::record(Slot &s, uint32_t image_index, VkExtent2D periphery) {
    const auto &k = device_.dispatch;
    const VkCommandBuffer cb = s.command_buffer;
    const VkImage image = images_[image_index];
    const bool upsample = periphery.width > 0 && periphery.height > 0 &&
                          (periphery.width != extent_.width || periphery.height != extent_.height);
    const bool has_tiles = !copy_regions_.empty();

    begin_recording(s);

    // The submit waits on the application's semaphores at the TRANSFER stage; the first barrier's
    // source stage is TRANSFER too, so its layout transition happens after that wait (a semaphore
    // signal makes all the application's writes available, so no source access is needed).
    // Whatever presented the image before the application re-acquired it is ordered by the
    // application's acquire semaphore, which its own rendering (and so its present semaphores)
    // already waited on.
    if (upsample) {
        VkImageMemoryBarrier barriers[2] = {
            layered_barrier(image, ready_access_, VK_ACCESS_TRANSFER_READ_BIT, present_layout_,
                            VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL),
            // Old contents are not needed. This slot's previous submit sampled the periphery
            // image in the fragment shader; the host waited for its fence, but the execution
            // dependency from FRAGMENT_SHADER states the write-after-read order on the queue too.
            layered_barrier(s.periphery.image, 0, VK_ACCESS_TRANSFER_WRITE_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                            VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL),
        };
        k.CmdPipelineBarrier(cb, ready_stages_ | VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT,
                             VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0, nullptr, 0, nullptr, 2, barriers);
        VkImageCopy copy{};
        copy.srcSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, layers_};
        copy.dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, layers_};
        copy.extent = {periphery.width, periphery.height, 1};
        k.CmdCopyImage(cb, image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, s.periphery.image,
                       VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &copy);

        record_upsample(s, image, periphery, s.periphery.image, /*source_written=*/true);
    } else if (has_tiles) {
        // Tiles over what the application rendered: keep the contents (old layout, not UNDEFINED).
        VkImageMemoryBarrier b = layered_barrier(image, ready_access_, VK_ACCESS_TRANSFER_WRITE_BIT,
                                                 present_layout_, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL);
        k.CmdPipelineBarrier(cb, ready_stages_, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0, nullptr, 0, nullptr, 1,
                             &b);
    }

    record_tile_copies(s, image);
    end_recording(s);
}

void Compositor::record_upsample(Slot &s, VkImage image, VkExtent2D periphery, VkImage source,
                                 bool source_written) {
    const auto &k = device_.dispatch;
    const VkCommandBuffer cb = s.command_buffer;
    const bool has_tiles = !copy_regions_.empty();
    // The periphery's writes to the image (a blit's or a draw's) before the tile copies
    // overwrite the fovea (write-after-write), or before the present.
    const auto after_periphery = [&](VkPipelineStageFlags stage, VkAccessFlags access, VkImageLayout layout) {
        const VkImageMemoryBarrier b = layered_barrier(
            image, access, has_tiles ? VkAccessFlags{VK_ACCESS_TRANSFER_WRITE_BIT} : done_access_, layout,
            has_tiles ? VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL : present_layout_);
        k.CmdPipelineBarrier(cb, stage,
                             has_tiles ? VkPipelineStageFlags{VK_PIPELINE_STAGE_TRANSFER_BIT} : done_stages_,
                             0, 0, nullptr, 0, nullptr, 1, &b);
    };
    if (blit_) {
        // The earlier read of the swapchain image (a copy out of it) before the blit overwrites it
        // (write-after-read); a `source_written` by a copy just before, before the blit reads it.
        // A source that is read as it is (Compositor::latest_, made readable when it was uploaded)
        // needs no barrier here.
        VkImageMemoryBarrier to_blit[2] = {
            layered_barrier(image, 0, VK_ACCESS_TRANSFER_WRITE_BIT, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                            VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL),
            layered_barrier(source, VK_ACCESS_TRANSFER_WRITE_BIT, VK_ACCESS_TRANSFER_READ_BIT,
                            VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL),
        };
        k.CmdPipelineBarrier(cb, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0,
                             nullptr, 0, nullptr, source_written ? 2 : 1, to_blit);
        // The periphery image is exactly the periphery's size, so the filter's clamp to its
        // edge is the clamp to the periphery's edge that the shader does.
        // Per layer, around that layer's tiles.
        std::vector<VkImageBlit> regions;
        std::vector<VkBufferImageCopy> in_layer;
        for (uint32_t layer = 0; layer < layers_; ++layer) {
            in_layer.clear();
            for (const VkBufferImageCopy &c : copy_regions_)
                if (c.imageSubresource.baseArrayLayer == layer) in_layer.push_back(c);
            for (VkImageBlit r : blit_regions(extent_, periphery, in_layer)) {
                r.srcSubresource.baseArrayLayer = layer;
                r.dstSubresource.baseArrayLayer = layer;
                regions.push_back(r);
            }
        }
        k.CmdBlitImage(cb, source, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, image,
                       VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, static_cast<uint32_t>(regions.size()),
                       regions.data(), VK_FILTER_LINEAR);
        after_periphery(VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT,
                        VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL);
    } else {
        // The copy's write of the periphery image before the fragment shader reads it; the
        // copy's read of the swapchain image before the draw overwrites it (write-after-read:
        // an execution dependency, plus the transition to the attachment layout).
        VkImageMemoryBarrier to_draw[2] = {
            layered_barrier(s.periphery.image, VK_ACCESS_TRANSFER_WRITE_BIT, VK_ACCESS_SHADER_READ_BIT,
                            VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL),
            layered_barrier(image, 0, VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT,
                            VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL),
        };
        k.CmdPipelineBarrier(cb, VK_PIPELINE_STAGE_TRANSFER_BIT,
                             VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT |
                                 VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT,
                             0, 0, nullptr, 0, nullptr, 2, to_draw);

        // One pass per layer (a layered image's eyes), each drawing its layer from the same layer of
        // the periphery image; the passes write distinct subresources, so none waits on another.
        PushConstants push{};
        push.scale[0] = float(periphery.width) / float(extent_.width);
        push.scale[1] = float(periphery.height) / float(extent_.height);
        push.texel_size[0] = 1.0f / float(s.periphery.extent.width);
        push.texel_size[1] = 1.0f / float(s.periphery.extent.height);
        push.max_centre[0] = float(periphery.width) - 0.5f;
        push.max_centre[1] = float(periphery.height) - 0.5f;
        const VkViewport viewport{0.0f, 0.0f, float(extent_.width), float(extent_.height), 0.0f, 1.0f};
        std::vector<VkBufferImageCopy> in_layer;
        for (uint32_t layer = 0; layer < layers_; ++layer) {
            in_layer.clear();
            for (const VkBufferImageCopy &c : copy_regions_)
                if (c.imageSubresource.baseArrayLayer == layer) in_layer.push_back(c);
            VkRenderPassBeginInfo pass{};
            pass.sType = VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO;
            pass.renderPass = render_pass_;
            pass.framebuffer = s.framebuffers[layer];
            pass.renderArea = {{0, 0}, extent_};
            k.CmdBeginRenderPass(cb, &pass, VK_SUBPASS_CONTENTS_INLINE);
            k.CmdBindPipeline(cb, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline_);
            k.CmdBindDescriptorSets(cb, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline_layout_, 0, 1, &s.set, 0,
                                    nullptr);
            k.CmdSetViewport(cb, 0, 1, &viewport);
            push.layer = int32_t(layer);
            k.CmdPushConstants(cb, pipeline_layout_, VK_SHADER_STAGE_FRAGMENT_BIT, 0, sizeof(push), &push);
            // Only around this layer's foveae: the tile copies below overwrite them, so what the
            // pass leaves there (undefined: the attachment is not loaded) is never seen.
            for (const VkRect2D &band : periphery_bands(extent_, in_layer)) {
                k.CmdSetScissor(cb, 0, 1, &band);
                k.CmdDraw(cb, 3, 1, 0, 0);
            }
            k.CmdEndRenderPass(cb);
        }

        after_periphery(VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT,
                        VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL);
    }
}

void Compositor::record_tile_copies(Slot &s, VkImage image) {
    if (copy_regions_.empty()) return;
    const auto &k = device_.dispatch;
    const VkCommandBuffer cb = s.command_buffer;
    // The tiles' buffers were written (and flushed) by the host before vkQueueSubmit, which
    // makes host writes visible to the device (no host barrier needed; composite_periphery's saved
    // foveae have their own barrier). Tiles do not overlap (composite drops those that would), so
    // their copies need no barrier between them.
    for (size_t i = 0; i < copy_regions_.size(); ++i)
        k.CmdCopyBufferToImage(cb, copy_buffers_[i], image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1,
                               &copy_regions_[i]);
    // Back to the present layout. The present waits on our semaphore, whose signal makes
    // these writes available and visible to the presentation engine: no destination stage
    // or access beyond the end of the pipe.
    VkImageMemoryBarrier b =
        colour_image_barrier(image, VK_ACCESS_TRANSFER_WRITE_BIT, done_access_,
                             VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, present_layout_, 0, 0, layers_);
    k.CmdPipelineBarrier(cb, VK_PIPELINE_STAGE_TRANSFER_BIT, done_stages_, 0, 0, nullptr, 0, nullptr, 1, &b);
}

void Compositor::read_timing(Slot &s) {
    if (!s.timing_pending) return;
    s.timing_pending = false;
    invalidate_host_buffer(device_, s.timing);
    uint64_t stamps[2] = {};
    std::memcpy(stamps, s.timing.mapped, sizeof(stamps));
    if (const double ms = timestamps_ms(device_, stamps[0], stamps[1]); ms > 0) latest_gpu_ms_ = ms;
}

double Compositor::latest_gpu_ms() {
    std::lock_guard lock(mutex_);
    return latest_gpu_ms_;
}

Compositor::Slot *Compositor::ready_slot(uint32_t image_index, bool wait_taken, VkResult *result) {
    if (image_index >= images_.size()) {
        *result = VK_ERROR_UNKNOWN;
        return nullptr;
    }
    std::string error;
    auto &slot_ptr = slots_[image_index];
    if (!slot_ptr) {
        slot_ptr = std::make_unique<Slot>();
        if (!init_slot(*slot_ptr, image_index, &error)) {
            SPLITVK_WARN("compositor: %s", error.c_str());
            destroy_slot(*slot_ptr);
            slot_ptr.reset();
            *result = VK_ERROR_OUT_OF_DEVICE_MEMORY;
            return nullptr;
        }
    }
    Slot &s = *slot_ptr;
    const VkDevice d = device_.handle;
    const auto &k = device_.dispatch;
    // The slot's previous submits (of this image's previous present) must be done before its
    // command buffer, tiles' buffers, periphery image and fences are reused. Bounded: rather skip
    // the composition of this frame than hang the application.
    if (s.in_flight) {
        const VkResult waited = k.WaitForFences(d, 1, &s.fence, VK_TRUE, kSlotWaitNs);
        if (waited != VK_SUCCESS) {
            *result = waited;
            return nullptr;
        }
        s.in_flight = false;
        s.tiles_in_use.clear(); // the copies from them are done
        read_timing(s);
    }
    if (wait_taken && s.taken_in_flight) {
        const VkResult waited = k.WaitForFences(d, 1, &s.taken_fence, VK_TRUE, kSlotWaitNs);
        if (waited != VK_SUCCESS) {
            *result = waited;
            return nullptr;
        }
        s.taken_in_flight = false;
    }
    *result = VK_SUCCESS;
    return &s;
}

VkResult Compositor::take_waits(VkQueue queue, uint32_t image_index, std::span<const VkSemaphore> waits,
                                VkSemaphore *taken, VkFence *done) {
    std::lock_guard lock(mutex_);
    VkResult result = VK_SUCCESS;
    Slot *s = ready_slot(image_index, /*wait_taken=*/true, &result);
    if (!s) return result;
    const auto &k = device_.dispatch;
    std::vector<VkPipelineStageFlags> stages(waits.size(), VK_PIPELINE_STAGE_ALL_COMMANDS_BIT);
    const VkSubmitInfo submit = submit_info(nullptr, waits, stages.data(), &s->taken);
    k.ResetFences(device_.handle, 1, &s->taken_fence);
    result = k.QueueSubmit(queue, 1, &submit, s->taken_fence);
    if (result != VK_SUCCESS) return result;
    s->taken_in_flight = true;
    *taken = s->taken;
    *done = s->taken_fence;
    return VK_SUCCESS;
}

VkResult Compositor::composite(VkQueue queue, uint32_t image_index, std::span<const VkSemaphore> waits,
                               VkExtent2D periphery, std::span<const FoveaTile> tiles, VkSemaphore *signal) {
    std::lock_guard lock(mutex_);
    VkResult result = VK_SUCCESS;
    std::string error;
    // The slot's take_waits() batch of this frame is not waited for: it precedes this submit on
    // the queue, and its semaphore is among `waits`.
    Slot *slot = ready_slot(image_index, /*wait_taken=*/false, &result);
    if (!slot) return result;
    Slot &s = *slot;

    periphery.width = std::min(periphery.width, extent_.width);
    periphery.height = std::min(periphery.height, extent_.height);
    const bool upsample = periphery.width > 0 && periphery.height > 0 &&
                          (periphery.width != extent_.width || periphery.height != extent_.height);

    // Tiles: clipped to the image, overlapping ones dropped (a composite must not write a texel
    // twice). Each is copied from where it was decoded: its clipped rect, rows of its own width.
    std::vector<ClippedTile> clipped;
    for (const FoveaTile &t : tiles) {
        ClippedTile c;
        if (!clip(t, extent_, layers_, texel_bytes_, &c)) continue;
        if (std::any_of(clipped.begin(), clipped.end(),
                        [&](const ClippedTile &o) { return overlaps(o, c); })) {
            SPLITVK_DEBUG("compositor: dropped a tile that overlaps another");
            continue;
        }
        clipped.push_back(c);
    }
    if (!upsample && clipped.empty()) return VK_NOT_READY; // nothing to do: present as asked

    if (upsample && !ensure_periphery_image(s, periphery, &error)) {
        SPLITVK_WARN("compositor: %s", error.c_str());
        return VK_ERROR_OUT_OF_DEVICE_MEMORY;
    }
    copy_regions_.clear();
    copy_buffers_.clear();
    s.tiles_in_use.clear(); // ready_slot(): the slot's previous copies are done
    for (const ClippedTile &c : clipped) {
        const FoveaTile &t = *c.tile;
        VkBufferImageCopy region{};
        // A multiple of the texel size, as t.offset is.
        region.bufferOffset =
            t.offset + (VkDeviceSize{uint32_t(c.skipped.y)} * t.rect.extent.width + uint32_t(c.skipped.x)) *
                           texel_bytes_;
        region.bufferRowLength = t.rect.extent.width;
        region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, t.layer, 1};
        region.imageOffset = {c.offset.x, c.offset.y, 0};
        region.imageExtent = {c.extent.width, c.extent.height, 1};
        copy_regions_.push_back(region);
        copy_buffers_.push_back(t.buffer);
        if (t.keep) s.tiles_in_use.push_back(t.keep);
    }

    record(s, image_index, upsample ? periphery : VkExtent2D{});
    return submit(s, queue, waits, signal);
}

VkResult Compositor::submit(Slot &s, VkQueue queue, std::span<const VkSemaphore> waits, VkSemaphore *signal) {
    const auto &k = device_.dispatch;
    std::vector<VkPipelineStageFlags> stages(waits.size(), VK_PIPELINE_STAGE_TRANSFER_BIT);
    // No one to signal for (an OpenXR runtime's image, ordered by the queue): a binary semaphore
    // signalled and never waited on could not be signalled again.
    const VkSubmitInfo submit =
        submit_info(&s.command_buffer, waits, stages.data(), signal ? &s.semaphore : nullptr);
    k.ResetFences(device_.handle, 1, &s.fence);
    // On failure the semaphores and the fence are left as they were (except after device loss).
    const VkResult result = k.QueueSubmit(queue, 1, &submit, s.fence);
    if (result != VK_SUCCESS) return result;
    note_timed_submit(device_, s.timestamps);
    s.in_flight = true;
    s.timing_pending = s.timing_recorded;
    if (signal) *signal = s.semaphore;
    return VK_SUCCESS;
}

// ---------------------------------------------------------------------------- the swapped split

void Compositor::destroy_latest_periphery() {
    destroy_compositor_image(device_, latest_);
    latest_layout_ = VK_IMAGE_LAYOUT_UNDEFINED;
    latest_filled_ = false;
}

bool Compositor::ensure_latest_periphery(VkExtent2D extent, std::string *error) {
    if (latest_.image && latest_.extent.width == extent.width && latest_.extent.height == extent.height)
        return true;
    const VkDevice d = device_.handle;
    const auto &k = device_.dispatch;
    // Every slot's submit may read the latest periphery: all must be done before it goes (a new
    // size means a new scale, which a session does not change, so this is rare).
    for (auto &slot : slots_)
        if (slot && slot->in_flight &&
            k.WaitForFences(d, 1, &slot->fence, VK_TRUE, kSlotWaitNs) != VK_SUCCESS) {
            *error = "a composite still reads the latest periphery";
            return false;
        }
    destroy_latest_periphery();
    // The swapchain's format: the parts are copied in as bytes, as fovea tiles are.
    return create_compositor_image(device_, format_, extent, 1,
                                   VK_IMAGE_USAGE_TRANSFER_DST_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                                   /*with_view=*/false, "the latest periphery's image", latest_, error);
}

// Called only while the slot is idle (its fence waited for), so the old buffer can go.
bool Compositor::ensure_saved_buffer(Slot &s, VkDeviceSize size, std::string *error) {
    if (s.saved && s.saved_size >= size) return true;
    const VkDevice d = device_.handle;
    const auto &k = device_.dispatch;
    if (s.saved) k.DestroyBuffer(d, s.saved, nullptr);
    if (s.saved_memory) k.FreeMemory(d, s.saved_memory, nullptr);
    s.saved = VK_NULL_HANDLE;
    s.saved_memory = VK_NULL_HANDLE;
    s.saved_size = 0;
    VkBufferCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
    info.size = size;
    info.usage = VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
    info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
    if (k.CreateBuffer(d, &info, nullptr, &s.saved) != VK_SUCCESS) {
        s.saved = VK_NULL_HANDLE;
        *error = "cannot create the buffer the foveae are saved in";
        return false;
    }
    VkMemoryRequirements req{};
    k.GetBufferMemoryRequirements(d, s.saved, &req);
    if (!allocate_device_local(device_, req, &s.saved_memory) ||
        k.BindBufferMemory(d, s.saved, s.saved_memory, 0) != VK_SUCCESS) {
        *error = "cannot allocate the memory the foveae are saved in";
        return false;
    }
    s.saved_size = size;
    return true;
}

namespace {

// The band of a seam: its rectangle less the fovea, as the rectangles around the fovea
// (periphery_bands of the rectangle, the fovea its one tile), in image coordinates. The feather
// copies and draws these only: inside the fovea the copy back overwrites whatever is there.
std::vector<VkRect2D> seam_bands(const VkRect2D &rect, const VkRect2D &fovea) {
    VkBufferImageCopy inner{};
    inner.imageOffset = {fovea.offset.x - rect.offset.x, fovea.offset.y - rect.offset.y, 0};
    inner.imageExtent = {fovea.extent.width, fovea.extent.height, 1};
    std::vector<VkRect2D> bands = periphery_bands(rect.extent, std::span(&inner, 1));
    for (VkRect2D &band : bands) {
        band.offset.x += rect.offset.x;
        band.offset.y += rect.offset.y;
    }
    return bands;
}

} // namespace

// Called only while the slot is idle (its fence waited for), so the old image can go.
bool Compositor::ensure_seam_image(Slot &s, VkExtent2D extent, std::string *error) {
    if (s.seam.image && s.seam.extent.width >= extent.width && s.seam.extent.height >= extent.height)
        return true;
    // The swapchain's format: copied into as bytes, decoded (sRGB) when the feather draw reads it.
    if (!create_compositor_image(device_, format_, extent, 1,
                                 VK_IMAGE_USAGE_TRANSFER_DST_BIT | VK_IMAGE_USAGE_SAMPLED_BIT,
                                 /*with_view=*/true, "the image the seams are saved in", s.seam, error))
        return false;
    write_sampled_view(device_, s.seam_set, s.seam.view);
    return true;
}

VkResult Compositor::composite_periphery(VkQueue queue, uint32_t image_index,
                                         std::span<const VkSemaphore> waits, const PeripheryImage *periphery,
                                         std::span<const VkRect2D> keep, VkSemaphore *signal,
                                         uint32_t feather) {
    std::lock_guard lock(mutex_);
    // Window swapchains only in this slice: an OpenXR runtime's layered image is not cut.
    if (layers_ != 1) return VK_ERROR_FEATURE_NOT_PRESENT;
    if (periphery && (periphery->extent.width == 0 || periphery->extent.height == 0 ||
                      periphery->extent.width > extent_.width || periphery->extent.height > extent_.height))
        return VK_ERROR_FORMAT_NOT_SUPPORTED;
    if (!periphery && !latest_filled_) return VK_NOT_READY; // no periphery yet: present as is
    VkResult result = VK_SUCCESS;
    Slot *slot = ready_slot(image_index, /*wait_taken=*/false, &result);
    if (!slot) return result;
    Slot &s = *slot;
    std::string error;
    if (periphery && !ensure_latest_periphery(periphery->extent, &error)) {
        SPLITVK_WARN("compositor: %s", error.c_str());
        return VK_ERROR_OUT_OF_DEVICE_MEMORY;
    }
    if (!blit_ && !ensure_periphery_image(s, latest_.extent, &error)) {
        SPLITVK_WARN("compositor: %s", error.c_str());
        return VK_ERROR_OUT_OF_DEVICE_MEMORY;
    }

    // The foveae to keep, clipped to the image, overlapping ones dropped (copied back, a texel
    // must be written once), packed one after the other into the slot's saved buffer.
    copy_regions_.clear();
    copy_buffers_.clear();
    s.tiles_in_use.clear(); // ready_slot(): the slot's previous copies are done
    std::vector<ClippedTile> kept;
    VkDeviceSize saved_bytes = 0;
    for (const VkRect2D &rect : keep) {
        ClippedTile c;
        if (!clip(rect, extent_, &c)) continue;
        if (std::any_of(kept.begin(), kept.end(), [&](const ClippedTile &o) { return overlaps(o, c); })) {
            SPLITVK_DEBUG("compositor: dropped a fovea that overlaps another");
            continue;
        }
        kept.push_back(c);
        VkBufferImageCopy region{};
        region.bufferOffset = saved_bytes;
        region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
        region.imageOffset = {c.offset.x, c.offset.y, 0};
        region.imageExtent = {c.extent.width, c.extent.height, 1};
        copy_regions_.push_back(region);
        saved_bytes += VkDeviceSize{c.extent.width} * c.extent.height * texel_bytes_;
    }
    if (saved_bytes > 0 && !ensure_saved_buffer(s, saved_bytes, &error)) {
        SPLITVK_WARN("compositor: %s", error.c_str());
        return VK_ERROR_OUT_OF_DEVICE_MEMORY;
    }
    copy_buffers_.assign(copy_regions_.size(), s.saved);

    // The feathered seams: around each fovea kept, its seam rectangle, by the rule the client cut its
    // passes with (so every pixel blended is one the client rendered), side by side in the seam image.
    seams_.clear();
    feather_ = feather_pipeline_ ? feather : 0;
    if (feather > 0 && !feather_pipeline_) {
        static std::once_flag logged;
        std::call_once(logged, [&] {
            SPLITVK_WARN("compositor: format %d cannot be blended into: the swapped split's seam is hard",
                         int(format_));
        });
    }
    if (feather_ > 0) {
        VkExtent2D seam_extent{};
        for (const ClippedTile &c : kept) {
            Seam seam;
            seam.fovea = {c.offset, c.extent};
            seam.rect = split::seam_rect(seam.fovea, extent_, feather_);
            seam.x = int32_t(seam_extent.width);
            seam_extent.width += seam.rect.extent.width;
            seam_extent.height = std::max(seam_extent.height, seam.rect.extent.height);
            seams_.push_back(seam);
        }
        if (!seams_.empty() && !ensure_seam_image(s, seam_extent, &error)) {
            SPLITVK_WARN("compositor: %s", error.c_str());
            return VK_ERROR_OUT_OF_DEVICE_MEMORY;
        }
    }

    // The periphery's parts, clipped to it, into the latest periphery.
    std::vector<VkBufferImageCopy> parts;
    std::vector<VkBuffer> part_buffers;
    if (periphery)
        for (const FoveaTile &t : periphery->parts) {
            ClippedTile c;
            if (!clip(t, latest_.extent, 1, texel_bytes_, &c)) continue;
            VkBufferImageCopy region{};
            region.bufferOffset = t.offset + (VkDeviceSize{uint32_t(c.skipped.y)} * t.rect.extent.width +
                                              uint32_t(c.skipped.x)) *
                                                 texel_bytes_;
            region.bufferRowLength = t.rect.extent.width;
            region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
            region.imageOffset = {c.offset.x, c.offset.y, 0};
            region.imageExtent = {c.extent.width, c.extent.height, 1};
            parts.push_back(region);
            part_buffers.push_back(t.buffer);
            if (t.keep) s.tiles_in_use.push_back(t.keep);
        }

    if (parts.empty() && !latest_filled_) return VK_NOT_READY; // nothing to upsample
    record_periphery(s, image_index, parts, part_buffers);
    result = submit(s, queue, waits, signal);
    if (result != VK_SUCCESS) return result;
    if (!parts.empty()) {
        latest_layout_ = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
        latest_filled_ = true;
    }
    return VK_SUCCESS;
}

void Compositor::record_periphery(Slot &s, uint32_t image_index, std::span<const VkBufferImageCopy> parts,
                                  std::span<const VkBuffer> part_buffers) {
    const auto &k = device_.dispatch;
    const VkCommandBuffer cb = s.command_buffer;
    const VkImage image = images_[image_index];
    const bool has_foveae = !copy_regions_.empty();
    const bool upload = !parts.empty();
    begin_recording(s);

    // (1) The image to TRANSFER_SRC after the application's semaphores (waited on at TRANSFER, as in
    // record()); the latest periphery to TRANSFER_DST for the upload, keeping its contents (parts
    // that do not cover it leave the previous periphery there): the previous composite's blit read
    // it earlier on this queue (write-after-read: an execution dependency). The draw's periphery
    // copy: write-after-read against this slot's previous draw, as in record().
    const bool feathered = !seams_.empty();
    VkImageMemoryBarrier before[4];
    uint32_t count = 0;
    before[count++] = colour_image_barrier(image, ready_access_, VK_ACCESS_TRANSFER_READ_BIT, present_layout_,
                                           VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
    if (upload)
        before[count++] = colour_image_barrier(latest_.image, 0, VK_ACCESS_TRANSFER_WRITE_BIT, latest_layout_,
                                               VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL);
    if (!blit_)
        before[count++] =
            colour_image_barrier(s.periphery.image, 0, VK_ACCESS_TRANSFER_WRITE_BIT,
                                 VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL);
    // The seam image: its old contents go; this slot's previous feather draw sampled it (the
    // FRAGMENT_SHADER source stage orders that read before this write).
    if (feathered)
        before[count++] =
            colour_image_barrier(s.seam.image, 0, VK_ACCESS_TRANSFER_WRITE_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                                 VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL);
    k.CmdPipelineBarrier(cb, ready_stages_ | VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT,
                         VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0, nullptr, 0, nullptr, count, before);

    // (2) The client's foveae out to the saved buffer (this slot's previous copy back from it is
    // done: ready_slot() waited for its fence).
    if (has_foveae)
        k.CmdCopyImageToBuffer(cb, image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, s.saved,
                               static_cast<uint32_t>(copy_regions_.size()), copy_regions_.data());
    // The client's bands around its foveae into the seam image, each seam's at its place there.
    if (feathered) {
        std::vector<VkImageCopy> seam_copies;
        for (const Seam &seam : seams_)
            for (const VkRect2D &band : seam_bands(seam.rect, seam.fovea)) {
                VkImageCopy copy{};
                copy.srcSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
                copy.srcOffset = {band.offset.x, band.offset.y, 0};
                copy.dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
                copy.dstOffset = {seam.x + band.offset.x - seam.rect.offset.x,
                                  band.offset.y - seam.rect.offset.y, 0};
                copy.extent = {band.extent.width, band.extent.height, 1};
                seam_copies.push_back(copy);
            }
        k.CmdCopyImage(cb, image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, s.seam.image,
                       VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, static_cast<uint32_t>(seam_copies.size()),
                       seam_copies.data());
    }
    // (3) The decoded parts into the latest periphery (host writes flushed before the submit).
    for (size_t i = 0; i < parts.size(); ++i)
        k.CmdCopyBufferToImage(cb, part_buffers[i], latest_.image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1,
                               &parts[i]);
    // The saved foveae before they are copied back; the upload before the latest periphery is read
    // (by this submit and by later ones on the queue, which this barrier's second scope covers).
    VkBufferMemoryBarrier saved{};
    saved.sType = VK_STRUCTURE_TYPE_BUFFER_MEMORY_BARRIER;
    saved.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    saved.dstAccessMask = VK_ACCESS_TRANSFER_READ_BIT;
    saved.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    saved.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    saved.buffer = s.saved;
    saved.size = VK_WHOLE_SIZE;
    const VkImageMemoryBarrier uploaded =
        colour_image_barrier(latest_.image, VK_ACCESS_TRANSFER_WRITE_BIT, VK_ACCESS_TRANSFER_READ_BIT,
                             VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
    if (has_foveae || upload)
        k.CmdPipelineBarrier(cb, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0,
                             nullptr, has_foveae ? 1 : 0, &saved, upload ? 1 : 0, &uploaded);

    // (4) Upsampled over the whole image but where the foveae go back (blit_regions/periphery_bands
    // around copy_regions_): the blit straight from the latest periphery; the draw samples a copy
    // of it in the slot's periphery image, as record()'s does.
    if (blit_) {
        record_upsample(s, image, latest_.extent, latest_.image, /*source_written=*/false);
    } else {
        VkImageCopy copy{};
        copy.srcSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
        copy.dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
        copy.extent = {latest_.extent.width, latest_.extent.height, 1};
        k.CmdCopyImage(cb, latest_.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, s.periphery.image,
                       VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &copy);
        record_upsample(s, image, latest_.extent, s.periphery.image, /*source_written=*/true);
    }
    // (5) The feathered seams, blended over the upsampled periphery around the foveae.
    if (feathered) record_seams(s, image);
    // (6) The foveae back, byte for byte, and the present layout. Last, after the feather too: whatever
    // the upsample, the blend or an sRGB decode and encode left inside a fovea is overwritten by the
    // client's own bytes, so the foveae are exact whatever the seam.
    record_tile_copies(s, image);
    end_recording(s);
}

void Compositor::record_seams(Slot &s, VkImage image) {
    const auto &k = device_.dispatch;
    const VkCommandBuffer cb = s.command_buffer;
    // The seam image's copy before the fragment shader reads it; the upsample's writes to the image
    // (made available to transfers by record_upsample's last barrier, at TRANSFER) before the
    // blend reads and writes them.
    const VkImageMemoryBarrier to_draw[2] = {
        colour_image_barrier(s.seam.image, VK_ACCESS_TRANSFER_WRITE_BIT, VK_ACCESS_SHADER_READ_BIT,
                             VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL),
        colour_image_barrier(image, VK_ACCESS_TRANSFER_WRITE_BIT,
                             VK_ACCESS_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT,
                             VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL),
    };
    k.CmdPipelineBarrier(cb, VK_PIPELINE_STAGE_TRANSFER_BIT,
                         VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT |
                             VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT,
                         0, 0, nullptr, 0, nullptr, 2, to_draw);

    // One pass for every seam, its render area their bounding box: blends where seams overlap (which
    // distinct eyes' never do) are ordered within a subpass, so no barrier is needed between them.
    VkRect2D area = seams_.front().rect;
    for (const Seam &seam : seams_) {
        const int32_t x1 = std::max(area.offset.x + int32_t(area.extent.width),
                                    seam.rect.offset.x + int32_t(seam.rect.extent.width));
        const int32_t y1 = std::max(area.offset.y + int32_t(area.extent.height),
                                    seam.rect.offset.y + int32_t(seam.rect.extent.height));
        area.offset.x = std::min(area.offset.x, seam.rect.offset.x);
        area.offset.y = std::min(area.offset.y, seam.rect.offset.y);
        area.extent = {uint32_t(x1 - area.offset.x), uint32_t(y1 - area.offset.y)};
    }
    VkRenderPassBeginInfo pass{};
    pass.sType = VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO;
    pass.renderPass = seam_pass_;
    pass.framebuffer = s.framebuffers.front();
    pass.renderArea = area;
    k.CmdBeginRenderPass(cb, &pass, VK_SUBPASS_CONTENTS_INLINE);
    k.CmdBindPipeline(cb, VK_PIPELINE_BIND_POINT_GRAPHICS, feather_pipeline_);
    k.CmdBindDescriptorSets(cb, VK_PIPELINE_BIND_POINT_GRAPHICS, feather_layout_, 0, 1, &s.seam_set, 0,
                            nullptr);
    const VkViewport viewport{0.0f, 0.0f, float(extent_.width), float(extent_.height), 0.0f, 1.0f};
    k.CmdSetViewport(cb, 0, 1, &viewport);
    for (const Seam &seam : seams_) {
        FeatherPushConstants push{};
        push.seam_origin[0] = seam.rect.offset.x;
        push.seam_origin[1] = seam.rect.offset.y;
        push.client_origin[0] = seam.x;
        push.client_origin[1] = 0;
        push.fovea_min[0] = float(seam.fovea.offset.x);
        push.fovea_min[1] = float(seam.fovea.offset.y);
        push.fovea_max[0] = float(seam.fovea.offset.x) + float(seam.fovea.extent.width);
        push.fovea_max[1] = float(seam.fovea.offset.y) + float(seam.fovea.extent.height);
        push.feather = float(feather_);
        k.CmdPushConstants(cb, feather_layout_, VK_SHADER_STAGE_FRAGMENT_BIT, 0, sizeof(push), &push);
        // The band only (no fragment inside the fovea, whose copy back overwrites it anyway).
        for (const VkRect2D &band : seam_bands(seam.rect, seam.fovea)) {
            k.CmdSetScissor(cb, 0, 1, &band);
            k.CmdDraw(cb, 3, 1, 0, 0);
        }
    }
    k.CmdEndRenderPass(cb);
    // The blend's writes before the fovea copies (write-after-write where a band meets its fovea,
    // and the layout the copies want).
    const VkImageMemoryBarrier to_copy =
        colour_image_barrier(image, VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT, VK_ACCESS_TRANSFER_WRITE_BIT,
                             VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL);
    k.CmdPipelineBarrier(cb, VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0,
                         0, nullptr, 0, nullptr, 1, &to_copy);
}

// ---------------------------------------------------------------------------- registry by swapchain

namespace {

// One per swapchain. Its lock is held while its compositor is made or replaced (pipelines, a
// wait for the old one's submits), which concerns that swapchain's presents only.
struct Entry {
    std::mutex mutex; // what follows
    std::unique_ptr<Compositor> compositor;
    uint32_t failed_family = UINT32_MAX; // create() failed for this family (logged once)
};

} // namespace

struct CompositorTable {
    // The map only: held for a lookup, never while a compositor is made, used or destroyed.
    std::mutex mutex;
    std::unordered_map<VkSwapchainKHR, std::shared_ptr<Entry>> compositors;
};

std::shared_ptr<CompositorTable> make_compositor_table() {
    return std::make_shared<CompositorTable>();
}

UpsampleFilter upsample_filter(UpsampleMode mode) {
    return mode == UpsampleMode::Bicubic ? UpsampleFilter::CatmullRom : UpsampleFilter::BilinearBlit;
}

Compositor *compositor_for(DeviceState &device, const SwapchainState &swapchain, uint32_t queue_family,
                           bool timed) {
    if (!swapchain.composable || queue_family == UINT32_MAX) return nullptr;
    std::shared_ptr<Entry> e;
    {
        CompositorTable &t = *device.compositors;
        std::lock_guard lock(t.mutex);
        std::shared_ptr<Entry> &slot = t.compositors[swapchain.handle];
        if (!slot) slot = std::make_shared<Entry>();
        e = slot;
    }
    // One made for another queue family (its command pool cannot serve this one) is destroyed
    // after the lock, as it waits for its submits.
    std::unique_ptr<Compositor> replaced;
    std::lock_guard lock(e->mutex);
    if (e->compositor && e->compositor->queue_family() == queue_family) return e->compositor.get();
    if (e->failed_family == queue_family) return nullptr;
    replaced = std::move(e->compositor);
    std::string error;
    const UpsampleMode mode = device.session ? device.session->settings().upsample : UpsampleMode::Bilinear;
    e->compositor = Compositor::create(device, swapchain, queue_family, &error, upsample_filter(mode), timed);
    if (!e->compositor) {
        e->failed_family = queue_family;
        SPLITVK_WARN("compositor: swapchain %dx%d presents uncomposited: %s", int(swapchain.extent.width),
                     int(swapchain.extent.height), error.c_str());
    } else if (mode == UpsampleMode::Bicubic) {
        SPLITVK_INFO("compositor: swapchain %dx%d upsamples its periphery bicubic (Catmull-Rom)",
                     int(swapchain.extent.width), int(swapchain.extent.height));
    }
    return e->compositor.get();
}

void release_compositor(DeviceState &device, VkSwapchainKHR swapchain) {
    std::shared_ptr<Entry> doomed;
    {
        CompositorTable &t = *device.compositors;
        std::lock_guard lock(t.mutex);
        const auto it = t.compositors.find(swapchain);
        if (it == t.compositors.end()) return;
        doomed = std::move(it->second);
        t.compositors.erase(it);
    }
}

void release_compositors(DeviceState &device) {
    std::unordered_map<VkSwapchainKHR, std::shared_ptr<Entry>> doomed;
    {
        CompositorTable &t = *device.compositors;
        std::lock_guard lock(t.mutex);
        doomed = std::move(t.compositors);
        t.compositors.clear();
    }
}

} // namespace splitvk
