#pragma once

// The agent half of the image-space split (docs/architecture.md §4): in split passes (render passes or
// dynamic renderings that draw into a swapchain image) the agent keeps the app's full-resolution
// viewports and intersects every scissor with split::fovea_scissor of its viewport (scissor i pairs
// with viewport i): every fovea that viewport's draws can end up in, so that only foveal pixels
// are shaded. The frame's foveae come from common/split_geometry.h (split::frame_foveae, once
// the frame is presented) and the viewports in effect from common/split_tracker.h, exactly as on
// the client, so both sides report the same fovea rects for a frame.
//
// The derived scissors are re-emitted whenever a viewport, a scissor or a pipeline with static
// state changes inside a split pass, and the app's own scissors when the pass ends (dynamic state
// outlives the pass). Pipelines with a static scissor get VK_DYNAMIC_STATE_SCISSOR at creation,
// with their static values set at bind. Clear rects are left as recorded: clears shade nothing,
// and only the fovea rects are read back.
//
// SPLITVK_AGENT_SCISSOR=guard:N extends the same scissoring to passes that draw only
// into screen-space targets (classified at creation by common/target_rule.h against the newest
// swapchain, as on the client). Such a pass is recorded before the frame's pass into the swapchain
// image, so its viewports do not say where the foveae will be: every place a fovea can be for
// SPLITVK_EYES (one: the centre; two: both eyes; auto: all three) is taken, as one bounding
// rectangle (a scissor is one rectangle per viewport), mapped into the target (divided by its
// divisor, rounded outwards; an eye-sized target is taken to hold either eye 1:1, so it gets what
// of those foveae lies in each eye) and grown by N of the target's pixels. Pixels outside it keep
// stale contents; the foveae stay exact only while N covers the reach of every filter that carries
// them towards the foveae (a bloom chain compounds: each halving doubles what it reads in its
// source's pixels), and a pass whose shaders also write storage (a histogram) sees only the guarded
// pixels. Passes with any other attachment run in full. Under OpenXR the targets of an eye image's
// extent are cut around its eyes' foveae instead (split::runtime_guard_foveae: each at its view
// direction, every eye and layer of that extent, as the pass does not say which it renders for); an
// eye-sized target whose eyes are not the image's halves is replayed whole. Passes whose contents are in
// secondaries are scissored alike through variants of their secondaries (begin_variant).
//
// SPLITVK_GAZE other than fixed moves the foveae from frame to frame, by a gaze that only
// the frame's FramePresent carries. Scissors are baked into command buffers when they are recorded,
// and applications record once and submit many times (vkcube), so a scissor cut to one frame's
// foveae would leave a later frame's fovea unshaded. Re-recording every split pass per frame would
// re-record most of the frame on every present; instead the scissors stay conservative: every place
// a fovea can be is the whole eye it belongs to (split::fovea_scissor with moving_gaze), so a split
// pass is shaded over each eye it draws into (in full for SPLITVK_EYES=1 or auto) and guard:N cuts
// offscreen passes to the eyes only. The agent shades more, and every fovea is exact wherever the
// frame's gaze puts it.

#include "settings.h"
#include "split_tracker.h"
#include "swapchain_images.h"
#include "target_rule.h"
#include "vk_replay.h"

#include <vulkan/vulkan.h>

#include <cstdint>
#include <memory>
#include <optional>
#include <unordered_map>
#include <vector>

namespace splitvk::agent {

class FoveaShading {
public:
    FoveaShading(ReplayDispatch &vk, SwapchainImages &swapchains) : vk_(vk), swapchains_(swapchains) {}

    // The client's eye layout and fovea size; Settings' defaults until called. `moving_gaze`: the
    // foveae follow each frame's gaze (SplitConfig::moving_gaze), so the scissors of split passes
    // and guarded passes cover every place a fovea can move to (see the top of this file).
    void configure(EyeMode eyes, const FoveaSize &fovea, const AgentScissor &scissor = {},
                   bool moving_gaze = false) {
        eyes_ = eyes;
        fovea_ = fovea;
        scissor_ = scissor;
        moving_gaze_ = moving_gaze;
        ++generation_;
    }
    bool moving_gaze() const { return moving_gaze_; }
    const FoveaSize &fovea() const { return fovea_; }
    // Off: everything replays as recorded (SPLITVK_VERIFY compares whole frames, and the client
    // does not split then, or only in the swapped split, which keeps it off). Set before the first
    // command.
    void set_enabled(bool enabled) { enabled_ = enabled; }
    bool enabled() const { return enabled_; }

    // The fovea rects of what split passes drew into swapchain image `image_id` (client id) in the
    // submits replayed since the last call (split::frame_foveae of their coverage; full-resolution
    // coordinates, sorted by x then y, as the client's take_split_frame reports them). Clears the
    // record.
    // An OpenXR runtime's image gives its eyes' foveae instead (split::runtime_eye_foveae), in their
    // array layers. A window image's foveae sit at `gaze`, the frame's (FramePresent::gaze). Every
    // fovea takes `size`, the frame's (FramePresent::fovea_size), or the configured one when unset.
    std::vector<split::LayerFovea> take_drawn_foveae(uint64_t image_id, const split::Gaze &gaze = {},
                                                     const split::FrameFoveaSize &size = {});

    // Object tracking (after the driver call; destroys before it).
    void image_created(VkImage image, const VkImageCreateInfo &info);
    void image_destroyed(VkImage image);
    void image_view_created(VkImageView view, const VkImageViewCreateInfo &info);
    void image_view_destroyed(VkImageView view);
    void framebuffer_created(VkFramebuffer framebuffer, const VkFramebufferCreateInfo &info);
    void framebuffer_destroyed(VkFramebuffer framebuffer);
    // The create infos to pass down (valid until the next call), then what was created.
    const VkGraphicsPipelineCreateInfo *prepare_pipelines(uint32_t count,
                                                          const VkGraphicsPipelineCreateInfo *infos);
    void pipelines_created(uint32_t count, const VkPipeline *pipelines);
    void pipeline_destroyed(VkPipeline pipeline);

    // Command buffer commands, after the recorded call was replayed (except set_scissors, which
    // replays it).
    void begin_command_buffer(VkCommandBuffer cb, const VkCommandBufferBeginInfo *info);
    // A copy or blit into a swapchain image counts as drawing into it: the foveae of the
    // eyes each destination rectangle covers, as the client notes them (layer/capture/transfer.cpp).
    void transfer_into(VkCommandBuffer cb, VkImage image, uint32_t count, const VkRect2D *rects);
    // Secondaries executed inside a split pass: the foveae of the viewports they drew with.
    void execute_commands(VkCommandBuffer cb, uint32_t count, const VkCommandBuffer *secondaries);

    // Mirror windows: an engine that copies or blits a swapchain image (an OpenXR eye image) into
    // another one (its desktop window's) in the same command buffer makes the second image's foveae
    // read pixels of the first that its own foveae do not cover. `image_ids` are the swapchain
    // images that transfers in `cb`'s recording read (its executed secondaries' included), known
    // before its commands are replayed (set right after its vkBeginCommandBuffer). Its split passes
    // into those images are replayed whole, and, under guard:N, so are its passes into screen-space
    // targets (their pixels reach the copied image away from its foveae too). The foveae noted for
    // the images stay those of the viewports drawn with, as on the client.
    void note_transfer_reads(VkCommandBuffer cb, std::vector<uint64_t> image_ids);
    // What note_transfer_reads said for `cb`'s recording in progress or last recorded.
    const std::vector<uint64_t> &transfer_reads(VkCommandBuffer cb) const;

    // Secondaries inside scissored passes. A secondary that continues a render
    // pass is recorded before the agent knows which pass will execute it (its stream arrives at its
    // vkEndCommandBuffer, before the primary's), so its own recording keeps the app's scissors and
    // is shaded whole. For a pass that is scissored (a split pass, or a guarded one under guard:N),
    // the replayer records a variant of the secondary from its stream, begun with begin_variant:
    // its scissors are narrowed as a primary's are inside that pass, from the viewports and
    // scissors the secondary sets itself (they are not inherited). A variant serves every pass with
    // the same PassScissor; the foveae drawn are still counted from the secondary itself.
    struct PassScissor {
        bool swapchain = false; // a split pass into swapchain image `image`; else a guarded one
        uint64_t image = 0;
        VkExtent2D extent{};
        std::optional<std::vector<split::LayerFovea>>
            eyes;                // an OpenXR runtime's image: where its foveae can be
        VkRect2D guard{};        // a guarded pass: its scissor
        uint64_t generation = 0; // of configure(): a variant is for one eye layout and fovea size
        // The swapped split's scaled pass into swapchain image `image` (periphery_scaling.h): the
        // variant's viewports and scissors are scaled instead, for `extent`.
        bool scaled = false;
        // Whether a variant recorded for `other` narrows exactly as one for this pass would.
        bool same_as(const PassScissor &other) const;
    };
    // The scissoring of the pass in progress in `primary`; none when it is shaded whole.
    std::optional<PassScissor> pass_scissor(VkCommandBuffer primary) const;
    // `cb` was begun as a secondary that continues a render pass.
    bool continues_pass(VkCommandBuffer cb) const;
    // The next vkBeginCommandBuffer of `variant` records it for a pass scissored as `scissor`.
    void begin_variant(VkCommandBuffer variant, const PassScissor &scissor);
    void bind_pipeline(VkCommandBuffer cb, VkPipelineBindPoint bind_point, VkPipeline pipeline);
    void set_viewports(VkCommandBuffer cb, uint32_t first, uint32_t count, const VkViewport *viewports,
                       bool with_count);
    void set_scissors(VkCommandBuffer cb, uint32_t first, uint32_t count, const VkRect2D *scissors,
                      bool with_count);
    void begin_render_pass(VkCommandBuffer cb, const VkRenderPassBeginInfo &begin, bool secondary);
    void begin_rendering(VkCommandBuffer cb, const VkRenderingInfo &info);
    void end_pass(VkCommandBuffer cb);

    // A replayed submit: the split passes of these command buffers drew their foveae.
    void submitted(uint32_t count, const VkCommandBuffer *command_buffers);

private:
    bool target(VkImageView view, uint64_t *image_id, VkExtent2D *extent) const;
    // guard:N: the scissor of a pass whose attachments are all screen-space targets. False, with
    // *refused saying which, where one is a target the foveae cannot be mapped to: that pass is
    // replayed whole.
    struct GuardRefusal {
        VkExtent2D extent{}; // of the target; {0, 0}: not guarded for another reason, said nowhere
        // An eye-sized target of OpenXR eye images whose eyes are not their halves
        // (split::runtime_guard_foveae); otherwise a window's (split::guard_maps_target).
        bool runtime = false;
    };
    bool guard_rect(const std::vector<VkImageView> &views, VkExtent2D *extent, VkRect2D *rect,
                    GuardRefusal *refused) const;
    // `emit`: false for a pass whose contents are in secondaries (no scissor may be set in it; its
    // secondaries' variants get the guard).
    void enter_guarded(VkCommandBuffer cb, split::CommandTracker &t, const std::vector<VkImageView> &views,
                       bool emit);
    void enter_split(VkCommandBuffer cb, split::CommandTracker &tracker, uint64_t image_id,
                     VkExtent2D extent);
    void emit_scissors(VkCommandBuffer cb, const split::CommandTracker &tracker);
    // Whether a split pass of `cb` into swapchain image `image_id` is replayed whole
    // (note_transfer_reads).
    bool copied_out(VkCommandBuffer cb, uint64_t image_id) const;
    // begin_split for a pass into a swapchain image, saying once per session that one is replayed whole.
    void begin_swapchain_pass(VkCommandBuffer cb, split::CommandTracker &tracker, uint64_t image_id,
                              VkExtent2D extent);
    split::CommandTracker *tracker(VkCommandBuffer cb);

    ReplayDispatch &vk_;
    SwapchainImages &swapchains_;
    bool enabled_ = true;
    EyeMode eyes_ = Settings{}.eyes;
    // The foveae of an OpenXR runtime's image (its eyes', at the frame's gaze or their view
    // directions once known), or none for a window's, whose foveae SPLITVK_EYES places.
    std::optional<std::vector<split::LayerFovea>> runtime_foveae(uint64_t image_id, VkExtent2D extent,
                                                                 const FoveaSize &fovea,
                                                                 const split::Gaze &gaze) const;
    // Where those foveae can be in this session (split::runtime_fovea_areas): what scissors cover.
    std::optional<std::vector<split::LayerFovea>> runtime_fovea_areas(uint64_t image_id,
                                                                      VkExtent2D extent) const;
    FoveaSize fovea_ = Settings{}.fovea;
    AgentScissor scissor_;
    bool moving_gaze_ = false;
    struct View {
        VkImage image = VK_NULL_HANDLE;
        uint32_t mip = 0;
    };
    std::unordered_map<VkImageView, View> views_;
    struct Target {
        VkExtent2D screen{}; // the swapchain extent it was classified against
        VkExtent2D extent{}; // mip 0, per layer
        split::TargetClass kind;
    };
    std::unordered_map<VkImage, Target> targets_;               // screen-space targets only
    std::unordered_map<VkCommandBuffer, VkRect2D> guard_rects_; // of the guarded pass in progress
    bool guard_logged_ = false;
    bool unmapped_logged_ = false;         // a pass replayed whole: said once
    bool runtime_unmapped_logged_ = false; // one of OpenXR eye images' (GuardRefusal::runtime)
    bool variant_logged_ = false;
    bool copied_out_logged_ = false;
    bool copied_guard_logged_ = false;
    // note_transfer_reads, by command buffer (absent: none)
    std::unordered_map<VkCommandBuffer, std::vector<uint64_t>> transfer_reads_;
    uint64_t generation_ = 0;                                           // configure() calls
    std::unordered_map<VkCommandBuffer, PassScissor> pending_variants_; // begin_variant, until begun
    std::unordered_map<VkFramebuffer, std::vector<VkImageView>> framebuffers_;
    std::unordered_map<VkPipeline, std::shared_ptr<const split::StaticViewportState>> pipelines_;
    std::unordered_map<VkCommandBuffer, split::CommandTracker> command_buffers_;
    std::unordered_map<uint64_t, split::DrawnImage> drawn_; // client image id -> what was drawn
    // prepare_pipelines' output
    std::vector<std::shared_ptr<split::StaticViewportState>> pending_;
    std::vector<VkGraphicsPipelineCreateInfo> infos_;
    std::vector<split::DynamicStateStorage> storage_;
};

} // namespace splitvk::agent
