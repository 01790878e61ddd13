// The scene drawn into offscreen targets instead of the swapchain image: an HDR colour buffer, a
// G-buffer, or a layered eye texture drawn with multiview. Its depth buffer is its own.
#pragma once

#include "scene_gpu.h"

#include <vector>

namespace atrium {

struct OffscreenSceneInfo {
    std::vector<VkFormat> colors;          // one target per colour attachment, in order
    std::vector<VkClearColorValue> clears; // one per colour
    SceneShading shading = SceneShading::hdr;
    uint32_t eyes = 2;
    bool multiview = false;     // one layer per eye, one eye wide, drawn once with a view mask
    bool sample_depth = false;  // keep the depth buffer for a later pass to sample
    bool screen_layers = false; // multiview: layers at the screen's extent, not one eye's
    // The pass's draws in secondary command buffers, one per eye, recorded each frame after the
    // pass begins; their inheritance names the render pass but not the framebuffer. Not multiview.
    bool secondaries = false;
};

inline OffscreenSceneInfo in_secondaries(OffscreenSceneInfo info, bool secondaries) {
    info.secondaries = secondaries;
    return info;
}

class OffscreenScene {
public:
    OffscreenScene(const SceneGpu &scene, const OffscreenSceneInfo &info);
    ~OffscreenScene();
    OffscreenScene(const OffscreenScene &) = delete;
    OffscreenScene &operator=(const OffscreenScene &) = delete;

    // `screen`: the swapchain's extent. Side by side, the targets have that extent; with
    // multiview, one eye's (the left eye's width; the screen's with screen_layers) and a layer per eye.
    void create_targets(VkExtent2D screen);
    void destroy_targets();
    // The pass, leaving every target in SHADER_READ_ONLY_OPTIMAL.
    void record(VkCommandBuffer cmd, uint32_t slot) const;

    VkImageView color(size_t i) const { return colors_[i].view; }
    VkImageView depth() const { return depth_.view; }

private:
    const SceneGpu &scene_;
    const OffscreenSceneInfo info_;
    VkDevice device_;
    VkRenderPass pass_ = VK_NULL_HANDLE;
    VkPipeline pipeline_ = VK_NULL_HANDLE;

    VkExtent2D screen_{}, extent_{};
    std::vector<Image> colors_;
    Image depth_;
    VkFramebuffer framebuffer_ = VK_NULL_HANDLE;

    struct Secondaries {
        VkCommandPool pool = VK_NULL_HANDLE; // reset each frame: its slot's fence was waited for
        std::vector<VkCommandBuffer> eyes;
    };
    std::vector<Secondaries> secondaries_; // per frame slot, with info.secondaries
};

} // namespace atrium
