#pragma once

// The agent half of the swapped split (SPLITVK_CLIENT_RENDERS=fovea, docs/architecture.md §4): the
// client renders the foveae and the agent the periphery, at the client's SPLITVK_SCALE
// (PeripheryConfig::scale). A pass into a window's swapchain image (split::swapchain_pass_draw says
// Scaled for the agent) is drawn into the image's top-left split::scaled_extent(image, scale), with
// the rectangles the client's own scaled passes take (split::scaled_pass_rect and
// split::scaled_pass_viewport): its render area, viewports, scissors and clear rects; pipelines with
// static viewports or scissors get them made dynamic at creation and set at bind. A blit into the
// image has its destination scaled alike (a downsample of its source). That rectangle is the
// frame's periphery: the tile streamer reads it back in place, with no downsampling blit.
//
// Screen-space targets stay full size (split::scales_screen_space_targets): the scaled pass into the
// swapchain image samples them by normalised coordinates, so hdr, deferred and multiview frames are
// right, and scaled in their last pass only.
//
// A pass whose contents are in secondaries executes variants of them recorded for it (the
// replayer's, as for fovea shading: begin_variant), their state scaled alike.
//
// What cannot be drawn scaled is replayed as recorded, and the frame falls back to the full-size
// picture downsampled (option A), per frame (take_frame): a copy or resolve into the image, a
// pipeline with static state created before the swapped split began. A secondary of a scaled pass
// with no variant (recorded before the swapped split began, or past the kept streams' bound) makes
// its frame mixed. A frame that mixes both (a
// scaled pass and a whole write into the same image) has no consistent periphery: its tiles go as
// invalid, said once. A frame the agent replays with whole_frames (the client verifies) is never
// scaled.
//
// The fovea is shaded too (no mask yet): the client's foveae cover it, and the seam band around them
// (SPLITVK_SEAM's feather) needs the periphery under it all the same.

#include "fovea_shading.h"
#include "split_tracker.h"
#include "swapchain_images.h"
#include "vk_replay.h"

#include <vulkan/vulkan.h>

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <unordered_map>
#include <vector>

namespace splitvk::agent {

class PeripheryScaling {
public:
    PeripheryScaling(ReplayDispatch &vk, SwapchainImages &swapchains) : vk_(vk), swapchains_(swapchains) {}

    // PeripheryConfig: on with its scale, unless it asks for whole frames. Off until then: every pass
    // replays as recorded.
    void configure(double scale, bool whole_frames);
    bool enabled() const { return enabled_; }
    double scale() const { return scale_; }

    // How the periphery of a presented image's frame is to be read: what the submits replayed since
    // the last call wrote into it. Clears the record.
    enum class Frame {
        Whole,  // nothing scaled (or nothing written): downsample the full-size picture
        Scaled, // only scaled writes: the top-left scaled rectangle is the periphery
        Mixed,  // both: no consistent periphery
    };
    Frame take_frame(uint64_t image_id);

    // Object tracking (after the driver call; destroys before it).
    void image_view_created(VkImageView view, const VkImageViewCreateInfo &info);
    void image_view_destroyed(VkImageView view);
    void framebuffer_created(VkFramebuffer framebuffer, const VkFramebufferCreateInfo &info);
    void framebuffer_destroyed(VkFramebuffer framebuffer);
    // The create infos to pass down (valid until the next call), then what was created.
    const VkGraphicsPipelineCreateInfo *prepare_pipelines(uint32_t count,
                                                          const VkGraphicsPipelineCreateInfo *infos);
    void pipelines_created(uint32_t count, const VkPipeline *pipelines);
    void pipeline_destroyed(VkPipeline pipeline);

    void begin_command_buffer(VkCommandBuffer cb, const VkCommandBufferBeginInfo *info);
    // Secondaries in scaled passes. A secondary that continues a render pass is recorded before the
    // agent knows the pass that executes it, with the app's state; the replayer records a variant of
    // it for a scaled pass from its kept stream (as for fovea shading's scissored passes,
    // FoveaShading::PassScissor with `scaled`), begun with begin_variant: from its first command it
    // is inside the pass, its viewports, scissors and clear rects scaled for `extent`.
    bool continues_pass(VkCommandBuffer cb) const;
    // The variant key of the scaled pass in progress in `primary` whose contents are secondaries.
    std::optional<FoveaShading::PassScissor> pass_variant(VkCommandBuffer primary) const;
    void begin_variant(VkCommandBuffer variant, uint64_t image_id, VkExtent2D extent);
    // A secondary executed in such a pass as recorded (no variant could be made): a full-size write.
    void unscaled_secondary(VkCommandBuffer primary);
    // Before the recorded begin is replayed: the render area to replay it with (scaled in a pass into
    // a window's swapchain image, whose viewports and scissors are set scaled here, before it; dynamic
    // state set outside a pass holds inside it). None: as recorded.
    std::optional<VkRect2D> begin_render_pass(VkCommandBuffer cb, const VkRenderPassBeginInfo &begin,
                                              bool secondary_contents);
    std::optional<VkRect2D> begin_rendering(VkCommandBuffer cb, const VkRenderingInfo &info);
    // After the recorded end: the app's own state again.
    void end_pass(VkCommandBuffer cb);
    // After the recorded call was replayed: the state re-set scaled inside a scaled pass.
    void bind_pipeline(VkCommandBuffer cb, VkPipelineBindPoint bind_point, VkPipeline pipeline);
    void set_viewports(VkCommandBuffer cb, uint32_t first, uint32_t count, const VkViewport *viewports,
                       bool with_count);
    void set_scissors(VkCommandBuffer cb, uint32_t first, uint32_t count, const VkRect2D *scissors,
                      bool with_count);
    // Clear rects inside a scaled pass, to replay instead of the recorded ones (possibly none);
    // nullopt: as recorded.
    std::optional<std::vector<VkClearRect>> clear_rects(VkCommandBuffer cb, uint32_t count,
                                                        const VkClearRect *rects) const;
    // A blit into a window's swapchain image: the destination offsets to replay it with, scaled into
    // the top-left rectangle (false: as recorded). `offsets` holds two VkOffset3D per region.
    bool scale_blit(VkCommandBuffer cb, VkImage dst, uint32_t count, std::array<VkOffset3D, 2> *offsets);
    // A copy or resolve into an image: a swapchain image's frame then holds a full-size write.
    void whole_write(VkCommandBuffer cb, VkImage dst);
    // vkCmdExecuteCommands: what the secondaries wrote counts for the primary.
    void execute_commands(VkCommandBuffer cb, uint32_t count, const VkCommandBuffer *secondaries);
    // A replayed submit: what these command buffers wrote goes into their images' frames.
    void submitted(uint32_t count, const VkCommandBuffer *command_buffers);

private:
    struct Writes {
        bool scaled = false;
        bool whole = false;
    };
    struct Recording {
        split::CommandTracker tracker;
        bool scaled_pass = false;                    // the pass in progress is drawn scaled
        bool secondary_contents = false;             // ... from secondaries, executed as variants
        bool continues_pass = false;                 // a secondary begun to continue a render pass
        std::unordered_map<uint64_t, Writes> writes; // by client image id
    };
    Recording *recording(VkCommandBuffer cb);
    // The window swapchain image `views` draw into, if one does (and an OpenXR runtime's is none).
    bool window_target(const VkImageView *views, size_t count, uint64_t *image_id, VkExtent2D *extent) const;
    std::optional<VkRect2D> enter(VkCommandBuffer cb, Recording &r, uint64_t image_id, VkExtent2D extent,
                                  const VkRect2D &area, bool secondary_contents);
    void emit_viewports(VkCommandBuffer cb, const Recording &r);
    void emit_scissors(VkCommandBuffer cb, const Recording &r);
    void log_whole_once(const char *why);

    ReplayDispatch &vk_;
    SwapchainImages &swapchains_;
    bool enabled_ = false;
    double scale_ = 1;
    std::unordered_map<VkImageView, VkImage> views_;
    std::unordered_map<VkFramebuffer, std::vector<VkImageView>> framebuffers_;
    struct Pipeline {
        std::shared_ptr<const split::StaticViewportState> statics;
        bool dynamic = false; // its static state was made dynamic here
    };
    std::unordered_map<VkPipeline, Pipeline> pipelines_;
    std::unordered_map<VkCommandBuffer, Recording> recordings_;
    std::unordered_map<uint64_t, Writes> frames_; // by client image id: what the frame wrote
    struct Variant {
        uint64_t image = 0;
        VkExtent2D extent{};
    };
    std::unordered_map<VkCommandBuffer, Variant> pending_variants_; // begin_variant, until begun
    bool scaled_logged_ = false;
    bool variant_logged_ = false;
    bool whole_logged_ = false;
    bool mixed_logged_ = false;
    // prepare_pipelines' output
    std::vector<std::shared_ptr<split::StaticViewportState>> pending_;
    std::vector<VkGraphicsPipelineCreateInfo> infos_;
    std::vector<split::DynamicStateStorage> storage_;
};

} // namespace splitvk::agent
