#include "fovea_shading.h"

#include "log.h"
#include "split_geometry.h"

#include <algorithm>
#include <cstdint>

namespace splitvk::agent {

std::vector<split::LayerFovea> FoveaShading::take_drawn_foveae(uint64_t image_id, const split::Gaze &gaze,
                                                               const split::FrameFoveaSize &size) {
    const auto it = drawn_.find(image_id);
    if (it == drawn_.end()) return {};
    const FoveaSize fovea = split::frame_fovea_size(fovea_, size);
    // The whole frame's coverage decides its foveae (split::frame_foveae), as the client's does.
    std::vector<split::LayerFovea> foveae = split::in_layer_zero(it->second.foveae(eyes_, fovea, gaze));
    // An OpenXR eye image: its eyes' foveae, wherever its passes drew, as the client composites them.
    if (auto eyes = runtime_foveae(image_id, it->second.extent, fovea, gaze); eyes && !foveae.empty())
        foveae = std::move(*eyes);
    drawn_.erase(it);
    return foveae;
}

std::optional<std::vector<split::LayerFovea>> FoveaShading::runtime_foveae(uint64_t image_id,
                                                                           VkExtent2D extent,
                                                                           const FoveaSize &fovea,
                                                                           const split::Gaze &gaze) const {
    const std::vector<split::RuntimeEye> *eyes = nullptr;
    uint32_t layers = 1;
    if (!swapchains_.runtime_image(image_id, &eyes, &layers)) return std::nullopt;
    return split::runtime_eye_foveae(extent, layers, *eyes, fovea, gaze);
}

std::optional<std::vector<split::LayerFovea>> FoveaShading::runtime_fovea_areas(uint64_t image_id,
                                                                                VkExtent2D extent) const {
    const std::vector<split::RuntimeEye> *eyes = nullptr;
    uint32_t layers = 1;
    if (!swapchains_.runtime_image(image_id, &eyes, &layers)) return std::nullopt;
    return split::runtime_fovea_areas(extent, layers, *eyes, fovea_, moving_gaze_);
}

void FoveaShading::image_created(VkImage image, const VkImageCreateInfo &info) {
    const VkExtent2D screen = swapchains_.newest_extent();
    if (!enabled_ || !image || screen.width == 0) return; // before the first swapchain: not a target
    split::TargetClass kind = split::classify_target(info, screen, eyes_);
    if (kind.screen_space)
        targets_[image] = {screen, {info.extent.width, info.extent.height}, std::move(kind)};
}

void FoveaShading::image_destroyed(VkImage image) {
    targets_.erase(image);
}

void FoveaShading::image_view_created(VkImageView view, const VkImageViewCreateInfo &info) {
    if (enabled_ && view) views_[view] = {info.image, info.subresourceRange.baseMipLevel};
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
    transfer_reads_.erase(cb);
    split::CommandTracker *t = tracker(cb);
    if (!t) return;
    t->reset();
    const auto variant = pending_variants_.find(cb);
    // Shaded whole (its image is unknown until executed); its viewports become foveae then.
    if (info && (info->flags & VK_COMMAND_BUFFER_USAGE_RENDER_PASS_CONTINUE_BIT) && info->pInheritanceInfo) {
        t->begin_secondary();
        // A variant: inside its pass from its first command, as a primary is after the pass's begin.
        if (variant != pending_variants_.end()) {
            const PassScissor &s = variant->second;
            t->begin_split(s.image, s.extent, s.swapchain);
            if (!s.swapchain) guard_rects_[cb] = s.guard;
        }
    }
    if (variant != pending_variants_.end()) pending_variants_.erase(variant);
}

bool FoveaShading::PassScissor::same_as(const PassScissor &other) const {
    const auto same_rect = [](const VkRect2D &a, const VkRect2D &b) {
        return a.offset.x == b.offset.x && a.offset.y == b.offset.y && a.extent.width == b.extent.width &&
               a.extent.height == b.extent.height;
    };
    // A split pass's scissors follow from the viewports, the image's extent and, for a runtime's
    // image, its eyes' foveae: which of a swapchain's images it is does not matter.
    if (swapchain != other.swapchain || generation != other.generation || scaled != other.scaled)
        return false;
    if (extent.width != other.extent.width || extent.height != other.extent.height) return false;
    if (!swapchain) return same_rect(guard, other.guard);
    if (eyes.has_value() != other.eyes.has_value()) return false;
    if (!eyes) return true;
    return std::equal(eyes->begin(), eyes->end(), other.eyes->begin(), other.eyes->end(),
                      [&](const split::LayerFovea &a, const split::LayerFovea &b) {
                          return a.layer == b.layer && same_rect(a.rect, b.rect);
                      });
}

std::optional<FoveaShading::PassScissor> FoveaShading::pass_scissor(VkCommandBuffer primary) const {
    if (!enabled_) return std::nullopt;
    const auto it = command_buffers_.find(primary);
    if (it == command_buffers_.end() || !it->second.in_split()) return std::nullopt;
    const split::CommandTracker &t = it->second;
    PassScissor s;
    s.swapchain = t.swapchain_pass();
    s.image = t.image();
    s.extent = t.extent();
    s.generation = generation_;
    if (s.swapchain) {
        if (copied_out(primary, t.image())) return std::nullopt;
        s.eyes = runtime_fovea_areas(t.image(), t.extent());
    } else {
        const auto guard = guard_rects_.find(primary);
        if (guard == guard_rects_.end()) return std::nullopt;
        s.guard = guard->second;
    }
    return s;
}

bool FoveaShading::continues_pass(VkCommandBuffer cb) const {
    const auto it = command_buffers_.find(cb);
    return enabled_ && it != command_buffers_.end() && it->second.secondary();
}

void FoveaShading::begin_variant(VkCommandBuffer variant, const PassScissor &scissor) {
    if (!variant_logged_)
        SPLITVK_INFO("secondaries executed in %s pass of %ux%u: recorded again, scissored for the pass",
                     scissor.swapchain ? "a split" : "a guarded", scissor.extent.width,
                     scissor.extent.height);
    variant_logged_ = true;
    pending_variants_[variant] = scissor;
}

void FoveaShading::transfer_into(VkCommandBuffer cb, VkImage image, uint32_t count, const VkRect2D *rects) {
    split::CommandTracker *t = tracker(cb);
    uint64_t image_id = 0;
    VkExtent2D extent{};
    if (!t || !swapchains_.find_image(image, &image_id, &extent)) return;
    for (uint32_t i = 0; i < count; ++i)
        t->note_transfer(image_id, extent, rects[i]);
}

void FoveaShading::note_transfer_reads(VkCommandBuffer cb, std::vector<uint64_t> image_ids) {
    if (!enabled_) return;
    if (image_ids.empty())
        transfer_reads_.erase(cb);
    else
        transfer_reads_[cb] = std::move(image_ids);
}

const std::vector<uint64_t> &FoveaShading::transfer_reads(VkCommandBuffer cb) const {
    static const std::vector<uint64_t> none;
    const auto it = transfer_reads_.find(cb);
    return it == transfer_reads_.end() ? none : it->second;
}

bool FoveaShading::copied_out(VkCommandBuffer cb, uint64_t image_id) const {
    const std::vector<uint64_t> &reads = transfer_reads(cb);
    return std::find(reads.begin(), reads.end(), image_id) != reads.end();
}

void FoveaShading::begin_swapchain_pass(VkCommandBuffer cb, split::CommandTracker &t, uint64_t image_id,
                                        VkExtent2D extent) {
    t.begin_split(image_id, extent);
    if (!copied_out_logged_ && copied_out(cb, image_id))
        SPLITVK_INFO("fovea shading: swapchain image 0x%llx is copied out of in its command buffer; its "
                     "passes are shaded whole",
                     static_cast<unsigned long long>(image_id));
    copied_out_logged_ |= copied_out(cb, image_id);
}

void FoveaShading::execute_commands(VkCommandBuffer cb, uint32_t count, const VkCommandBuffer *secondaries) {
    split::CommandTracker *t = tracker(cb);
    if (!t) return;
    for (uint32_t i = 0; i < count; ++i) {
        const auto it = command_buffers_.find(secondaries[i]);
        if (it != command_buffers_.end()) t->merge_executed(it->second);
    }
}

void FoveaShading::bind_pipeline(VkCommandBuffer cb, VkPipelineBindPoint bind_point, VkPipeline pipeline) {
    split::CommandTracker *t = bind_point == VK_PIPELINE_BIND_POINT_GRAPHICS ? tracker(cb) : nullptr;
    if (!t) return;
    const bool had_viewports = t->static_viewports(), had_scissors = t->static_scissors();
    const auto it = pipelines_.find(pipeline);
    t->bind_pipeline(it == pipelines_.end() ? nullptr : it->second);
    // The client notes foveae on the same condition (layer/capture/pipeline.cpp), so both sides agree.
    const bool viewports_changed = had_viewports || t->static_viewports();
    if (had_scissors || t->static_scissors() || (t->in_split() && viewports_changed)) emit_scissors(cb, *t);
    if (viewports_changed) t->note_foveae();
}

void FoveaShading::set_viewports(VkCommandBuffer cb, uint32_t first, uint32_t count,
                                 const VkViewport *viewports, bool with_count) {
    split::CommandTracker *t = tracker(cb);
    if (!t) return;
    t->set_viewports(first, count, viewports, with_count);
    if (!t->static_viewports() && t->secondary()) t->note_foveae();
    if (t->static_viewports() || !t->in_split()) return;
    t->note_foveae();
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
    return it != views_.end() && swapchains_.find_image(it->second.image, image_id, extent);
}

bool FoveaShading::guard_rect(const std::vector<VkImageView> &views, VkExtent2D *extent, VkRect2D *rect,
                              GuardRefusal *refused) const {
    bool any = false;
    int64_t x0 = 0, y0 = 0, x1 = 0, y1 = 0;
    for (VkImageView view : views) {
        if (!view) continue;
        const auto v = views_.find(view);
        if (v == views_.end()) return false;
        const auto it = targets_.find(v->second.image);
        if (it == targets_.end()) return false; // not screen-space: its texels are not the screen's
        const Target &target = it->second;
        // Kept across a resize, it no longer says where the new swapchain's foveae are.
        const VkExtent2D newest = swapchains_.newest_extent();
        if (newest.width != target.screen.width || newest.height != target.screen.height) return false;
        const VkExtent2D e = split::mip_extent(target.extent, v->second.mip);
        const VkExtent2D s = target.screen;
        bool window = false;
        const auto runtime = swapchains_.runtime_swapchains(s, &window);
        std::vector<VkRect2D> foveae;
        if ((window || runtime.empty()) &&
            !split::window_guard_foveae(target.kind, s, eyes_, fovea_, moving_gaze_, &foveae)) {
            refused->extent = e;
            return false;
        }
        // OpenXR eye images of this extent: their eyes' foveae, where the split puts them (each at its
        // view direction, SPLITVK_EYES aside), not a window's. The eyes are those of the views
        // received so far, as at the composite of the frame this pass belongs to (a view is sent at
        // xrEndFrame, before the next frame's passes; a command buffer recorded once and submitted
        // again keeps the guard of its recording, as its split passes keep their scissors).
        for (const SwapchainImages::RuntimeSwapchain &swapchain : runtime) {
            std::vector<VkRect2D> eye_foveae;
            if (!split::runtime_guard_foveae(s, swapchain.layers, *swapchain.eyes, target.kind.eye, fovea_,
                                             moving_gaze_, &eye_foveae)) {
                *refused = {e, true};
                return false;
            }
            foveae.insert(foveae.end(), eye_foveae.begin(), eye_foveae.end());
        }
        VkRect2D r{};
        if (!split::guard_in_target(foveae, target.kind, e, v->second.mip, scissor_.pixels, &r)) return false;
        const int64_t tx0 = r.offset.x, ty0 = r.offset.y;
        const int64_t tx1 = tx0 + r.extent.width, ty1 = ty0 + r.extent.height;
        if (!any) {
            *extent = e;
            x0 = tx0, y0 = ty0, x1 = tx1, y1 = ty1;
        } else {
            x0 = std::min(x0, tx0), y0 = std::min(y0, ty0), x1 = std::max(x1, tx1), y1 = std::max(y1, ty1);
        }
        any = true;
    }
    if (!any || x1 <= x0 || y1 <= y0) return false;
    *rect = {{static_cast<int32_t>(x0), static_cast<int32_t>(y0)},
             {static_cast<uint32_t>(x1 - x0), static_cast<uint32_t>(y1 - y0)}};
    return true;
}

void FoveaShading::enter_guarded(VkCommandBuffer cb, split::CommandTracker &t,
                                 const std::vector<VkImageView> &views, bool emit) {
    VkExtent2D extent{};
    VkRect2D rect{};
    GuardRefusal refused;
    if (!scissor_.guard) return;
    if (const std::vector<uint64_t> &reads = transfer_reads(cb); !reads.empty()) {
        if (!copied_guard_logged_)
            SPLITVK_INFO("SPLITVK_AGENT_SCISSOR=guard:%u: swapchain image 0x%llx is copied out of in a "
                         "command buffer; its passes into screen-space targets are replayed whole",
                         scissor_.pixels, static_cast<unsigned long long>(reads.front()));
        copied_guard_logged_ = true;
        return;
    }
    if (!guard_rect(views, &extent, &rect, &refused)) {
        const VkExtent2D &e = refused.extent;
        if (e.width && refused.runtime && !runtime_unmapped_logged_)
            SPLITVK_INFO(
                "SPLITVK_AGENT_SCISSOR=guard:%u: a target of %ux%u, half an OpenXR eye image's width, "
                "cannot be mapped to its eyes (their sub-images are not the image's halves); "
                "replayed whole",
                scissor_.pixels, e.width, e.height);
        else if (e.width && !refused.runtime && !unmapped_logged_)
            SPLITVK_INFO("SPLITVK_AGENT_SCISSOR=guard:%u: a layered target of %ux%u cannot be mapped to the "
                         "foveae with SPLITVK_EYES=1; replayed whole",
                         scissor_.pixels, e.width, e.height);
        (refused.runtime ? runtime_unmapped_logged_ : unmapped_logged_) |= e.width != 0;
        return;
    }
    if (!guard_logged_)
        SPLITVK_INFO(
            "SPLITVK_AGENT_SCISSOR=guard:%u: scissoring passes into screen-space targets; the first, "
            "%ux%u, to %d,%d %ux%u",
            scissor_.pixels, extent.width, extent.height, rect.offset.x, rect.offset.y, rect.extent.width,
            rect.extent.height);
    guard_logged_ = true;
    guard_rects_[cb] = rect;
    t.begin_split(0, extent, false);
    if (emit) emit_scissors(cb, t);
}

void FoveaShading::enter_split(VkCommandBuffer cb, split::CommandTracker &t, uint64_t image_id,
                               VkExtent2D extent) {
    begin_swapchain_pass(cb, t, image_id, extent);
    if (!copied_out(cb, image_id)) emit_scissors(cb, t); // else the app's scissors are in effect
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
            // Its secondaries are executed as variants scissored for it (pass_scissor); the
            // viewports they draw with give the foveae. Only vkCmdExecuteCommands may follow in
            // the primary: no scissors to set.
            begin_swapchain_pass(cb, *t, image_id, extent);
            t->contents_in_secondaries();
            return;
        }
    if (count) enter_guarded(cb, *t, std::vector<VkImageView>(views, views + count), !secondary);
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
                // As begin_render_pass's: its secondaries are executed as variants scissored for
                // it, the viewports they draw with give the foveae (the client's layer notes the
                // same ones).
                begin_swapchain_pass(cb, *t, image_id, extent);
                t->contents_in_secondaries();
                return;
            }
            return enter_split(cb, *t, image_id, extent);
        }
    }
    std::vector<VkImageView> views;
    for (uint32_t i = 0; i < info.colorAttachmentCount; ++i) {
        views.push_back(info.pColorAttachments[i].imageView);
        if (info.pColorAttachments[i].resolveMode != VK_RESOLVE_MODE_NONE)
            views.push_back(info.pColorAttachments[i].resolveImageView);
    }
    for (const VkRenderingAttachmentInfo *a : {info.pDepthAttachment, info.pStencilAttachment})
        if (a) {
            views.push_back(a->imageView);
            if (a->resolveMode != VK_RESOLVE_MODE_NONE) views.push_back(a->resolveImageView);
        }
    enter_guarded(cb, *t, views, !(info.flags & VK_RENDERING_CONTENTS_SECONDARY_COMMAND_BUFFERS_BIT));
}

void FoveaShading::end_pass(VkCommandBuffer cb) {
    split::CommandTracker *t = tracker(cb);
    if (!t || !t->in_split()) return;
    t->end_split();
    emit_scissors(cb, *t);
}

void FoveaShading::emit_scissors(VkCommandBuffer cb, const split::CommandTracker &t) {
    const bool whole = t.swapchain_pass() && copied_out(cb, t.image());
    const auto guard = t.in_split() && !t.swapchain_pass() ? guard_rects_.find(cb) : guard_rects_.end();
    const auto runtime = t.in_split() && !whole && guard == guard_rects_.end()
                             ? runtime_fovea_areas(t.image(), t.extent())
                             : std::nullopt;
    const auto out = [&](size_t i, const VkRect2D &r) {
        if (!t.in_split() || whole) return r;
        if (guard != guard_rects_.end()) return split::intersect(r, guard->second);
        const VkViewport *v = t.viewport(i);
        // Without viewport i the eye is unknown; the scissor is narrowed once the viewport is set.
        if (runtime) return split::intersect(r, split::runtime_scissor(*runtime, v));
        return split::narrow_to_foveae(r, v, t.extent(), eyes_, fovea_, moving_gaze_);
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
    split::for_each_valid_run(dynamic, values, [&](uint32_t first, uint32_t count, const VkRect2D *r) {
        vk_.CmdSetScissor(cb, first, count, r);
    });
}

void FoveaShading::submitted(uint32_t count, const VkCommandBuffer *command_buffers) {
    if (!enabled_) return;
    for (uint32_t i = 0; i < count; ++i) {
        const auto it = command_buffers_.find(command_buffers[i]);
        if (it == command_buffers_.end()) continue;
        for (const split::DrawnImage &d : it->second.drawn()) {
            split::DrawnImage &entry = drawn_[d.image];
            entry.image = d.image;
            entry.extent = d.extent;
            entry.coverage |= d.coverage;
        }
    }
}

} // namespace splitvk::agent
