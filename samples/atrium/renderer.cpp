#include "renderer.h"

#include "atrium_spirv.h"
#include "linear_upload.h"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace atrium {

namespace {

constexpr VkFormat depth_format = VK_FORMAT_D32_SFLOAT;
constexpr VkFormat texture_format = VK_FORMAT_R8G8B8A8_SRGB;

struct PushConstants {
    uint32_t eye;
    float specular;
    float shininess;
};

// Lighting, linear RGB. The sky is the clear colour, given in sRGB bytes.
const glm::vec3 to_sun = glm::normalize(glm::vec3(0.38f, 0.88f, 0.28f));
const glm::vec3 sun_color(2.6f, 2.4f, 2.1f);
const glm::vec3 sky_ambient(0.30f, 0.36f, 0.46f);
const glm::vec3 ground_ambient(0.17f, 0.14f, 0.11f);
const glm::vec3 sky_srgb(135.0f / 255.0f, 180.0f / 255.0f, 235.0f / 255.0f);

bool is_srgb(VkFormat format) {
    return format == VK_FORMAT_B8G8R8A8_SRGB || format == VK_FORMAT_R8G8B8A8_SRGB;
}

float srgb_to_linear(float c) {
    return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
}

VkDeviceSize align_up(VkDeviceSize value, VkDeviceSize alignment) {
    return (value + alignment - 1) / alignment * alignment;
}

VkShaderModule create_shader(VkDevice device, const uint32_t *code, size_t bytes) {
    VkShaderModuleCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO;
    info.codeSize = bytes;
    info.pCode = code;
    VkShaderModule module;
    ATRIUM_VK_CHECK(vkCreateShaderModule(device, &info, nullptr, &module));
    return module;
}

} // namespace

Renderer::Renderer(VkContext &context, Swapchain &swapchain, const Scene &scene,
                   const std::vector<Texture> &textures, const CameraPath &camera,
                   const RendererOptions &options)
    : context_(context), swapchain_(swapchain), scene_(scene), camera_(camera), options_(options),
      device_(context.device()) {
    if (options_.dynamic_rendering) {
        cmd_begin_rendering_ = reinterpret_cast<PFN_vkCmdBeginRenderingKHR>(
            vkGetDeviceProcAddr(device_, "vkCmdBeginRenderingKHR"));
        cmd_end_rendering_ =
            reinterpret_cast<PFN_vkCmdEndRenderingKHR>(vkGetDeviceProcAddr(device_, "vkCmdEndRenderingKHR"));
        if (!cmd_begin_rendering_ || !cmd_end_rendering_) throw Error("vkCmdBeginRenderingKHR is missing");
    }
    upload(scene, textures);
    create_descriptors(textures.size());
    present_pass_ = create_render_pass(VK_IMAGE_LAYOUT_PRESENT_SRC_KHR);
    if (options_.screenshot_frame) readback_pass_ = create_render_pass(VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
    create_pipeline(scene.double_sided);
    create_targets();

    for (FrameSlot &slot : slots_) {
        VkCommandPoolCreateInfo pool{};
        pool.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
        pool.flags = VK_COMMAND_POOL_CREATE_TRANSIENT_BIT;
        pool.queueFamilyIndex = context_.queue_family();
        ATRIUM_VK_CHECK(vkCreateCommandPool(device_, &pool, nullptr, &slot.pool));
        VkCommandBufferAllocateInfo alloc{};
        alloc.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
        alloc.commandPool = slot.pool;
        alloc.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
        alloc.commandBufferCount = 1;
        ATRIUM_VK_CHECK(vkAllocateCommandBuffers(device_, &alloc, &slot.commands));
        VkFenceCreateInfo fence{};
        fence.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
        fence.flags = VK_FENCE_CREATE_SIGNALED_BIT;
        ATRIUM_VK_CHECK(vkCreateFence(device_, &fence, nullptr, &slot.done));
        VkSemaphoreCreateInfo semaphore{};
        semaphore.sType = VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO;
        ATRIUM_VK_CHECK(vkCreateSemaphore(device_, &semaphore, nullptr, &slot.acquired));
    }
}

Renderer::~Renderer() {
    vkDeviceWaitIdle(device_);
    for (FrameSlot &slot : slots_) {
        vkDestroySemaphore(device_, slot.acquired, nullptr);
        vkDestroyFence(device_, slot.done, nullptr);
        vkDestroyCommandPool(device_, slot.pool, nullptr);
    }
    destroy_targets();
    context_.destroy(readback_);
    vkDestroyPipeline(device_, pipeline_, nullptr);
    for (VkPipeline eye_pipeline : eye_pipelines_)
        vkDestroyPipeline(device_, eye_pipeline, nullptr);
    vkDestroyPipelineLayout(device_, pipeline_layout_, nullptr);
    vkDestroyRenderPass(device_, present_pass_, nullptr);
    vkDestroyRenderPass(device_, readback_pass_, nullptr);
    vkDestroyDescriptorPool(device_, descriptor_pool_, nullptr);
    vkDestroyDescriptorSetLayout(device_, frame_layout_, nullptr);
    vkDestroyDescriptorSetLayout(device_, material_layout_, nullptr);
    vkDestroySampler(device_, sampler_, nullptr);
    for (Image &texture : textures_)
        context_.destroy(texture);
    context_.destroy(uniforms_);
    context_.destroy(indices_);
    context_.destroy(vertices_);
}

void Renderer::upload(const Scene &scene, const std::vector<Texture> &textures) {
    const VkDeviceSize vertex_bytes = scene.vertices.size() * sizeof(Vertex);
    const VkDeviceSize index_bytes = scene.indices.size() * sizeof(uint32_t);
    VkDeviceSize staging_bytes = align_up(vertex_bytes, 16) + align_up(index_bytes, 16);
    std::optional<LinearUpload> linear;
    if (options_.linear_textures)
        linear.emplace(context_, textures, texture_format);
    else
        for (const Texture &t : textures)
            staging_bytes += align_up(t.texels.size(), 16);

    Buffer staging =
        context_.create_buffer(staging_bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                               VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT);
    auto *bytes = static_cast<uint8_t *>(staging.mapped);
    VkDeviceSize offset = 0;
    const auto stage = [&](const void *data, VkDeviceSize size) {
        std::memcpy(bytes + offset, data, size);
        const VkDeviceSize at = offset;
        offset += align_up(size, 16);
        return at;
    };
    const VkDeviceSize vertex_offset = stage(scene.vertices.data(), vertex_bytes);
    const VkDeviceSize index_offset = stage(scene.indices.data(), index_bytes);

    vertices_ = context_.create_buffer(vertex_bytes,
                                       VK_BUFFER_USAGE_VERTEX_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                       VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
    indices_ = context_.create_buffer(index_bytes,
                                      VK_BUFFER_USAGE_INDEX_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                      VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);

    VkCommandPoolCreateInfo pool_info{};
    pool_info.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
    pool_info.flags = VK_COMMAND_POOL_CREATE_TRANSIENT_BIT;
    pool_info.queueFamilyIndex = context_.queue_family();
    VkCommandPool pool;
    ATRIUM_VK_CHECK(vkCreateCommandPool(device_, &pool_info, nullptr, &pool));
    VkCommandBufferAllocateInfo alloc{};
    alloc.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
    alloc.commandPool = pool;
    alloc.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    alloc.commandBufferCount = 1;
    VkCommandBuffer cmd;
    ATRIUM_VK_CHECK(vkAllocateCommandBuffers(device_, &alloc, &cmd));
    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    ATRIUM_VK_CHECK(vkBeginCommandBuffer(cmd, &begin));

    const VkBufferCopy vertex_copy{vertex_offset, 0, vertex_bytes}, index_copy{index_offset, 0, index_bytes};
    vkCmdCopyBuffer(cmd, staging.buffer, vertices_.buffer, 1, &vertex_copy);
    vkCmdCopyBuffer(cmd, staging.buffer, indices_.buffer, 1, &index_copy);

    std::vector<VkImageMemoryBarrier> to_transfer, to_shader;
    for (const Texture &t : textures) {
        VkImageCreateInfo info{};
        info.sType = VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO;
        info.imageType = VK_IMAGE_TYPE_2D;
        info.format = texture_format;
        info.extent = {t.size, t.size, 1};
        info.mipLevels = t.levels;
        info.arrayLayers = 1;
        info.samples = VK_SAMPLE_COUNT_1_BIT;
        info.tiling = VK_IMAGE_TILING_OPTIMAL;
        info.usage = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
        info.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
        textures_.push_back(context_.create_image(info, VK_IMAGE_ASPECT_COLOR_BIT));

        VkImageMemoryBarrier b{};
        b.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER;
        b.srcQueueFamilyIndex = b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
        b.image = textures_.back().image;
        b.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, t.levels, 0, 1};
        b.srcAccessMask = 0;
        b.dstAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
        b.oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;
        b.newLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
        to_transfer.push_back(b);
        b.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
        b.dstAccessMask = VK_ACCESS_SHADER_READ_BIT;
        b.oldLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
        b.newLayout = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL;
        to_shader.push_back(b);
    }
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0,
                         nullptr, 0, nullptr, uint32_t(to_transfer.size()), to_transfer.data());
    if (linear) linear->record(cmd, textures_);
    for (size_t i = 0; i < textures.size() && !linear; ++i) {
        const Texture &t = textures[i];
        const VkDeviceSize base = stage(t.texels.data(), t.texels.size());
        std::vector<VkBufferImageCopy> regions;
        for (uint32_t level = 0; level < t.levels; ++level) {
            VkBufferImageCopy r{};
            r.bufferOffset = base + t.level_offset[level];
            r.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, level, 0, 1};
            r.imageExtent = {t.size >> level, t.size >> level, 1};
            regions.push_back(r);
        }
        vkCmdCopyBufferToImage(cmd, staging.buffer, textures_[i].image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                               uint32_t(regions.size()), regions.data());
    }

    // Make the copies visible to vertex input and fragment shading of every later submission.
    VkBufferMemoryBarrier buffers[2] = {};
    for (VkBufferMemoryBarrier &b : buffers) {
        b.sType = VK_STRUCTURE_TYPE_BUFFER_MEMORY_BARRIER;
        b.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
        b.srcQueueFamilyIndex = b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
        b.size = VK_WHOLE_SIZE;
    }
    buffers[0].dstAccessMask = VK_ACCESS_VERTEX_ATTRIBUTE_READ_BIT;
    buffers[0].buffer = vertices_.buffer;
    buffers[1].dstAccessMask = VK_ACCESS_INDEX_READ_BIT;
    buffers[1].buffer = indices_.buffer;
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT,
                         VK_PIPELINE_STAGE_VERTEX_INPUT_BIT | VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT, 0, 0,
                         nullptr, 2, buffers, uint32_t(to_shader.size()), to_shader.data());
    ATRIUM_VK_CHECK(vkEndCommandBuffer(cmd));

    VkFenceCreateInfo fence_info{};
    fence_info.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
    VkFence fence;
    ATRIUM_VK_CHECK(vkCreateFence(device_, &fence_info, nullptr, &fence));
    VkSubmitInfo submit{};
    submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
    submit.commandBufferCount = 1;
    submit.pCommandBuffers = &cmd;
    ATRIUM_VK_CHECK(vkQueueSubmit(context_.queue(), 1, &submit, fence));
    ATRIUM_VK_CHECK(vkWaitForFences(device_, 1, &fence, VK_TRUE, UINT64_MAX));
    vkDestroyFence(device_, fence, nullptr);
    vkDestroyCommandPool(device_, pool, nullptr);
    context_.destroy(staging);

    VkSamplerCreateInfo sampler{};
    sampler.sType = VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO;
    sampler.magFilter = sampler.minFilter = VK_FILTER_LINEAR;
    sampler.mipmapMode = VK_SAMPLER_MIPMAP_MODE_LINEAR;
    sampler.addressModeU = sampler.addressModeV = sampler.addressModeW = VK_SAMPLER_ADDRESS_MODE_REPEAT;
    sampler.maxLod = VK_LOD_CLAMP_NONE;
    ATRIUM_VK_CHECK(vkCreateSampler(device_, &sampler, nullptr, &sampler_));
}

void Renderer::create_descriptors(size_t textures) {
    VkDescriptorSetLayoutBinding frame_binding{0, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1,
                                               VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT,
                                               nullptr};
    VkDescriptorSetLayoutCreateInfo layout{};
    layout.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO;
    layout.bindingCount = 1;
    layout.pBindings = &frame_binding;
    ATRIUM_VK_CHECK(vkCreateDescriptorSetLayout(device_, &layout, nullptr, &frame_layout_));
    VkDescriptorSetLayoutBinding material_binding{0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1,
                                                  VK_SHADER_STAGE_FRAGMENT_BIT, nullptr};
    layout.pBindings = &material_binding;
    ATRIUM_VK_CHECK(vkCreateDescriptorSetLayout(device_, &layout, nullptr, &material_layout_));

    const VkDescriptorPoolSize sizes[] = {
        {VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, frames_in_flight},
        {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, uint32_t(textures)},
    };
    VkDescriptorPoolCreateInfo pool{};
    pool.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
    pool.maxSets = frames_in_flight + uint32_t(textures);
    pool.poolSizeCount = 2;
    pool.pPoolSizes = sizes;
    ATRIUM_VK_CHECK(vkCreateDescriptorPool(device_, &pool, nullptr, &descriptor_pool_));

    // One uniform block per frame in flight, in one persistently mapped host-coherent buffer: the
    // CPU rewrites a slot's block only after waiting for the slot's fence.
    const VkDeviceSize stride =
        align_up(sizeof(FrameUniforms), context_.properties().limits.minUniformBufferOffsetAlignment);
    uniforms_ =
        context_.create_buffer(stride * frames_in_flight, VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT,
                               VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT);

    std::vector<VkDescriptorSetLayout> layouts(frames_in_flight, frame_layout_);
    layouts.insert(layouts.end(), textures, material_layout_);
    std::vector<VkDescriptorSet> sets(layouts.size());
    VkDescriptorSetAllocateInfo alloc{};
    alloc.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
    alloc.descriptorPool = descriptor_pool_;
    alloc.descriptorSetCount = uint32_t(layouts.size());
    alloc.pSetLayouts = layouts.data();
    ATRIUM_VK_CHECK(vkAllocateDescriptorSets(device_, &alloc, sets.data()));

    std::vector<VkDescriptorBufferInfo> buffer_infos(frames_in_flight);
    std::vector<VkDescriptorImageInfo> image_infos(textures);
    std::vector<VkWriteDescriptorSet> writes;
    for (uint32_t i = 0; i < frames_in_flight; ++i) {
        slots_[i].frame_set = sets[i];
        slots_[i].uniforms =
            reinterpret_cast<FrameUniforms *>(static_cast<uint8_t *>(uniforms_.mapped) + i * stride);
        buffer_infos[i] = {uniforms_.buffer, i * stride, sizeof(FrameUniforms)};
        VkWriteDescriptorSet w{};
        w.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
        w.dstSet = sets[i];
        w.descriptorCount = 1;
        w.descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
        w.pBufferInfo = &buffer_infos[i];
        writes.push_back(w);
    }
    for (size_t t = 0; t < textures; ++t) {
        texture_sets_.push_back(sets[frames_in_flight + t]);
        image_infos[t] = {sampler_, textures_[t].view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
        VkWriteDescriptorSet w{};
        w.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
        w.dstSet = texture_sets_.back();
        w.descriptorCount = 1;
        w.descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
        w.pImageInfo = &image_infos[t];
        writes.push_back(w);
    }
    vkUpdateDescriptorSets(device_, uint32_t(writes.size()), writes.data(), 0, nullptr);
}

VkRenderPass Renderer::create_render_pass(VkImageLayout final_layout) {
    VkAttachmentDescription attachments[2] = {};
    attachments[0].format = swapchain_.format();
    attachments[0].samples = VK_SAMPLE_COUNT_1_BIT;
    attachments[0].loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
    attachments[0].storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    attachments[0].stencilLoadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
    attachments[0].stencilStoreOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
    attachments[0].initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    attachments[0].finalLayout = final_layout;
    attachments[1] = attachments[0];
    attachments[1].format = depth_format;
    attachments[1].storeOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
    attachments[1].finalLayout = VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL;

    const VkAttachmentReference color_ref{0, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
    const VkAttachmentReference depth_ref{1, VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL};
    VkSubpassDescription subpass{};
    subpass.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
    subpass.colorAttachmentCount = 1;
    subpass.pColorAttachments = &color_ref;
    subpass.pDepthStencilAttachment = &depth_ref;

    VkSubpassDependency deps[2] = {};
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

    VkRenderPassCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO;
    info.attachmentCount = 2;
    info.pAttachments = attachments;
    info.subpassCount = 1;
    info.pSubpasses = &subpass;
    info.dependencyCount = 2;
    info.pDependencies = deps;
    VkRenderPass pass;
    ATRIUM_VK_CHECK(vkCreateRenderPass(device_, &info, nullptr, &pass));
    return pass;
}

void Renderer::create_pipeline(bool double_sided) {
    const VkDescriptorSetLayout set_layouts[] = {frame_layout_, material_layout_};
    const VkPushConstantRange push{VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0,
                                   sizeof(PushConstants)};
    VkPipelineLayoutCreateInfo layout{};
    layout.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
    layout.setLayoutCount = 2;
    layout.pSetLayouts = set_layouts;
    layout.pushConstantRangeCount = 1;
    layout.pPushConstantRanges = &push;
    ATRIUM_VK_CHECK(vkCreatePipelineLayout(device_, &layout, nullptr, &pipeline_layout_));

    const VkShaderModule vert = create_shader(device_, spirv::scene_vert, sizeof(spirv::scene_vert));
    const VkShaderModule frag = create_shader(device_, spirv::scene_frag, sizeof(spirv::scene_frag));
    const VkBool32 encode_srgb = is_srgb(swapchain_.format()) ? VK_FALSE : VK_TRUE;
    const VkSpecializationMapEntry entry{0, 0, sizeof(VkBool32)};
    const VkSpecializationInfo specialization{1, &entry, sizeof(encode_srgb), &encode_srgb};
    VkPipelineShaderStageCreateInfo stages[2] = {};
    stages[0].sType = stages[1].sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
    stages[0].stage = VK_SHADER_STAGE_VERTEX_BIT;
    stages[0].module = vert;
    stages[0].pName = "main";
    stages[1].stage = VK_SHADER_STAGE_FRAGMENT_BIT;
    stages[1].module = frag;
    stages[1].pName = "main";
    stages[1].pSpecializationInfo = &specialization;

    const VkVertexInputBindingDescription binding{0, sizeof(Vertex), VK_VERTEX_INPUT_RATE_VERTEX};
    const VkVertexInputAttributeDescription attributes[] = {
        {0, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(Vertex, position)},
        {1, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(Vertex, normal)},
        {2, 0, VK_FORMAT_R32G32_SFLOAT, offsetof(Vertex, uv)},
    };
    VkPipelineVertexInputStateCreateInfo vertex_input{};
    vertex_input.sType = VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO;
    vertex_input.vertexBindingDescriptionCount = 1;
    vertex_input.pVertexBindingDescriptions = &binding;
    vertex_input.vertexAttributeDescriptionCount = 3;
    vertex_input.pVertexAttributeDescriptions = attributes;
    VkPipelineInputAssemblyStateCreateInfo assembly{};
    assembly.sType = VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO;
    assembly.topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
    VkPipelineViewportStateCreateInfo viewport{};
    viewport.sType = VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO;
    viewport.viewportCount = 1;
    viewport.scissorCount = 1;
    VkPipelineRasterizationStateCreateInfo raster{};
    raster.sType = VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO;
    raster.polygonMode = VK_POLYGON_MODE_FILL;
    raster.cullMode = double_sided ? VK_CULL_MODE_NONE : VK_CULL_MODE_BACK_BIT;
    // Counter-clockwise in world space stays counter-clockwise on screen because the projection
    // flips y (Vulkan's framebuffer y points down).
    raster.frontFace = VK_FRONT_FACE_COUNTER_CLOCKWISE;
    raster.lineWidth = 1.0f;
    VkPipelineMultisampleStateCreateInfo multisample{};
    multisample.sType = VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO;
    multisample.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;
    VkPipelineDepthStencilStateCreateInfo depth{};
    depth.sType = VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO;
    depth.depthTestEnable = VK_TRUE;
    depth.depthWriteEnable = VK_TRUE;
    depth.depthCompareOp = VK_COMPARE_OP_LESS;
    VkPipelineColorBlendAttachmentState blend_attachment{};
    blend_attachment.colorWriteMask = VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_G_BIT |
                                      VK_COLOR_COMPONENT_B_BIT | VK_COLOR_COMPONENT_A_BIT;
    VkPipelineColorBlendStateCreateInfo blend{};
    blend.sType = VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO;
    blend.attachmentCount = 1;
    blend.pAttachments = &blend_attachment;
    const VkDynamicState dynamic_states[] = {VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR};
    VkPipelineDynamicStateCreateInfo dynamic{};
    dynamic.sType = VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO;
    dynamic.dynamicStateCount = 2;
    dynamic.pDynamicStates = dynamic_states;

    VkGraphicsPipelineCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO;
    info.stageCount = 2;
    info.pStages = stages;
    info.pVertexInputState = &vertex_input;
    info.pInputAssemblyState = &assembly;
    info.pViewportState = &viewport;
    info.pRasterizationState = &raster;
    info.pMultisampleState = &multisample;
    info.pDepthStencilState = &depth;
    info.pColorBlendState = &blend;
    info.pDynamicState = &dynamic;
    info.layout = pipeline_layout_;
    info.renderPass = present_pass_;
    info.subpass = 0;
    const VkFormat color_format = swapchain_.format();
    VkPipelineRenderingCreateInfoKHR rendering{};
    rendering.sType = VK_STRUCTURE_TYPE_PIPELINE_RENDERING_CREATE_INFO_KHR;
    rendering.colorAttachmentCount = 1;
    rendering.pColorAttachmentFormats = &color_format;
    rendering.depthAttachmentFormat = depth_format;
    if (options_.dynamic_rendering) {
        info.pNext = &rendering;
        info.renderPass = VK_NULL_HANDLE;
    }
    VkResult result = vkCreateGraphicsPipelines(device_, VK_NULL_HANDLE, 1, &info, nullptr, &pipeline_);
    // Static state exercises the layer's other path: it must make these dynamic to scale them.
    const VkExtent2D extent = swapchain_.extent();
    for (uint32_t eye = 0; options_.static_viewports && result == VK_SUCCESS && eye < options_.eyes; ++eye) {
        const uint32_t x = eye == 0 ? 0 : extent.width / options_.eyes;
        const uint32_t width = eye + 1 == options_.eyes ? extent.width - x : extent.width / options_.eyes;
        const VkViewport eye_viewport{float(x), 0.0f, float(width), float(extent.height), 0.0f, 1.0f};
        const VkRect2D eye_scissor{{int32_t(x), 0}, {width, extent.height}};
        VkPipelineViewportStateCreateInfo fixed = viewport;
        fixed.pViewports = &eye_viewport;
        fixed.pScissors = &eye_scissor;
        VkGraphicsPipelineCreateInfo eye_info = info;
        eye_info.pViewportState = &fixed;
        eye_info.pDynamicState = nullptr;
        result =
            vkCreateGraphicsPipelines(device_, VK_NULL_HANDLE, 1, &eye_info, nullptr, &eye_pipelines_[eye]);
    }
    vkDestroyShaderModule(device_, vert, nullptr);
    vkDestroyShaderModule(device_, frag, nullptr);
    ATRIUM_VK_CHECK(result);
}

void Renderer::create_targets() {
    const VkExtent2D extent = swapchain_.extent();
    VkImageCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO;
    info.imageType = VK_IMAGE_TYPE_2D;
    info.format = depth_format;
    info.extent = {extent.width, extent.height, 1};
    info.mipLevels = 1;
    info.arrayLayers = 1;
    info.samples = VK_SAMPLE_COUNT_1_BIT;
    info.tiling = VK_IMAGE_TILING_OPTIMAL;
    info.usage = VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT;
    info.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    depth_ = context_.create_image(info, VK_IMAGE_ASPECT_DEPTH_BIT);

    for (VkImageView view : swapchain_.views()) {
        const VkImageView attachments[] = {view, depth_.view};
        VkFramebufferCreateInfo fb{};
        fb.sType = VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO;
        fb.renderPass = present_pass_; // also compatible with readback_pass_
        fb.attachmentCount = 2;
        fb.pAttachments = attachments;
        fb.width = extent.width;
        fb.height = extent.height;
        fb.layers = 1;
        framebuffers_.push_back(VK_NULL_HANDLE);
        ATRIUM_VK_CHECK(vkCreateFramebuffer(device_, &fb, nullptr, &framebuffers_.back()));
        VkSemaphoreCreateInfo semaphore{};
        semaphore.sType = VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO;
        rendered_.push_back(VK_NULL_HANDLE);
        ATRIUM_VK_CHECK(vkCreateSemaphore(device_, &semaphore, nullptr, &rendered_.back()));
    }
}

void Renderer::destroy_targets() {
    for (VkSemaphore s : rendered_)
        vkDestroySemaphore(device_, s, nullptr);
    for (VkFramebuffer fb : framebuffers_)
        vkDestroyFramebuffer(device_, fb, nullptr);
    rendered_.clear();
    framebuffers_.clear();
    context_.destroy(depth_);
}

void Renderer::recreate_swapchain() {
    wait_idle();
    destroy_targets();
    swapchain_.recreate();
    create_targets();
}

// What the render pass's layouts and external dependencies do (create_render_pass), as barriers.
void Renderer::begin_rendering(VkCommandBuffer cmd, uint32_t image, VkExtent2D extent,
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
    info.layerCount = 1;
    info.colorAttachmentCount = 1;
    info.pColorAttachments = &color;
    info.pDepthAttachment = &depth;
    cmd_begin_rendering_(cmd, &info);
}

void Renderer::end_rendering(VkCommandBuffer cmd, uint32_t image, bool readback) {
    cmd_end_rendering_(cmd);
    // To PRESENT_SRC (the present's semaphore waits for everything), or to TRANSFER_SRC for the
    // screenshot's copy, which reads what was rendered.
    VkImageMemoryBarrier barrier{};
    barrier.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER;
    barrier.srcAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
    barrier.dstAccessMask = readback ? VK_ACCESS_TRANSFER_READ_BIT : 0;
    barrier.oldLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
    barrier.newLayout = readback ? VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL : VK_IMAGE_LAYOUT_PRESENT_SRC_KHR;
    barrier.srcQueueFamilyIndex = barrier.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    barrier.image = swapchain_.images()[image];
    barrier.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT,
                         readback ? VK_PIPELINE_STAGE_TRANSFER_BIT : VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, 0,
                         0, nullptr, 0, nullptr, 1, &barrier);
}

void Renderer::wait_idle() {
    ATRIUM_VK_CHECK(vkDeviceWaitIdle(device_));
}

void Renderer::update_uniforms(FrameSlot &slot, uint64_t frame) {
    const VkExtent2D extent = swapchain_.extent();
    FrameUniforms u{};
    for (uint32_t eye = 0; eye < options_.eyes; ++eye) {
        const uint32_t width =
            eye == 0 ? extent.width / options_.eyes : extent.width - extent.width / options_.eyes;
        const EyeView view = camera_.eye_view(frame, eye, options_.eyes, float(width) / float(extent.height));
        u.view_proj[eye] = view.view_proj;
        u.eye_position[eye] = glm::vec4(view.position, 1.0f);
    }
    if (options_.eyes == 1) {
        u.view_proj[1] = u.view_proj[0];
        u.eye_position[1] = u.eye_position[0];
    }
    u.sun_direction = glm::vec4(to_sun, 0.0f);
    u.sun_color = glm::vec4(sun_color, 1.0f);
    u.sky_color = glm::vec4(sky_ambient, 1.0f);
    u.ground_color = glm::vec4(ground_ambient, 1.0f);
    const SunOcclusion &occlusion = scene_.sun_occlusion;
    u.sun_opening = occlusion.enabled ? occlusion.opening : glm::vec4(1.0f, 0.0f, 0.0f, 0.0f);
    u.sun_facades = occlusion.facades;
    u.sun_params = glm::vec4(occlusion.roof_height, 0.0f, 0.0f, 0.0f);
    std::memcpy(slot.uniforms, &u, sizeof(u));
}

void Renderer::record(FrameSlot &slot, uint32_t image, bool readback) {
    const VkExtent2D extent = swapchain_.extent();
    VkCommandBuffer cmd = slot.commands;
    ATRIUM_VK_CHECK(vkResetCommandPool(device_, slot.pool, 0));
    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    ATRIUM_VK_CHECK(vkBeginCommandBuffer(cmd, &begin));

    // A UNORM swapchain stores the clear colour as given; an SRGB one encodes it.
    const glm::vec3 sky =
        is_srgb(swapchain_.format())
            ? glm::vec3(srgb_to_linear(sky_srgb.r), srgb_to_linear(sky_srgb.g), srgb_to_linear(sky_srgb.b))
            : sky_srgb;
    VkClearValue clears[2] = {};
    clears[0].color = {{sky.r, sky.g, sky.b, 1.0f}};
    clears[1].depthStencil = {1.0f, 0};
    VkRenderPassBeginInfo pass{};
    pass.sType = VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO;
    pass.renderPass = readback ? readback_pass_ : present_pass_;
    pass.framebuffer = framebuffers_[image];
    pass.renderArea = {{0, 0}, extent};
    pass.clearValueCount = 2;
    pass.pClearValues = clears;
    if (options_.dynamic_rendering)
        begin_rendering(cmd, image, extent, clears);
    else
        vkCmdBeginRenderPass(cmd, &pass, VK_SUBPASS_CONTENTS_INLINE);

    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline_);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline_layout_, 0, 1, &slot.frame_set, 0,
                            nullptr);
    const VkDeviceSize zero = 0;
    vkCmdBindVertexBuffers(cmd, 0, 1, &vertices_.buffer, &zero);
    vkCmdBindIndexBuffer(cmd, indices_.buffer, 0, VK_INDEX_TYPE_UINT32);

    for (uint32_t eye = 0; eye < options_.eyes; ++eye) {
        // Eye 0 is the left half [0, W/2), eye 1 the right half.
        const uint32_t x = eye == 0 ? 0 : extent.width / options_.eyes;
        const uint32_t width = eye + 1 == options_.eyes ? extent.width - x : extent.width / options_.eyes;
        const VkViewport viewport{float(x), 0.0f, float(width), float(extent.height), 0.0f, 1.0f};
        const VkRect2D scissor{{int32_t(x), 0}, {width, extent.height}};
        if (options_.static_viewports) {
            vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, eye_pipelines_[eye]);
        } else {
            vkCmdSetViewport(cmd, 0, 1, &viewport);
            vkCmdSetScissor(cmd, 0, 1, &scissor);
        }
        if (options_.clear_depth_per_eye) {
            VkClearAttachment clear{};
            clear.aspectMask = VK_IMAGE_ASPECT_DEPTH_BIT;
            clear.clearValue.depthStencil = {1.0f, 0};
            const VkClearRect rect{scissor, 0, 1};
            vkCmdClearAttachments(cmd, 1, &clear, 1, &rect);
        }
        uint32_t bound_texture = UINT32_MAX;
        for (const DrawRange &draw : scene_.draws) {
            const Material &material = scene_.materials[draw.material];
            if (material.texture != bound_texture) {
                bound_texture = material.texture;
                vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline_layout_, 1, 1,
                                        &texture_sets_[bound_texture], 0, nullptr);
            }
            const PushConstants push{eye, material.specular, material.shininess};
            vkCmdPushConstants(cmd, pipeline_layout_,
                               VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0, sizeof(push),
                               &push);
            vkCmdDrawIndexed(cmd, draw.index_count, 1, draw.first_index, 0, 0);
        }
    }
    if (options_.dynamic_rendering)
        end_rendering(cmd, image, readback);
    else
        vkCmdEndRenderPass(cmd);

    if (readback) {
        VkBufferImageCopy region{};
        region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
        region.imageExtent = {extent.width, extent.height, 1};
        const VkImage swapchain_image = swapchain_.images()[image];
        vkCmdCopyImageToBuffer(cmd, swapchain_image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, readback_.buffer,
                               1, &region);
        // Back to PRESENT_SRC once the copy has read the image (an execution dependency suffices
        // for a write after a read), and make the copied bytes visible to the host.
        VkImageMemoryBarrier to_present{};
        to_present.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER;
        to_present.srcAccessMask = 0;
        to_present.dstAccessMask = 0;
        to_present.oldLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
        to_present.newLayout = VK_IMAGE_LAYOUT_PRESENT_SRC_KHR;
        to_present.srcQueueFamilyIndex = to_present.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
        to_present.image = swapchain_image;
        to_present.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
        VkBufferMemoryBarrier to_host{};
        to_host.sType = VK_STRUCTURE_TYPE_BUFFER_MEMORY_BARRIER;
        to_host.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
        to_host.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
        to_host.srcQueueFamilyIndex = to_host.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
        to_host.buffer = readback_.buffer;
        to_host.size = VK_WHOLE_SIZE;
        vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT,
                             VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT | VK_PIPELINE_STAGE_HOST_BIT, 0, 0, nullptr,
                             1, &to_host, 1, &to_present);
    }
    ATRIUM_VK_CHECK(vkEndCommandBuffer(cmd));
}

void Renderer::draw_frame(uint64_t frame) {
    FrameSlot &slot = slots_[slot_index_];
    ATRIUM_VK_CHECK(vkWaitForFences(device_, 1, &slot.done, VK_TRUE, UINT64_MAX));

    uint32_t image = 0;
    bool stale = false;
    for (;;) {
        const VkResult r = vkAcquireNextImageKHR(device_, swapchain_.handle(), UINT64_MAX, slot.acquired,
                                                 VK_NULL_HANDLE, &image);
        if (r == VK_ERROR_OUT_OF_DATE_KHR) {
            recreate_swapchain(); // nothing was signalled: slot.acquired is still unsignalled
            continue;
        }
        if (r != VK_SUBOPTIMAL_KHR) ATRIUM_VK_CHECK(r);
        stale = r == VK_SUBOPTIMAL_KHR; // usable now; replaced after presenting
        break;
    }
    // Reset only once a submission that signals the fence is certain to follow.
    ATRIUM_VK_CHECK(vkResetFences(device_, 1, &slot.done));

    const bool readback = options_.screenshot_frame && *options_.screenshot_frame == frame;
    if (readback) {
        const VkExtent2D extent = swapchain_.extent();
        context_.destroy(readback_);
        readback_ = context_.create_buffer(
            VkDeviceSize(extent.width) * extent.height * 4, VK_BUFFER_USAGE_TRANSFER_DST_BIT,
            VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT);
        readback_extent_ = extent;
    }
    update_uniforms(slot, frame);
    record(slot, image, readback);

    const VkPipelineStageFlags wait_stage = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
    VkSubmitInfo submit{};
    submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
    submit.waitSemaphoreCount = 1;
    submit.pWaitSemaphores = &slot.acquired;
    submit.pWaitDstStageMask = &wait_stage;
    submit.commandBufferCount = 1;
    submit.pCommandBuffers = &slot.commands;
    submit.signalSemaphoreCount = 1;
    submit.pSignalSemaphores = &rendered_[image];
    ATRIUM_VK_CHECK(vkQueueSubmit(context_.queue(), 1, &submit, slot.done));
    if (readback) screenshot_taken_ = true;

    // The semaphore belongs to the image, not to the slot: the presentation engine is done with it
    // only when the image is acquired again.
    const VkSwapchainKHR handle = swapchain_.handle();
    VkPresentInfoKHR present{};
    present.sType = VK_STRUCTURE_TYPE_PRESENT_INFO_KHR;
    present.waitSemaphoreCount = 1;
    present.pWaitSemaphores = &rendered_[image];
    present.swapchainCount = 1;
    present.pSwapchains = &handle;
    present.pImageIndices = &image;
    const VkResult r = vkQueuePresentKHR(context_.queue(), &present);
    if (r == VK_ERROR_OUT_OF_DATE_KHR || r == VK_SUBOPTIMAL_KHR || stale)
        recreate_swapchain();
    else
        ATRIUM_VK_CHECK(r);
    slot_index_ = (slot_index_ + 1) % frames_in_flight;
}

std::optional<Renderer::Readback> Renderer::screenshot() const {
    if (!screenshot_taken_) return std::nullopt;
    const bool bgra =
        swapchain_.format() == VK_FORMAT_B8G8R8A8_UNORM || swapchain_.format() == VK_FORMAT_B8G8R8A8_SRGB;
    return Readback{readback_extent_.width, readback_extent_.height, size_t(readback_extent_.width) * 4, bgra,
                    static_cast<const uint8_t *>(readback_.mapped)};
}

} // namespace atrium
