#include "path_direct.h"

#include "passes.h"

namespace atrium {

DirectPath::DirectPath(const SceneGpu &scene, const Swapchain &swapchain, const RendererOptions &options)
    : scene_(scene), swapchain_(swapchain), options_(options), device_(scene.device()) {
    if (options_.dynamic_rendering) {
        cmd_begin_rendering_ = reinterpret_cast<PFN_vkCmdBeginRenderingKHR>(
            vkGetDeviceProcAddr(device_, "vkCmdBeginRenderingKHR"));
        cmd_end_rendering_ =
            reinterpret_cast<PFN_vkCmdEndRenderingKHR>(vkGetDeviceProcAddr(device_, "vkCmdEndRenderingKHR"));
        if (!cmd_begin_rendering_ || !cmd_end_rendering_) throw Error("vkCmdBeginRenderingKHR is missing");
    }
    present_pass_ = create_render_pass(swapchain_.final_layout());
    if (options_.screenshot_frame) readback_pass_ = create_render_pass(VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);

    ScenePipelineInfo info;
    info.render_pass = present_pass_;
    info.encode_srgb = !takes_linear(swapchain_.format());
    const VkFormat color_format = swapchain_.format();
    VkPipelineRenderingCreateInfoKHR rendering{};
    rendering.sType = VK_STRUCTURE_TYPE_PIPELINE_RENDERING_CREATE_INFO_KHR;
    rendering.colorAttachmentCount = 1;
    rendering.pColorAttachmentFormats = &color_format;
    rendering.depthAttachmentFormat = depth_format;
    if (options_.dynamic_rendering) {
        info.next = &rendering;
        info.render_pass = VK_NULL_HANDLE;
    }
    pipeline_ = scene_.create_pipeline(info);
    if (options_.engine_extensions)
        markers_ = std::make_unique<EngineMarkers>(scene_.context(), present_pass_);
    // Static state exercises the layer's other path: it must make these dynamic to scale them.
    for (uint32_t eye = 0; options_.static_viewports && eye < options_.eyes; ++eye) {
        const VkRect2D eye_scissor = eye_rect(swapchain_.extent(), options_.eyes, eye);
        const VkViewport eye_viewport{float(eye_scissor.offset.x),      0.0f, float(eye_scissor.extent.width),
                                      float(eye_scissor.extent.height), 0.0f, 1.0f};
        ScenePipelineInfo fixed = info;
        fixed.static_viewport = &eye_viewport;
        fixed.static_scissor = &eye_scissor;
        eye_pipelines_[eye] = scene_.create_pipeline(fixed);
    }
}

DirectPath::~DirectPath() {
    destroy_targets();
    markers_.reset();
    vkDestroyPipeline(device_, pipeline_, nullptr);
    for (VkPipeline eye_pipeline : eye_pipelines_)
        vkDestroyPipeline(device_, eye_pipeline, nullptr);
    vkDestroyRenderPass(device_, present_pass_, nullptr);
    vkDestroyRenderPass(device_, readback_pass_, nullptr);
}

VkRenderPass DirectPath::create_render_pass(VkImageLayout final_layout) {
    RenderPassInfo info;
    info.colors = {Attachment{swapchain_.format(), VK_ATTACHMENT_LOAD_OP_CLEAR, VK_ATTACHMENT_STORE_OP_STORE,
                              VK_IMAGE_LAYOUT_UNDEFINED, final_layout}};
    info.depth = Attachment{depth_format, VK_ATTACHMENT_LOAD_OP_CLEAR, VK_ATTACHMENT_STORE_OP_DONT_CARE,
                            VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL};

    std::vector<VkSubpassDependency> &deps = info.dependencies;
    deps.resize(2);
    // In: the swapchain image's layout transition and clear wait for the acquire semaphore, which
    // the submission waits for at COLOR_ATTACHMENT_OUTPUT; the depth buffer, shared by the frames
    // in flight, is cleared only after the previous frame's depth tests are done with it.
    deps[0].srcSubpass = VK_SUBPASS_EXTERNAL;
    deps[0].dstSubpass = 0;
    deps[0].srcStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT |
                           VK_PIPELINE_STAGE_EARLY_FRAGMENT_TESTS_BIT |
                           VK_PIPELINE_STAGE_LATE_FRAGMENT_TESTS_BIT;
    deps[0].dstStageMask = deps[0].srcStageMask;
    deps[0].srcAccessMask = VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
    deps[0].dstAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT |
                            VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_READ_BIT |
                            VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
    // Out: the screenshot frame's copy to the readback buffer reads what the pass wrote. Only the
    // readback pass needs it, but compatible render passes must have identical dependencies.
    // (Presenting needs none: the semaphore signal waits for all prior commands.)
    deps[1].srcSubpass = 0;
    deps[1].dstSubpass = VK_SUBPASS_EXTERNAL;
    deps[1].srcStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
    deps[1].dstStageMask = VK_PIPELINE_STAGE_TRANSFER_BIT;
    deps[1].srcAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
    deps[1].dstAccessMask = VK_ACCESS_TRANSFER_READ_BIT;

    return atrium::create_render_pass(device_, info);
}

void DirectPath::create_targets() {
    const VkExtent2D extent = swapchain_.extent();
    depth_ =
        create_target(scene_.context(), extent, depth_format, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT);
    // Also compatible with readback_pass_.
    for (VkImageView view : swapchain_.views())
        framebuffers_.push_back(create_framebuffer(device_, present_pass_, {view, depth_.view}, extent));
}

void DirectPath::destroy_targets() {
    for (VkFramebuffer fb : framebuffers_)
        vkDestroyFramebuffer(device_, fb, nullptr);
    framebuffers_.clear();
    scene_.context().destroy(depth_);
}

// What the render pass's layouts and external dependencies do (create_render_pass), as barriers.
void DirectPath::begin_rendering(VkCommandBuffer cmd, uint32_t image, VkExtent2D extent,
                                 const VkClearValue *clears) {
    VkImageMemoryBarrier barriers[2] = {};
    for (auto &b : barriers) {
        b.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER;
        b.oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;
        b.srcQueueFamilyIndex = b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    }
    barriers[0].dstAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
    barriers[0].newLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
    barriers[0].image = swapchain_.images()[image];
    barriers[0].subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    barriers[1].srcAccessMask = VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
    barriers[1].dstAccessMask =
        VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
    barriers[1].newLayout = VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL;
    barriers[1].image = depth_.image;
    barriers[1].subresourceRange = {VK_IMAGE_ASPECT_DEPTH_BIT, 0, 1, 0, 1};
    const VkPipelineStageFlags stages = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT |
                                        VK_PIPELINE_STAGE_EARLY_FRAGMENT_TESTS_BIT |
                                        VK_PIPELINE_STAGE_LATE_FRAGMENT_TESTS_BIT;
    vkCmdPipelineBarrier(cmd, stages, stages, 0, 0, nullptr, 0, nullptr, 2, barriers);

    VkRenderingAttachmentInfoKHR color{};
    color.sType = VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO_KHR;
    color.imageView = swapchain_.views()[image];
    color.imageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
    color.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
    color.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    color.clearValue = clears[0];
    VkRenderingAttachmentInfoKHR depth = color;
    depth.imageView = depth_.view;
    depth.imageLayout = VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL;
    depth.storeOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
    depth.clearValue = clears[1];
    VkRenderingInfoKHR info{};
    info.sType = VK_STRUCTURE_TYPE_RENDERING_INFO_KHR;
    info.renderArea = {{0, 0}, extent};
    if (contents() == VK_SUBPASS_CONTENTS_SECONDARY_COMMAND_BUFFERS)
        info.flags = VK_RENDERING_CONTENTS_SECONDARY_COMMAND_BUFFERS_BIT_KHR;
    info.layerCount = 1;
    info.colorAttachmentCount = 1;
    info.pColorAttachments = &color;
    info.pDepthAttachment = &depth;
    cmd_begin_rendering_(cmd, &info);
}

void DirectPath::end_rendering(VkCommandBuffer cmd, uint32_t image, bool readback) {
    cmd_end_rendering_(cmd);
    // To PRESENT_SRC (the present's semaphore waits for everything; an OpenXR image stays in
    // COLOR_ATTACHMENT_OPTIMAL), or to TRANSFER_SRC for the screenshot's copy, which reads what was
    // rendered.
    VkImageMemoryBarrier barrier{};
    barrier.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER;
    barrier.srcAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
    barrier.dstAccessMask = readback ? VK_ACCESS_TRANSFER_READ_BIT : 0;
    barrier.oldLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
    barrier.newLayout = readback ? VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL : swapchain_.final_layout();
    barrier.srcQueueFamilyIndex = barrier.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    barrier.image = swapchain_.images()[image];
    barrier.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT,
                         readback ? VK_PIPELINE_STAGE_TRANSFER_BIT : VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, 0,
                         0, nullptr, 0, nullptr, 1, &barrier);
}

void DirectPath::record(const FrameContext &frame) {
    const VkExtent2D extent = swapchain_.extent();
    VkCommandBuffer cmd = frame.cmd;
    const uint32_t image = frame.image;
    const bool readback = frame.readback;
    VkClearValue clears[2] = {};
    clears[0].color = sky_clear(swapchain_.format());
    clears[1].depthStencil = {1.0f, 0};
    VkRenderPassBeginInfo pass{};
    pass.sType = VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO;
    pass.renderPass = readback ? readback_pass_ : present_pass_;
    pass.framebuffer = framebuffers_[image];
    pass.renderArea = {{0, 0}, extent};
    pass.clearValueCount = 2;
    pass.pClearValues = clears;
    if (markers_) markers_->record_capture(cmd);
    if (options_.dynamic_rendering)
        begin_rendering(cmd, image, extent, clears);
    else
        vkCmdBeginRenderPass(cmd, &pass, contents());
    record_contents(frame);
    for (uint32_t eye = 0; markers_ && eye < options_.eyes; ++eye) {
        set_viewport(cmd, eye_rect(extent, options_.eyes, eye));
        markers_->record_draw(cmd);
    }
    if (options_.dynamic_rendering)
        end_rendering(cmd, image, readback);
    else
        vkCmdEndRenderPass(cmd);
}

void DirectPath::record_contents(const FrameContext &frame) {
    const VkCommandBuffer cmd = frame.cmd;
    scene_.bind(cmd, pipeline_, frame.slot);
    for (uint32_t eye = 0; eye < options_.eyes; ++eye)
        record_eye(cmd, eye, 0, scene_.draw_count());
}

void DirectPath::record_eye(VkCommandBuffer cmd, uint32_t eye, size_t first, size_t end) const {
    const VkRect2D scissor = eye_rect(swapchain_.extent(), options_.eyes, eye);
    if (options_.static_viewports)
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, eye_pipelines_[eye]);
    else
        set_viewport(cmd, scissor);
    if (options_.clear_depth_per_eye) {
        VkClearAttachment clear{};
        clear.aspectMask = VK_IMAGE_ASPECT_DEPTH_BIT;
        clear.clearValue.depthStencil = {1.0f, 0};
        const VkClearRect rect{scissor, 0, 1};
        vkCmdClearAttachments(cmd, 1, &clear, 1, &rect);
    }
    scene_.draw(cmd, eye, first, end);
}

} // namespace atrium
