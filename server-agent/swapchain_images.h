#pragma once

// Swapchains on the agent (docs/architecture.md §3): there is no surface, so a swapchain's images become
// offscreen images of the same format, extent, layers and usage (plus TRANSFER_SRC for readback),
// registered under the client's image ids. Presented images are read back for verification
// (SPLITVK_VERIFY=full) here.
//
// What a client declares of a swapchain (format, extent, layers) places the foveae, as it does on
// the client; what the images are sizes every read-back of them. The two are the same for the
// images the agent makes; an OpenXR runtime's images are the client's own vkCreateImage, which this
// class is told of (image_created), and may be anything.

#include "metadata.h"
#include "split_geometry.h"
#include "vk_codec.h"
#include "vulkan_context.h"

#include <vulkan/vulkan.h>

#include <cstdint>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

namespace splitvk::agent {

class SwapchainImages {
public:
    SwapchainImages(VulkanContext &context, codec::HandleTable &table) : context_(context), table_(table) {}
    ~SwapchainImages();
    SwapchainImages(const SwapchainImages &) = delete;
    SwapchainImages &operator=(const SwapchainImages &) = delete;

    // False with one line in `error` for a swapchain that cannot be made or adopted; `warning` gets
    // one line when an OpenXR runtime's images are not what the client declared.
    bool create(const protocol::SwapchainImages &message, std::string *error, std::string *warning);
    bool destroy(uint64_t swapchain_id, std::string *error);

    // Whether `image` (the agent's handle) is a swapchain image; if so its client id and extent
    // (fovea_shading.h: split passes are the ones drawing into these).
    bool find_image(VkImage image, uint64_t *image_id, VkExtent2D *extent) const;
    // Whether `image_id` is an image of an OpenXR runtime's swapchain (adopted, SwapchainImages::Source::
    // Runtime): its eyes are the projection views', whatever SPLITVK_EYES says of windows. *eyes (when
    // given) are then the eyes the client sent (SwapchainView; none before the first), *layers its
    // images' array layers.
    bool runtime_image(uint64_t image_id, const std::vector<split::RuntimeEye> **eyes = nullptr,
                       uint32_t *layers = nullptr) const;
    // The OpenXR runtime swapchains whose images are `extent` (what a screen-space target classified
    // against that extent may be rendered for), each with its array layers and the eyes the client
    // sent; *window (when given) says whether a window's swapchain has that extent too.
    struct RuntimeSwapchain {
        uint32_t layers = 1;
        const std::vector<split::RuntimeEye> *eyes = nullptr;
    };
    std::vector<RuntimeSwapchain> runtime_swapchains(VkExtent2D extent, bool *window = nullptr) const;
    // SwapchainView: an eye of an OpenXR swapchain (split::note_runtime_eye). False with `error` for a
    // swapchain that is not a runtime's, or an eye outside its images (layer or rectangle).
    bool note_eye(uint64_t swapchain_id, const split::RuntimeEye &eye, std::string *error);
    // The extent of the newest swapchain, {0, 0} before the first: what screen-space targets are
    // classified against, as the client does (common/target_rule.h).
    VkExtent2D newest_extent() const { return newest_; }

    // Every image the stream creates (vkCreateImage, after the driver call), and its destruction:
    // what an OpenXR runtime's swapchain images are.
    void image_created(VkImage image, const VkImageCreateInfo &info);
    void image_destroyed(VkImage image);

    // A rectangle of layer 0 of a presented image (left in its presented layout by the app), or the
    // whole image with every array layer, one after the other (width 0), read back tightly packed at
    // tile_texel_bytes() of the image's format. The caller has made the frame's submits complete.
    // Returns false with `error` on failure; sets *unsupported (and reads nothing) for formats
    // whose texels tiles do not carry (tile_format.h).
    struct Rect {
        uint32_t x = 0, y = 0, width = 0, height = 0; // width 0: the whole image
    };
    bool read_back(uint64_t swapchain_id, uint32_t image_index, Rect rect, protocol::VerifyFrame &out,
                   bool *unsupported, std::string *error);

    // A presented image: the agent's VkImage, the client's id for it, and its format, extent and
    // layers as the image is (not as declared). False with one line in `error` for an unknown
    // swapchain or index.
    struct Presented {
        VkImage image = VK_NULL_HANDLE;
        uint64_t image_id = 0;
        VkFormat format = VK_FORMAT_UNDEFINED;
        VkImageLayout layout = VK_IMAGE_LAYOUT_PRESENT_SRC_KHR; // what the frame's commands left it in
        VkExtent2D extent{};
        uint32_t layers = 1;
    };
    bool presented(uint64_t swapchain_id, uint32_t image_index, Presented *out, std::string *error) const;

private:
    // An image as it was created.
    struct Shape {
        VkFormat format = VK_FORMAT_UNDEFINED;
        VkExtent2D extent{};
        uint32_t layers = 1;
        bool operator==(const Shape &other) const {
            return format == other.format && extent.width == other.extent.width &&
                   extent.height == other.extent.height && layers == other.layers;
        }
    };
    struct Swapchain {
        protocol::SwapchainImages info;
        Shape shape; // of its images
        std::vector<VkImage> images;
        std::vector<VkDeviceMemory> memory;
        std::vector<split::RuntimeEye> eyes; // a runtime's swapchain: what SwapchainView said
    };
    bool adopt(const protocol::SwapchainImages &message, Swapchain &swapchain, std::string *error,
               std::string *warning) const;
    bool check_format(const protocol::SwapchainImages &message, std::string *error) const;
    void release(Swapchain &swapchain);
    // The swapchain a present names, its image index checked; null, with `error` said, otherwise.
    const Swapchain *presented_swapchain(uint64_t swapchain_id, uint32_t image_index,
                                         std::string *error) const;
    bool ensure_readback(VkDeviceSize bytes, std::string *error);

    VulkanContext &context_;
    codec::HandleTable &table_;
    std::unordered_map<uint64_t, Swapchain> swapchains_;
    // Images the stream created that can be read back as a swapchain's: 2D, one sample. Others are
    // absent, and adopting one is an error.
    std::unordered_map<VkImage, Shape> created_;
    VkExtent2D newest_{};
    VkCommandPool pool_ = VK_NULL_HANDLE;
    VkCommandBuffer command_buffer_ = VK_NULL_HANDLE;
    VkFence fence_ = VK_NULL_HANDLE;
    HostBuffer staging_;
};

} // namespace splitvk::agent
