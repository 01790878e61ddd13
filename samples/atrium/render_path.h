// A render path: how a frame of the atrium is drawn, from the scene to the swapchain image. The
// Renderer owns the frame loop (acquire, submit, present, screenshot); a path records one frame.
#pragma once

#include "options.h"
#include "scene_gpu.h"
#include "vk_context.h"

#include <cstdint>
#include <memory>
#include <optional>

namespace atrium {

struct RendererOptions {
    uint32_t eyes = 2;
    std::optional<uint64_t> screenshot_frame; // read this frame's swapchain image back
    bool static_viewports = false;            // per-eye pipelines with static viewport/scissor
    bool clear_depth_per_eye = false;         // vkCmdClearAttachments on each eye's depth
    bool dynamic_rendering = false;           // vkCmdBeginRenderingKHR instead of a render pass
    bool linear_textures = false;             // textures uploaded through linear images (any path)
    PathKind path = PathKind::direct;
    bool screen_layers = false;        // multiview: eye layers at the window's size
    bool scene_in_secondaries = false; // hdr, deferred, compute: the scene pass's draws in secondaries
    bool engine_extensions = false;    // direct: the markers of engine_markers.h
    BufferAddressMode buffer_address = BufferAddressMode::none; // the scene's matrices through an address
};

struct FrameContext {
    VkCommandBuffer cmd;
    uint32_t slot;  // frame slot, for SceneGpu::bind and per-slot resources
    uint32_t image; // swapchain image
    bool readback;  // the screenshot frame
};

class RenderPath {
public:
    virtual ~RenderPath() = default;

    // The targets that have the swapchain's extent (or a fraction of it); called with the device
    // idle, after the swapchain was (re)created and before it is destroyed.
    virtual void create_targets() = 0;
    virtual void destroy_targets() = 0;

    // Records frame `frame`. The swapchain image ends in the swapchain's final_layout() or, when
    // readback, in TRANSFER_SRC_OPTIMAL with its writes visible to transfer reads.
    virtual void record(const FrameContext &frame) = 0;

    // The stage whose first write to the swapchain image waits for the acquire semaphore.
    virtual VkPipelineStageFlags acquire_stage() const {
        return VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
    }
};

std::unique_ptr<RenderPath> make_render_path(const SceneGpu &scene, const Swapchain &swapchain,
                                             const RendererOptions &options);

// The sky's colour as the swapchain's clear value, and as linear radiance that tone-maps to it.
VkClearColorValue sky_clear(VkFormat swapchain_format);
VkClearColorValue sky_radiance();

} // namespace atrium
