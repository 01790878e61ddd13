// --path deferred: a G-buffer pass (albedo + specular, normal + shininess, depth), a full-screen
// lighting pass that reads it with texelFetch at gl_FragCoord into an HDR target, and a
// post-processing pass (tone mapping, vignette) into the swapchain image.
#include "atrium_spirv.h"
#include "offscreen_scene.h"
#include "passes.h"
#include "paths.h"

namespace atrium {

namespace {

constexpr VkFormat albedo_format = VK_FORMAT_R8G8B8A8_UNORM;
constexpr VkFormat normal_format = VK_FORMAT_R16G16B16A16_SFLOAT;
constexpr VkFormat radiance_format = VK_FORMAT_R16G16B16A16_SFLOAT;

struct LightingPush {
    VkClearColorValue sky;
    float split;
};

struct PostPush {
    float split;
    float vignette;
};

class DeferredPath : public RenderPath {
public:
    DeferredPath(const SceneGpu &scene, const Swapchain &swapchain, const RendererOptions &options);
    ~DeferredPath() override;

    void create_targets() override;
    void destroy_targets() override;
    void record(const FrameContext &frame) override;

private:
    const SceneGpu &scene_;
    VkDevice device_;
    const Swapchain &swapchain_;
    uint32_t eyes_;
    OffscreenScene gbuffer_;
    SwapchainPass final_;
    VkRenderPass lighting_pass_;
    VkSampler sampler_;
    FullscreenPass lighting_, post_;
    DescriptorSets sets_;
    VkDescriptorSet lighting_in_, post_in_;

    Image radiance_;
    VkFramebuffer radiance_framebuffer_ = VK_NULL_HANDLE;
};

FullscreenInfo with_frame(FullscreenInfo info, VkDescriptorSetLayout frame_layout) {
    info.frame_layout = frame_layout;
    return info;
}

DeferredPath::DeferredPath(const SceneGpu &scene, const Swapchain &swapchain, const RendererOptions &options)
    : scene_(scene), device_(scene.device()), swapchain_(swapchain), eyes_(options.eyes),
      gbuffer_(
          scene,
          in_secondaries(
              {{albedo_format, normal_format}, {{}, {}}, SceneShading::gbuffer, options.eyes, false, true},
              options.scene_in_secondaries)),
      final_(device_, swapchain), lighting_pass_(create_render_pass(
                                      device_, Attachment{radiance_format, VK_ATTACHMENT_LOAD_OP_DONT_CARE})),
      sampler_(create_sampler(device_, VK_FILTER_NEAREST)),
      lighting_(device_,
                with_frame(fullscreen_info(lighting_pass_, spirv::lighting_frag, 3, sizeof(LightingPush)),
                           scene.frame_layout())),
      post_(device_,
            fullscreen_info(final_.render_pass(), spirv::post_frag, 1, sizeof(PostPush), swapchain.format())),
      sets_(device_, 2) {
    lighting_in_ = sets_.allocate(lighting_.inputs_layout());
    post_in_ = sets_.allocate(post_.inputs_layout());
}

DeferredPath::~DeferredPath() {
    destroy_targets();
    vkDestroySampler(device_, sampler_, nullptr);
    vkDestroyRenderPass(device_, lighting_pass_, nullptr);
}

void DeferredPath::create_targets() {
    const VkExtent2D extent = swapchain_.extent();
    gbuffer_.create_targets(extent);
    final_.create_framebuffers();
    radiance_ = create_target(scene_.context(), extent, radiance_format,
                              VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT);
    radiance_framebuffer_ = create_framebuffer(device_, lighting_pass_, {radiance_.view}, extent);
    sets_.write_sampled(lighting_in_, {gbuffer_.color(0), gbuffer_.color(1), gbuffer_.depth()}, sampler_);
    sets_.write_sampled(post_in_, {radiance_.view}, sampler_);
}

void DeferredPath::destroy_targets() {
    vkDestroyFramebuffer(device_, radiance_framebuffer_, nullptr);
    radiance_framebuffer_ = VK_NULL_HANDLE;
    scene_.context().destroy(radiance_);
    final_.destroy_framebuffers();
    gbuffer_.destroy_targets();
}

void DeferredPath::record(const FrameContext &frame) {
    const VkCommandBuffer cmd = frame.cmd;
    const VkExtent2D extent = swapchain_.extent();
    const float split = eye_split(extent, eyes_);
    gbuffer_.record(cmd, frame.slot);

    begin_pass(cmd, lighting_pass_, radiance_framebuffer_, extent);
    set_viewport(cmd, {{0, 0}, extent});
    const LightingPush lighting{sky_radiance(), split};
    lighting_.draw(cmd, lighting_in_, &lighting, scene_.frame_set(frame.slot));
    vkCmdEndRenderPass(cmd);

    final_.begin(cmd, frame.image, frame.readback);
    const PostPush post{split, 0.18f};
    post_.draw(cmd, post_in_, &post);
    vkCmdEndRenderPass(cmd);
}

} // namespace

std::unique_ptr<RenderPath> make_deferred_path(const SceneGpu &scene, const Swapchain &swapchain,
                                               const RendererOptions &options) {
    return std::make_unique<DeferredPath>(scene, swapchain, options);
}

} // namespace atrium
