// Instance, device and swapchain for one xcb window.
#pragma once

#include "vk_util.h"

#include <functional>
#include <vector>

namespace atrium {

class XcbWindow;

// How another API creates the instance and the device and picks the physical device, adding what
// it needs (OpenXR's XR_KHR_vulkan_enable2). Each throws Error on failure.
struct VkCreators {
    std::function<VkInstance(const VkInstanceCreateInfo &)> create_instance;
    std::function<VkPhysicalDevice(VkInstance)> physical_device;
    std::function<VkDevice(VkPhysicalDevice, const VkDeviceCreateInfo &)> create_device;
};

class VkContext {
public:
    // Throws Error when there is no Vulkan driver or no device that can present to the window.
    // dynamic_rendering: enable VK_KHR_dynamic_rendering (and what it requires); multiview: the
    // core 1.1 multiview feature.
    // engine_extensions: what EngineMarkers needs (engine_markers.h); buffer_address:
    // VK_KHR_buffer_device_address and its bufferDeviceAddress feature.
    VkContext(const XcbWindow &window, bool dynamic_rendering, bool multiview = false,
              bool engine_extensions = false, bool buffer_address = false);
    // The instance and device come from `creators` (Vulkan 1.1, a graphics queue). Without a
    // window there is no swapchain extension and surface() is VK_NULL_HANDLE; with one, the surface
    // is `window`'s and the queue must be able to present to it.
    VkContext(const VkCreators &creators, bool dynamic_rendering, bool multiview,
              const XcbWindow *window = nullptr);
    ~VkContext();
    VkContext(const VkContext &) = delete;
    VkContext &operator=(const VkContext &) = delete;

    VkInstance instance() const { return instance_; }
    VkPhysicalDevice physical_device() const { return physical_device_; }
    VkDevice device() const { return device_; }
    VkQueue queue() const { return queue_; }
    uint32_t queue_family() const { return queue_family_; }
    VkSurfaceKHR surface() const { return surface_; }
    const VkPhysicalDeviceProperties &properties() const { return properties_; }

    // Resources with dedicated allocations. Host-visible buffers are mapped for their lifetime.
    Buffer create_buffer(VkDeviceSize size, VkBufferUsageFlags usage, VkMemoryPropertyFlags properties);
    void destroy(Buffer &buffer);
    // The view covers every mip level and layer.
    Image create_image(const VkImageCreateInfo &info, VkImageAspectFlags aspect,
                       VkImageViewType view_type = VK_IMAGE_VIEW_TYPE_2D);
    void destroy(Image &image);

private:
    // The device on physical_device_ and queue_family_, through `create` when given.
    void create_device(bool dynamic_rendering, bool multiview, bool engine_extensions, bool swapchain,
                       bool buffer_address,
                       const std::function<VkDevice(VkPhysicalDevice, const VkDeviceCreateInfo &)> *create);
    uint32_t memory_type(uint32_t type_bits, VkMemoryPropertyFlags properties) const;

    VkInstance instance_ = VK_NULL_HANDLE;
    VkSurfaceKHR surface_ = VK_NULL_HANDLE;
    VkPhysicalDevice physical_device_ = VK_NULL_HANDLE;
    VkPhysicalDeviceProperties properties_{};
    VkPhysicalDeviceMemoryProperties memory_properties_{};
    VkDevice device_ = VK_NULL_HANDLE;
    uint32_t queue_family_ = 0;
    VkQueue queue_ = VK_NULL_HANDLE;
};

struct SwapchainRequest {
    VkFormat format = VK_FORMAT_B8G8R8A8_UNORM;
    VkPresentModeKHR present_mode = VK_PRESENT_MODE_MAILBOX_KHR;
    bool transfer_src = false; // for reading images back (screenshots)
    bool transfer_dst = false; // for blitting into them (--path compute)
};

class Swapchain {
public:
    // Falls back to FIFO, with a note on stderr, if the requested present mode is unsupported.
    Swapchain(VkContext &context, const SwapchainRequest &request);
    // Images that another API owns and presents (an OpenXR swapchain's), each with `layers` array
    // layers: only views onto them (2D, or 2D_ARRAY when layers > 1), no VkSwapchainKHR. Frames
    // leave them in COLOR_ATTACHMENT_OPTIMAL, as OpenXR requires at release.
    Swapchain(VkContext &context, VkFormat format, VkExtent2D extent, const std::vector<VkImage> &images,
              uint32_t layers = 1);
    ~Swapchain();
    Swapchain(const Swapchain &) = delete;
    Swapchain &operator=(const Swapchain &) = delete;

    // Replaces the swapchain after VK_ERROR_OUT_OF_DATE_KHR / VK_SUBOPTIMAL_KHR. The caller makes
    // sure that the device is idle. Not for external images.
    void recreate();

    VkSwapchainKHR handle() const { return swapchain_; }
    VkFormat format() const { return format_; }
    VkExtent2D extent() const { return extent_; }
    VkPresentModeKHR present_mode() const { return present_mode_; }
    const std::vector<VkImage> &images() const { return images_; }
    const std::vector<VkImageView> &views() const { return views_; }
    // The layout a frame leaves its image in: PRESENT_SRC_KHR, or COLOR_ATTACHMENT_OPTIMAL for
    // external images.
    VkImageLayout final_layout() const { return final_layout_; }

private:
    void create(VkSwapchainKHR old);
    void destroy_views();

    VkContext &context_;
    SwapchainRequest request_;
    VkSwapchainKHR swapchain_ = VK_NULL_HANDLE;
    VkFormat format_ = VK_FORMAT_UNDEFINED;
    VkExtent2D extent_{};
    VkPresentModeKHR present_mode_ = VK_PRESENT_MODE_FIFO_KHR;
    std::vector<VkImage> images_;
    std::vector<VkImageView> views_;
    VkImageLayout final_layout_ = VK_IMAGE_LAYOUT_PRESENT_SRC_KHR;
};

const char *present_mode_name(VkPresentModeKHR mode);

} // namespace atrium
