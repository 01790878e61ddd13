// The table of ImageState, one per VkImage the layer knows (image.h).

#include "core/image.h"

#include <unordered_map>

namespace splitvk {
struct ImageTable {
    std::shared_mutex mutex; // the table and every ImageState in it (image.h says why)
    std::unordered_map<VkImage, ImageState> images;
};

std::shared_ptr<ImageTable> make_image_table() {
    return std::make_shared<ImageTable>();
}

void add_image(DeviceState &device, VkImage image, ImageState state) {
    ImageTable &t = *device.images;
    std::unique_lock lock(t.mutex);
    t.images[image] = std::move(state);
}

void remove_image(DeviceState &device, VkImage image) {
    if (image == VK_NULL_HANDLE) return;
    ImageTable &t = *device.images;
    std::unique_lock lock(t.mutex);
    t.images.erase(image);
}

void note_swapchain_images(DeviceState &device, VkSwapchainKHR swapchain, uint32_t count,
                           const VkImage *images) {
    ImageTable &t = *device.images;
    std::unique_lock lock(t.mutex);
    for (uint32_t i = 0; i < count; ++i) {
        ImageState &state = t.images[images[i]];
        if (!state.device) state.device = &device;
        if (state.swapchain != swapchain) state.drawn.reset(); // drawn for another swapchain's frames
        state.swapchain = swapchain;
    }
}

void forget_swapchain_images(DeviceState &device, VkSwapchainKHR swapchain, uint32_t count,
                             const VkImage *images) {
    ImageTable &t = *device.images;
    std::unique_lock lock(t.mutex);
    for (uint32_t i = 0; i < count; ++i) {
        const auto it = t.images.find(images[i]);
        if (it == t.images.end() || it->second.swapchain != swapchain) continue;
        if (!it->second.created) {
            t.images.erase(it);
            continue;
        }
        it->second.swapchain = VK_NULL_HANDLE;
        it->second.drawn.reset();
    }
}

bool read_image(const DeviceState &device, VkImage image,
                const std::function<void(const ImageState &)> &read) {
    if (image == VK_NULL_HANDLE) return false;
    ImageTable &t = *device.images;
    std::shared_lock lock(t.mutex);
    const auto it = t.images.find(image);
    if (it == t.images.end()) return false;
    read(it->second);
    return true;
}

void for_each_image(const DeviceState &device,
                    const std::function<void(VkImage, const ImageState &)> &visit) {
    ImageTable &t = *device.images;
    std::shared_lock lock(t.mutex);
    for (const auto &[image, state] : t.images)
        visit(image, state);
}

LockedImages::LockedImages(DeviceState &device)
    : table_(*device.images), lock_(table_.mutex, std::defer_lock) {}

ImageState *LockedImages::find(VkImage image) {
    if (!lock_.owns_lock()) lock_.lock();
    const auto it = table_.images.find(image);
    return it == table_.images.end() ? nullptr : &it->second;
}

} // namespace splitvk
