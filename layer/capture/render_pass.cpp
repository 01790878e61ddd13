// Render pass instances and dynamic renderings, and their rewrite (render_pass.h).

#include "capture/render_pass.h"

#include "capture/command_buffer.h"
#include "capture/fovea_mask.h"
#include "capture/resource.h"
#include "capture/screen_space.h"
#include "capture/session.h"
#include "capture/split.h"
#include "core/gpu_timing.h"
#include "core/image.h"
#include "core/object_map.h"
#include "core/swapchain.h"
#include "core/vk_util.h"
#include "layer_entry_points.h"
#include "log.h"
#include "split_geometry.h"

#include <algorithm>
#include <mutex>
#include <optional>
#include <set>
#include <utility>
#include <vector>

namespace splitvk {
namespace {

struct ImageViewState {
    VkImage image = VK_NULL_HANDLE;
    VkImageSubresourceRange range{};       // what a render pass's final layout applies to
    VkFormat format = VK_FORMAT_UNDEFINED; // what a dynamic rendering's secondaries inherit
};
struct FramebufferState {
    std::vector<VkImageView> attachments; // empty when imageless
    VkExtent2D extent{};                  // the app's
    bool scaled = false;                  // created at the scaled size: it holds a screen-space target
};

} // namespace

struct RenderPassTable {
    ObjectMap<VkImageView, ImageViewState> views;
    ObjectMap<VkFramebuffer, FramebufferState> framebuffers;
    // The target each render pass was last begun on: a secondary that continues a pass without
    // naming its framebuffer (engines record them before they know the swapchain image) is
    // recorded for that target's scaling. Engines begin the pass before recording its secondaries
    // for the frame. Forgotten when the render pass is destroyed or its handle value created anew
    // (forget_render_pass).
    split::PassPredictions pass_predictions;
    // The latest target of each kind of dynamic rendering with secondary contents
    // (split::rendering_key): their secondaries name only the formats and view mask they inherit.
    split::PassPredictions rendering_predictions;
};

std::shared_ptr<RenderPassTable> make_render_pass_table() {
    return std::make_shared<RenderPassTable>();
}

namespace {

// The extent of `view`'s image when it is an image of a live composable swapchain.
bool split_target(const DeviceState &dev, VkImageView view, VkImage *image, VkExtent2D *extent,
                  bool *runtime) {
    const ImageViewState *v = view ? dev.render_passes->views.find(view) : nullptr;
    if (!v || !swapchain_image_extent(dev, v->image, extent, runtime)) return false;
    *image = v->image;
    return true;
}

bool find_target(const DeviceState &dev, uint32_t count, const VkImageView *views, VkImage *image,
                 VkExtent2D *extent, bool *runtime) {
    for (uint32_t i = 0; i < count; ++i)
        if (split_target(dev, views[i], image, extent, runtime)) return true;
    return false;
}

bool any_screen_space(const DeviceState &dev, std::span<const VkImageView> views) {
    for (VkImageView view : views) {
        const ImageViewState *v = view ? dev.render_passes->views.find(view) : nullptr;
        if (v && is_screen_space(dev, v->image)) return true;
    }
    return false;
}

// What a render pass instance or dynamic rendering draws into, as the split sees it.
struct PassTarget {
    bool swapchain = false; // a swapchain image of a composable swapchain, while splitting
    bool runtime = false;   // that swapchain is an OpenXR runtime's (swapchain.h)
    bool scaled = false;    // a screen-space target among its attachments
    // SPLITVK_CLIENT_RENDERS=fovea (split_cutting): a pass into a window's swapchain image keeps its
    // area and is cut to the foveae; a pass into screen-space targets only is cut to `guard`.
    bool cut = false;
    std::optional<VkRect2D> guard;
    // A cut pass into an OpenXR runtime's eye image: every place its foveae can be, and the version
    // of the eyes they were placed by (CommandTracker::cut_runtime_pass).
    std::vector<split::LayerFovea> runtime_areas;
    uint64_t eyes_version = 0;
    VkImage image = VK_NULL_HANDLE;
    VkExtent2D extent{}; // the swapchain's, else the full extent its scaled areas are relative to
    bool split() const { return swapchain || scaled || guard; }
};

// SPLITVK_CLIENT_RENDERS=fovea: a pass into an OpenXR runtime's eye image is cut to the places its
// foveae can be: each eye's fovea at its view direction (split::runtime_fovea_areas, as the agent's
// scissors cut them in the paper's split), grown by the seam's band, which the compositor blends
// across (split::seam_rect, the window's rule). False, with the pass rendered whole, where its
// image's composite could not keep them: a layered image (multiview: the compositor's swapped
// composite is one layer's), and under SPLITVK_VERIFY, which reads the image back as drawn.
bool cut_runtime_target(const DeviceState &dev, PassTarget &t) {
    VkSwapchainKHR member = VK_NULL_HANDLE;
    read_image(dev, t.image, [&](const ImageState &state) { member = state.swapchain; });
    const SwapchainState *swapchain = member ? find_swapchain(dev, member) : nullptr;
    if (!swapchain || !swapchain->runtime) return false;
    if (swapchain->array_layers > 1) {
        static std::once_flag logged;
        std::call_once(logged, [] {
            SPLITVK_INFO("swapped split: passes into layered OpenXR eye images (multiview) are not cut: "
                         "they render whole, and the agent sends no periphery for them");
        });
        return false;
    }
    if (dev.session->verify()) {
        static std::once_flag logged;
        std::call_once(logged, [] {
            SPLITVK_INFO("swapped split: SPLITVK_VERIFY compares OpenXR eye images as drawn: their passes "
                         "are not cut");
        });
        return false;
    }
    const Settings &settings = split_settings();
    const RuntimeEyes eyes = runtime_eyes(*swapchain);
    t.runtime_areas = split::runtime_fovea_areas(swapchain->extent, swapchain->array_layers, eyes.eyes,
                                                 settings.fovea, settings.gaze != GazeMode::Fixed);
    for (split::LayerFovea &area : t.runtime_areas)
        area.rect = split::seam_rect(area.rect, swapchain->extent, settings.seam.feather);
    t.eyes_version = eyes.version;
    return true;
}

// The guard of a pass whose attachments are all screen-space targets kept full size in fovea mode
// (ImageState::guard_kind): the union of split::window_guard_rect over its views, the agent's
// guard:N rule with SPLITVK_CLIENT_GUARD. None, so that the pass runs whole, where an attachment is
// anything else, a target was classified against an older swapchain extent, or the guard is `full`.
std::optional<VkRect2D> guard_of(const DeviceState &dev, std::span<const VkImageView> views) {
    const Settings &settings = split_settings();
    if (settings.client_guard.full || views.empty()) return std::nullopt;
    VkExtent2D screen{};
    if (!screen_extent(dev, &screen)) return std::nullopt;
    std::optional<VkRect2D> guard;
    for (VkImageView view : views) {
        if (!view) continue;
        const ImageViewState *v = dev.render_passes->views.find(view);
        if (!v) return std::nullopt;
        std::optional<split::TargetClass> kind;
        VkExtent2D classified{}, extent{};
        read_image(dev, v->image, [&](const ImageState &state) {
            kind = state.guard_kind;
            classified = state.guard_screen;
            extent = {state.extent.width, state.extent.height};
        });
        if (!kind || classified.width != screen.width || classified.height != screen.height)
            return std::nullopt;
        const uint32_t mip = v->range.baseMipLevel;
        VkRect2D r{};
        if (!split::window_guard_rect(*kind, screen, split::mip_extent(extent, mip), mip, settings.eyes,
                                      settings.fovea, settings.gaze != GazeMode::Fixed,
                                      settings.client_guard.pixels, &r))
            return std::nullopt;
        if (!guard) {
            guard = r;
            continue;
        }
        const int64_t x0 = std::min<int64_t>(guard->offset.x, r.offset.x);
        const int64_t y0 = std::min<int64_t>(guard->offset.y, r.offset.y);
        const int64_t x1 = std::max<int64_t>(int64_t{guard->offset.x} + guard->extent.width,
                                             int64_t{r.offset.x} + r.extent.width);
        const int64_t y1 = std::max<int64_t>(int64_t{guard->offset.y} + guard->extent.height,
                                             int64_t{r.offset.y} + r.extent.height);
        guard = VkRect2D{{int32_t(x0), int32_t(y0)}, {uint32_t(x1 - x0), uint32_t(y1 - y0)}};
    }
    if (guard) {
        static std::once_flag logged;
        std::call_once(logged, [&] {
            SPLITVK_INFO("SPLITVK_CLIENT_GUARD=guard:%u: cutting passes into screen-space targets to the "
                         "foveae grown by %u pixels; the first to %d,%d %ux%u (exact only while the guard "
                         "covers every filter's reach towards the foveae: blurs compound; storage writes "
                         "see only the guard)",
                         settings.client_guard.pixels, settings.client_guard.pixels, guard->offset.x,
                         guard->offset.y, guard->extent.width, guard->extent.height);
        });
    }
    return guard;
}

// Fovea mode: a swapchain pass is cut (a runtime's runs whole), any other may be guarded.
void decide_cut(const DeviceState &dev, PassTarget &t, std::span<const VkImageView> views) {
    if (!split_cutting(dev)) {
        // The swapped split with no agent to render its periphery: whole, not scaled (split_swapped).
        if (split_swapped(dev)) t.swapchain = false;
        return;
    }
    const split::PassDraw draw =
        split::swapchain_pass_draw(split::SplitSide::Client, ClientRenders::Fovea, t.runtime);
    if (t.swapchain && t.runtime && draw == split::PassDraw::Cut) {
        t.cut = cut_runtime_target(dev, t);
        if (!t.cut) t.swapchain = false;
        return;
    }
    if (t.swapchain && draw == split::PassDraw::Whole) {
        t.swapchain = false;
        return;
        return;
    }
    t.cut = t.swapchain && draw == split::PassDraw::Cut;
    if (!t.swapchain && !t.scaled) t.guard = guard_of(dev, views);
}

std::span<const VkImageView> begin_views(const VkRenderPassBeginInfo *begin, const FramebufferState *fb) {
    if (const auto *info = find_in_chain<VkRenderPassAttachmentBeginInfo>(
            begin->pNext, VK_STRUCTURE_TYPE_RENDER_PASS_ATTACHMENT_BEGIN_INFO))
        return {info->pAttachments, info->attachmentCount};
    if (fb) return fb->attachments;
    return {};
}

PassTarget pass_target(DeviceState &dev, const VkRenderPassBeginInfo *begin) {
    PassTarget t;
    const FramebufferState *fb = dev.render_passes->framebuffers.find(begin->framebuffer);
    if (!fb) return t;
    const std::span<const VkImageView> views = begin_views(begin, fb);
    t.swapchain = split_recording(dev) && find_target(dev, static_cast<uint32_t>(views.size()), views.data(),
                                                      &t.image, &t.extent, &t.runtime);
    t.scaled = fb->scaled;
    if (!t.swapchain) t.extent = fb->extent;
    decide_cut(dev, t, views);
    return t;
}

PassTarget rendering_target(DeviceState &dev, const VkRenderingInfo *info) {
    PassTarget t;
    const bool splitting = split_recording(dev);
    const auto consider = [&](VkImageView view) {
        if (!view) return;
        if (splitting && !t.swapchain && split_target(dev, view, &t.image, &t.extent, &t.runtime))
            t.swapchain = true;
        const ImageViewState *v = dev.render_passes->views.find(view);
        VkExtent2D full{};
        if (v && screen_space_extent(dev, v->image, &full)) {
            if (!t.scaled && !t.swapchain) t.extent = full;
            t.scaled = true;
        }
    };
    const auto attachment = [&](const VkRenderingAttachmentInfo *a) {
        if (!a) return;
        consider(a->imageView);
        if (a->resolveMode != VK_RESOLVE_MODE_NONE) consider(a->resolveImageView);
    };
    for (uint32_t i = 0; i < info->colorAttachmentCount; ++i)
        attachment(&info->pColorAttachments[i]);
    attachment(info->pDepthAttachment);
    attachment(info->pStencilAttachment);
    if (!t.swapchain && t.scaled) {
        // The render area's own full extent: a pass into a half-size target names a half-size area.
        t.extent.width = std::max(t.extent.width, info->renderArea.extent.width);
        t.extent.height = std::max(t.extent.height, info->renderArea.extent.height);
    }
    std::vector<VkImageView> views;
    const auto add = [&](const VkRenderingAttachmentInfo *a) {
        if (!a || !a->imageView) return;
        views.push_back(a->imageView);
        if (a->resolveMode != VK_RESOLVE_MODE_NONE) views.push_back(a->resolveImageView);
    };
    for (uint32_t i = 0; i < info->colorAttachmentCount; ++i)
        add(&info->pColorAttachments[i]);
    add(info->pDepthAttachment);
    add(info->pStencilAttachment);
    decide_cut(dev, t, views);
    if (t.guard) t.extent = info->renderArea.extent;
    return t;
}

// Secondaries of a pass into an OpenXR eye image run whole: they are recorded before the pass that
// executes them says which eye image it draws into, so they could not be cut by its eyes.
void whole_if_runtime_cut(PassTarget &t) {
    if (!t.cut || !t.runtime) return;
    t.cut = false;
    t.swapchain = false;
    t.runtime_areas.clear();
}

// The swapchain sizes the split line was given for: once per size, so that a resize says what the
// new size's periphery is, and two windows presenting in turn do not repeat it every frame.
std::mutex g_logged_extents_mutex;
std::set<std::pair<uint32_t, uint32_t>> g_logged_extents;

void log_split_extent_once(VkExtent2D extent, bool cut) {
    {
        std::lock_guard lock(g_logged_extents_mutex);
        if (!g_logged_extents.emplace(extent.width, extent.height).second) return;
    }
    if (cut) {
        SPLITVK_INFO("swapped split: passes into %ux%u swapchain images are cut to the foveae; the agent "
                     "renders the periphery",
                     extent.width, extent.height);
        return;
    }
    const VkExtent2D periphery = split::scaled_extent(extent, split_settings().scale);
    SPLITVK_INFO("split: passes into %ux%u swapchain images render their periphery at %ux%u", extent.width,
                 extent.height, periphery.width, periphery.height);
}

void enter_split(DeviceState &dev, VkCommandBuffer cb, split::CommandTracker &tracker,
                 const PassTarget &target) {
    if (target.swapchain) log_split_extent_once(target.extent, target.cut);
    tracker.begin_split(codec::handle_value(target.image), target.extent, target.swapchain);
    if (target.cut && target.runtime)
        tracker.cut_runtime_pass(target.runtime_areas, target.eyes_version);
    else if (target.cut || target.guard)
        tracker.cut_pass(target.guard);
    emit_viewports(dev, cb, tracker);
    emit_scissors(dev, cb, tracker);
}

void leave_split(DeviceState &dev, VkCommandBuffer cb) {
    split::CommandTracker *tracker = split_tracker(cb);
    if (!tracker || !tracker->in_split()) return;
    // The periphery's GPU time runs from the first scaled pass to the end of the swapchain's.
    if (tracker->swapchain_pass())
        if (CommandTiming *timing = command_buffer_timing(cb)) time_split_pass_ended(dev, cb, *timing);
    tracker->end_split();
    emit_viewports(dev, cb, *tracker);
    emit_scissors(dev, cb, *tracker);
}

VkRect2D scaled_area(const VkRect2D &area, VkExtent2D extent) {
    return split::scaled_pass_rect(area, extent, split_settings().scale);
}

// The images of a render pass instance's attachments, for their final layouts (resource.h).
void note_attachments(DeviceState &dev, VkCommandBuffer cb, const VkRenderPassBeginInfo *begin) {
    std::span<const VkImageView> views;
    if (const auto *info = find_in_chain<VkRenderPassAttachmentBeginInfo>(
            begin->pNext, VK_STRUCTURE_TYPE_RENDER_PASS_ATTACHMENT_BEGIN_INFO))
        views = {info->pAttachments, info->attachmentCount};
    const FramebufferState *fb = dev.render_passes->framebuffers.find(begin->framebuffer);
    if (views.empty() && fb) views = fb->attachments;
    std::vector<AttachmentImage> attachments;
    for (VkImageView view : views) {
        const ImageViewState *v = dev.render_passes->views.find(view);
        attachments.push_back(v ? AttachmentImage{v->image, v->range} : AttachmentImage{});
    }
    note_render_pass_begin(dev, cb, begin->renderPass, attachments);
}

void end_render_pass(DeviceState &dev, VkCommandBuffer cb) {
    note_render_pass_end(cb);
    leave_split(dev, cb);
}

// A split pass or rendering whose contents are secondary command buffers. Its secondaries were
// recorded for the latest target of its render pass or kind of rendering (begin_secondary), and
// their viewports give its foveae, on the agent alike (server-agent/fovea_shading.cpp). Only
// vkCmdExecuteCommands may follow inside it: no state to set, and its periphery is timed from just
// before it begins (top of pipe; the reset is outside it as for any pass) to its end.
template <class Begin>
void begin_split_of_secondaries(DeviceState &dev, VkCommandBuffer cb, split::CommandTracker &tracker,
                                const PassTarget &target, Begin &&begin) {
    if (CommandTiming *timing = command_buffer_timing(cb)) {
        time_before_split_pass(dev, cb, *timing);
        time_split_pass_begun(dev, cb, *timing);
    }
    begin();
    if (target.swapchain) log_split_extent_once(target.extent, target.cut);
    tracker.begin_split(codec::handle_value(target.image), target.extent, target.swapchain);
    if (target.cut) tracker.cut_pass();
    tracker.contents_in_secondaries();
}

template <class Down>
void begin_render_pass(DeviceState &dev, VkCommandBuffer cb, const VkRenderPassBeginInfo *begin,
                       bool secondary, Down &&down) {
    note_attachments(dev, cb, begin);
    PassTarget target = pass_target(dev, begin);
    // Secondaries of a guarded pass run whole in this slice.
    if (secondary) target.guard.reset();
    if (secondary) whole_if_runtime_cut(target);
    dev.render_passes->pass_predictions.note_begin(
        codec::handle_value(begin->renderPass),
        {target.swapchain || target.scaled, target.extent, target.cut});
    split::CommandTracker *tracker = target.split() ? split_tracker(cb) : nullptr;
    if (!tracker && !target.scaled) return down(begin);
    VkRenderPassBeginInfo scaled = *begin;
    // A cut pass keeps the app's render area.
    if (!target.cut && !target.guard) scaled.renderArea = scaled_area(begin->renderArea, target.extent);
    if (!tracker) return down(&scaled);
    if (!secondary) {
        CommandTiming *timing = command_buffer_timing(cb);
        if (timing) time_before_split_pass(dev, cb, *timing);
        down(&scaled);
        if (timing) time_split_pass_begun(dev, cb, *timing);
        enter_split(dev, cb, *tracker, target);
        if (target.swapchain && !target.runtime && !target.cut)
            mask_foveae(dev, cb, *tracker, *begin, target.extent, scaled.renderArea);
        return;
    }
    begin_split_of_secondaries(dev, cb, *tracker, target, [&] { down(&scaled); });
}

VkFormat view_format(const DeviceState &dev, VkImageView view) {
    const ImageViewState *v = view ? dev.render_passes->views.find(view) : nullptr;
    return v ? v->format : VK_FORMAT_UNDEFINED;
}

uint64_t rendering_key(const DeviceState &dev, const VkRenderingInfo &info) {
    std::vector<VkFormat> colours;
    for (uint32_t i = 0; i < info.colorAttachmentCount; ++i)
        colours.push_back(view_format(dev, info.pColorAttachments[i].imageView));
    return split::rendering_key(
        colours.data(), info.colorAttachmentCount,
        info.pDepthAttachment ? view_format(dev, info.pDepthAttachment->imageView) : VK_FORMAT_UNDEFINED,
        info.pStencilAttachment ? view_format(dev, info.pStencilAttachment->imageView) : VK_FORMAT_UNDEFINED,
        info.viewMask);
}

template <class Down>
void begin_rendering(DeviceState &dev, VkCommandBuffer cb, const VkRenderingInfo *info, Down &&down) {
    PassTarget target = rendering_target(dev, info);
    const bool secondary = info->flags & VK_RENDERING_CONTENTS_SECONDARY_COMMAND_BUFFERS_BIT;
    // Secondaries of a guarded rendering run whole in this slice.
    if (secondary) target.guard.reset();
    if (secondary) whole_if_runtime_cut(target);
    // Noted unscaled too, so that a kind of rendering that stops being scaled predicts so.
    if (secondary)
        dev.render_passes->rendering_predictions.note_begin(
            rendering_key(dev, *info), {target.swapchain || target.scaled, target.extent, target.cut});
    split::CommandTracker *tracker = target.split() ? split_tracker(cb) : nullptr;
    if (!tracker && !target.scaled) return down(info);
    VkRenderingInfo scaled = *info;
    // A cut rendering keeps the app's render area.
    if (!target.cut && !target.guard) scaled.renderArea = scaled_area(info->renderArea, target.extent);
    // A resumed rendering continues the suspended one, which was scaled alike.
    if (!tracker) return down(&scaled);
    if (secondary) return begin_split_of_secondaries(dev, cb, *tracker, target, [&] { down(&scaled); });
    CommandTiming *timing = command_buffer_timing(cb);
    if (timing) time_before_split_pass(dev, cb, *timing);
    down(&scaled);
    if (timing) time_split_pass_begun(dev, cb, *timing);
    enter_split(dev, cb, *tracker, target);
    if (target.swapchain && !target.runtime && !target.cut)
        mask_foveae(dev, cb, *tracker, *info, target.extent, scaled.renderArea);
}

} // namespace

VkImage image_of_view(const DeviceState &dev, VkImageView view) {
    const ImageViewState *v = view ? dev.render_passes->views.find(view) : nullptr;
    return v ? v->image : VK_NULL_HANDLE;
}

bool swapchain_image_extent(const DeviceState &dev, VkImage image, VkExtent2D *extent, bool *runtime) {
    VkSwapchainKHR member = VK_NULL_HANDLE;
    read_image(dev, image, [&](const ImageState &state) { member = state.swapchain; });
    const SwapchainState *swapchain = member ? find_swapchain(dev, member) : nullptr;
    // The swapchain's handle value may have been reused since: check the image still belongs.
    if (!swapchain || !swapchain_composable(*swapchain)) return false;
    for (VkImage i : swapchain->images)
        if (i == image) {
            *extent = swapchain->extent;
            if (runtime) *runtime = swapchain->runtime;
            return true;
        }
    return false;
}

void begin_secondary(DeviceState &dev, VkCommandBuffer cb, const VkCommandBufferBeginInfo &begin) {
    if (!(begin.flags & VK_COMMAND_BUFFER_USAGE_RENDER_PASS_CONTINUE_BIT) || !begin.pInheritanceInfo) return;
    split::CommandTracker *tracker = split_tracker(cb);
    if (!tracker) return;
    tracker->begin_secondary();
    const VkCommandBufferInheritanceInfo &inheritance = *begin.pInheritanceInfo;
    split::PassPrediction target;
    if (inheritance.renderPass == VK_NULL_HANDLE) {
        // Dynamic rendering: predicted from the formats and view mask it inherits.
        const auto *rendering = find_in_chain<VkCommandBufferInheritanceRenderingInfo>(
            inheritance.pNext, VK_STRUCTURE_TYPE_COMMAND_BUFFER_INHERITANCE_RENDERING_INFO);
        if (!rendering) return;
        const auto predicted = dev.render_passes->rendering_predictions.predict(split::rendering_key(
            rendering->pColorAttachmentFormats, rendering->colorAttachmentCount,
            rendering->depthAttachmentFormat, rendering->stencilAttachmentFormat, rendering->viewMask));
        if (predicted) target = *predicted;
    } else if (inheritance.framebuffer != VK_NULL_HANDLE) {
        VkRenderPassBeginInfo info{};
        info.sType = VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO;
        info.renderPass = inheritance.renderPass;
        info.framebuffer = inheritance.framebuffer;
        const PassTarget t = pass_target(dev, &info);
        target = {t.swapchain || t.scaled, t.extent, t.cut};
    } else if (const auto predicted =
                   dev.render_passes->pass_predictions.predict(codec::handle_value(inheritance.renderPass))) {
        target = *predicted;
    }
    // Scaled like the pass it continues; its viewports are kept for the executing pass's foveae.
    // Fovea mode: cut like it instead, its scissors narrowed by its own viewports.
    if (target.scaled) tracker->begin_split(0, target.extent, target.swapchain);
    if (target.scaled && target.swapchain) tracker->cut_pass();
}

void forget_render_pass(DeviceState &dev, VkRenderPass render_pass) {
    if (render_pass != VK_NULL_HANDLE)
        dev.render_passes->pass_predictions.forget(codec::handle_value(render_pass));
}

namespace observe {

void CmdExecuteCommands(DeviceState &, VkCommandBuffer cb, uint32_t count,
                        const VkCommandBuffer *secondaries) {
    split::CommandTracker *tracker = split_tracker(cb);
    if (!tracker) return;
    for (uint32_t i = 0; i < count; ++i) {
        const split::CommandTracker *secondary = split_tracker(secondaries[i]);
        if (!secondary) continue;
        if (secondary->secondary() && secondary->in_split() != tracker->in_split())
            log_unscalable_once(
                "a secondary command buffer was recorded for a pass scaled otherwise than the one "
                "that executes it: the client's periphery of that pass is wrong (the foveae stay "
                "exact only where the agent's tiles cover them)");
        tracker->merge_executed(*secondary);
    }
}

} // namespace observe

namespace observe {

void GetSwapchainImagesKHR(DeviceState &dev, VkDevice, VkSwapchainKHR swapchain,
                           uint32_t *pSwapchainImageCount, VkImage *pSwapchainImages) {
    if (pSwapchainImages) note_swapchain_images(dev, swapchain, *pSwapchainImageCount, pSwapchainImages);
}

void CreateImageView(DeviceState &dev, VkDevice, const VkImageViewCreateInfo *pCreateInfo,
                     const VkAllocationCallbacks *, VkImageView *pView) {
    auto state = std::make_unique<ImageViewState>();
    state->image = pCreateInfo->image;
    state->range = pCreateInfo->subresourceRange;
    state->format = pCreateInfo->format;
    dev.render_passes->views.insert(*pView, std::move(state));
}

// Forgotten before the driver may hand the value out again (codegen/emit_layer.py): a view created
// meanwhile on another thread must not lose its state.
void DestroyImageView(DeviceState &dev, VkDevice, VkImageView imageView, const VkAllocationCallbacks *) {
    if (imageView != VK_NULL_HANDLE) dev.render_passes->views.remove(imageView);
}

// Forgotten before the driver may hand the value out again: a framebuffer created meanwhile on
// another thread at the scaled size would otherwise lose its state (its passes would go down with
// unscaled render areas).
void DestroyFramebuffer(DeviceState &dev, VkDevice, VkFramebuffer framebuffer,
                        const VkAllocationCallbacks *) {
    if (framebuffer != VK_NULL_HANDLE) dev.render_passes->framebuffers.remove(framebuffer);
}

} // namespace observe

namespace rewrite {

VkResult CreateFramebuffer(DeviceState &dev, PFN_vkCreateFramebuffer down, VkDevice device,
                           const VkFramebufferCreateInfo *pCreateInfo,
                           const VkAllocationCallbacks *pAllocator, VkFramebuffer *pFramebuffer) {
    // A framebuffer holding a screen-space target is created at the scaled size, which every
    // attachment then covers (the others are at least that large).
    VkFramebufferCreateInfo info_down = *pCreateInfo;
    VkFramebufferAttachmentsCreateInfo attachments_down{};
    std::vector<VkFramebufferAttachmentImageInfo> image_infos;
    bool scaled = false;
    if (!(pCreateInfo->flags & VK_FRAMEBUFFER_CREATE_IMAGELESS_BIT) && pCreateInfo->pAttachments) {
        scaled = any_screen_space(dev, {pCreateInfo->pAttachments, pCreateInfo->attachmentCount});
    } else if (auto *info = static_cast<const VkFramebufferAttachmentsCreateInfo *>(pCreateInfo->pNext);
               info && info->sType == VK_STRUCTURE_TYPE_FRAMEBUFFER_ATTACHMENTS_CREATE_INFO) {
        // Imageless: the attachment infos describe the images, which the rule scaled alike.
        image_infos.assign(info->pAttachmentImageInfos,
                           info->pAttachmentImageInfos + info->attachmentImageInfoCount);
        for (VkFramebufferAttachmentImageInfo &image : image_infos)
            if (screen_space_attachment(dev, image)) {
                const VkExtent2D e =
                    split::scaled_extent({image.width, image.height}, split_settings().scale);
                image.width = e.width;
                image.height = e.height;
                scaled = true;
            }
        attachments_down = *info;
        attachments_down.pAttachmentImageInfos = image_infos.data();
        info_down.pNext = &attachments_down;
    }
    if (scaled) {
        const VkExtent2D e =
            split::scaled_extent({pCreateInfo->width, pCreateInfo->height}, split_settings().scale);
        info_down.width = e.width;
        info_down.height = e.height;
    }
    const VkResult result = down(device, &info_down, pAllocator, pFramebuffer);
    if (result == VK_SUCCESS) {
        auto state = std::make_unique<FramebufferState>();
        if (!(pCreateInfo->flags & VK_FRAMEBUFFER_CREATE_IMAGELESS_BIT) && pCreateInfo->pAttachments)
            state->attachments.assign(pCreateInfo->pAttachments,
                                      pCreateInfo->pAttachments + pCreateInfo->attachmentCount);
        state->extent = {pCreateInfo->width, pCreateInfo->height};
        state->scaled = scaled;
        dev.render_passes->framebuffers.insert(*pFramebuffer, std::move(state));
    }
    return result;
}

void CmdBeginRenderPass(DeviceState &dev, PFN_vkCmdBeginRenderPass down, VkCommandBuffer commandBuffer,
                        const VkRenderPassBeginInfo *pRenderPassBegin, VkSubpassContents contents) {
    begin_render_pass(dev, commandBuffer, pRenderPassBegin, contents != VK_SUBPASS_CONTENTS_INLINE,
                      [&](const VkRenderPassBeginInfo *b) { down(commandBuffer, b, contents); });
}

void CmdBeginRenderPass2(DeviceState &dev, PFN_vkCmdBeginRenderPass2 down, VkCommandBuffer commandBuffer,
                         const VkRenderPassBeginInfo *pRenderPassBegin,
                         const VkSubpassBeginInfo *pSubpassBeginInfo) {
    begin_render_pass(dev, commandBuffer, pRenderPassBegin,
                      pSubpassBeginInfo->contents != VK_SUBPASS_CONTENTS_INLINE,
                      [&](const VkRenderPassBeginInfo *b) { down(commandBuffer, b, pSubpassBeginInfo); });
}

void CmdEndRenderPass(DeviceState &dev, PFN_vkCmdEndRenderPass down, VkCommandBuffer commandBuffer) {
    down(commandBuffer);
    end_render_pass(dev, commandBuffer);
}

void CmdEndRenderPass2(DeviceState &dev, PFN_vkCmdEndRenderPass2 down, VkCommandBuffer commandBuffer,
                       const VkSubpassEndInfo *pSubpassEndInfo) {
    down(commandBuffer, pSubpassEndInfo);
    end_render_pass(dev, commandBuffer);
}

void CmdBeginRendering(DeviceState &dev, PFN_vkCmdBeginRendering down, VkCommandBuffer commandBuffer,
                       const VkRenderingInfo *pRenderingInfo) {
    begin_rendering(dev, commandBuffer, pRenderingInfo,
                    [&](const VkRenderingInfo *i) { down(commandBuffer, i); });
}

void CmdEndRendering(DeviceState &dev, PFN_vkCmdEndRendering down, VkCommandBuffer commandBuffer) {
    down(commandBuffer);
    leave_split(dev, commandBuffer);
}

void CmdClearAttachments(DeviceState &, PFN_vkCmdClearAttachments down, VkCommandBuffer commandBuffer,
                         uint32_t attachmentCount, const VkClearAttachment *pAttachments, uint32_t rectCount,
                         const VkClearRect *pRects) {
    const split::CommandTracker *tracker = split_tracker(commandBuffer);
    // A cut pass clears as recorded: scissors do not bound clears, and the composite overwrites what
    // lies outside the foveae.
    if (!tracker || !tracker->in_split() || tracker->cut())
        return down(commandBuffer, attachmentCount, pAttachments, rectCount, pRects);
    std::vector<VkClearRect> rects;
    for (uint32_t i = 0; i < rectCount; ++i) {
        VkClearRect r = pRects[i];
        r.rect = scaled_area(r.rect, tracker->extent());
        // A rect clamped away entirely is invalid to pass down (clear rects must not be empty).
        if (r.rect.extent.width && r.rect.extent.height) rects.push_back(r);
    }
    if (!rects.empty())
        down(commandBuffer, attachmentCount, pAttachments, static_cast<uint32_t>(rects.size()), rects.data());
}

} // namespace rewrite
} // namespace splitvk
