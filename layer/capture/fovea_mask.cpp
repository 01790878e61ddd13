#include "capture/fovea_mask.h"

#include "capture/session.h"
#include "capture/split.h"
#include "core/object_map.h"
#include "core/vk_util.h"
#include "log.h"
#include "split_geometry.h"
#include "vk_format_info.h"

#include <algorithm>
#include <cmath>
#include <mutex>
#include <optional>
#include <set>
#include <utility>
#include <vector>

namespace splitvk {

namespace {

// A render pass whose depth attachment (`attachment`) can carry the mask; absent otherwise.
struct RenderPassDepth {
    uint32_t attachment = 0;
};

} // namespace

struct RenderPassDepthTable {
    ObjectMap<VkRenderPass, RenderPassDepth> passes;
};

std::shared_ptr<RenderPassDepthTable> make_render_pass_depth_table() {
    return std::make_shared<RenderPassDepthTable>();
}

namespace {

bool depth_cleared_and_dropped(VkFormat format, VkAttachmentLoadOp load, VkAttachmentStoreOp store) {
    return format_info(format).depth && load == VK_ATTACHMENT_LOAD_OP_CLEAR &&
           store == VK_ATTACHMENT_STORE_OP_DONT_CARE;
}

template <class CreateInfo>
void note_depth(DeviceState &device, VkRenderPass render_pass, const CreateInfo &info,
                uint32_t depth_attachment) {
    forget_render_pass_depth(device, render_pass);
    if (info.subpassCount != 1 || depth_attachment >= info.attachmentCount) return;
    const auto &attachment = info.pAttachments[depth_attachment];
    if (!depth_cleared_and_dropped(attachment.format, attachment.loadOp, attachment.storeOp)) return;
    device.render_pass_depth->passes.insert(
        render_pass, std::make_unique<RenderPassDepth>(RenderPassDepth{depth_attachment}));
}

// The size of the foveae every frame of the pass's image will have at least, known while the pass
// is recorded: SPLITVK_FOVEA's, or with auto the size of the moment (`*sized`); none when a frame's
// foveae are decided later (see the top of fovea_mask.h).
std::optional<FoveaSize> recorded_size(DeviceState &device, split::FrameFoveaSize *sized) {
    const Settings &settings = split_settings();
    if (!settings.fovea_mask || settings.gaze != GazeMode::Fixed || settings.eyes == EyeMode::Auto)
        return std::nullopt;
    // SPLITVK_CLIENT_RENDERS=fovea: the client renders the foveae themselves, and nothing else.
    if (device.session && device.session->client_renders() == ClientRenders::Fovea) return std::nullopt;
    if (!settings.fovea.automatic) return settings.fovea;
    AutoFovea *sizing = device.session ? device.session->auto_fovea() : nullptr;
    if (!sizing) return std::nullopt;
    *sized = sizing->size();
    return split::frame_fovea_size(settings.fovea, *sized);
}

std::vector<VkRect2D> foveae_of(VkExtent2D image, EyeMode eyes, const FoveaSize &fovea) {
    if (eyes == EyeMode::One) return {split::fovea_of_eye({{0, 0}, image}, fovea)};
    return {split::fovea_of_eye(split::left_eye(image), fovea),
            split::fovea_of_eye(split::right_eye(image), fovea)};
}

// The scaled texels that lie wholly inside `fovea`, less kFoveaMaskGuard on every side, within
// `area`; zero extent when none.
VkRect2D mask_of(const VkRect2D &fovea, split::AxisScale scale, const VkRect2D &area) {
    const auto x0 = static_cast<int64_t>(std::ceil(fovea.offset.x * scale.x)) + kFoveaMaskGuard;
    const auto y0 = static_cast<int64_t>(std::ceil(fovea.offset.y * scale.y)) + kFoveaMaskGuard;
    const auto x1 =
        static_cast<int64_t>(std::floor((fovea.offset.x + fovea.extent.width) * scale.x)) - kFoveaMaskGuard;
    const auto y1 =
        static_cast<int64_t>(std::floor((fovea.offset.y + fovea.extent.height) * scale.y)) - kFoveaMaskGuard;
    if (x1 <= x0 || y1 <= y0) return {};
    const VkRect2D inner{{static_cast<int32_t>(x0), static_cast<int32_t>(y0)},
                         {static_cast<uint32_t>(x1 - x0), static_cast<uint32_t>(y1 - y0)}};
    return split::intersect(inner, area);
}

void log_mask_once(VkExtent2D image) {
    static std::mutex mutex;
    static std::set<std::pair<uint32_t, uint32_t>> logged;
    {
        std::lock_guard lock(mutex);
        if (!logged.emplace(image.width, image.height).second) return;
    }
    SPLITVK_INFO("split: the periphery of %ux%u swapchain images leaves its foveae unshaded (depth mask)",
                 image.width, image.height);
}

// Clears the masks of `image`'s foveae in the pass's depth attachment to the end of the depth range
// that its clear value is not at, which every LESS test (clear 1) or GREATER test (clear 0) fails.
void record_mask(DeviceState &device, VkCommandBuffer command_buffer, split::CommandTracker &tracker,
                 VkExtent2D image, const VkRect2D &area, float cleared_depth) {
    split::FrameFoveaSize sized;
    const std::optional<FoveaSize> size = recorded_size(device, &sized);
    if (!size) return;
    std::vector<VkClearRect> rects;
    const split::AxisScale scale = split::axis_scale(image, split_settings().scale);
    for (const VkRect2D &fovea : foveae_of(image, split_settings().eyes, *size)) {
        const VkRect2D mask = mask_of(fovea, scale, area);
        if (mask.extent.width > 0 && mask.extent.height > 0) rects.push_back({mask, 0, 1});
    }
    if (rects.empty()) return;
    VkClearAttachment clear{};
    clear.aspectMask = VK_IMAGE_ASPECT_DEPTH_BIT;
    clear.clearValue.depthStencil.depth = cleared_depth >= 0.5f ? 0.0f : 1.0f;
    device.dispatch.CmdClearAttachments(command_buffer, 1, &clear, static_cast<uint32_t>(rects.size()),
                                        rects.data());
    if (sized.set()) tracker.note_mask(sized);
    log_mask_once(image);
}

} // namespace

void note_render_pass_depth(DeviceState &device, VkRenderPass render_pass,
                            const VkRenderPassCreateInfo &info) {
    const VkAttachmentReference *depth =
        info.subpassCount == 1 ? info.pSubpasses[0].pDepthStencilAttachment : nullptr;
    note_depth(device, render_pass, info, depth ? depth->attachment : VK_ATTACHMENT_UNUSED);
}

void note_render_pass_depth(DeviceState &device, VkRenderPass render_pass,
                            const VkRenderPassCreateInfo2 &info) {
    const VkAttachmentReference2 *depth =
        info.subpassCount == 1 ? info.pSubpasses[0].pDepthStencilAttachment : nullptr;
    // A depth resolve would carry the mask into the resolved image.
    const auto *resolve =
        info.subpassCount == 1
            ? find_in_chain<VkSubpassDescriptionDepthStencilResolve>(
                  info.pSubpasses[0].pNext, VK_STRUCTURE_TYPE_SUBPASS_DESCRIPTION_DEPTH_STENCIL_RESOLVE)
            : nullptr;
    const bool resolves = resolve && resolve->pDepthStencilResolveAttachment &&
                          resolve->pDepthStencilResolveAttachment->attachment != VK_ATTACHMENT_UNUSED;
    note_depth(device, render_pass, info, depth && !resolves ? depth->attachment : VK_ATTACHMENT_UNUSED);
}

void forget_render_pass_depth(DeviceState &device, VkRenderPass render_pass) {
    device.render_pass_depth->passes.remove(render_pass);
}

void mask_foveae(DeviceState &device, VkCommandBuffer command_buffer, split::CommandTracker &tracker,
                 const VkRenderPassBeginInfo &begin, VkExtent2D image, const VkRect2D &area) {
    const RenderPassDepth *depth = device.render_pass_depth->passes.find(begin.renderPass);
    if (!depth || depth->attachment >= begin.clearValueCount || !begin.pClearValues) return;
    record_mask(device, command_buffer, tracker, image, area,
                begin.pClearValues[depth->attachment].depthStencil.depth);
}

void mask_foveae(DeviceState &device, VkCommandBuffer command_buffer, split::CommandTracker &tracker,
                 const VkRenderingInfo &info, VkExtent2D image, const VkRect2D &area) {
    const VkRenderingAttachmentInfo *depth = info.pDepthAttachment;
    if (!depth || !depth->imageView || (info.flags & VK_RENDERING_RESUMING_BIT) ||
        depth->resolveMode != VK_RESOLVE_MODE_NONE || depth->loadOp != VK_ATTACHMENT_LOAD_OP_CLEAR ||
        depth->storeOp != VK_ATTACHMENT_STORE_OP_DONT_CARE)
        return;
    record_mask(device, command_buffer, tracker, image, area, depth->clearValue.depthStencil.depth);
}

} // namespace splitvk
