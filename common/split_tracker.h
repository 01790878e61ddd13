#pragma once

// Per-command-buffer viewport/scissor state of the split (docs/architecture.md §4), shared by the layer
// (which rewrites the state into the scaled periphery) and the agent (which narrows scissors to the foveae).
// Both sides feed it the application's original calls, so they agree on which viewports were in effect inside
// each split pass and thus on the foveae drawn.
//
// Dynamic viewport/scissor state persists across render pass instances within a command buffer,
// and a pipeline with static state overrides it only while bound: the tracker keeps the app's
// dynamic values (unscaled) and the bound pipeline's static values separately, so that each side
// can re-emit the state in effect whenever a split pass begins or ends or the pipeline changes.

#include "settings.h"
#include "split_geometry.h"

#include <vulkan/vulkan.h>

#include <algorithm>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <unordered_map>
#include <vector>

namespace splitvk::split {

// A graphics pipeline's static viewport/scissor state, which the rewriting side made dynamic at
// creation (so it must set these values itself while the pipeline is bound).
struct StaticViewportState {
    bool has_viewports = false;
    bool has_scissors = false;
    std::vector<VkViewport> viewports;
    std::vector<VkRect2D> scissors;
};

// A swapchain image drawn by split passes: the image (client id or handle value), its full
// extent, and which of its halves the viewports in effect drew (split_geometry.h). The foveae follow
// from the whole frame's coverage (split::frame_foveae), taken at present on both sides.
struct DrawnImage {
    uint64_t image = 0;
    VkExtent2D extent{};
    EyeCoverage coverage;
    // The client alone, with SPLITVK_FOVEA=auto: the largest fovea size its passes left unshaded
    // (layer/capture/fovea_mask.h), which the frame's foveae must not be smaller than.
    FrameFoveaSize masked;
    // The client alone, with SPLITVK_CLIENT_RENDERS=fovea: a pass into it was cut to the foveae
    // (CommandTracker::cut_pass), so the frame's periphery must come from the agent.
    bool cut = false;
    // The client alone: the version of an OpenXR runtime image's eyes (the projection views) that its
    // cut passes were cut by (CommandTracker::cut_runtime_pass); kNoRuntimeCut when none was, and
    // kMixedRuntimeCut when two were cut by different eyes. A frame's foveae are exact only where
    // its eyes are the ones its passes were cut by.
    static constexpr int64_t kNoRuntimeCut = -1;
    static constexpr int64_t kMixedRuntimeCut = -2;
    int64_t cut_eyes = kNoRuntimeCut;

    std::vector<VkRect2D> foveae(EyeMode mode, const FoveaSize &fovea, const Gaze &gaze = {}) const;
};

// The eyes version of two records of one image's cut passes joined (DrawnImage::cut_eyes).
int64_t merge_cut_eyes(int64_t a, int64_t b);

// Unions `from` into `into` (one entry per image; the coverages are joined).
void merge_drawn(std::vector<DrawnImage> &into, const std::vector<DrawnImage> &from);

template <class T>
struct StateArray {
    std::vector<T> values;
    std::vector<bool> set;
    bool with_count = false; // last set through vkCmdSet*WithCount (count included)

    void assign(uint32_t first, uint32_t count, const T *items, bool count_too) {
        if (count_too) {
            values.assign(items, items + count);
            set.assign(count, true);
        } else {
            if (values.size() < first + count) {
                values.resize(first + count);
                set.resize(first + count, false);
            }
            for (uint32_t i = 0; i < count; ++i) {
                values[first + i] = items[i];
                set[first + i] = true;
            }
        }
        with_count = count_too;
    }
    bool valid(size_t i) const { return i < set.size() && set[i]; }
    bool empty() const { return values.empty(); }
};

// Calls set(first, count, out.data() + first) for each run of consecutive indices that `state` holds
// a value for; `out` has one entry per index of state.values (the values to pass down, perhaps
// rewritten). The indices between runs were never set, so they hold no valid value to pass down.
template <class T, class Out, class Set>
void for_each_valid_run(const StateArray<T> &state, const std::vector<Out> &out, Set &&set) {
    for (uint32_t first = 0; first < out.size();) {
        if (!state.valid(first)) {
            ++first;
            continue;
        }
        uint32_t end = first;
        while (end < out.size() && state.valid(end))
            ++end;
        set(first, end - first, out.data() + first);
        first = end;
    }
}

class CommandTracker {
public:
    void reset() { *this = CommandTracker(); }

    void set_viewports(uint32_t first, uint32_t count, const VkViewport *v, bool with_count) {
        viewports_.assign(first, count, v, with_count);
    }
    void set_scissors(uint32_t first, uint32_t count, const VkRect2D *r, bool with_count) {
        scissors_.assign(first, count, r, with_count);
    }
    // A graphics pipeline bind; null when the pipeline has no static viewport/scissor state.
    // Binding a pipeline with static state writes that state into the command buffer's (Vulkan's
    // "pipeline state that is not dynamic is applied to the command buffer state"), so a
    // dynamic-state pipeline bound next without a vkCmdSet* sees the static values.
    void bind_pipeline(std::shared_ptr<const StaticViewportState> state);
    const StaticViewportState *pipeline() const { return pipeline_.get(); }
    bool static_viewports() const { return pipeline_ && pipeline_->has_viewports; }
    bool static_scissors() const { return pipeline_ && pipeline_->has_scissors; }

    // `swapchain`: the pass draws into swapchain image `image`, whose foveae are noted; otherwise it
    // draws only into screen-space targets, scaled alike but with no fovea of its own.
    void begin_split(uint64_t image, VkExtent2D extent, bool swapchain = true) {
        in_split_ = true;
        noted_in_pass_ = false;
        swapchain_ = swapchain;
        image_ = image;
        extent_ = extent;
        cut_ = false;
        guard_.reset();
        runtime_areas_.clear();
        runtime_eyes_ = DrawnImage::kNoRuntimeCut;
    }
    // The client with SPLITVK_CLIENT_RENDERS=fovea, right after begin_split: the pass keeps
    // its full-size render area and viewports, and its scissors are cut instead of scaled: to the
    // foveae (split::narrow_to_foveae) in a pass into a swapchain image, to `guard` in a pass into
    // screen-space targets only (split::window_guard_rect), or not at all without one.
    void cut_pass(std::optional<VkRect2D> guard = std::nullopt) {
        cut_ = true;
        guard_ = guard;
    }
    // The same for a pass into an OpenXR runtime's eye image: its scissors are cut to `areas`, every
    // place its foveae can be with the eyes of version `eyes_version` (split::runtime_fovea_areas,
    // grown by the seam's band), as far as each viewport reaches them (split::runtime_scissor).
    void cut_runtime_pass(std::vector<LayerFovea> areas, uint64_t eyes_version) {
        cut_ = true;
        guard_.reset();
        runtime_areas_ = std::move(areas);
        runtime_eyes_ = static_cast<int64_t>(eyes_version);
    }
    // A pass cut by cut_runtime_pass: where its scissors may draw; null for any other pass.
    const std::vector<LayerFovea> *runtime_areas() const {
        return cut() && runtime_eyes_ != DrawnImage::kNoRuntimeCut ? &runtime_areas_ : nullptr;
    }
    bool cut() const { return in_split_ && cut_; }
    const std::optional<VkRect2D> &guard() const { return guard_; }
    // A pass that set no viewport of its own drew with the ones it inherited: their foveae are
    // noted now. They are not noted at the pass's begin, because a pass that sets its own before
    // drawing never draws the inherited ones, and a fovea noted but never shaded would be
    // composited from pixels the agent left out (atrium --path hdr: the last bloom pass's viewport).
    void end_split() {
        if (in_split_ && !noted_in_pass_) note_foveae();
        in_split_ = false;
        swapchain_ = false;
        cut_ = false;
        guard_.reset();
        runtime_areas_.clear();
        runtime_eyes_ = DrawnImage::kNoRuntimeCut;
    }
    bool in_split() const { return in_split_; }
    bool swapchain_pass() const { return in_split_ && swapchain_; }
    uint64_t image() const { return image_; }
    VkExtent2D extent() const { return extent_; }

    // The app's dynamic values (unscaled).
    const StateArray<VkViewport> &dynamic_viewports() const { return viewports_; }
    const StateArray<VkRect2D> &dynamic_scissors() const { return scissors_; }

    // The viewport in effect at index i: the bound pipeline's static one or the app's dynamic one.
    const VkViewport *viewport(size_t i) const;
    size_t viewport_count() const;
    const VkRect2D *scissor(size_t i) const;
    size_t scissor_count() const;

    // Inside a split pass: adds the coverage of every viewport in effect to the pass's image record.
    // Called whenever the pass changes the viewports in effect (viewport set, pipeline bind), and
    // at the pass's end when it changed none (end_split).
    void note_foveae();
    // A copy or blit into swapchain image `image` (of `extent`) wrote `region`: it counts as drawing
    // there, covering what a viewport of that rectangle would. `cut`: in the swapped split
    // it wrote the client's full-size picture, whose periphery the client did not render (its passes
    // and dispatches were cut), so the frame's periphery must come from the agent as for a cut pass.
    void note_transfer(uint64_t image, VkExtent2D extent, const VkRect2D &region, bool cut = false);
    // Inside a split pass into a swapchain image: the client left the foveae of `size` unshaded.
    void note_mask(const FrameFoveaSize &size);
    // Secondary command buffers. A secondary that continues a render pass
    // (RENDER_PASS_CONTINUE) does not know the image it will draw into, so it keeps the viewports it
    // draws with as recorded; they count as drawn when a primary executes it inside a split pass
    // into a swapchain image, from that image's extent. Both sides do this, so they agree on the foveae.
    void begin_secondary() { secondary_ = true; }
    bool secondary() const { return secondary_; }
    // A primary's pass whose contents come from secondaries: it draws nothing with its own viewports.
    void contents_in_secondaries() { noted_in_pass_ = true; }
    // vkCmdExecuteCommands: what the executed secondary drew counts for this command buffer.
    void merge_executed(const CommandTracker &secondary);
    const std::vector<DrawnImage> &drawn() const { return drawn_; }

    // The descriptor sets bound at the compute bind point, by set number (vkCmdBindDescriptorSets):
    // a dispatch scales its group counts when one of them writes a screen-space target. Part of the
    // command buffer's state, so a command buffer begun again has none bound, and its dispatches are
    // not scaled for a set its previous recording bound.
    void bind_compute_sets(uint32_t first, uint32_t count, const VkDescriptorSet *sets) {
        if (compute_sets_.size() < size_t{first} + count) compute_sets_.resize(size_t{first} + count);
        std::copy(sets, sets + count, compute_sets_.begin() + first);
    }
    const std::vector<VkDescriptorSet> &compute_sets() const { return compute_sets_; }
    // Whether a dispatch recorded now writes a screen-space target, so that its group counts are
    // scaled: one of the bound compute sets does, as `writes_screen_space(set)` says (the layer's
    // descriptor_set.cpp).
    template <class WritesScreenSpace>
    bool dispatch_writes_screen_space(WritesScreenSpace &&writes_screen_space) const {
        for (VkDescriptorSet set : compute_sets_)
            if (set != VK_NULL_HANDLE && writes_screen_space(set)) return true;
        return false;
    }

private:
    DrawnImage &drawn_entry(uint64_t image, VkExtent2D extent);

    StateArray<VkViewport> viewports_;
    StateArray<VkRect2D> scissors_;
    std::shared_ptr<const StaticViewportState> pipeline_;
    bool in_split_ = false;
    bool noted_in_pass_ = false;
    bool swapchain_ = false;
    bool secondary_ = false;
    bool cut_ = false;
    std::optional<VkRect2D> guard_;
    std::vector<LayerFovea> runtime_areas_;
    int64_t runtime_eyes_ = DrawnImage::kNoRuntimeCut;
    std::vector<VkViewport> secondary_viewports_; // a secondary's, as recorded
    uint64_t image_ = 0;
    VkExtent2D extent_{};
    std::vector<DrawnImage> drawn_;
    std::vector<VkDescriptorSet> compute_sets_;
};

// How a render pass's latest instance was scaled (client): a secondary that
// continues the pass without naming its framebuffer is recorded for that prediction. Keyed by the
// render pass's handle value, which a driver may hand out again once the pass is destroyed: the
// layer forgets the value at vkDestroyRenderPass (before the driver call) and again at
// vkCreateRenderPass (a new pass has no instance yet, whatever the layer saw of the old one's
// end), so a new render pass never inherits a dead one's target. Thread-safe: passes are
// begun and secondaries begun from any thread.
struct PassPrediction {
    bool scaled = false; // the pass's target is scaled (a swapchain image or a screen-space target)
    VkExtent2D extent{}; // the full extent its scaled areas are relative to
    // SPLITVK_CLIENT_RENDERS=fovea: a pass into a swapchain image, cut to the foveae rather than
    // scaled (its secondaries narrow their scissors by their own viewports).
    bool swapchain = false;
};

class PassPredictions {
public:
    void note_begin(uint64_t render_pass, const PassPrediction &prediction);
    // The latest instance's target; none when the pass was never begun since it was created.
    std::optional<PassPrediction> predict(uint64_t render_pass) const;
    void forget(uint64_t render_pass);

private:
    mutable std::mutex mutex_;
    std::unordered_map<uint64_t, PassPrediction> latest_;
};

// The same prediction for dynamic renderings whose contents are in secondaries: a secondary's
// inheritance names no image and no render pass, only the rendering's attachment formats and view
// mask (VkCommandBufferInheritanceRenderingInfo), so those are the key. Renderings that differ in
// none of them are predicted alike; the layer says once when a secondary is executed in a rendering
// scaled otherwise than predicted. VK_FORMAT_UNDEFINED stands for an absent attachment, as in the
// inheritance info.
uint64_t rendering_key(const VkFormat *colours, uint32_t colour_count, VkFormat depth, VkFormat stencil,
                       uint32_t view_mask);

// Reads a pipeline's static viewport/scissor state from its create info. Returns null when both
// are dynamic (or absent); `*add_viewport` / `*add_scissor` say which dynamic states the caller
// must add to make the rest dynamic (the caller decides whether it needs viewports dynamic).
std::shared_ptr<StaticViewportState> static_viewport_state(const VkGraphicsPipelineCreateInfo &info);

// `info`'s dynamic states plus VIEWPORT / SCISSOR as requested, in `storage` (which `out`
// points into); `out` is the create info to pass down.
struct DynamicStateStorage {
    std::vector<VkDynamicState> states;
    VkPipelineDynamicStateCreateInfo info{};
};
void add_dynamic_states(const VkGraphicsPipelineCreateInfo &info, bool viewport, bool scissor,
                        DynamicStateStorage &storage, VkGraphicsPipelineCreateInfo &out);

} // namespace splitvk::split
