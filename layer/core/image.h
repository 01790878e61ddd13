#pragma once

// VkImage: one ImageState per image the layer knows, in its device's table (image.cpp). An image enters it
// at vkCreateImage on a device with a session (resource.cpp) or when the application queries a
// swapchain's images (render_pass.cpp; an OpenXR runtime's swapchain: swapchain.cpp), and leaves
// it in one place: vkDestroyImage, or the destroy of its swapchain, both before the driver call,
// so a handle value the driver hands out again starts with a fresh state.
//
// One lock guards the table and every field of every ImageState: a shared lock for readers (a
// command recording asks whether an image is screen-space or a swapchain image; a snapshot reads
// the layouts), an exclusive one for every change (creates and destroys; the layouts and the drawn
// record, both updated at submit on the submitting queue's thread; the drawn record taken at
// present, on the present path). Several queues may submit work that touches one image, and the
// present path reads what a submit on another thread wrote, so the fields need the lock even where
// Vulkan's external synchronisation would cover the handle. The lock is held only while a field is
// read or written, never around a call into the driver or into another table's lock, with one
// exception: a submit looks its command buffers up (command_buffer.h: note_submitted) while it
// holds the table, so the command-buffer table's lock nests inside this one and never around it.

#include "core/device.h"
#include "split_tracker.h"

#include <vulkan/vulkan.h>

#include <functional>
#include <mutex>
#include <optional>
#include <shared_mutex>
#include <vector>

namespace splitvk {

struct ImageState {
    DeviceState *device = nullptr;

    // What vkCreateImage made on a device with a session (resource.cpp); false for a swapchain's
    // own image, which the layer neither tracks layouts of nor snapshots.
    bool created = false;
    VkImageType type = VK_IMAGE_TYPE_2D;
    VkFormat format = VK_FORMAT_UNDEFINED;
    VkExtent3D extent{}; // as created down the chain: scaled for a screen-space target
    uint32_t mips = 1;
    uint32_t layers = 1;
    VkSampleCountFlagBits samples = VK_SAMPLE_COUNT_1_BIT;
    bool readable = false; // created with TRANSFER_SRC
    bool bound = false;
    std::vector<VkImageLayout> layouts; // [layer * mips + mip], as the GPU will have them (resource.h)

    // A screen-space target (screen_space.h): created at the scaled size; `full` is the extent of
    // its mip 0 the application asked for, which every region it names is relative to.
    bool screen_space = false;
    VkExtent2D full{};
    // SPLITVK_CLIENT_RENDERS=fovea: a screen-space target kept full size; its class and the swapchain
    // extent it was classified against (screen_space.h: GuardTarget), for the guard of passes into it.
    std::optional<split::TargetClass> guard_kind;
    VkExtent2D guard_screen{};

    // The swapchain whose image this is (split.h), VK_NULL_HANDLE for any other image. For an
    // OpenXR runtime's swapchain an image the runtime created with vkCreateImage.
    VkSwapchainKHR swapchain = VK_NULL_HANDLE;
    // What the submitted split passes drew into it since the present path last took it (split.h).
    std::optional<split::DrawnImage> drawn;

    VkImageLayout &layout(uint32_t mip, uint32_t layer) { return layouts[size_t{layer} * mips + mip]; }
    VkImageLayout layout(uint32_t mip, uint32_t layer) const { return layouts[size_t{layer} * mips + mip]; }
};

// vkCreateImage: `image` is `state` from now on (whatever an earlier image of that handle value was).
void add_image(DeviceState &device, VkImage image, ImageState state);
// vkDestroyImage, before the driver call.
void remove_image(DeviceState &device, VkImage image);
// A swapchain's images (vkGetSwapchainImagesKHR, or an OpenXR runtime's): an image already known
// (the runtime created it) keeps its state and becomes a member.
void note_swapchain_images(DeviceState &device, VkSwapchainKHR swapchain, uint32_t count,
                           const VkImage *images);
// The swapchain is destroyed (before the driver call): its own images leave the table; an image
// vkCreateImage made stays, no longer a member.
void forget_swapchain_images(DeviceState &device, VkSwapchainKHR swapchain, uint32_t count,
                             const VkImage *images);

// Under the shared lock: `read` sees the image's state; false (and `read` not called) when the
// table has none. `read` must not call back into this table.
bool read_image(const DeviceState &device, VkImage image,
                const std::function<void(const ImageState &)> &read);
// Under the shared lock: every image of `device`.
void for_each_image(const DeviceState &device, const std::function<void(VkImage, const ImageState &)> &visit);

// The table under its exclusive lock from the first find() for as long as this lives: changes made
// through find() (one lock for several, so that a submit's layouts apply as a whole). The lock is
// taken only when something is looked up, so a submit with no layouts to apply and nothing drawn
// (most of them with the split off) never contends with the threads recording. Nothing else of
// this table may be called meanwhile.
class LockedImages {
public:
    explicit LockedImages(DeviceState &device);
    ImageState *find(VkImage image);

private:
    ImageTable &table_;
    std::unique_lock<std::shared_mutex> lock_;
};

} // namespace splitvk
