#include "offscreen_scene.h"

#include "passes.h"
#include "vk_util.h"

#include <stdexcept>

namespace atrium {

namespace {

constexpr VkFormat depth_format = VK_FORMAT_D32_SFLOAT;

} // namespace

OffscreenScene::OffscreenScene(const SceneGpu &scene, const OffscreenSceneInfo &info)
    : scene_(scene), info_(info), device_(scene.device()) {
    RenderPassInfo pass;
    for (VkFormat format : info.colors)
        pass.colors.push_back({format});
    pass.depth = Attachment{depth_format};
    if (!info.sample_depth) {
        pass.depth->store = VK_ATTACHMENT_STORE_OP_DONT_CARE;
        pass.depth->final = VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL;
    }
    if (info.multiview) pass.view_mask = (1u << info.eyes) - 1;
    pass_ = create_render_pass(device_, pass);
    ScenePipelineInfo pipeline;
    pipeline.render_pass = pass_;
    pipeline.shading = info.shading;
    pipeline_ = scene_.create_pipeline(pipeline);
    if (info.secondaries && info.multiview)
        throw std::invalid_argument("a multiview scene pass draws once: not in secondaries");
    for (uint32_t slot = 0; info.secondaries && slot < frames_in_flight; ++slot) {
        Secondaries &s = secondaries_.emplace_back();
        VkCommandPoolCreateInfo pool_info{};
        pool_info.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
        pool_info.flags = VK_COMMAND_POOL_CREATE_TRANSIENT_BIT;
        pool_info.queueFamilyIndex = scene.context().queue_family();
        ATRIUM_VK_CHECK(vkCreateCommandPool(device_, &pool_info, nullptr, &s.pool));
        s.eyes.resize(info.eyes);
        VkCommandBufferAllocateInfo alloc{};
        alloc.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
        alloc.commandPool = s.pool;
        alloc.level = VK_COMMAND_BUFFER_LEVEL_SECONDARY;
        alloc.commandBufferCount = info.eyes;
        ATRIUM_VK_CHECK(vkAllocateCommandBuffers(device_, &alloc, s.eyes.data()));
    }
}

OffscreenScene::~OffscreenScene() {
    for (const Secondaries &s : secondaries_)
        vkDestroyCommandPool(device_, s.pool, nullptr);
    destroy_targets();
    vkDestroyPipeline(device_, pipeline_, nullptr);
    vkDestroyRenderPass(device_, pass_, nullptr);
}

void OffscreenScene::create_targets(VkExtent2D screen) {
    screen_ = screen;
    extent_ = info_.multiview && !info_.screen_layers ? eye_rect(screen, info_.eyes, 0).extent : screen;
    const uint32_t layers = info_.multiview ? info_.eyes : 0;
    for (VkFormat format : info_.colors)
        colors_.push_back(create_target(scene_.context(), extent_, format,
                                        VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT,
                                        layers));
    depth_ = create_target(scene_.context(), extent_, depth_format,
                           VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT |
                               (info_.sample_depth ? VK_IMAGE_USAGE_SAMPLED_BIT : 0),
                           layers);
    std::vector<VkImageView> views;
    for (const Image &color : colors_)
        views.push_back(color.view);
    views.push_back(depth_.view);
    framebuffer_ = create_framebuffer(device_, pass_, views, extent_);
}

void OffscreenScene::destroy_targets() {
    vkDestroyFramebuffer(device_, framebuffer_, nullptr);
    framebuffer_ = VK_NULL_HANDLE;
    for (Image &color : colors_)
        scene_.context().destroy(color);
    colors_.clear();
    scene_.context().destroy(depth_);
}

void OffscreenScene::record(VkCommandBuffer cmd, uint32_t slot) const {
    std::vector<VkClearValue> clears;
    for (const VkClearColorValue &color : info_.clears)
        clears.push_back({.color = color});
    clears.push_back({.depthStencil = {1.0f, 0}});
    if (info_.secondaries) {
        begin_pass(cmd, pass_, framebuffer_, extent_, clears, VK_SUBPASS_CONTENTS_SECONDARY_COMMAND_BUFFERS);
        const Secondaries &s = secondaries_[slot];
        ATRIUM_VK_CHECK(vkResetCommandPool(device_, s.pool, 0));
        VkCommandBufferInheritanceInfo inheritance{};
        inheritance.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_INHERITANCE_INFO;
        inheritance.renderPass = pass_;
        inheritance.subpass = 0;
        VkCommandBufferBeginInfo begin{};
        begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
        begin.flags =
            VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT | VK_COMMAND_BUFFER_USAGE_RENDER_PASS_CONTINUE_BIT;
        begin.pInheritanceInfo = &inheritance;
        for (uint32_t eye = 0; eye < info_.eyes; ++eye) {
            ATRIUM_VK_CHECK(vkBeginCommandBuffer(s.eyes[eye], &begin));
            scene_.bind(s.eyes[eye], pipeline_, slot);
            set_viewport(s.eyes[eye], eye_rect(screen_, info_.eyes, eye));
            scene_.draw(s.eyes[eye], eye);
            ATRIUM_VK_CHECK(vkEndCommandBuffer(s.eyes[eye]));
        }
        vkCmdExecuteCommands(cmd, info_.eyes, s.eyes.data());
        vkCmdEndRenderPass(cmd);
        return;
    }
    begin_pass(cmd, pass_, framebuffer_, extent_, clears);
    scene_.bind(cmd, pipeline_, slot);
    if (info_.multiview) {
        set_viewport(cmd, {{0, 0}, extent_});
        scene_.draw(cmd, 0);
    } else {
        for (uint32_t eye = 0; eye < info_.eyes; ++eye) {
            set_viewport(cmd, eye_rect(screen_, info_.eyes, eye));
            scene_.draw(cmd, eye);
        }
    }
    vkCmdEndRenderPass(cmd);
}

} // namespace atrium
