// The table of ImageState, one per VkImage the layer knows (image.h).

#include "core/image.h"

#include <unordered_map>

namespace splitvk {
namespace {

std::shared_mutex g_mutex; // the table and every ImageState in it (image.h says why)
std::unordered_map<VkImage, ImageState> g_images;

} // namespace

void add_image(VkImage image, ImageState state) {
    std::unique_lock lock(g_mutex);
    g_images[image] = std::move(state);
}

void remove_image(VkImage image) {
    if (image == VK_NULL_HANDLE) return;
    std::unique_lock lock(g_mutex);
    g_images.erase(image);
}

void note_swapchain_images(DeviceState &device, VkSwapchainKHR swapchain, uint32_t count,
                           const VkImage *images) {
    std::unique_lock lock(g_mutex);
    for (uint32_t i = 0; i < count; ++i) {
        ImageState &state = g_images[images[i]];
        if (!state.device) state.device = &device;
        if (state.swapchain != swapchain) state.drawn.reset(); // drawn for another swapchain's frames
        state.swapchain = swapchain;
    }
}

void forget_swapchain_images(VkSwapchainKHR swapchain, uint32_t count, const VkImage *images) {
    std::unique_lock lock(g_mutex);
    for (uint32_t i = 0; i < count; ++i) {
        const auto it = g_images.find(images[i]);
        if (it == g_images.end() || it->second.swapchain != swapchain) continue;
        if (!it->second.created) {
            g_images.erase(it);
            continue;
        }
        it->second.swapchain = VK_NULL_HANDLE;
        it->second.drawn.reset();
    }
}

void forget_images(DeviceState &device) {
    std::unique_lock lock(g_mutex);
    std::erase_if(g_images, [&](const auto &entry) { return entry.second.device == &device; });
}

bool read_image(VkImage image, const std::function<void(const ImageState &)> &read) {
    if (image == VK_NULL_HANDLE) return false;
    std::shared_lock lock(g_mutex);
    const auto it = g_images.find(image);
    if (it == g_images.end()) return false;
    read(it->second);
    return true;
}

void for_each_image(const DeviceState &device,
                    const std::function<void(VkImage, const ImageState &)> &visit) {
    std::shared_lock lock(g_mutex);
    for (const auto &[image, state] : g_images)
        if (state.device == &device) visit(image, state);
}

LockedImages::LockedImages() : lock_(g_mutex, std::defer_lock) {}

ImageState *LockedImages::find(VkImage image) {
    if (!lock_.owns_lock()) lock_.lock();
    const auto it = g_images.find(image);
    return it == g_images.end() ? nullptr : &it->second;
}

} // namespace splitvk
