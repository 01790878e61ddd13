#include "periphery_scaling.h"

#include "log.h"
#include "split_geometry.h"

#include <algorithm>

namespace splitvk::agent {

void PeripheryScaling::configure(double scale, bool whole_frames) {
    scale_ = scale;
    enabled_ = split::swapchain_pass_draw(split::SplitSide::Agent, ClientRenders::Fovea, false,
                                          whole_frames) == split::PassDraw::Scaled;
}

PeripheryScaling::Frame PeripheryScaling::take_frame(uint64_t image_id) {
    const auto it = frames_.find(image_id);
    if (it == frames_.end()) return Frame::Whole;
    const Writes w = it->second;
    frames_.erase(it);
    if (w.scaled && w.whole) {
        if (!mixed_logged_)
            SPLITVK_WARN("swapped split: a frame drew swapchain image 0x%llx both scaled and at full size; "
                         "its periphery is not sent (the client keeps its last one); said once",
                         static_cast<unsigned long long>(image_id));
        mixed_logged_ = true;
        return Frame::Mixed;
    }
    return w.scaled ? Frame::Scaled : Frame::Whole;
}

void PeripheryScaling::image_view_created(VkImageView view, const VkImageViewCreateInfo &info) {
    if (enabled_ && view) views_[view] = info.image;
}

void PeripheryScaling::image_view_destroyed(VkImageView view) {
    views_.erase(view);
}

void PeripheryScaling::framebuffer_created(VkFramebuffer framebuffer, const VkFramebufferCreateInfo &info) {
    if (!enabled_ || !framebuffer) return;
    auto &views = framebuffers_[framebuffer];
    views.clear();
    if (!(info.flags & VK_FRAMEBUFFER_CREATE_IMAGELESS_BIT) && info.pAttachments)
        views.assign(info.pAttachments, info.pAttachments + info.attachmentCount);
}

void PeripheryScaling::framebuffer_destroyed(VkFramebuffer framebuffer) {
    framebuffers_.erase(framebuffer);
}

const VkGraphicsPipelineCreateInfo *
PeripheryScaling::prepare_pipelines(uint32_t count, const VkGraphicsPipelineCreateInfo *infos) {
    pending_.clear();
    pending_.resize(count);
    for (uint32_t i = 0; i < count; ++i)
        pending_[i] = split::static_viewport_state(infos[i]);
    if (!enabled_) return infos;
    infos_.resize(count);
    storage_.clear();
    storage_.resize(count); // not resized again: infos_ point into it
    for (uint32_t i = 0; i < count; ++i)
        split::add_dynamic_states(infos[i], pending_[i] && pending_[i]->has_viewports,
                                  pending_[i] && pending_[i]->has_scissors, storage_[i], infos_[i]);
    return infos_.data();
}

void PeripheryScaling::pipelines_created(uint32_t count, const VkPipeline *pipelines) {
    // Pipelines with static state are known even before the swapped split began: a scaled pass that
    // binds one, whose state the driver keeps static, cannot be drawn scaled.
    for (uint32_t i = 0; i < count && i < pending_.size(); ++i)
        if (pending_[i] && pipelines[i]) pipelines_[pipelines[i]] = {std::move(pending_[i]), enabled_};
    pending_.clear();
}

void PeripheryScaling::pipeline_destroyed(VkPipeline pipeline) {
    pipelines_.erase(pipeline);
}

PeripheryScaling::Recording *PeripheryScaling::recording(VkCommandBuffer cb) {
    if (!enabled_) return nullptr;
    return &recordings_[cb];
}

void PeripheryScaling::begin_command_buffer(VkCommandBuffer cb, const VkCommandBufferBeginInfo *info) {
    Recording *r = recording(cb);
    if (!r) return;
    *r = Recording{};
    r->continues_pass =
        info && (info->flags & VK_COMMAND_BUFFER_USAGE_RENDER_PASS_CONTINUE_BIT) && info->pInheritanceInfo;
    const auto variant = pending_variants_.find(cb);
    if (variant == pending_variants_.end()) return;
    // A variant: inside its scaled pass from its first command, as a primary is after the pass's
    // begin. What it writes counts for the primary's pass already.
    r->tracker.begin_split(variant->second.image, variant->second.extent);
    r->scaled_pass = true;
    pending_variants_.erase(variant);
}

bool PeripheryScaling::continues_pass(VkCommandBuffer cb) const {
    const auto it = enabled_ ? recordings_.find(cb) : recordings_.end();
    return it != recordings_.end() && it->second.continues_pass;
}

std::optional<FoveaShading::PassScissor> PeripheryScaling::pass_variant(VkCommandBuffer primary) const {
    const auto it = enabled_ ? recordings_.find(primary) : recordings_.end();
    if (it == recordings_.end() || !it->second.scaled_pass || !it->second.secondary_contents)
        return std::nullopt;
    FoveaShading::PassScissor key;
    key.swapchain = true;
    key.scaled = true;
    key.image = it->second.tracker.image();
    key.extent = it->second.tracker.extent();
    return key;
}

void PeripheryScaling::begin_variant(VkCommandBuffer variant, uint64_t image_id, VkExtent2D extent) {
    if (!variant_logged_)
        SPLITVK_INFO("swapped split: secondaries executed in a scaled pass of %ux%u: recorded again, scaled "
                     "for the pass",
                     extent.width, extent.height);
    variant_logged_ = true;
    pending_variants_[variant] = {image_id, extent};
}

void PeripheryScaling::unscaled_secondary(VkCommandBuffer primary) {
    Recording *r = recording(primary);
    if (!r || !r->scaled_pass) return;
    log_whole_once("a secondary command buffer could not be recorded again for a scaled pass");
    r->writes[r->tracker.image()].whole = true;
}

void PeripheryScaling::log_whole_once(const char *why) {
    if (!whole_logged_)
        SPLITVK_INFO("swapped split: %s; its frames' periphery is downsampled from the full-size picture",
                     why);
    whole_logged_ = true;
}

bool PeripheryScaling::window_target(const VkImageView *views, size_t count, uint64_t *image_id,
                                     VkExtent2D *extent) const {
    for (size_t i = 0; i < count; ++i) {
        const auto v = views_.find(views[i]);
        if (v == views_.end() || !swapchains_.find_image(v->second, image_id, extent)) continue;
        return split::swapchain_pass_draw(split::SplitSide::Agent, ClientRenders::Fovea,
                                          swapchains_.runtime_image(*image_id)) == split::PassDraw::Scaled;
    }
    return false;
}

std::optional<VkRect2D> PeripheryScaling::enter(VkCommandBuffer cb, Recording &r, uint64_t image_id,
                                                VkExtent2D extent, const VkRect2D &area,
                                                bool secondary_contents) {
    if (!scaled_logged_) {
        const VkExtent2D s = split::scaled_extent(extent, scale_);
        SPLITVK_INFO("swapped split: passes into %ux%u swapchain images are drawn at %ux%u, the periphery",
                     extent.width, extent.height, s.width, s.height);
    }
    scaled_logged_ = true;
    r.tracker.begin_split(image_id, extent);
    r.scaled_pass = true;
    r.writes[image_id].scaled = true;
    r.secondary_contents = secondary_contents;
    // Secondaries inherit no state: theirs is set in their variants.
    if (!secondary_contents) {
        emit_viewports(cb, r);
        emit_scissors(cb, r);
    }
    return split::scaled_pass_rect(area, extent, scale_);
}

std::optional<VkRect2D> PeripheryScaling::begin_render_pass(VkCommandBuffer cb,
                                                            const VkRenderPassBeginInfo &begin,
                                                            bool secondary_contents) {
    Recording *r = recording(cb);
    if (!r) return std::nullopt;
    const VkImageView *views = nullptr;
    size_t count = 0;
    for (auto *p = static_cast<const VkBaseInStructure *>(begin.pNext); p; p = p->pNext)
        if (p->sType == VK_STRUCTURE_TYPE_RENDER_PASS_ATTACHMENT_BEGIN_INFO) {
            const auto *a = reinterpret_cast<const VkRenderPassAttachmentBeginInfo *>(p);
            views = a->pAttachments;
            count = a->attachmentCount;
        }
    if (!views)
        if (const auto fb = framebuffers_.find(begin.framebuffer); fb != framebuffers_.end()) {
            views = fb->second.data();
            count = fb->second.size();
        }
    uint64_t image_id = 0;
    VkExtent2D extent{};
    if (!window_target(views, count, &image_id, &extent)) return std::nullopt;
    return enter(cb, *r, image_id, extent, begin.renderArea, secondary_contents);
}

std::optional<VkRect2D> PeripheryScaling::begin_rendering(VkCommandBuffer cb, const VkRenderingInfo &info) {
    Recording *r = recording(cb);
    if (!r) return std::nullopt;
    // A resumed rendering continues a suspended one, scaled alike.
    std::vector<VkImageView> views;
    for (uint32_t i = 0; i < info.colorAttachmentCount; ++i) {
        views.push_back(info.pColorAttachments[i].imageView);
        if (info.pColorAttachments[i].resolveMode != VK_RESOLVE_MODE_NONE)
            views.push_back(info.pColorAttachments[i].resolveImageView);
    }
    uint64_t image_id = 0;
    VkExtent2D extent{};
    if (!window_target(views.data(), views.size(), &image_id, &extent)) return std::nullopt;
    return enter(cb, *r, image_id, extent, info.renderArea,
                 info.flags & VK_RENDERING_CONTENTS_SECONDARY_COMMAND_BUFFERS_BIT);
}

void PeripheryScaling::end_pass(VkCommandBuffer cb) {
    Recording *r = recording(cb);
    if (!r || !r->scaled_pass) return;
    r->tracker.end_split();
    r->scaled_pass = false;
    r->secondary_contents = false;
    emit_viewports(cb, *r);
    emit_scissors(cb, *r);
}

void PeripheryScaling::bind_pipeline(VkCommandBuffer cb, VkPipelineBindPoint bind_point,
                                     VkPipeline pipeline) {
    Recording *r = bind_point == VK_PIPELINE_BIND_POINT_GRAPHICS ? recording(cb) : nullptr;
    if (!r) return;
    const auto it = pipelines_.find(pipeline);
    const bool had_viewports = r->tracker.static_viewports(), had_scissors = r->tracker.static_scissors();
    if (it != pipelines_.end() && !it->second.dynamic) {
        // Created before the swapped split began: its static state stays in the driver's pipeline.
        r->tracker.bind_pipeline(nullptr);
        if (r->scaled_pass) {
            log_whole_once("a pipeline with static viewports was created before the swapped split began");
            r->writes[r->tracker.image()].whole = true;
        }
        return;
    }
    r->tracker.bind_pipeline(it == pipelines_.end() ? nullptr : it->second.statics);
    // A pipeline's static state, made dynamic, is set at its bind; the dynamic state in effect again
    // after it inside a scaled pass (a bind of a pipeline without static state leaves the dynamic
    // state the driver has, which a scaled pass set scaled already).
    if (r->tracker.static_viewports() || (had_viewports && r->scaled_pass)) emit_viewports(cb, *r);
    if (r->tracker.static_scissors() || (had_scissors && r->scaled_pass)) emit_scissors(cb, *r);
}

void PeripheryScaling::set_viewports(VkCommandBuffer cb, uint32_t first, uint32_t count,
                                     const VkViewport *viewports, bool with_count) {
    Recording *r = recording(cb);
    if (!r) return;
    r->tracker.set_viewports(first, count, viewports, with_count);
    if (r->scaled_pass && !r->tracker.static_viewports()) emit_viewports(cb, *r);
}

void PeripheryScaling::set_scissors(VkCommandBuffer cb, uint32_t first, uint32_t count,
                                    const VkRect2D *scissors, bool with_count) {
    Recording *r = recording(cb);
    if (!r) return;
    r->tracker.set_scissors(first, count, scissors, with_count);
    if (r->scaled_pass && !r->tracker.static_scissors()) emit_scissors(cb, *r);
}

std::optional<std::vector<VkClearRect>> PeripheryScaling::clear_rects(VkCommandBuffer cb, uint32_t count,
                                                                      const VkClearRect *rects) const {
    const auto it = enabled_ ? recordings_.find(cb) : recordings_.end();
    if (it == recordings_.end() || !it->second.scaled_pass) return std::nullopt;
    std::vector<VkClearRect> out;
    for (uint32_t i = 0; i < count; ++i) {
        VkClearRect r = rects[i];
        r.rect = split::scaled_pass_rect(r.rect, it->second.tracker.extent(), scale_);
        // A rect clamped away entirely is invalid to replay (clear rects must not be empty).
        if (r.rect.extent.width && r.rect.extent.height) out.push_back(r);
    }
    return out;
}

bool PeripheryScaling::scale_blit(VkCommandBuffer cb, VkImage dst, uint32_t count,
                                  std::array<VkOffset3D, 2> *offsets) {
    Recording *r = recording(cb);
    uint64_t image_id = 0;
    VkExtent2D extent{};
    if (!r || !swapchains_.find_image(dst, &image_id, &extent) ||
        split::swapchain_pass_draw(split::SplitSide::Agent, ClientRenders::Fovea,
                                   swapchains_.runtime_image(image_id)) != split::PassDraw::Scaled)
        return false;
    const VkExtent2D scaled = split::scaled_extent(extent, scale_);
    const split::AxisScale axis = split::axis_scale(extent, scaled);
    for (uint32_t i = 0; i < count; ++i) {
        // A blit's corners may be in either order (a mirrored blit): each scaled on its own, rounded
        // to the nearest pixel so that both ends of a region keep its orientation.
        for (VkOffset3D &o : offsets[i]) {
            o.x = std::clamp<int32_t>(static_cast<int32_t>(o.x * axis.x + 0.5), 0, int32_t(scaled.width));
            o.y = std::clamp<int32_t>(static_cast<int32_t>(o.y * axis.y + 0.5), 0, int32_t(scaled.height));
        }
    }
    r->writes[image_id].scaled = true;
    return true;
}

void PeripheryScaling::whole_write(VkCommandBuffer cb, VkImage dst) {
    Recording *r = recording(cb);
    uint64_t image_id = 0;
    VkExtent2D extent{};
    if (!r || !swapchains_.find_image(dst, &image_id, &extent)) return;
    log_whole_once("a copy or resolve writes a swapchain image");
    r->writes[image_id].whole = true;
}

void PeripheryScaling::execute_commands(VkCommandBuffer cb, uint32_t count,
                                        const VkCommandBuffer *secondaries) {
    Recording *r = recording(cb);
    if (!r) return;
    for (uint32_t i = 0; i < count; ++i) {
        const auto it = recordings_.find(secondaries[i]);
        if (it == recordings_.end()) continue;
        for (const auto &[image, w] : it->second.writes) {
            r->writes[image].scaled |= w.scaled;
            r->writes[image].whole |= w.whole;
        }
    }
}

void PeripheryScaling::submitted(uint32_t count, const VkCommandBuffer *command_buffers) {
    if (!enabled_) return;
    for (uint32_t i = 0; i < count; ++i) {
        const auto it = recordings_.find(command_buffers[i]);
        if (it == recordings_.end()) continue;
        for (const auto &[image, w] : it->second.writes) {
            frames_[image].scaled |= w.scaled;
            frames_[image].whole |= w.whole;
        }
    }
}

void PeripheryScaling::emit_viewports(VkCommandBuffer cb, const Recording &r) {
    const split::CommandTracker &t = r.tracker;
    const auto out = [&](const VkViewport &v) {
        return r.scaled_pass ? split::scaled_pass_viewport(v, t.extent(), scale_) : v;
    };
    std::vector<VkViewport> values;
    if (t.static_viewports()) {
        for (const VkViewport &v : t.pipeline()->viewports)
            values.push_back(out(v));
        vk_.CmdSetViewport(cb, 0, static_cast<uint32_t>(values.size()), values.data());
        return;
    }
    const auto &dynamic = t.dynamic_viewports();
    if (dynamic.empty()) return;
    for (const VkViewport &v : dynamic.values)
        values.push_back(out(v));
    if (dynamic.with_count) {
        if (vk_.CmdSetViewportWithCount)
            vk_.CmdSetViewportWithCount(cb, static_cast<uint32_t>(values.size()), values.data());
        return;
    }
    split::for_each_valid_run(dynamic, values, [&](uint32_t first, uint32_t count, const VkViewport *v) {
        vk_.CmdSetViewport(cb, first, count, v);
    });
}

void PeripheryScaling::emit_scissors(VkCommandBuffer cb, const Recording &r) {
    const split::CommandTracker &t = r.tracker;
    const auto out = [&](const VkRect2D &s) {
        return r.scaled_pass ? split::scaled_pass_rect(s, t.extent(), scale_) : s;
    };
    std::vector<VkRect2D> values;
    if (t.static_scissors()) {
        for (const VkRect2D &s : t.pipeline()->scissors)
            values.push_back(out(s));
        vk_.CmdSetScissor(cb, 0, static_cast<uint32_t>(values.size()), values.data());
        return;
    }
    const auto &dynamic = t.dynamic_scissors();
    if (dynamic.empty()) return;
    for (const VkRect2D &s : dynamic.values)
        values.push_back(out(s));
    if (dynamic.with_count) {
        if (vk_.CmdSetScissorWithCount)
            vk_.CmdSetScissorWithCount(cb, static_cast<uint32_t>(values.size()), values.data());
        return;
    }
    split::for_each_valid_run(dynamic, values, [&](uint32_t first, uint32_t count, const VkRect2D *s) {
        vk_.CmdSetScissor(cb, first, count, s);
    });
}

} // namespace splitvk::agent
