// Draws the scene into the swapchain: one render pass per frame whose colour attachment is the
// swapchain image itself, with one viewport per eye, two frames in flight.
#pragma once

#include "camera.h"
#include "scene.h"
#include "textures.h"
#include "vk_context.h"

#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include <glm/glm.hpp>

namespace atrium {

// Per-frame uniforms, std140; must match the Frame block in shaders/scene.{vert,frag}.
struct FrameUniforms {
    glm::mat4 view_proj[2];
    glm::vec4 eye_position[2];
    glm::vec4 sun_direction;
    glm::vec4 sun_color;
    glm::vec4 sky_color;
    glm::vec4 ground_color;
    glm::vec4 sun_opening;
    glm::vec4 sun_facades;
    glm::vec4 sun_params;
};

struct RendererOptions {
    uint32_t eyes = 2;
    std::optional<uint64_t> screenshot_frame; // read this frame's swapchain image back
    bool static_viewports = false;            // per-eye pipelines with static viewport/scissor
    bool clear_depth_per_eye = false;         // vkCmdClearAttachments on each eye's depth
    bool dynamic_rendering = false;           // vkCmdBeginRenderingKHR instead of a render pass
    bool linear_textures = false;             // textures uploaded through linear images
};

class Renderer {
public:
    Renderer(VkContext &context, Swapchain &swapchain, const Scene &scene,
             const std::vector<Texture> &textures, const CameraPath &camera, const RendererOptions &options);
    ~Renderer();
    Renderer(const Renderer &) = delete;
    Renderer &operator=(const Renderer &) = delete;

    // Records, submits and presents frame `frame`, recreating the swapchain when it is out of date.
    void draw_frame(uint64_t frame);

    void wait_idle();

    struct Readback {
        uint32_t width, height;
        size_t row_stride;
        bool bgra;
        const uint8_t *pixels;
    };
    // The screenshot frame's pixels once it has been drawn and wait_idle() has returned.
    std::optional<Readback> screenshot() const;

private:
    static constexpr uint32_t frames_in_flight = 2;

    struct FrameSlot {
        VkCommandPool pool = VK_NULL_HANDLE;
        VkCommandBuffer commands = VK_NULL_HANDLE;
        VkFence done = VK_NULL_HANDLE;         // signalled when the slot's last submission completes
        VkSemaphore acquired = VK_NULL_HANDLE; // the swapchain image may be rendered to
        VkDescriptorSet frame_set = VK_NULL_HANDLE;
        FrameUniforms *uniforms = nullptr; // in persistently mapped, host-coherent memory
    };

    void upload(const Scene &scene, const std::vector<Texture> &textures);
    void create_descriptors(size_t textures);
    VkRenderPass create_render_pass(VkImageLayout final_layout);
    void create_pipeline(bool double_sided);
    void begin_rendering(VkCommandBuffer cmd, uint32_t image, VkExtent2D extent, const VkClearValue *clears);
    void end_rendering(VkCommandBuffer cmd, uint32_t image, bool readback);
    void create_targets();
    void destroy_targets();
    void recreate_swapchain();
    void update_uniforms(FrameSlot &slot, uint64_t frame);
    void record(FrameSlot &slot, uint32_t image, bool readback);

    VkContext &context_;
    Swapchain &swapchain_;
    const Scene &scene_;
    const CameraPath &camera_;
    RendererOptions options_;
    VkDevice device_;

    Buffer vertices_, indices_, uniforms_;
    std::vector<Image> textures_;
    VkSampler sampler_ = VK_NULL_HANDLE;
    VkDescriptorSetLayout frame_layout_ = VK_NULL_HANDLE, material_layout_ = VK_NULL_HANDLE;
    VkDescriptorPool descriptor_pool_ = VK_NULL_HANDLE;
    std::vector<VkDescriptorSet> texture_sets_;
    VkPipelineLayout pipeline_layout_ = VK_NULL_HANDLE;
    VkPipeline pipeline_ = VK_NULL_HANDLE;
    PFN_vkCmdBeginRenderingKHR cmd_begin_rendering_ = nullptr; // --dynamic-rendering (extension entry points)
    PFN_vkCmdEndRenderingKHR cmd_end_rendering_ = nullptr;
    VkPipeline eye_pipelines_[2] = {};            // --static-viewports: eye i's viewport and scissor baked in
    VkRenderPass present_pass_ = VK_NULL_HANDLE;  // ends in PRESENT_SRC_KHR
    VkRenderPass readback_pass_ = VK_NULL_HANDLE; // ends in TRANSFER_SRC_OPTIMAL, for the screenshot

    // Per swapchain image, rebuilt with the swapchain.
    Image depth_;
    std::vector<VkFramebuffer> framebuffers_;
    std::vector<VkSemaphore> rendered_; // one per image: waited on by that image's present

    std::array<FrameSlot, frames_in_flight> slots_;
    uint32_t slot_index_ = 0;

    Buffer readback_;
    VkExtent2D readback_extent_{};
    bool screenshot_taken_ = false;
};

} // namespace atrium
