// VK_LAYER_SPLITVK_test_xr_readback: a test-only layer that shows what leaves the application's
// device: the eye images an OpenXR runtime receives, and the images a window present shows. The
// tests put it BELOW splitvk and validation, next to the driver, so that it sees each image exactly
// as the runtime or the window system gets it: after the application's rendering and splitvk's
// composite.
//
// OpenXR (with TEST_XR_READBACK_DIR): an OpenXR application hands each eye image to the runtime
// with a barrier that releases it to VK_QUEUE_FAMILY_EXTERNAL; Monado records that barrier once per
// image, in a command buffer of its own on the application's device, and submits it at every
// xrReleaseSwapchainImage. The layer remembers, per command buffer, the images its
// vkCmdPipelineBarrier(2) release to the external queue family (cleared at vkBeginCommandBuffer). At a
// vkQueueSubmit of such a command buffer, before passing the submit down, it waits for the queue,
// copies each image (in the layout the barrier releases it from) and writes it to
// $TEST_XR_READBACK_DIR/image<K>-<N>.pam: K numbers the images with external memory (the runtime's)
// in the order they were created, N counts that image's releases from 0. With
// TEST_XR_READBACK_KEEP=M only each image's last M files are kept.
//
// Windows (with TEST_PRESENT_READBACK_DIR): the layer knows each swapchain's images, format and
// extent (vkCreateSwapchainKHR, vkGetSwapchainImagesKHR) and each queue's family (vkGetDeviceQueue(2)).
// At a vkQueuePresentKHR, before passing it down, it waits for the present's semaphores and the queue,
// copies each presented image (in VK_IMAGE_LAYOUT_PRESENT_SRC_KHR) and writes it to
// $TEST_PRESENT_READBACK_DIR/present-<N>.pam: N counts the process's presented images from 0 (one
// per swapchain a present names), whichever thread presents (splitvk's present thread does).
//
// Each copy is transitioned from its layout and back with a command buffer of the layer's own. A
// PAM file (P7, MAXVAL 255) holds the texels unconverted, DEPTH bytes each: TUPLTYPE RGB_ALPHA for
// the 4-byte formats, the format's name (R16G16B16A16_UNORM, R16G16B16A16_SFLOAT) for the 8-byte
// ones, whose bytes stay as the texels hold them (little-endian channels). The layers copied (both
// eyes of a layered image drawn with multiview) lie one below the other, so that a file of an image
// of L layers is L times its height. Images of other formats are not read back.
//
// Its own Vulkan calls go to the next layer (the driver), so that no layer above it sees them.
// Built into the build tree only and never installed.
#include "../test_layer/test_layer.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <string>
#include <unordered_map>
#include <vector>

namespace splitvk::xr_readback_layer {
namespace {

using test_layer::key;

#define XR_READBACK_DEVICE_FUNCTIONS(X)                                                                      \
    X(CreateImage)                                                                                           \
    X(DestroyImage)                                                                                          \
    X(BeginCommandBuffer)                                                                                    \
    X(EndCommandBuffer)                                                                                      \
    X(CmdPipelineBarrier)                                                                                    \
    X(CmdCopyImageToBuffer)                                                                                  \
    X(QueueSubmit)                                                                                           \
    X(QueueWaitIdle)                                                                                         \
    X(CreateCommandPool)                                                                                     \
    X(DestroyCommandPool)                                                                                    \
    X(AllocateCommandBuffers)                                                                                \
    X(FreeCommandBuffers)                                                                                    \
    X(CreateBuffer)                                                                                          \
    X(DestroyBuffer)                                                                                         \
    X(GetBufferMemoryRequirements)                                                                           \
    X(AllocateMemory)                                                                                        \
    X(FreeMemory)                                                                                            \
    X(BindBufferMemory)                                                                                      \
    X(MapMemory)                                                                                             \
    X(GetDeviceQueue)                                                                                        \
    X(GetDeviceQueue2)                                                                                       \
    X(CreateSwapchainKHR)                                                                                    \
    X(DestroySwapchainKHR)                                                                                   \
    X(GetSwapchainImagesKHR)                                                                                 \
    X(QueuePresentKHR)

struct Device {
    VkDevice handle = VK_NULL_HANDLE;
    VkPhysicalDeviceMemoryProperties memory{};
#define X(name) PFN_vk##name name = nullptr;
    XR_READBACK_DEVICE_FUNCTIONS(X)
#undef X
    PFN_vkCmdPipelineBarrier2 CmdPipelineBarrier2 = nullptr;
    PFN_vkCmdPipelineBarrier2 CmdPipelineBarrier2KHR = nullptr;
    // The layer's own command pools, per queue family, created on first need.
    std::unordered_map<uint32_t, VkCommandPool> pools;
};

struct ImageInfo {
    VkFormat format = VK_FORMAT_UNDEFINED;
    VkExtent3D extent{};
    uint32_t layers = 1;   // the image's array layers
    int ordinal = -1;      // among images with external memory, in creation order; -1 for others
    uint64_t releases = 0; // readbacks written so far
};

// An image to copy: one a command buffer releases to VK_QUEUE_FAMILY_EXTERNAL (layout and family
// those the barrier releases it from), or a presented one (VK_IMAGE_LAYOUT_PRESENT_SRC_KHR, the
// presenting queue's family).
struct CopySource {
    VkImage image = VK_NULL_HANDLE;
    VkImageLayout layout = VK_IMAGE_LAYOUT_UNDEFINED; // the layout it is in, and is left in
    uint32_t family = 0;                              // the queue family that owns it
    VkImageSubresourceRange range{};
};

// A window swapchain, as vkCreateSwapchainKHR made it and vkGetSwapchainImagesKHR named its images.
struct Swapchain {
    VkFormat format = VK_FORMAT_UNDEFINED;
    VkExtent2D extent{};
    uint32_t layers = 1;
    std::vector<VkImage> images;
};

std::mutex g_mutex;
std::unordered_map<test_layer::DispatchKey, Device>
    g_devices; // a device's queues and command buffers share its key
std::unordered_map<VkImage, ImageInfo> g_images;
int g_external_images = 0;
std::unordered_map<VkCommandBuffer, std::vector<CopySource>> g_releases;
std::unordered_map<VkSwapchainKHR, Swapchain> g_swapchains;
std::unordered_map<VkQueue, uint32_t> g_queue_families;
uint64_t g_presented_images = 0; // window readbacks numbered so far
std::mutex g_readback_mutex;

Device &device_of(const void *dispatchable) {
    std::lock_guard lock(g_mutex);
    return g_devices[key(dispatchable)];
}

bool has_external_memory(const VkImageCreateInfo &info) {
    for (auto *s = static_cast<const VkBaseInStructure *>(info.pNext); s; s = s->pNext)
        if (s->sType == VK_STRUCTURE_TYPE_EXTERNAL_MEMORY_IMAGE_CREATE_INFO) return true;
    return false;
}

uint32_t texel_size(VkFormat format) {
    switch (format) {
    case VK_FORMAT_R8G8B8A8_UNORM:
    case VK_FORMAT_R8G8B8A8_SRGB:
    case VK_FORMAT_B8G8R8A8_UNORM:
    case VK_FORMAT_B8G8R8A8_SRGB:
        return 4;
    case VK_FORMAT_R16G16B16A16_UNORM:
    case VK_FORMAT_R16G16B16A16_SFLOAT:
        return 8;
    default:
        return 0; // not read back
    }
}

// PAM's TUPLTYPE for the texels of `format`: readers tell the 8-byte formats apart by it.
const char *tuple_type(VkFormat format) {
    switch (format) {
    case VK_FORMAT_R16G16B16A16_UNORM:
        return "R16G16B16A16_UNORM";
    case VK_FORMAT_R16G16B16A16_SFLOAT:
        return "R16G16B16A16_SFLOAT";
    default:
        return "RGB_ALPHA";
    }
}

// ------------------------------------------------------------------------------------ readback

uint32_t host_memory_type(const Device &d, uint32_t type_bits) {
    const VkMemoryPropertyFlags wanted =
        VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
    for (uint32_t i = 0; i < d.memory.memoryTypeCount; ++i)
        if ((type_bits & (1u << i)) && (d.memory.memoryTypes[i].propertyFlags & wanted) == wanted) return i;
    return UINT32_MAX;
}

void barrier(const Device &d, VkCommandBuffer cb, const CopySource &r, VkImageLayout from, VkImageLayout to) {
    VkImageMemoryBarrier b{};
    b.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER;
    b.srcAccessMask = VK_ACCESS_MEMORY_WRITE_BIT | VK_ACCESS_MEMORY_READ_BIT;
    b.dstAccessMask = VK_ACCESS_MEMORY_WRITE_BIT | VK_ACCESS_MEMORY_READ_BIT;
    b.oldLayout = from;
    b.newLayout = to;
    b.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    b.image = r.image;
    b.subresourceRange = r.range;
    d.CmdPipelineBarrier(cb, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, 0, 0,
                         nullptr, 0, nullptr, 1, &b);
}

void write_pam(const std::filesystem::path &path, const ImageInfo &info, const uint8_t *texels) {
    const uint32_t size = texel_size(info.format);
    const auto tmp = path.string() + ".tmp";
    {
        std::ofstream out(tmp, std::ios::binary);
        out << "P7\nWIDTH " << info.extent.width << "\nHEIGHT " << info.extent.height * info.layers
            << "\nDEPTH " << size << "\nMAXVAL 255\nTUPLTYPE " << tuple_type(info.format) << "\nENDHDR\n";
        out.write(reinterpret_cast<const char *>(texels),
                  static_cast<std::streamsize>(size_t{info.extent.width} * info.extent.height * info.layers *
                                               size));
    }
    std::filesystem::rename(tmp, path); // a reader sees whole files only
}

std::filesystem::path readback_path(const std::string &dir, int ordinal, uint64_t release) {
    char name[64];
    std::snprintf(name, sizeof name, "image%d-%05llu.pam", ordinal, static_cast<unsigned long long>(release));
    return std::filesystem::path(dir) / name;
}

std::filesystem::path present_path(const std::string &dir, uint64_t presented) {
    char name[64];
    std::snprintf(name, sizeof name, "present-%05llu.pam", static_cast<unsigned long long>(presented));
    return std::filesystem::path(dir) / name;
}

// Copies level 0 of the layers r.range names of an image `info` describes to `path`. The queue is
// idle; the image is in r.layout, and is again when this returns. Called under g_readback_mutex (the
// layer's command pools are used from one thread at a time).
bool copy_to_file(Device &d, VkQueue queue, const CopySource &r, ImageInfo info,
                  const std::filesystem::path &path) {
    const uint32_t base = r.range.baseArrayLayer;
    if (base >= info.layers || texel_size(info.format) == 0) return false;
    info.layers = r.range.layerCount == VK_REMAINING_ARRAY_LAYERS
                      ? info.layers - base
                      : std::min(r.range.layerCount, info.layers - base);
    const VkDeviceSize bytes =
        VkDeviceSize{info.extent.width} * info.extent.height * info.layers * texel_size(info.format);
    VkCommandPool &pool = d.pools[r.family];
    if (!pool) {
        VkCommandPoolCreateInfo pool_info{};
        pool_info.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
        pool_info.queueFamilyIndex = r.family;
        if (d.CreateCommandPool(d.handle, &pool_info, nullptr, &pool) != VK_SUCCESS) return false;
    }
    VkBufferCreateInfo buffer_info{};
    buffer_info.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
    buffer_info.size = bytes;
    buffer_info.usage = VK_BUFFER_USAGE_TRANSFER_DST_BIT;
    VkBuffer buffer = VK_NULL_HANDLE;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    VkCommandBuffer cb = VK_NULL_HANDLE;
    VkMemoryRequirements req{};
    void *mapped = nullptr;
    bool ok = d.CreateBuffer(d.handle, &buffer_info, nullptr, &buffer) == VK_SUCCESS;
    if (ok) {
        d.GetBufferMemoryRequirements(d.handle, buffer, &req);
        VkMemoryAllocateInfo alloc{};
        alloc.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
        alloc.allocationSize = req.size;
        alloc.memoryTypeIndex = host_memory_type(d, req.memoryTypeBits);
        ok = alloc.memoryTypeIndex != UINT32_MAX &&
             d.AllocateMemory(d.handle, &alloc, nullptr, &memory) == VK_SUCCESS &&
             d.BindBufferMemory(d.handle, buffer, memory, 0) == VK_SUCCESS &&
             d.MapMemory(d.handle, memory, 0, VK_WHOLE_SIZE, 0, &mapped) == VK_SUCCESS;
    }
    if (ok) {
        VkCommandBufferAllocateInfo cb_info{};
        cb_info.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
        cb_info.commandPool = pool;
        cb_info.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
        cb_info.commandBufferCount = 1;
        // A dispatchable object made below the loader gets its dispatch pointer from the loader.
        ok = d.AllocateCommandBuffers(d.handle, &cb_info, &cb) == VK_SUCCESS &&
             test_layer::set_loader_data(d.handle, cb) == VK_SUCCESS;
    }
    if (ok) {
        VkCommandBufferBeginInfo begin{};
        begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
        begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
        d.BeginCommandBuffer(cb, &begin);
        barrier(d, cb, r, r.layout, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
        VkBufferImageCopy copy{};
        copy.imageSubresource = {r.range.aspectMask, 0, base, info.layers}; // layer after layer
        copy.imageExtent = {info.extent.width, info.extent.height, 1};
        d.CmdCopyImageToBuffer(cb, r.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, buffer, 1, &copy);
        barrier(d, cb, r, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, r.layout);
        d.EndCommandBuffer(cb);
        VkSubmitInfo submit{};
        submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
        submit.commandBufferCount = 1;
        submit.pCommandBuffers = &cb;
        ok = d.QueueSubmit(queue, 1, &submit, VK_NULL_HANDLE) == VK_SUCCESS &&
             d.QueueWaitIdle(queue) == VK_SUCCESS;
    }
    if (ok) write_pam(path, info, static_cast<const uint8_t *>(mapped));
    if (cb) d.FreeCommandBuffers(d.handle, pool, 1, &cb);
    if (buffer) d.DestroyBuffer(d.handle, buffer, nullptr);
    if (memory) d.FreeMemory(d.handle, memory, nullptr);
    return ok;
}

// An eye image a submit releases to the runtime, to $TEST_XR_READBACK_DIR. The queue is idle.
// Called under g_readback_mutex.
void read_back_release(Device &d, VkQueue queue, const CopySource &r, const std::string &dir) {
    ImageInfo info;
    {
        std::lock_guard lock(g_mutex);
        const auto it = g_images.find(r.image);
        if (it == g_images.end() || it->second.ordinal < 0 || texel_size(it->second.format) == 0) return;
        info = it->second;
        ++it->second.releases;
    }
    if (!copy_to_file(d, queue, r, info, readback_path(dir, info.ordinal, info.releases))) {
        std::fprintf(stderr, "xr_readback: reading back image %d failed\n", info.ordinal);
        return;
    }
    const char *keep = std::getenv("TEST_XR_READBACK_KEEP");
    const uint64_t m = keep ? std::strtoull(keep, nullptr, 10) : 0;
    if (m > 0 && info.releases >= m) {
        std::error_code ec;
        std::filesystem::remove(readback_path(dir, info.ordinal, info.releases - m), ec);
    }
}

// ------------------------------------------------------------------------------------ entry points

VKAPI_ATTR VkResult VKAPI_CALL CreateImage(VkDevice device, const VkImageCreateInfo *info,
                                           const VkAllocationCallbacks *alloc, VkImage *image) {
    Device &d = device_of(device);
    VkImageCreateInfo created = *info;
    const bool external = has_external_memory(*info);
    // The runtime's images are copied from: lavapipe ignores usage for the copy, validation (above)
    // never sees it. splitvk adds the same bit to every image when it is on.
    if (external) created.usage |= VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
    const VkResult result = d.CreateImage(device, &created, alloc, image);
    if (result == VK_SUCCESS) {
        std::lock_guard lock(g_mutex);
        ImageInfo i;
        i.format = info->format;
        i.extent = info->extent;
        i.layers = info->arrayLayers;
        if (external) i.ordinal = g_external_images++;
        g_images[*image] = i;
    }
    return result;
}

VKAPI_ATTR void VKAPI_CALL DestroyImage(VkDevice device, VkImage image, const VkAllocationCallbacks *alloc) {
    Device &d = device_of(device);
    {
        std::lock_guard lock(g_mutex);
        g_images.erase(image);
    }
    d.DestroyImage(device, image, alloc);
}

VKAPI_ATTR VkResult VKAPI_CALL BeginCommandBuffer(VkCommandBuffer cb, const VkCommandBufferBeginInfo *info) {
    {
        std::lock_guard lock(g_mutex);
        g_releases.erase(cb);
    }
    return device_of(cb).BeginCommandBuffer(cb, info);
}

void note_release(VkCommandBuffer cb, VkImage image, VkImageLayout layout, uint32_t src_family,
                  uint32_t dst_family, const VkImageSubresourceRange &range) {
    if (dst_family != VK_QUEUE_FAMILY_EXTERNAL || src_family == VK_QUEUE_FAMILY_EXTERNAL) return;
    std::lock_guard lock(g_mutex);
    g_releases[cb].push_back({image, layout, src_family, range});
}

VKAPI_ATTR void VKAPI_CALL CmdPipelineBarrier(VkCommandBuffer cb, VkPipelineStageFlags src,
                                              VkPipelineStageFlags dst, VkDependencyFlags flags,
                                              uint32_t memory_count, const VkMemoryBarrier *memory,
                                              uint32_t buffer_count, const VkBufferMemoryBarrier *buffers,
                                              uint32_t image_count, const VkImageMemoryBarrier *images) {
    for (uint32_t i = 0; i < image_count; ++i)
        note_release(cb, images[i].image, images[i].oldLayout, images[i].srcQueueFamilyIndex,
                     images[i].dstQueueFamilyIndex, images[i].subresourceRange);
    device_of(cb).CmdPipelineBarrier(cb, src, dst, flags, memory_count, memory, buffer_count, buffers,
                                     image_count, images);
}

void note_releases(VkCommandBuffer cb, const VkDependencyInfo *info) {
    for (uint32_t i = 0; i < info->imageMemoryBarrierCount; ++i) {
        const VkImageMemoryBarrier2 &b = info->pImageMemoryBarriers[i];
        note_release(cb, b.image, b.oldLayout, b.srcQueueFamilyIndex, b.dstQueueFamilyIndex,
                     b.subresourceRange);
    }
}

VKAPI_ATTR void VKAPI_CALL CmdPipelineBarrier2(VkCommandBuffer cb, const VkDependencyInfo *info) {
    note_releases(cb, info);
    device_of(cb).CmdPipelineBarrier2(cb, info);
}

VKAPI_ATTR void VKAPI_CALL CmdPipelineBarrier2KHR(VkCommandBuffer cb, const VkDependencyInfo *info) {
    note_releases(cb, info);
    device_of(cb).CmdPipelineBarrier2KHR(cb, info);
}

VKAPI_ATTR VkResult VKAPI_CALL QueueSubmit(VkQueue queue, uint32_t count, const VkSubmitInfo *submits,
                                           VkFence fence) {
    Device &d = device_of(queue);
    std::vector<CopySource> releases;
    {
        std::lock_guard lock(g_mutex);
        for (uint32_t s = 0; s < count; ++s)
            for (uint32_t c = 0; c < submits[s].commandBufferCount; ++c) {
                const auto it = g_releases.find(submits[s].pCommandBuffers[c]);
                if (it != g_releases.end())
                    releases.insert(releases.end(), it->second.begin(), it->second.end());
            }
    }
    const char *dir = std::getenv("TEST_XR_READBACK_DIR");
    if (!releases.empty() && dir && *dir) {
        // Everything submitted before (the application's rendering, splitvk's composite) is done.
        d.QueueWaitIdle(queue);
        std::lock_guard lock(g_readback_mutex);
        for (const CopySource &r : releases)
            read_back_release(d, queue, r, dir);
    }
    return d.QueueSubmit(queue, count, submits, fence);
}

VKAPI_ATTR void VKAPI_CALL GetDeviceQueue(VkDevice device, uint32_t family, uint32_t index, VkQueue *queue) {
    device_of(device).GetDeviceQueue(device, family, index, queue);
    std::lock_guard lock(g_mutex);
    g_queue_families[*queue] = family;
}

VKAPI_ATTR void VKAPI_CALL GetDeviceQueue2(VkDevice device, const VkDeviceQueueInfo2 *info, VkQueue *queue) {
    device_of(device).GetDeviceQueue2(device, info, queue);
    if (!*queue) return; // no queue with those flags
    std::lock_guard lock(g_mutex);
    g_queue_families[*queue] = info->queueFamilyIndex;
}

const char *present_readback_dir() {
    const char *dir = std::getenv("TEST_PRESENT_READBACK_DIR");
    return dir && *dir ? dir : nullptr;
}

VKAPI_ATTR VkResult VKAPI_CALL CreateSwapchainKHR(VkDevice device, const VkSwapchainCreateInfoKHR *info,
                                                  const VkAllocationCallbacks *alloc,
                                                  VkSwapchainKHR *swapchain) {
    Device &d = device_of(device);
    VkSwapchainCreateInfoKHR created = *info;
    // Presented images are copied from; validation (above) never sees the added usage.
    if (present_readback_dir()) created.imageUsage |= VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
    const VkResult result = d.CreateSwapchainKHR(device, &created, alloc, swapchain);
    if (result == VK_SUCCESS) {
        std::lock_guard lock(g_mutex);
        g_swapchains[*swapchain] = {info->imageFormat, info->imageExtent, info->imageArrayLayers, {}};
    }
    return result;
}

VKAPI_ATTR void VKAPI_CALL DestroySwapchainKHR(VkDevice device, VkSwapchainKHR swapchain,
                                               const VkAllocationCallbacks *alloc) {
    Device &d = device_of(device);
    {
        std::lock_guard lock(g_mutex);
        g_swapchains.erase(swapchain);
    }
    d.DestroySwapchainKHR(device, swapchain, alloc);
}

VKAPI_ATTR VkResult VKAPI_CALL GetSwapchainImagesKHR(VkDevice device, VkSwapchainKHR swapchain,
                                                     uint32_t *count, VkImage *images) {
    const VkResult result = device_of(device).GetSwapchainImagesKHR(device, swapchain, count, images);
    if (images && (result == VK_SUCCESS || result == VK_INCOMPLETE)) {
        std::lock_guard lock(g_mutex);
        if (const auto it = g_swapchains.find(swapchain); it != g_swapchains.end()) {
            std::vector<VkImage> &known = it->second.images;
            if (known.size() < *count) known.resize(*count);
            std::copy(images, images + *count, known.begin());
        }
    }
    return result;
}

VKAPI_ATTR VkResult VKAPI_CALL QueuePresentKHR(VkQueue queue, const VkPresentInfoKHR *info) {
    Device &d = device_of(queue);
    const char *dir = present_readback_dir();
    if (!dir) return d.QueuePresentKHR(queue, info);
    struct Presented {
        CopySource source;
        ImageInfo info;
        uint64_t number = 0;
    };
    std::vector<Presented> presented;
    {
        std::lock_guard lock(g_mutex);
        const auto family = g_queue_families.find(queue);
        for (uint32_t i = 0; i < info->swapchainCount; ++i) {
            const uint64_t number = g_presented_images++;
            const auto it = g_swapchains.find(info->pSwapchains[i]);
            if (family == g_queue_families.end() || it == g_swapchains.end() ||
                info->pImageIndices[i] >= it->second.images.size()) {
                std::fprintf(stderr, "xr_readback: presented image %llu is not one the layer knows\n",
                             static_cast<unsigned long long>(number));
                continue;
            }
            const Swapchain &sc = it->second;
            Presented p;
            p.source = {sc.images[info->pImageIndices[i]],
                        VK_IMAGE_LAYOUT_PRESENT_SRC_KHR,
                        family->second,
                        {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, sc.layers}};
            p.info.format = sc.format;
            p.info.extent = {sc.extent.width, sc.extent.height, 1};
            p.info.layers = sc.layers;
            p.number = number;
            presented.push_back(p);
        }
    }
    VkPresentInfoKHR present = *info;
    {
        std::lock_guard lock(g_readback_mutex);
        // The copies must see what is presented, whichever queue drew it: this queue waits for the
        // present's semaphores first, and the present, passed down once the queue is idle, has none
        // left to wait for (a binary semaphore is waited for once).
        if (present.waitSemaphoreCount > 0) {
            const std::vector<VkPipelineStageFlags> stages(present.waitSemaphoreCount,
                                                           VK_PIPELINE_STAGE_ALL_COMMANDS_BIT);
            VkSubmitInfo submit{};
            submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
            submit.waitSemaphoreCount = present.waitSemaphoreCount;
            submit.pWaitSemaphores = present.pWaitSemaphores;
            submit.pWaitDstStageMask = stages.data();
            if (d.QueueSubmit(queue, 1, &submit, VK_NULL_HANDLE) == VK_SUCCESS) {
                present.waitSemaphoreCount = 0;
                present.pWaitSemaphores = nullptr;
            }
        }
        d.QueueWaitIdle(queue);
        for (const Presented &p : presented)
            if (!copy_to_file(d, queue, p.source, p.info, present_path(dir, p.number)))
                std::fprintf(stderr, "xr_readback: reading back presented image %llu failed\n",
                             static_cast<unsigned long long>(p.number));
    }
    return d.QueuePresentKHR(queue, &present);
}

} // namespace
} // namespace splitvk::xr_readback_layer

namespace splitvk::test_layer {

PFN_vkVoidFunction device_entry_point(const char *name) {
    using namespace xr_readback_layer;
    struct Intercepted {
        const char *name;
        PFN_vkVoidFunction function;
    };
    static const Intercepted intercepted[] = {
        {"vkCreateImage", reinterpret_cast<PFN_vkVoidFunction>(CreateImage)},
        {"vkDestroyImage", reinterpret_cast<PFN_vkVoidFunction>(DestroyImage)},
        {"vkBeginCommandBuffer", reinterpret_cast<PFN_vkVoidFunction>(BeginCommandBuffer)},
        {"vkCmdPipelineBarrier", reinterpret_cast<PFN_vkVoidFunction>(CmdPipelineBarrier)},
        {"vkCmdPipelineBarrier2", reinterpret_cast<PFN_vkVoidFunction>(CmdPipelineBarrier2)},
        {"vkCmdPipelineBarrier2KHR", reinterpret_cast<PFN_vkVoidFunction>(CmdPipelineBarrier2KHR)},
        {"vkQueueSubmit", reinterpret_cast<PFN_vkVoidFunction>(QueueSubmit)},
        {"vkGetDeviceQueue", reinterpret_cast<PFN_vkVoidFunction>(GetDeviceQueue)},
        {"vkGetDeviceQueue2", reinterpret_cast<PFN_vkVoidFunction>(GetDeviceQueue2)},
        {"vkCreateSwapchainKHR", reinterpret_cast<PFN_vkVoidFunction>(CreateSwapchainKHR)},
        {"vkDestroySwapchainKHR", reinterpret_cast<PFN_vkVoidFunction>(DestroySwapchainKHR)},
        {"vkGetSwapchainImagesKHR", reinterpret_cast<PFN_vkVoidFunction>(GetSwapchainImagesKHR)},
        {"vkQueuePresentKHR", reinterpret_cast<PFN_vkVoidFunction>(QueuePresentKHR)},
    };
    for (const Intercepted &i : intercepted)
        if (!std::strcmp(name, i.name)) return i.function;
    return nullptr;
}

void device_created(VkPhysicalDevice gpu, VkDevice device, PFN_vkGetDeviceProcAddr next,
                    const VkDeviceCreateInfo &) {
    using namespace xr_readback_layer;
    Device d;
    d.handle = device;
    auto memory_properties = reinterpret_cast<PFN_vkGetPhysicalDeviceMemoryProperties>(
        next_instance_proc(gpu, "vkGetPhysicalDeviceMemoryProperties"));
    memory_properties(gpu, &d.memory);
#define X(name) d.name = reinterpret_cast<PFN_vk##name>(next(device, "vk" #name));
    XR_READBACK_DEVICE_FUNCTIONS(X)
#undef X
    d.CmdPipelineBarrier2 =
        reinterpret_cast<PFN_vkCmdPipelineBarrier2>(next(device, "vkCmdPipelineBarrier2"));
    d.CmdPipelineBarrier2KHR =
        reinterpret_cast<PFN_vkCmdPipelineBarrier2>(next(device, "vkCmdPipelineBarrier2KHR"));
    std::lock_guard lock(g_mutex);
    g_devices[key(device)] = d;
}

void device_destroying(VkDevice device) {
    using namespace xr_readback_layer;
    Device d;
    {
        std::lock_guard lock(g_mutex);
        d = g_devices[key(device)];
        g_devices.erase(key(device));
    }
    for (const auto &[family, pool] : d.pools)
        d.DestroyCommandPool(device, pool, nullptr);
}

} // namespace splitvk::test_layer
