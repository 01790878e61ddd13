#include "split_tracker.h"

#include "split_geometry.h"

#include <algorithm>

namespace splitvk::split {

int64_t merge_cut_eyes(int64_t a, int64_t b) {
    if (a == DrawnImage::kNoRuntimeCut) return b;
    if (b == DrawnImage::kNoRuntimeCut || a == b) return a;
    return DrawnImage::kMixedRuntimeCut;
}

void merge_drawn(std::vector<DrawnImage> &into, const std::vector<DrawnImage> &from) {
    for (const DrawnImage &d : from) {
        auto it =
            std::find_if(into.begin(), into.end(), [&](const DrawnImage &x) { return x.image == d.image; });
        if (it == into.end()) {
            into.push_back(d);
            continue;
        }
        it->extent = d.extent;
        it->coverage |= d.coverage;
        it->masked = larger(it->masked, d.masked);
        it->cut = it->cut || d.cut;
        it->cut_eyes = merge_cut_eyes(it->cut_eyes, d.cut_eyes);
    }
}

std::vector<VkRect2D> DrawnImage::foveae(EyeMode mode, const FoveaSize &fovea, const Gaze &gaze) const {
    return frame_foveae(coverage, extent, mode, fovea, gaze);
}

void CommandTracker::bind_pipeline(std::shared_ptr<const StaticViewportState> state) {
    pipeline_ = std::move(state);
    if (!pipeline_) return;
    if (pipeline_->has_viewports)
        viewports_.assign(0, static_cast<uint32_t>(pipeline_->viewports.size()), pipeline_->viewports.data(),
                          false);
    if (pipeline_->has_scissors)
        scissors_.assign(0, static_cast<uint32_t>(pipeline_->scissors.size()), pipeline_->scissors.data(),
                         false);
}

const VkViewport *CommandTracker::viewport(size_t i) const {
    if (static_viewports()) return i < pipeline_->viewports.size() ? &pipeline_->viewports[i] : nullptr;
    return viewports_.valid(i) ? &viewports_.values[i] : nullptr;
}

size_t CommandTracker::viewport_count() const {
    return static_viewports() ? pipeline_->viewports.size() : viewports_.values.size();
}

const VkRect2D *CommandTracker::scissor(size_t i) const {
    if (static_scissors()) return i < pipeline_->scissors.size() ? &pipeline_->scissors[i] : nullptr;
    return scissors_.valid(i) ? &scissors_.values[i] : nullptr;
}

size_t CommandTracker::scissor_count() const {
    return static_scissors() ? pipeline_->scissors.size() : scissors_.values.size();
}

// The record of `image` among those drawn, added on first use; it takes the extent drawn at.
DrawnImage &CommandTracker::drawn_entry(uint64_t image, VkExtent2D extent) {
    auto it =
        std::find_if(drawn_.begin(), drawn_.end(), [&](const DrawnImage &x) { return x.image == image; });
    if (it == drawn_.end()) it = drawn_.insert(drawn_.end(), DrawnImage{image, extent, {}, {}});
    it->extent = extent;
    // A transfer notes its image outside any pass: drawn full size, not cut.
    if (cut() && swapchain_ && image == image_) {
        it->cut = true;
        it->cut_eyes = merge_cut_eyes(it->cut_eyes, runtime_eyes_);
    }
    return *it;
}

void CommandTracker::merge_executed(const CommandTracker &secondary) {
    merge_drawn(drawn_, secondary.drawn_);
    if (!in_split_ || !swapchain_) return;
    DrawnImage &entry = drawn_entry(image_, extent_);
    for (const VkViewport &v : secondary.secondary_viewports_)
        entry.coverage |= viewport_coverage(v, extent_);
    noted_in_pass_ = true;
}

void CommandTracker::note_foveae() {
    if (secondary_) {
        for (size_t i = 0; i < viewport_count(); ++i)
            if (const VkViewport *v = viewport(i)) {
                const bool known = std::any_of(
                    secondary_viewports_.begin(), secondary_viewports_.end(), [&](const VkViewport &k) {
                        return k.x == v->x && k.y == v->y && k.width == v->width && k.height == v->height;
                    });
                if (!known) secondary_viewports_.push_back(*v);
            }
        return;
    }
    if (!in_split_ || !swapchain_) return;
    DrawnImage &entry = drawn_entry(image_, extent_);
    for (size_t i = 0; i < viewport_count(); ++i)
        if (const VkViewport *v = viewport(i)) entry.coverage |= viewport_coverage(*v, extent_);
    noted_in_pass_ = true;
}

void CommandTracker::note_mask(const FrameFoveaSize &size) {
    if (!in_split_ || !swapchain_) return;
    DrawnImage &entry = drawn_entry(image_, extent_);
    entry.masked = larger(entry.masked, size);
}

void CommandTracker::note_transfer(uint64_t image, VkExtent2D extent, const VkRect2D &region, bool cut) {
    if (region.extent.width == 0 || region.extent.height == 0) return;
    const VkViewport as_viewport{static_cast<float>(region.offset.x),
                                 static_cast<float>(region.offset.y),
                                 static_cast<float>(region.extent.width),
                                 static_cast<float>(region.extent.height),
                                 0.f,
                                 1.f};
    DrawnImage &entry = drawn_entry(image, extent);
    entry.coverage |= viewport_coverage(as_viewport, extent);
    entry.cut = entry.cut || cut;
}

void PassPredictions::note_begin(uint64_t render_pass, const PassPrediction &prediction) {
    std::lock_guard lock(mutex_);
    latest_[render_pass] = prediction;
}

std::optional<PassPrediction> PassPredictions::predict(uint64_t render_pass) const {
    std::lock_guard lock(mutex_);
    const auto it = latest_.find(render_pass);
    if (it == latest_.end()) return std::nullopt;
    return it->second;
}

void PassPredictions::forget(uint64_t render_pass) {
    std::lock_guard lock(mutex_);
    latest_.erase(render_pass);
}

uint64_t rendering_key(const VkFormat *colours, uint32_t colour_count, VkFormat depth, VkFormat stencil,
                       uint32_t view_mask) {
    // FNV-1a over the fields in order; the count is hashed too, so trailing UNDEFINED colours count.
    uint64_t h = 0xcbf29ce484222325ull;
    const auto mix = [&](uint64_t v) {
        for (int i = 0; i < 8; ++i) {
            h ^= (v >> (8 * i)) & 0xff;
            h *= 0x100000001b3ull;
        }
    };
    mix(colour_count);
    for (uint32_t i = 0; i < colour_count; ++i)
        mix(static_cast<uint64_t>(colours[i]));
    mix(static_cast<uint64_t>(depth));
    mix(static_cast<uint64_t>(stencil));
    mix(view_mask);
    return h;
}

namespace {

bool has_state(const VkPipelineDynamicStateCreateInfo *dynamic, VkDynamicState state) {
    if (!dynamic) return false;
    for (uint32_t i = 0; i < dynamic->dynamicStateCount; ++i)
        if (dynamic->pDynamicStates[i] == state) return true;
    return false;
}

} // namespace

std::shared_ptr<StaticViewportState> static_viewport_state(const VkGraphicsPipelineCreateInfo &info) {
    const VkPipelineDynamicStateCreateInfo *dynamic = info.pDynamicState;
    // With rasterization statically discarded, pViewportState is ignored (and may be garbage).
    if (info.pRasterizationState && info.pRasterizationState->rasterizerDiscardEnable &&
        !has_state(dynamic, VK_DYNAMIC_STATE_RASTERIZER_DISCARD_ENABLE))
        return nullptr;
    // Pipeline libraries carry partial state; their parts are not tracked.
    if (info.flags & VK_PIPELINE_CREATE_LIBRARY_BIT_KHR) return nullptr;
    const VkPipelineViewportStateCreateInfo *vs = info.pViewportState;
    if (!vs) return nullptr;
    auto state = std::make_shared<StaticViewportState>();
    if (!has_state(dynamic, VK_DYNAMIC_STATE_VIEWPORT) &&
        !has_state(dynamic, VK_DYNAMIC_STATE_VIEWPORT_WITH_COUNT) && vs->pViewports && vs->viewportCount) {
        state->has_viewports = true;
        state->viewports.assign(vs->pViewports, vs->pViewports + vs->viewportCount);
    }
    if (!has_state(dynamic, VK_DYNAMIC_STATE_SCISSOR) &&
        !has_state(dynamic, VK_DYNAMIC_STATE_SCISSOR_WITH_COUNT) && vs->pScissors && vs->scissorCount) {
        state->has_scissors = true;
        state->scissors.assign(vs->pScissors, vs->pScissors + vs->scissorCount);
    }
    if (!state->has_viewports && !state->has_scissors) return nullptr;
    return state;
}

void add_dynamic_states(const VkGraphicsPipelineCreateInfo &info, bool viewport, bool scissor,
                        DynamicStateStorage &storage, VkGraphicsPipelineCreateInfo &out) {
    out = info;
    if (!viewport && !scissor) return;
    storage.states.clear();
    if (info.pDynamicState)
        storage.states.assign(info.pDynamicState->pDynamicStates,
                              info.pDynamicState->pDynamicStates + info.pDynamicState->dynamicStateCount);
    if (viewport) storage.states.push_back(VK_DYNAMIC_STATE_VIEWPORT);
    if (scissor) storage.states.push_back(VK_DYNAMIC_STATE_SCISSOR);
    storage.info = info.pDynamicState ? *info.pDynamicState : VkPipelineDynamicStateCreateInfo{};
    storage.info.sType = VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO;
    storage.info.dynamicStateCount = static_cast<uint32_t>(storage.states.size());
    storage.info.pDynamicStates = storage.states.data();
    out.pDynamicState = &storage.info;
}

} // namespace splitvk::split
