// --path direct: one render pass per frame whose colour attachment is the swapchain image itself,
// with one viewport per eye (today's path of the paper's client, and vkcube's structure).
#pragma once

#include "engine_markers.h"
#include "render_path.h"

#include <memory>
#include <vector>

namespace atrium {

class DirectPath : public RenderPath {
public:
    DirectPath(const SceneGpu &scene, const Swapchain &swapchain, const RendererOptions &options);
    ~DirectPath() override;

    void create_targets() override;
    void destroy_targets() override;
    void record(const FrameContext &frame) override;

protected:
    static constexpr VkFormat depth_format = VK_FORMAT_D32_SFLOAT;

    // What the pass holds: the eyes' draws, recorded inline here.
    virtual VkSubpassContents contents() const { return VK_SUBPASS_CONTENTS_INLINE; }
    virtual void record_contents(const FrameContext &frame);
    // Eye `eye`'s viewport and scissor, then draws [first, end), into a bound scene pipeline.
    void record_eye(VkCommandBuffer cmd, uint32_t eye, size_t first, size_t end) const;

    const SceneGpu &scene_;
    const Swapchain &swapchain_;
    const RendererOptions options_;
    VkDevice device_;
    VkPipeline pipeline_ = VK_NULL_HANDLE;
    VkRenderPass present_pass_ = VK_NULL_HANDLE; // ends in the swapchain's final layout

private:
    VkRenderPass create_render_pass(VkImageLayout final_layout);
    void begin_rendering(VkCommandBuffer cmd, uint32_t image, VkExtent2D extent, const VkClearValue *clears);
    void end_rendering(VkCommandBuffer cmd, uint32_t image, bool readback);

    PFN_vkCmdBeginRenderingKHR cmd_begin_rendering_ = nullptr; // --dynamic-rendering (extension entry points)
    PFN_vkCmdEndRenderingKHR cmd_end_rendering_ = nullptr;
    VkPipeline eye_pipelines_[2] = {};            // --static-viewports: eye i's viewport and scissor baked in
    VkRenderPass readback_pass_ = VK_NULL_HANDLE; // ends in TRANSFER_SRC_OPTIMAL, for the screenshot
    std::unique_ptr<EngineMarkers> markers_;      // --engine-extensions

    // Per swapchain image, rebuilt with the swapchain.
    Image depth_;
    std::vector<VkFramebuffer> framebuffers_;
};

} // namespace atrium
