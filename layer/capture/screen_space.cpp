// Screen-space targets on the client (screen_space.h).

#include "capture/screen_space.h"

#include "capture/session.h"
#include "capture/split.h"
#include "core/image.h"
#include "core/swapchain.h"
#include "log.h"
#include "split_geometry.h"

#include <mutex>
#include <optional>
#include <set>
#include <string>

namespace splitvk {

struct ScreenTable {
    std::mutex mutex;                 // what follows
    std::optional<VkExtent2D> screen; // newest composable swapchain
    bool scaled = false;              // created a target scaled
};

std::shared_ptr<ScreenTable> make_screen_table() {
    return std::make_shared<ScreenTable>();
}

namespace {

bool screen_of(const DeviceState &device, VkExtent2D *screen) {
    ScreenTable &t = *device.screen;
    std::lock_guard lock(t.mutex);
    if (!t.screen) return false;
    *screen = *t.screen;
    return true;
}

const char *aspect_of(const VkImageCreateInfo &info) {
    if (info.usage & VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT) return "depth/stencil";
    if (info.usage & VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT) return "colour";
    return "storage";
}

// An OpenXR runtime's composable swapchain among the device's images.
bool runtime_swapchain_known(const DeviceState &device) {
    std::set<VkSwapchainKHR> members;
    for_each_image(device, [&](VkImage, const ImageState &state) {
        if (state.swapchain) members.insert(state.swapchain);
    });
    for (VkSwapchainKHR member : members)
        if (const SwapchainState *swapchain = find_swapchain(device, member); swapchain && swapchain->runtime)
            return true;
    return false;
}

} // namespace

void note_screen_extent(DeviceState &device, VkExtent2D extent) {
    std::lock_guard lock(device.screen->mutex);
    device.screen->screen = extent;
}

bool screen_extent(const DeviceState &device, VkExtent2D *screen) {
    return screen_of(device, screen);
}

bool scaled_targets_created(const DeviceState &device) {
    std::lock_guard lock(device.screen->mutex);
    return device.screen->scaled;
}

bool screen_space_create_info(DeviceState &device, const VkImageCreateInfo &app, VkImageCreateInfo *down,
                              GuardTarget *guard) {
    const Settings &settings = split_settings();
    if (settings.targets != TargetMode::Auto || !split_recording(device)) return false;
    VkExtent2D screen{};
    if (!screen_of(device, &screen)) return false; // before the first swapchain: full size
    const split::TargetClass c = split::classify_target(app, screen, settings.eyes);
    if (!c.screen_space) {
        // Only images that could have been targets are worth a line: a texture of any size is not.
        if (app.imageType == VK_IMAGE_TYPE_2D &&
            (app.usage & (VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT |
                          VK_IMAGE_USAGE_STORAGE_BIT)))
            SPLITVK_INFO("targets: %ux%u %s image stays full size: %s", app.extent.width, app.extent.height,
                         aspect_of(app), c.reason.c_str());
        return false;
    }
    if (device.session->client_renders() == ClientRenders::Fovea) {
        // The agent renders the periphery: the client keeps the target whole and cuts the passes
        // into it to the foveae grown by SPLITVK_CLIENT_GUARD. Not under OpenXR: the guard places the
        // foveae by the window's rule, not at the views' directions, so an OpenXR application's
        // offscreen passes run whole (its eye images' own passes are cut, render_pass.cpp).
        if (runtime_swapchain_known(device)) return false;
        guard->kind = c;
        guard->screen = screen;
        SPLITVK_INFO("targets: %ux%u %s image x%u is screen-space (%s of %ux%u): full size, its passes cut "
                     "to the foveae's guard",
                     app.extent.width, app.extent.height, aspect_of(app), app.arrayLayers, c.reason.c_str(),
                     screen.width, screen.height);
        return false;
    }
    {
        std::lock_guard lock(device.screen->mutex);
        device.screen->scaled = true;
    }
    *down = app;
    down->extent = split::scaled_target_extent(app.extent, settings.scale);
    SPLITVK_INFO("targets: %ux%u %s image x%u is screen-space (%s of %ux%u): rendered at %ux%u",
                 app.extent.width, app.extent.height, aspect_of(app), app.arrayLayers, c.reason.c_str(),
                 screen.width, screen.height, down->extent.width, down->extent.height);
    return true;
}

bool screen_space_extent(const DeviceState &device, VkImage image, VkExtent2D *full) {
    bool screen_space = false;
    read_image(device, image, [&](const ImageState &state) {
        screen_space = state.screen_space;
        if (screen_space) *full = state.full;
    });
    return screen_space;
}

VkRect2D scale_image_rect(const DeviceState &device, VkImage image, uint32_t mip, const VkRect2D &rect) {
    VkExtent2D full{};
    if (!screen_space_extent(device, image, &full)) return rect;
    return split::scale_target_rect(rect, full, mip, split_settings().scale);
}

bool screen_space_attachment(const DeviceState &device, const VkFramebufferAttachmentImageInfo &info) {
    const Settings &settings = split_settings();
    // Images are made full size while the device does not split (before an agent accepts it, or
    // passing its frames through), and so are their framebuffers.
    if (settings.targets != TargetMode::Auto || !split_recording(device)) return false;
    // Fovea mode keeps every target full size (screen_space_create_info).
    if (device.session && device.session->client_renders() == ClientRenders::Fovea) return false;
    VkExtent2D screen{};
    if (!screen_of(device, &screen)) return false;
    VkImageCreateInfo image{};
    image.sType = VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO;
    image.flags = info.flags;
    image.imageType = VK_IMAGE_TYPE_2D;
    image.extent = {info.width, info.height, 1};
    image.mipLevels = 1;
    image.arrayLayers = info.layerCount;
    image.samples = VK_SAMPLE_COUNT_1_BIT;
    image.tiling = VK_IMAGE_TILING_OPTIMAL;
    image.usage = info.usage;
    return split::classify_target(image, screen, settings.eyes).screen_space;
}

void log_unscalable_once(const char *reason) {
    static std::mutex mutex;
    static std::set<std::string> logged;
    {
        std::lock_guard lock(mutex);
        if (!logged.emplace(reason).second) return;
    }
    SPLITVK_INFO("targets: %s", reason);
}

} // namespace splitvk
