// --path hdr: the scene into an R16G16B16A16_SFLOAT target, a bloom chain over it (bright-pass
// into half size, downsampled to a quarter and an eighth, then upsampled and added back up to
// half size), and a tone-mapping pass that adds the bloom into the swapchain image.
#include "atrium_spirv.h"
#include "offscreen_scene.h"
#include "passes.h"
#include "paths.h"

#include <array>

namespace atrium {

namespace {

constexpr VkFormat hdr_format = VK_FORMAT_R16G16B16A16_SFLOAT;
constexpr uint32_t bloom_levels = 3; // 1/2, 1/4, 1/8
// Linear radiance above which a pixel blooms: specular highlights and the brightest sunlit
// stone, not the sky (about 1.8 in blue).
constexpr float bloom_threshold = 2.0f;
constexpr float bloom_strength = 0.35f;

struct BloomPush {
    float texel[2]; // one texel of the source, in uv
    float threshold;
    float pad;
};

class HdrPath : public RenderPath {
public:
    HdrPath(const SceneGpu &scene, const Swapchain &swapchain, const RendererOptions &options);
    ~HdrPath() override;

    void create_targets() override;
    void destroy_targets() override;
    void record(const FrameContext &frame) override;

private:
    VkDevice device_;
    VkContext &context_;
    const Swapchain &swapchain_;
    OffscreenScene scene_;
    SwapchainPass final_;
    VkRenderPass bloom_write_, bloom_add_; // replace a level / add to it
    VkSampler sampler_;
    FullscreenPass bright_, down_, up_, tonemap_;
    DescriptorSets sets_;
    VkDescriptorSet bright_in_, tonemap_in_;
    std::array<VkDescriptorSet, bloom_levels> level_in_{}; // samples level i

    VkExtent2D extent_{};
    std::array<Image, bloom_levels> bloom_;
    std::array<VkFramebuffer, bloom_levels> bloom_framebuffers_{};
};

Attachment bloom_level(bool add) {
    Attachment color{hdr_format};
    color.load = add ? VK_ATTACHMENT_LOAD_OP_LOAD : VK_ATTACHMENT_LOAD_OP_DONT_CARE;
    color.initial = add ? VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL : VK_IMAGE_LAYOUT_UNDEFINED;
    return color;
}

HdrPath::HdrPath(const SceneGpu &scene, const Swapchain &swapchain, const RendererOptions &options)
    : device_(scene.device()), context_(scene.context()), swapchain_(swapchain),
      scene_(scene, in_secondaries({{hdr_format}, {sky_radiance()}, SceneShading::hdr, options.eyes},
                                   options.scene_in_secondaries)),
      final_(device_, swapchain), bloom_write_(create_render_pass(device_, bloom_level(false))),
      bloom_add_(create_render_pass(device_, bloom_level(true))),
      sampler_(create_sampler(device_, VK_FILTER_LINEAR)),
      bright_(device_, fullscreen_info(bloom_write_, spirv::bloom_bright_frag, 1, sizeof(BloomPush))),
      down_(device_, fullscreen_info(bloom_write_, spirv::bloom_down_frag, 1, sizeof(BloomPush))),
      up_(device_, additive(fullscreen_info(bloom_add_, spirv::bloom_up_frag, 1, sizeof(BloomPush)))),
      tonemap_(device_, fullscreen_info(final_.render_pass(), spirv::tonemap_frag, 2, sizeof(float),
                                        swapchain.format())),
      sets_(device_, 2 + bloom_levels) {
    bright_in_ = sets_.allocate(bright_.inputs_layout());
    tonemap_in_ = sets_.allocate(tonemap_.inputs_layout());
    for (VkDescriptorSet &set : level_in_)
        set = sets_.allocate(down_.inputs_layout());
}

HdrPath::~HdrPath() {
    destroy_targets();
    vkDestroySampler(device_, sampler_, nullptr);
    vkDestroyRenderPass(device_, bloom_write_, nullptr);
    vkDestroyRenderPass(device_, bloom_add_, nullptr);
}

void HdrPath::create_targets() {
    extent_ = swapchain_.extent();
    scene_.create_targets(extent_);
    final_.create_framebuffers();
    for (uint32_t i = 0; i < bloom_levels; ++i) {
        const VkExtent2D size = mip_extent(extent_, i + 1);
        bloom_[i] = create_target(context_, size, hdr_format,
                                  VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT);
        bloom_framebuffers_[i] = create_framebuffer(device_, bloom_write_, {bloom_[i].view}, size);
        sets_.write_sampled(level_in_[i], {bloom_[i].view}, sampler_);
    }
    sets_.write_sampled(bright_in_, {scene_.color(0)}, sampler_);
    sets_.write_sampled(tonemap_in_, {scene_.color(0), bloom_[0].view}, sampler_);
}

void HdrPath::destroy_targets() {
    for (uint32_t i = 0; i < bloom_levels; ++i) {
        vkDestroyFramebuffer(device_, bloom_framebuffers_[i], nullptr);
        bloom_framebuffers_[i] = VK_NULL_HANDLE;
        context_.destroy(bloom_[i]);
    }
    final_.destroy_framebuffers();
    scene_.destroy_targets();
}

void HdrPath::record(const FrameContext &frame) {
    const VkCommandBuffer cmd = frame.cmd;
    scene_.record(cmd, frame.slot);

    const auto bloom_step = [&](VkRenderPass pass, uint32_t level, const FullscreenPass &shader,
                                VkDescriptorSet input, VkExtent2D source) {
        const VkExtent2D size = mip_extent(extent_, level + 1);
        begin_pass(cmd, pass, bloom_framebuffers_[level], size);
        set_viewport(cmd, {{0, 0}, size});
        const BloomPush push{
            {1.0f / float(source.width), 1.0f / float(source.height)}, bloom_threshold, 0.0f};
        shader.draw(cmd, input, &push);
        vkCmdEndRenderPass(cmd);
    };
    bloom_step(bloom_write_, 0, bright_, bright_in_, extent_);
    for (uint32_t level = 1; level < bloom_levels; ++level)
        bloom_step(bloom_write_, level, down_, level_in_[level - 1], mip_extent(extent_, level));
    for (uint32_t level = bloom_levels - 1; level-- > 0;)
        bloom_step(bloom_add_, level, up_, level_in_[level + 1], mip_extent(extent_, level + 2));

    final_.begin(cmd, frame.image, frame.readback);
    tonemap_.draw(cmd, tonemap_in_, &bloom_strength);
    vkCmdEndRenderPass(cmd);
}

} // namespace

std::unique_ptr<RenderPath> make_hdr_path(const SceneGpu &scene, const Swapchain &swapchain,
                                          const RendererOptions &options) {
    return std::make_unique<HdrPath>(scene, swapchain, options);
}

} // namespace atrium
