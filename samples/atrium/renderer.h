// The frame loop: two frames in flight, each acquiring a swapchain image, recording it with the
// selected render path (render_path.h), submitting and presenting it.
#pragma once

#include "camera.h"
#include "render_path.h"
#include "scene.h"
#include "scene_gpu.h"
#include "textures.h"
#include "vk_context.h"

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

namespace atrium {

// The sun, sky and ground of every frame, and the scene's courtyard shadow.
void set_lighting(FrameUniforms &u, const Scene &scene);

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
    struct FrameSlot {
        VkCommandPool pool = VK_NULL_HANDLE;
        VkCommandBuffer commands = VK_NULL_HANDLE;
        VkFence done = VK_NULL_HANDLE;         // signalled when the slot's last submission completes
        VkSemaphore acquired = VK_NULL_HANDLE; // the swapchain image may be rendered to
    };

    void create_targets();
    void destroy_targets();
    void recreate_swapchain();
    void update_uniforms(uint32_t slot, uint64_t frame);
    void record(uint32_t slot, uint32_t image, bool readback);

    VkContext &context_;
    Swapchain &swapchain_;
    const Scene &scene_;
    const CameraPath &camera_;
    RendererOptions options_;
    VkDevice device_;

    SceneGpu scene_gpu_;
    std::unique_ptr<RenderPath> path_;

    // Per swapchain image, rebuilt with the swapchain.
    std::vector<VkSemaphore> rendered_; // one per image: waited on by that image's present

    std::array<FrameSlot, frames_in_flight> slots_;
    uint32_t slot_index_ = 0;

    Buffer readback_;
    VkExtent2D readback_extent_{};
    bool screenshot_taken_ = false;
};

} // namespace atrium
