// Building blocks of the render paths that draw offscreen: screen-space targets, render passes
// with the dependencies a frame of such passes needs, the swapchain's final pass, and
// full-screen passes that read sampled images.
#pragma once

#include "vk_context.h"

#include <cstdint>
#include <initializer_list>
#include <optional>
#include <vector>

namespace atrium {

// A 2D image with a 2D view, or (layers > 0) an array of that many layers with a 2D_ARRAY view.
Image create_target(VkContext &context, VkExtent2D extent, VkFormat format, VkImageUsageFlags usage,
                    uint32_t layers = 0);

// `extent` divided by 2^level (at least 1x1): the bloom chain's sizes.
VkExtent2D mip_extent(VkExtent2D extent, uint32_t level);

struct Attachment {
    VkFormat format = VK_FORMAT_UNDEFINED;
    VkAttachmentLoadOp load = VK_ATTACHMENT_LOAD_OP_CLEAR;
    VkAttachmentStoreOp store = VK_ATTACHMENT_STORE_OP_STORE;
    VkImageLayout initial = VK_IMAGE_LAYOUT_UNDEFINED;
    VkImageLayout final = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL;
};

// One subpass. Its external dependencies order it after whatever earlier pass, dispatch, copy
// or blit of this frame or the previous one touched its attachments, and make its writes visible
// to later sampling, storage reads and transfers: every target is reused frame after frame.
struct RenderPassInfo {
    std::vector<Attachment> colors;
    std::optional<Attachment> depth;
    uint32_t view_mask = 0; // multiview: one bit per view, rendered into the matching layer
    std::vector<VkSubpassDependency> dependencies; // empty: the ones described above
};
VkRenderPass create_render_pass(VkDevice device, const RenderPassInfo &info);
// The passes of full-screen shaders: one colour attachment.
VkRenderPass create_render_pass(VkDevice device, const Attachment &color);

VkFramebuffer create_framebuffer(VkDevice device, VkRenderPass pass, const std::vector<VkImageView> &views,
                                 VkExtent2D extent);

void begin_pass(VkCommandBuffer cmd, VkRenderPass pass, VkFramebuffer framebuffer, VkExtent2D extent,
                const std::vector<VkClearValue> &clears = {},
                VkSubpassContents contents = VK_SUBPASS_CONTENTS_INLINE);

void set_viewport(VkCommandBuffer cmd, VkRect2D rect);

VkSampler create_sampler(VkDevice device, VkFilter filter); // clamped to the edge, no mips

// The last pass of a frame: draws into the swapchain image, which it leaves ready to present or,
// on the screenshot frame, ready to be copied.
class SwapchainPass {
public:
    SwapchainPass(VkDevice device, const Swapchain &swapchain);
    ~SwapchainPass();
    SwapchainPass(const SwapchainPass &) = delete;
    SwapchainPass &operator=(const SwapchainPass &) = delete;

    void create_framebuffers();
    void destroy_framebuffers();
    // Begins the pass over the whole image, with a full-image viewport and scissor.
    void begin(VkCommandBuffer cmd, uint32_t image, bool readback) const;
    VkRenderPass render_pass() const { return present_; } // compatible with the readback pass

private:
    VkDevice device_;
    const Swapchain &swapchain_;
    VkRenderPass present_ = VK_NULL_HANDLE, readback_ = VK_NULL_HANDLE;
    std::vector<VkFramebuffer> framebuffers_;
};

struct FullscreenInfo {
    VkRenderPass render_pass = VK_NULL_HANDLE;
    const uint32_t *fragment = nullptr;
    size_t fragment_bytes = 0;
    uint32_t inputs = 1;                                 // combined image samplers 0..n-1 of the inputs set
    uint32_t push_bytes = 0;                             // fragment push constants
    bool additive = false;                               // add to the target instead of replacing it
    std::optional<bool> encode_srgb;                     // the fragment shader's constant 0, where it has one
    VkDescriptorSetLayout frame_layout = VK_NULL_HANDLE; // set 0 when given; the inputs are then set 1
};

// A FullscreenInfo for SPIR-V array `code`. `display` names the format of a target that receives
// display colours: the shader then encodes sRGB itself unless that format takes linear colours.
template <size_t N>
FullscreenInfo fullscreen_info(VkRenderPass pass, const uint32_t (&code)[N], uint32_t inputs,
                               uint32_t push_bytes, std::optional<VkFormat> display = std::nullopt) {
    FullscreenInfo info;
    info.render_pass = pass;
    info.fragment = code;
    info.fragment_bytes = sizeof(code);
    info.inputs = inputs;
    info.push_bytes = push_bytes;
    if (display) info.encode_srgb = !takes_linear(*display);
    return info;
}

inline FullscreenInfo additive(FullscreenInfo info) {
    info.additive = true;
    return info;
}

// One full-screen triangle through a fragment shader that reads sampled images.
class FullscreenPass {
public:
    FullscreenPass(VkDevice device, const FullscreenInfo &info);
    ~FullscreenPass();
    FullscreenPass(const FullscreenPass &) = delete;
    FullscreenPass &operator=(const FullscreenPass &) = delete;

    VkDescriptorSetLayout inputs_layout() const { return inputs_layout_; }
    // Draws with the current viewport; `frame` is set 0 when the pass has a frame layout.
    void draw(VkCommandBuffer cmd, VkDescriptorSet inputs, const void *push,
              VkDescriptorSet frame = VK_NULL_HANDLE) const;

private:
    VkDevice device_;
    bool has_frame_set_;
    uint32_t push_bytes_;
    VkDescriptorSetLayout inputs_layout_ = VK_NULL_HANDLE;
    VkPipelineLayout layout_ = VK_NULL_HANDLE;
    VkPipeline pipeline_ = VK_NULL_HANDLE;
};

// Descriptor sets for a path's passes; their images are rewritten when the targets are rebuilt.
class DescriptorSets {
public:
    DescriptorSets(VkDevice device, uint32_t max_sets);
    ~DescriptorSets();
    DescriptorSets(const DescriptorSets &) = delete;
    DescriptorSets &operator=(const DescriptorSets &) = delete;

    VkDescriptorSet allocate(VkDescriptorSetLayout layout);
    // Bindings 0..n-1: the views as combined image samplers in SHADER_READ_ONLY_OPTIMAL.
    void write_sampled(VkDescriptorSet set, std::initializer_list<VkImageView> views, VkSampler sampler);
    // Binding `binding`: a storage image in GENERAL.
    void write_storage(VkDescriptorSet set, uint32_t binding, VkImageView view);

private:
    VkDevice device_;
    VkDescriptorPool pool_ = VK_NULL_HANDLE;
};

} // namespace atrium
