// --path compute: the scene into an HDR target, then a compute shader that blurs lightly, tone
// maps and encodes it into a screen-size storage image, which is blitted into the swapchain image.
// The dispatch covers the storage image in 8x8 groups, ceil(width / 8) x ceil(height / 8), as
// engines size their screen-space dispatches.
#include "atrium_spirv.h"
#include "offscreen_scene.h"
#include "passes.h"
#include "paths.h"

namespace atrium {

namespace {

constexpr VkFormat hdr_format = VK_FORMAT_R16G16B16A16_SFLOAT;
constexpr VkFormat result_format = VK_FORMAT_R16G16B16A16_SFLOAT;
constexpr uint32_t group_size = 8; // post.comp's local size

VkImageMemoryBarrier image_barrier(VkImage image, VkAccessFlags src, VkAccessFlags dst, VkImageLayout from,
                                   VkImageLayout to) {
    VkImageMemoryBarrier b{};
    b.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER;
    b.srcAccessMask = src;
    b.dstAccessMask = dst;
    b.oldLayout = from;
    b.newLayout = to;
    b.srcQueueFamilyIndex = b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    b.image = image;
    b.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    return b;
}

class ComputePath : public RenderPath {
public:
    ComputePath(const SceneGpu &scene, const Swapchain &swapchain, const RendererOptions &options);
    ~ComputePath() override;

    void create_targets() override;
    void destroy_targets() override;
    void record(const FrameContext &frame) override;
    // The first write to the swapchain image is the blit.
    VkPipelineStageFlags acquire_stage() const override { return VK_PIPELINE_STAGE_TRANSFER_BIT; }

private:
    VkContext &context_;
    VkDevice device_;
    const Swapchain &swapchain_;
    OffscreenScene scene_;
    VkSampler sampler_;
    VkDescriptorSetLayout set_layout_ = VK_NULL_HANDLE;
    VkPipelineLayout layout_ = VK_NULL_HANDLE;
    VkPipeline pipeline_ = VK_NULL_HANDLE;
    DescriptorSets sets_;
    VkDescriptorSet set_;

    Image result_;
};

ComputePath::ComputePath(const SceneGpu &scene, const Swapchain &swapchain, const RendererOptions &options)
    : context_(scene.context()), device_(scene.device()), swapchain_(swapchain),
      scene_(scene, in_secondaries({{hdr_format}, {sky_radiance()}, SceneShading::hdr, options.eyes},
                                   options.scene_in_secondaries)),
      sampler_(create_sampler(device_, VK_FILTER_NEAREST)), sets_(device_, 1) {
    VkFormatProperties formats;
    vkGetPhysicalDeviceFormatProperties(context_.physical_device(), swapchain.format(), &formats);
    if (!(formats.optimalTilingFeatures & VK_FORMAT_FEATURE_BLIT_DST_BIT))
        throw Error("--path compute: the swapchain format cannot be blitted to");
    vkGetPhysicalDeviceFormatProperties(context_.physical_device(), result_format, &formats);
    if (!(formats.optimalTilingFeatures & VK_FORMAT_FEATURE_STORAGE_IMAGE_BIT) ||
        !(formats.optimalTilingFeatures & VK_FORMAT_FEATURE_BLIT_SRC_BIT))
        throw Error("--path compute: R16G16B16A16_SFLOAT cannot be a storage image and a blit source");

    const VkDescriptorSetLayoutBinding bindings[] = {
        {0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr},
        {1, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr},
    };
    VkDescriptorSetLayoutCreateInfo set_layout{};
    set_layout.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO;
    set_layout.bindingCount = 2;
    set_layout.pBindings = bindings;
    ATRIUM_VK_CHECK(vkCreateDescriptorSetLayout(device_, &set_layout, nullptr, &set_layout_));
    set_ = sets_.allocate(set_layout_);
    VkPipelineLayoutCreateInfo layout{};
    layout.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
    layout.setLayoutCount = 1;
    layout.pSetLayouts = &set_layout_;
    ATRIUM_VK_CHECK(vkCreatePipelineLayout(device_, &layout, nullptr, &layout_));

    const VkShaderModule module = create_shader(device_, spirv::post_comp, sizeof(spirv::post_comp));
    // Blitting into an sRGB swapchain encodes; into a UNORM one the shader encodes itself.
    const VkBool32 encode_srgb = takes_linear(swapchain.format()) ? VK_FALSE : VK_TRUE;
    const VkSpecializationMapEntry entry{0, 0, sizeof(VkBool32)};
    const VkSpecializationInfo specialization{1, &entry, sizeof(encode_srgb), &encode_srgb};
    VkComputePipelineCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO;
    info.stage.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
    info.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
    info.stage.module = module;
    info.stage.pName = "main";
    info.stage.pSpecializationInfo = &specialization;
    info.layout = layout_;
    const VkResult result = vkCreateComputePipelines(device_, VK_NULL_HANDLE, 1, &info, nullptr, &pipeline_);
    vkDestroyShaderModule(device_, module, nullptr);
    ATRIUM_VK_CHECK(result);
}

ComputePath::~ComputePath() {
    destroy_targets();
    vkDestroyPipeline(device_, pipeline_, nullptr);
    vkDestroyPipelineLayout(device_, layout_, nullptr);
    vkDestroyDescriptorSetLayout(device_, set_layout_, nullptr);
    vkDestroySampler(device_, sampler_, nullptr);
}

void ComputePath::create_targets() {
    const VkExtent2D extent = swapchain_.extent();
    scene_.create_targets(extent);
    result_ = create_target(context_, extent, result_format,
                            VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT);
    sets_.write_sampled(set_, {scene_.color(0)}, sampler_);
    sets_.write_storage(set_, 1, result_.view);
}

void ComputePath::destroy_targets() {
    context_.destroy(result_);
    scene_.destroy_targets();
}

void ComputePath::record(const FrameContext &frame) {
    const VkCommandBuffer cmd = frame.cmd;
    const VkExtent2D extent = swapchain_.extent();
    const VkImage swapchain_image = swapchain_.images()[frame.image];
    scene_.record(cmd, frame.slot);

    // The previous frame's blit has read the result: overwrite it (execution dependency only).
    const VkImageMemoryBarrier to_storage = image_barrier(result_.image, 0, VK_ACCESS_SHADER_WRITE_BIT,
                                                          VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_GENERAL);
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, 0, 0,
                         nullptr, 0, nullptr, 1, &to_storage);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline_);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout_, 0, 1, &set_, 0, nullptr);
    vkCmdDispatch(cmd, (extent.width + group_size - 1) / group_size,
                  (extent.height + group_size - 1) / group_size, 1);

    // The swapchain image's transition chains to the acquire semaphore's wait at TRANSFER.
    const VkImageMemoryBarrier to_blit[] = {
        image_barrier(result_.image, VK_ACCESS_SHADER_WRITE_BIT, VK_ACCESS_TRANSFER_READ_BIT,
                      VK_IMAGE_LAYOUT_GENERAL, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL),
        image_barrier(swapchain_image, 0, VK_ACCESS_TRANSFER_WRITE_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                      VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL),
    };
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
                         VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0, nullptr, 0, nullptr, 2, to_blit);
    VkImageBlit blit{};
    blit.srcSubresource = blit.dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    blit.srcOffsets[1] = blit.dstOffsets[1] = {int32_t(extent.width), int32_t(extent.height), 1};
    vkCmdBlitImage(cmd, result_.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, swapchain_image,
                   VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &blit, VK_FILTER_NEAREST);

    // To PRESENT_SRC (the present's semaphore waits for everything), or to TRANSFER_SRC for the
    // screenshot's copy.
    const VkImageMemoryBarrier done = image_barrier(
        swapchain_image, VK_ACCESS_TRANSFER_WRITE_BIT, frame.readback ? VK_ACCESS_TRANSFER_READ_BIT : 0,
        VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
        frame.readback ? VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL : VK_IMAGE_LAYOUT_PRESENT_SRC_KHR);
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT,
                         frame.readback ? VK_PIPELINE_STAGE_TRANSFER_BIT
                                        : VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT,
                         0, 0, nullptr, 0, nullptr, 1, &done);
}

} // namespace

std::unique_ptr<RenderPath> make_compute_path(const SceneGpu &scene, const Swapchain &swapchain,
                                              const RendererOptions &options) {
    return std::make_unique<ComputePath>(scene, swapchain, options);
}

} // namespace atrium
