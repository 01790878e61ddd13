#include "passes.h"

#include "atrium_spirv.h"
#include "pipeline.h"

#include <algorithm>

namespace atrium {

namespace {

bool is_depth(VkFormat format) {
    return format == VK_FORMAT_D32_SFLOAT || format == VK_FORMAT_D16_UNORM ||
           format == VK_FORMAT_D24_UNORM_S8_UINT;
}

VkAttachmentDescription describe(const Attachment &a) {
    VkAttachmentDescription d{};
    d.format = a.format;
    d.samples = VK_SAMPLE_COUNT_1_BIT;
    d.loadOp = a.load;
    d.storeOp = a.store;
    d.stencilLoadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
    d.stencilStoreOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
    d.initialLayout = a.initial;
    d.finalLayout = a.final;
    return d;
}

} // namespace

Image create_target(VkContext &context, VkExtent2D extent, VkFormat format, VkImageUsageFlags usage,
                    uint32_t layers) {
    VkImageCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO;
    info.imageType = VK_IMAGE_TYPE_2D;
    info.format = format;
    info.extent = {extent.width, extent.height, 1};
    info.mipLevels = 1;
    info.samples = VK_SAMPLE_COUNT_1_BIT;
    info.tiling = VK_IMAGE_TILING_OPTIMAL;
    info.usage = usage;
    info.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    info.arrayLayers = std::max(layers, 1u);
    return context.create_image(info,
                                is_depth(format) ? VK_IMAGE_ASPECT_DEPTH_BIT : VK_IMAGE_ASPECT_COLOR_BIT,
                                layers ? VK_IMAGE_VIEW_TYPE_2D_ARRAY : VK_IMAGE_VIEW_TYPE_2D);
}

VkExtent2D mip_extent(VkExtent2D extent, uint32_t level) {
    return {std::max(extent.width >> level, 1u), std::max(extent.height >> level, 1u)};
}

VkRenderPass create_render_pass(VkDevice device, const RenderPassInfo &info) {
    std::vector<VkAttachmentDescription> attachments;
    std::vector<VkAttachmentReference> color_refs;
    for (const Attachment &a : info.colors) {
        color_refs.push_back({uint32_t(attachments.size()), VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL});
        attachments.push_back(describe(a));
    }
    const VkAttachmentReference depth_ref{uint32_t(attachments.size()),
                                          VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL};
    if (info.depth) attachments.push_back(describe(*info.depth));

    VkSubpassDescription subpass{};
    subpass.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
    subpass.colorAttachmentCount = uint32_t(color_refs.size());
    subpass.pColorAttachments = color_refs.data();
    subpass.pDepthStencilAttachment = info.depth ? &depth_ref : nullptr;

    constexpr VkPipelineStageFlags attachment_stages = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT |
                                                       VK_PIPELINE_STAGE_EARLY_FRAGMENT_TESTS_BIT |
                                                       VK_PIPELINE_STAGE_LATE_FRAGMENT_TESTS_BIT;
    VkSubpassDependency deps[2] = {};
    // In: after every earlier write to (or read of) these images, by a pass, a dispatch or a
    // transfer; COLOR_ATTACHMENT_OUTPUT also chains to the acquire semaphore's wait.
    deps[0].srcSubpass = VK_SUBPASS_EXTERNAL;
    deps[0].dstSubpass = 0;
    deps[0].srcStageMask = attachment_stages | VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT |
                           VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT;
    deps[0].srcAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT |
                            VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT | VK_ACCESS_SHADER_WRITE_BIT |
                            VK_ACCESS_TRANSFER_WRITE_BIT;
    deps[0].dstStageMask = attachment_stages | VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT;
    deps[0].dstAccessMask = VK_ACCESS_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT |
                            VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_READ_BIT |
                            VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT | VK_ACCESS_SHADER_READ_BIT;
    // Out: to the passes, dispatches and copies that read what this one wrote.
    deps[1].srcSubpass = 0;
    deps[1].dstSubpass = VK_SUBPASS_EXTERNAL;
    deps[1].srcStageMask = attachment_stages;
    deps[1].srcAccessMask =
        VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT | VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
    deps[1].dstStageMask = VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT | VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT |
                           VK_PIPELINE_STAGE_TRANSFER_BIT;
    deps[1].dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_TRANSFER_READ_BIT;

    VkRenderPassMultiviewCreateInfo multiview{};
    multiview.sType = VK_STRUCTURE_TYPE_RENDER_PASS_MULTIVIEW_CREATE_INFO;
    multiview.subpassCount = 1;
    multiview.pViewMasks = &info.view_mask;
    multiview.correlationMaskCount = 1;
    multiview.pCorrelationMasks = &info.view_mask;
    VkRenderPassCreateInfo create{};
    create.sType = VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO;
    create.pNext = info.view_mask ? &multiview : nullptr;
    create.attachmentCount = uint32_t(attachments.size());
    create.pAttachments = attachments.data();
    create.subpassCount = 1;
    create.pSubpasses = &subpass;
    create.dependencyCount = info.dependencies.empty() ? 2 : uint32_t(info.dependencies.size());
    create.pDependencies = info.dependencies.empty() ? deps : info.dependencies.data();
    VkRenderPass pass;
    ATRIUM_VK_CHECK(vkCreateRenderPass(device, &create, nullptr, &pass));
    return pass;
}

VkRenderPass create_render_pass(VkDevice device, const Attachment &color) {
    RenderPassInfo info;
    info.colors = {color};
    return create_render_pass(device, info);
}

VkFramebuffer create_framebuffer(VkDevice device, VkRenderPass pass, const std::vector<VkImageView> &views,
                                 VkExtent2D extent) {
    VkFramebufferCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO;
    info.renderPass = pass;
    info.attachmentCount = uint32_t(views.size());
    info.pAttachments = views.data();
    info.width = extent.width;
    info.height = extent.height;
    info.layers = 1; // multiview passes render to the layers their view mask names
    VkFramebuffer framebuffer;
    ATRIUM_VK_CHECK(vkCreateFramebuffer(device, &info, nullptr, &framebuffer));
    return framebuffer;
}

void begin_pass(VkCommandBuffer cmd, VkRenderPass pass, VkFramebuffer framebuffer, VkExtent2D extent,
                const std::vector<VkClearValue> &clears, VkSubpassContents contents) {
    VkRenderPassBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO;
    begin.renderPass = pass;
    begin.framebuffer = framebuffer;
    begin.renderArea = {{0, 0}, extent};
    begin.clearValueCount = uint32_t(clears.size());
    begin.pClearValues = clears.data();
    vkCmdBeginRenderPass(cmd, &begin, contents);
}

void set_viewport(VkCommandBuffer cmd, VkRect2D rect) {
    const VkViewport viewport{float(rect.offset.x),
                              float(rect.offset.y),
                              float(rect.extent.width),
                              float(rect.extent.height),
                              0.0f,
                              1.0f};
    vkCmdSetViewport(cmd, 0, 1, &viewport);
    vkCmdSetScissor(cmd, 0, 1, &rect);
}

VkSampler create_sampler(VkDevice device, VkFilter filter) {
    VkSamplerCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO;
    info.magFilter = info.minFilter = filter;
    info.mipmapMode = VK_SAMPLER_MIPMAP_MODE_NEAREST;
    info.addressModeU = info.addressModeV = info.addressModeW = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
    VkSampler sampler;
    ATRIUM_VK_CHECK(vkCreateSampler(device, &info, nullptr, &sampler));
    return sampler;
}

SwapchainPass::SwapchainPass(VkDevice device, const Swapchain &swapchain)
    : device_(device), swapchain_(swapchain) {
    Attachment color{swapchain.format(), VK_ATTACHMENT_LOAD_OP_DONT_CARE, VK_ATTACHMENT_STORE_OP_STORE,
                     VK_IMAGE_LAYOUT_UNDEFINED, swapchain.final_layout()};
    present_ = create_render_pass(device, color);
    color.final = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    readback_ = create_render_pass(device, color);
}

SwapchainPass::~SwapchainPass() {
    destroy_framebuffers();
    vkDestroyRenderPass(device_, present_, nullptr);
    vkDestroyRenderPass(device_, readback_, nullptr);
}

void SwapchainPass::create_framebuffers() {
    for (VkImageView view : swapchain_.views())
        framebuffers_.push_back(create_framebuffer(device_, present_, {view}, swapchain_.extent()));
}

void SwapchainPass::destroy_framebuffers() {
    for (VkFramebuffer framebuffer : framebuffers_)
        vkDestroyFramebuffer(device_, framebuffer, nullptr);
    framebuffers_.clear();
}

void SwapchainPass::begin(VkCommandBuffer cmd, uint32_t image, bool readback) const {
    const VkExtent2D extent = swapchain_.extent();
    begin_pass(cmd, readback ? readback_ : present_, framebuffers_[image], extent);
    set_viewport(cmd, {{0, 0}, extent});
}

FullscreenPass::FullscreenPass(VkDevice device, const FullscreenInfo &info)
    : device_(device), has_frame_set_(info.frame_layout != VK_NULL_HANDLE), push_bytes_(info.push_bytes) {
    std::vector<VkDescriptorSetLayoutBinding> bindings;
    for (uint32_t i = 0; i < info.inputs; ++i)
        bindings.push_back(
            {i, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_FRAGMENT_BIT, nullptr});
    VkDescriptorSetLayoutCreateInfo set_layout{};
    set_layout.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO;
    set_layout.bindingCount = uint32_t(bindings.size());
    set_layout.pBindings = bindings.data();
    ATRIUM_VK_CHECK(vkCreateDescriptorSetLayout(device, &set_layout, nullptr, &inputs_layout_));

    const VkDescriptorSetLayout sets[] = {info.frame_layout, inputs_layout_};
    const VkPushConstantRange push{VK_SHADER_STAGE_FRAGMENT_BIT, 0, info.push_bytes};
    VkPipelineLayoutCreateInfo layout{};
    layout.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
    layout.setLayoutCount = has_frame_set_ ? 2 : 1;
    layout.pSetLayouts = has_frame_set_ ? sets : sets + 1;
    layout.pushConstantRangeCount = info.push_bytes ? 1 : 0;
    layout.pPushConstantRanges = &push;
    ATRIUM_VK_CHECK(vkCreatePipelineLayout(device, &layout, nullptr, &layout_));

    const VkBool32 encode_srgb = info.encode_srgb.value_or(false) ? VK_TRUE : VK_FALSE;
    const VkSpecializationMapEntry entry{0, 0, sizeof(VkBool32)};
    const VkSpecializationInfo specialization{1, &entry, sizeof(encode_srgb), &encode_srgb};
    GraphicsPipelineInfo pipeline;
    pipeline.vertex = {spirv::fullscreen_vert, sizeof(spirv::fullscreen_vert)};
    pipeline.fragment = {info.fragment, info.fragment_bytes, info.encode_srgb ? &specialization : nullptr};
    pipeline.additive = info.additive;
    pipeline.layout = layout_;
    pipeline.render_pass = info.render_pass;
    pipeline_ = create_graphics_pipeline(device, pipeline);
}

FullscreenPass::~FullscreenPass() {
    vkDestroyPipeline(device_, pipeline_, nullptr);
    vkDestroyPipelineLayout(device_, layout_, nullptr);
    vkDestroyDescriptorSetLayout(device_, inputs_layout_, nullptr);
}

void FullscreenPass::draw(VkCommandBuffer cmd, VkDescriptorSet inputs, const void *push,
                          VkDescriptorSet frame) const {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline_);
    const VkDescriptorSet sets[] = {frame, inputs};
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, layout_, 0, has_frame_set_ ? 2 : 1,
                            has_frame_set_ ? sets : sets + 1, 0, nullptr);
    if (push_bytes_) vkCmdPushConstants(cmd, layout_, VK_SHADER_STAGE_FRAGMENT_BIT, 0, push_bytes_, push);
    vkCmdDraw(cmd, 3, 1, 0, 0);
}

DescriptorSets::DescriptorSets(VkDevice device, uint32_t max_sets) : device_(device) {
    const VkDescriptorPoolSize sizes[] = {
        {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 4 * max_sets},
        {VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, max_sets},
    };
    VkDescriptorPoolCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
    info.maxSets = max_sets;
    info.poolSizeCount = 2;
    info.pPoolSizes = sizes;
    ATRIUM_VK_CHECK(vkCreateDescriptorPool(device, &info, nullptr, &pool_));
}

DescriptorSets::~DescriptorSets() {
    vkDestroyDescriptorPool(device_, pool_, nullptr);
}

VkDescriptorSet DescriptorSets::allocate(VkDescriptorSetLayout layout) {
    VkDescriptorSetAllocateInfo alloc{};
    alloc.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
    alloc.descriptorPool = pool_;
    alloc.descriptorSetCount = 1;
    alloc.pSetLayouts = &layout;
    VkDescriptorSet set;
    ATRIUM_VK_CHECK(vkAllocateDescriptorSets(device_, &alloc, &set));
    return set;
}

void DescriptorSets::write_sampled(VkDescriptorSet set, std::initializer_list<VkImageView> views,
                                   VkSampler sampler) {
    std::vector<VkDescriptorImageInfo> images;
    for (VkImageView view : views)
        images.push_back({sampler, view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL});
    std::vector<VkWriteDescriptorSet> writes;
    for (uint32_t i = 0; i < images.size(); ++i) {
        VkWriteDescriptorSet w{};
        w.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
        w.dstSet = set;
        w.dstBinding = i;
        w.descriptorCount = 1;
        w.descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
        w.pImageInfo = &images[i];
        writes.push_back(w);
    }
    vkUpdateDescriptorSets(device_, uint32_t(writes.size()), writes.data(), 0, nullptr);
}

void DescriptorSets::write_storage(VkDescriptorSet set, uint32_t binding, VkImageView view) {
    const VkDescriptorImageInfo image{VK_NULL_HANDLE, view, VK_IMAGE_LAYOUT_GENERAL};
    VkWriteDescriptorSet w{};
    w.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
    w.dstSet = set;
    w.dstBinding = binding;
    w.descriptorCount = 1;
    w.descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE;
    w.pImageInfo = &image;
    vkUpdateDescriptorSets(device_, 1, &w, 0, nullptr);
}

} // namespace atrium
