// --path multiview: both eyes drawn in one pass (VK_KHR_multiview, core in Vulkan 1.1) into a
// layered sRGB eye texture, one layer per eye, one eye wide; then composed side by side into the
// swapchain image, layer 0 on the left half.
#include "atrium_spirv.h"
#include "offscreen_scene.h"
#include "passes.h"
#include "paths.h"

namespace atrium {

namespace {

constexpr VkFormat eye_format = VK_FORMAT_R8G8B8A8_SRGB;

class MultiviewPath : public RenderPath {
public:
    MultiviewPath(const SceneGpu &scene, const Swapchain &swapchain, const RendererOptions &options)
        : device_(scene.device()), swapchain_(swapchain), eyes_(options.eyes),
          eyes_scene_(scene, {{eye_format},
                              {sky_clear(eye_format)},
                              SceneShading::multiview,
                              options.eyes,
                              true,
                              false,
                              options.screen_layers}),
          final_(device_, swapchain), sampler_(create_sampler(device_, VK_FILTER_NEAREST)),
          compose_(device_, fullscreen_info(final_.render_pass(), spirv::compose_frag, 1, sizeof(float),
                                            swapchain.format())),
          sets_(device_, 1), compose_in_(sets_.allocate(compose_.inputs_layout())) {}

    ~MultiviewPath() override {
        destroy_targets();
        vkDestroySampler(device_, sampler_, nullptr);
    }

    void create_targets() override {
        eyes_scene_.create_targets(swapchain_.extent());
        final_.create_framebuffers();
        sets_.write_sampled(compose_in_, {eyes_scene_.color(0)}, sampler_);
    }

    void destroy_targets() override {
        final_.destroy_framebuffers();
        eyes_scene_.destroy_targets();
    }

    void record(const FrameContext &frame) override {
        eyes_scene_.record(frame.cmd, frame.slot);
        final_.begin(frame.cmd, frame.image, frame.readback);
        const float split = eye_split(swapchain_.extent(), eyes_);
        compose_.draw(frame.cmd, compose_in_, &split);
        vkCmdEndRenderPass(frame.cmd);
    }

private:
    VkDevice device_;
    const Swapchain &swapchain_;
    uint32_t eyes_;
    OffscreenScene eyes_scene_;
    SwapchainPass final_;
    VkSampler sampler_;
    FullscreenPass compose_;
    DescriptorSets sets_;
    VkDescriptorSet compose_in_;
};

} // namespace

std::unique_ptr<RenderPath> make_multiview_path(const SceneGpu &scene, const Swapchain &swapchain,
                                                const RendererOptions &options) {
    return std::make_unique<MultiviewPath>(scene, swapchain, options);
}

} // namespace atrium
