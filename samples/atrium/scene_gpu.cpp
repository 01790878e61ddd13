#include "scene_gpu.h"

#include "atrium_spirv.h"
#include "error.h"
#include "linear_upload.h"
#include "pipeline.h"

#include <cstddef>
#include <cstring>
#include <optional>

namespace atrium {

namespace {

constexpr VkFormat texture_format = VK_FORMAT_R8G8B8A8_SRGB;

// scene.vert/scene.frag read the first three; scene_address.vert also `frame` (--buffer-address).
struct PushConstants {
    uint32_t eye;
    float specular;
    float shininess;
    uint32_t pad = 0;
    VkDeviceAddress frame = 0;
};
constexpr uint32_t push_bytes_without_address = offsetof(PushConstants, pad);

static_assert(offsetof(FrameUniforms, frame_address) == 400, "scene_address_uniform.vert's std140 offset");

uint32_t push_bytes(BufferAddressMode mode) {
    return mode == BufferAddressMode::push ? uint32_t(sizeof(PushConstants)) : push_bytes_without_address;
}

VkDeviceSize align_up(VkDeviceSize value, VkDeviceSize alignment) {
    return (value + alignment - 1) / alignment * alignment;
}

} // namespace

VkRect2D eye_rect(VkExtent2D extent, uint32_t eyes, uint32_t eye) {
    const uint32_t x = eye == 0 ? 0 : extent.width / eyes;
    const uint32_t width = eye + 1 == eyes ? extent.width - x : extent.width / eyes;
    return {{int32_t(x), 0}, {width, extent.height}};
}

float eye_split(VkExtent2D extent, uint32_t eyes) {
    return eyes == 1 ? 1.0f : float(extent.width / eyes) / float(extent.width);
}

SceneGpu::SceneGpu(VkContext &context, const Scene &scene, const std::vector<Texture> &textures,
                   bool linear_textures, uint32_t slots, BufferAddressMode buffer_address)
    : context_(context), scene_(scene), device_(context.device()), frame_sets_(slots), uniforms_(slots),
      buffer_address_(buffer_address) {
    upload(textures, linear_textures);
    create_descriptors(textures.size());
    create_pipeline_layout();
}

SceneGpu::~SceneGpu() {
    vkDestroyPipelineLayout(device_, pipeline_layout_, nullptr);
    vkDestroyDescriptorPool(device_, descriptor_pool_, nullptr);
    vkDestroyDescriptorSetLayout(device_, frame_layout_, nullptr);
    vkDestroyDescriptorSetLayout(device_, material_layout_, nullptr);
    vkDestroySampler(device_, sampler_, nullptr);
    for (Image &texture : textures_)
        context_.destroy(texture);
    context_.destroy(uniform_buffer_);
    context_.destroy(indices_);
    context_.destroy(vertices_);
}

void SceneGpu::upload(const std::vector<Texture> &textures, bool linear_textures) {
    const VkDeviceSize vertex_bytes = scene_.vertices.size() * sizeof(Vertex);
    const VkDeviceSize index_bytes = scene_.indices.size() * sizeof(uint32_t);
    VkDeviceSize staging_bytes = align_up(vertex_bytes, 16) + align_up(index_bytes, 16);
    std::optional<LinearUpload> linear;
    if (linear_textures)
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
    const VkDeviceSize vertex_offset = stage(scene_.vertices.data(), vertex_bytes);
    const VkDeviceSize index_offset = stage(scene_.indices.data(), index_bytes);

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

void SceneGpu::create_descriptors(size_t textures) {
    const uint32_t slots = uint32_t(frame_sets_.size());
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
        {VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, slots},
        {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, uint32_t(textures)},
    };
    VkDescriptorPoolCreateInfo pool{};
    pool.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
    pool.maxSets = slots + uint32_t(textures);
    pool.poolSizeCount = 2;
    pool.pPoolSizes = sizes;
    ATRIUM_VK_CHECK(vkCreateDescriptorPool(device_, &pool, nullptr, &descriptor_pool_));

    // One uniform block per slot (frame in flight, or submission of one), in one persistently mapped
    // host-coherent buffer: the CPU rewrites a slot's block only after waiting for the slot's fence.
    const VkDeviceSize stride =
        align_up(sizeof(FrameUniforms), context_.properties().limits.minUniformBufferOffsetAlignment);
    uniform_buffer_ = context_.create_buffer(
        stride * slots,
        VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT |
            (buffer_address_ != BufferAddressMode::none ? VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT : 0),
        VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT);
    if (buffer_address_ != BufferAddressMode::none) {
        const auto get_address = reinterpret_cast<PFN_vkGetBufferDeviceAddressKHR>(
            vkGetDeviceProcAddr(device_, "vkGetBufferDeviceAddressKHR"));
        if (!get_address) throw Error("vkGetBufferDeviceAddressKHR is missing (--buffer-address)");
        VkBufferDeviceAddressInfo info{};
        info.sType = VK_STRUCTURE_TYPE_BUFFER_DEVICE_ADDRESS_INFO;
        info.buffer = uniform_buffer_.buffer;
        const VkDeviceAddress base = get_address(device_, &info);
        for (uint32_t i = 0; i < slots; ++i)
            frame_addresses_.push_back(base + i * stride); // each slot's block, inside the one buffer
    }

    std::vector<VkDescriptorSetLayout> layouts(slots, frame_layout_);
    layouts.insert(layouts.end(), textures, material_layout_);
    std::vector<VkDescriptorSet> sets(layouts.size());
    VkDescriptorSetAllocateInfo alloc{};
    alloc.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
    alloc.descriptorPool = descriptor_pool_;
    alloc.descriptorSetCount = uint32_t(layouts.size());
    alloc.pSetLayouts = layouts.data();
    ATRIUM_VK_CHECK(vkAllocateDescriptorSets(device_, &alloc, sets.data()));

    std::vector<VkDescriptorBufferInfo> buffer_infos(slots);
    std::vector<VkDescriptorImageInfo> image_infos(textures);
    std::vector<VkWriteDescriptorSet> writes;
    for (uint32_t i = 0; i < slots; ++i) {
        frame_sets_[i] = sets[i];
        uniforms_[i] =
            reinterpret_cast<FrameUniforms *>(static_cast<uint8_t *>(uniform_buffer_.mapped) + i * stride);
        buffer_infos[i] = {uniform_buffer_.buffer, i * stride, sizeof(FrameUniforms)};
        VkWriteDescriptorSet w{};
        w.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
        w.dstSet = sets[i];
        w.descriptorCount = 1;
        w.descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
        w.pBufferInfo = &buffer_infos[i];
        writes.push_back(w);
    }
    for (size_t t = 0; t < textures; ++t) {
        texture_sets_.push_back(sets[slots + t]);
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

void SceneGpu::create_pipeline_layout() {
    const VkDescriptorSetLayout set_layouts[] = {frame_layout_, material_layout_};
    const VkPushConstantRange push{VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0,
                                   push_bytes(buffer_address_)};
    VkPipelineLayoutCreateInfo layout{};
    layout.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
    layout.setLayoutCount = 2;
    layout.pSetLayouts = set_layouts;
    layout.pushConstantRangeCount = 1;
    layout.pPushConstantRanges = &push;
    ATRIUM_VK_CHECK(vkCreatePipelineLayout(device_, &layout, nullptr, &pipeline_layout_));
}

VkPipeline SceneGpu::create_pipeline(const ScenePipelineInfo &pipeline) const {
    GraphicsPipelineInfo info;
    const bool multiview = pipeline.shading == SceneShading::multiview;
    info.vertex =
        multiview ? ShaderCode{spirv::scene_multiview_vert, sizeof(spirv::scene_multiview_vert)}
        : buffer_address_ == BufferAddressMode::push
            ? ShaderCode{spirv::scene_address_vert, sizeof(spirv::scene_address_vert)}
        : buffer_address_ == BufferAddressMode::uniform
            ? ShaderCode{spirv::scene_address_uniform_vert, sizeof(spirv::scene_address_uniform_vert)}
            : ShaderCode{spirv::scene_vert, sizeof(spirv::scene_vert)};
    // scene.frag's constants: 0 encode_srgb, 1 display (false: linear HDR out).
    const VkBool32 constants[2] = {pipeline.encode_srgb ? VK_TRUE : VK_FALSE,
                                   pipeline.shading == SceneShading::hdr ? VK_FALSE : VK_TRUE};
    const VkSpecializationMapEntry entries[2] = {{0, 0, sizeof(VkBool32)},
                                                 {1, sizeof(VkBool32), sizeof(VkBool32)}};
    const VkSpecializationInfo specialization{pipeline.shading == SceneShading::hdr ? 2u : 1u, entries,
                                              sizeof(constants), constants};
    switch (pipeline.shading) {
    case SceneShading::display:
    case SceneShading::hdr:
        info.fragment = {spirv::scene_frag, sizeof(spirv::scene_frag), &specialization};
        break;
    case SceneShading::gbuffer:
        info.fragment = {spirv::gbuffer_frag, sizeof(spirv::gbuffer_frag)};
        info.color_attachments = 2;
        break;
    case SceneShading::multiview:
        info.fragment = {spirv::scene_multiview_frag, sizeof(spirv::scene_multiview_frag)};
        break;
    }

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
    info.vertex_input = &vertex_input;
    info.cull = scene_.double_sided ? VK_CULL_MODE_NONE : VK_CULL_MODE_BACK_BIT;
    info.depth_test = true;
    info.layout = pipeline_layout_;
    info.render_pass = pipeline.render_pass;
    info.next = pipeline.next;
    info.static_viewport = pipeline.static_viewport;
    info.static_scissor = pipeline.static_scissor;
    return create_graphics_pipeline(device_, info);
}

void SceneGpu::bind(VkCommandBuffer cmd, VkPipeline pipeline, uint32_t slot) const {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline);
    bound_slot_ = slot;
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline_layout_, 0, 1, &frame_sets_[slot],
                            0, nullptr);
    const VkDeviceSize zero = 0;
    vkCmdBindVertexBuffers(cmd, 0, 1, &vertices_.buffer, &zero);
    vkCmdBindIndexBuffer(cmd, indices_.buffer, 0, VK_INDEX_TYPE_UINT32);
}

void SceneGpu::draw(VkCommandBuffer cmd, uint32_t eye, size_t first, size_t end) const {
    uint32_t bound_texture = UINT32_MAX;
    for (size_t i = first; i < end; ++i) {
        const DrawRange &draw = scene_.draws[i];
        const Material &material = scene_.materials[draw.material];
        if (material.texture != bound_texture) {
            bound_texture = material.texture;
            vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline_layout_, 1, 1,
                                    &texture_sets_[bound_texture], 0, nullptr);
        }
        PushConstants push{eye, material.specular, material.shininess};
        if (buffer_address_ == BufferAddressMode::push) push.frame = frame_addresses_[bound_slot_];
        vkCmdPushConstants(cmd, pipeline_layout_, VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT,
                           0, push_bytes(buffer_address_), &push);
        vkCmdDrawIndexed(cmd, draw.index_count, 1, draw.first_index, 0, 0);
    }
}

} // namespace atrium
