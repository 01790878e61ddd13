#include "fovea_shading.h"

#include "log.h"
#include "split_geometry.h"

namespace splitvk::agent {

std::vector<VkRect2D> FoveaShading::take_drawn_foveae(uint64_t image_id) {
    const auto it = drawn_.find(image_id);
    if (it == drawn_.end()) return {};
    std::vector<VkRect2D> foveae = std::move(it->second);
    drawn_.erase(it);
    return foveae;
}

void FoveaShading::image_view_created(VkImageView view, VkImage image) {
    if (enabled_ && view) views_[view] = image;
}

void FoveaShading::image_view_destroyed(VkImageView view) {
    views_.erase(view);
}

void FoveaShading::framebuffer_created(VkFramebuffer framebuffer, const VkFramebufferCreateInfo &info) {
    if (!enabled_ || !framebuffer) return;
    auto &views = framebuffers_[framebuffer];
    views.clear();
    if (!(info.flags & VK_FRAMEBUFFER_CREATE_IMAGELESS_BIT) && info.pAttachments)
        views.assign(info.pAttachments, info.pAttachments + info.attachmentCount);
}

void FoveaShading::framebuffer_destroyed(VkFramebuffer framebuffer) {
    framebuffers_.erase(framebuffer);
}

const VkGraphicsPipelineCreateInfo *
FoveaShading::prepare_pipelines(uint32_t count, const VkGraphicsPipelineCreateInfo *infos) {
    pending_.clear();
    if (!enabled_) return infos;
    pending_.resize(count);
    infos_.resize(count);
    storage_.clear();
    storage_.resize(count); // not resized again: infos_ point into it
    for (uint32_t i = 0; i < count; ++i) {
        pending_[i] = split::static_viewport_state(infos[i]);
        // Only the scissor must become dynamic here: the agent keeps the app's viewports.
        split::add_dynamic_states(infos[i], false, pending_[i] && pending_[i]->has_scissors, storage_[i],
                                  infos_[i]);
    }
    return infos_.data();
}

void FoveaShading::pipelines_created(uint32_t count, const VkPipeline *pipelines) {
    for (uint32_t i = 0; i < count && i < pending_.size(); ++i)
        if (pending_[i] && pipelines[i]) pipelines_[pipelines[i]] = std::move(pending_[i]);
    pending_.clear();
}

void FoveaShading::pipeline_destroyed(VkPipeline pipeline) {
    pipelines_.erase(pipeline);
}

split::CommandTracker *FoveaShading::tracker(VkCommandBuffer cb) {
    if (!enabled_) return nullptr;
    return &command_buffers_[cb];
}

void FoveaShading::begin_command_buffer(VkCommandBuffer cb, const VkCommandBufferBeginInfo *info) {
    split::CommandTracker *t = tracker(cb);
    if (!t) return;
    t->reset();
    // Shaded whole (its image is unknown until executed); its viewports become foveae then.
    if (info && (info->flags & VK_COMMAND_BUFFER_USAGE_RENDER_PASS_CONTINUE_BIT) && info->pInheritanceInfo)
        t->begin_secondary();
}

void FoveaShading::transfer_into(VkCommandBuffer cb, VkImage image, uint32_t count, const VkRect2D *rects) {
    split::CommandTracker *t = tracker(cb);
    uint64_t image_id = 0;
    VkExtent2D extent{};
    if (!t || !swapchains_.find_image(image, &image_id, &extent)) return;
    for (uint32_t i = 0; i < count; ++i)
        t->note_transfer(image_id, extent, rects[i], eyes_, fovea_);
}

void FoveaShading::execute_commands(VkCommandBuffer cb, uint32_t count, const VkCommandBuffer *secondaries) {
    split::CommandTracker *t = tracker(cb);
    if (!t) return;
    for (uint32_t i = 0; i < count; ++i) {
        const auto it = command_buffers_.find(secondaries[i]);
        if (it != command_buffers_.end()) t->merge_executed(it->second, eyes_, fovea_);
    }
}

void FoveaShading::bind_pipeline(VkCommandBuffer cb, VkPipelineBindPoint bind_point, VkPipeline pipeline) {
    split::CommandTracker *t = bind_point == VK_PIPELINE_BIND_POINT_GRAPHICS ? tracker(cb) : nullptr;
    if (!t) return;
    const bool had_viewports = t->static_viewports(), had_scissors = t->static_scissors();
    const auto it = pipelines_.find(pipeline);
    t->bind_pipeline(it == pipelines_.end() ? nullptr : it->second);
    // The client notes foveae on the same condition (layer/pipeline.cpp), so both sides agree.
    const bool viewports_changed = had_viewports || t->static_viewports();
    if (had_scissors || t->static_scissors() || (t->in_split() && viewports_changed)) emit_scissors(cb, *t);
    if (viewports_changed) t->note_foveae(eyes_, fovea_);
}

void FoveaShading::set_viewports(VkCommandBuffer cb, uint32_t first, uint32_t count,
                                 const VkViewport *viewports, bool with_count) {
    split::CommandTracker *t = tracker(cb);
    if (!t) return;
    t->set_viewports(first, count, viewports, with_count);
    if (!t->static_viewports() && t->secondary()) t->note_foveae(eyes_, fovea_);
    if (t->static_viewports() || !t->in_split()) return;
    t->note_foveae(eyes_, fovea_);
    emit_scissors(cb, *t);
}

void FoveaShading::set_scissors(VkCommandBuffer cb, uint32_t first, uint32_t count, const VkRect2D *scissors,
                                bool with_count) {
    split::CommandTracker *t = tracker(cb);
    if (t) t->set_scissors(first, count, scissors, with_count);
    if (t && t->static_scissors()) return; // the bound pipeline's static scissors stay in effect
    if (t && t->in_split()) return emit_scissors(cb, *t);
    if (with_count) {
        if (vk_.CmdSetScissorWithCount) vk_.CmdSetScissorWithCount(cb, count, scissors);
    } else {
        vk_.CmdSetScissor(cb, first, count, scissors);
    }
}

bool FoveaShading::target(VkImageView view, uint64_t *image_id, VkExtent2D *extent) const {
    const auto it = views_.find(view);
    return it != views_.end() && swapchains_.find_image(it->second, image_id, extent);
}

void FoveaShading::enter_split(VkCommandBuffer cb, split::CommandTracker &t, uint64_t image_id,
                               VkExtent2D extent) {
    t.begin_split(image_id, extent);
    emit_scissors(cb, t);
}

void FoveaShading::begin_render_pass(VkCommandBuffer cb, const VkRenderPassBeginInfo &begin, bool secondary) {
    split::CommandTracker *t = tracker(cb);
    if (!t) return;
    const VkRenderPassAttachmentBeginInfo *attachments = nullptr;
    for (auto *p = static_cast<const VkBaseInStructure *>(begin.pNext); p; p = p->pNext)
        if (p->sType == VK_STRUCTURE_TYPE_RENDER_PASS_ATTACHMENT_BEGIN_INFO)
            attachments = reinterpret_cast<const VkRenderPassAttachmentBeginInfo *>(p);
    const VkImageView *views = nullptr;
    size_t count = 0;
    if (attachments) {
        views = attachments->pAttachments;
        count = attachments->attachmentCount;
    } else if (const auto fb = framebuffers_.find(begin.framebuffer); fb != framebuffers_.end()) {
        views = fb->second.data();
        count = fb->second.size();
    }
    uint64_t image_id = 0;
    VkExtent2D extent{};
    for (size_t i = 0; i < count; ++i)
        if (target(views[i], &image_id, &extent)) {
            if (!secondary) return enter_split(cb, *t, image_id, extent);
            // Its secondaries are shaded whole; the viewports they draw with give the foveae. Only
            // vkCmdExecuteCommands may follow in the primary: no scissors to set.
            t->begin_split(image_id, extent);
            t->contents_in_secondaries();
            return;
        }
}

void FoveaShading::begin_rendering(VkCommandBuffer cb, const VkRenderingInfo &info) {
    split::CommandTracker *t = tracker(cb);
    if (!t) return;
    uint64_t image_id = 0;
    VkExtent2D extent{};
    for (uint32_t i = 0; i < info.colorAttachmentCount; ++i) {
        const VkRenderingAttachmentInfo &a = info.pColorAttachments[i];
        if (target(a.imageView, &image_id, &extent) ||
            (a.resolveMode != VK_RESOLVE_MODE_NONE && target(a.resolveImageView, &image_id, &extent))) {
            if (info.flags & VK_RENDERING_CONTENTS_SECONDARY_COMMAND_BUFFERS_BIT) {
                if (!secondary_logged_)
                    SPLITVK_WARN(
                        "a split pass records its contents in secondary command buffers: shaded whole");
                secondary_logged_ = true;
                return;
            }
            return enter_split(cb, *t, image_id, extent);
        }
    }
}

void FoveaShading::end_pass(VkCommandBuffer cb) {
    split::CommandTracker *t = tracker(cb);
    if (!t || !t->in_split()) return;
    t->end_split(eyes_, fovea_);
    emit_scissors(cb, *t);
}

void FoveaShading::emit_scissors(VkCommandBuffer cb, const split::CommandTracker &t) {
    const auto out = [&](size_t i, const VkRect2D &r) {
        if (!t.in_split()) return r;
        const VkViewport *v = t.viewport(i);
        // Without viewport i the eye is unknown; the scissor is narrowed once the viewport is set.
        return v ? split::intersect(r, split::fovea_for_viewport(*v, t.extent(), eyes_, fovea_)) : r;
    };
    std::vector<VkRect2D> values;
    if (t.static_scissors()) {
        for (size_t i = 0; i < t.pipeline()->scissors.size(); ++i)
            values.push_back(out(i, t.pipeline()->scissors[i]));
        vk_.CmdSetScissor(cb, 0, static_cast<uint32_t>(values.size()), values.data());
        return;
    }
    const auto &dynamic = t.dynamic_scissors();
    if (dynamic.empty()) return;
    for (size_t i = 0; i < dynamic.values.size(); ++i)
        values.push_back(out(i, dynamic.values[i]));
    if (dynamic.with_count) {
        if (vk_.CmdSetScissorWithCount)
            vk_.CmdSetScissorWithCount(cb, static_cast<uint32_t>(values.size()), values.data());
        return;
    }
    for (uint32_t first = 0; first < values.size();) {
        if (!dynamic.valid(first)) {
            ++first;
            continue;
        }
        uint32_t end = first;
        while (end < values.size() && dynamic.valid(end))
            ++end;
        vk_.CmdSetScissor(cb, first, end - first, values.data() + first);
        first = end;
    }
}

void FoveaShading::submitted(uint32_t count, const VkCommandBuffer *command_buffers) {
    if (!enabled_) return;
    for (uint32_t i = 0; i < count; ++i) {
        const auto it = command_buffers_.find(command_buffers[i]);
        if (it == command_buffers_.end()) continue;
        for (const split::DrawnImage &d : it->second.drawn()) {
            auto &foveae = drawn_[d.image];
            for (const VkRect2D &r : d.foveae)
                split::add_fovea(foveae, r);
        }
    }
}

} // namespace splitvk::agent
