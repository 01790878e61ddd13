// What every render path draws the atrium with: the scene's buffers and textures on the device,
// the per-frame uniforms, the scene's pipeline layout and its pipelines, and the draw calls.
#pragma once

#include "options.h"
#include "scene.h"
#include "textures.h"
#include "vk_context.h"

#include <array>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

namespace atrium {

// Frames the CPU may record ahead of the GPU.
constexpr uint32_t frames_in_flight = 2;

// Per-frame uniforms, std140; must match the Frame block in shaders/frame.glsl (scene.vert
// declares a prefix of it).
struct FrameUniforms {
    glm::mat4 view_proj[2];
    glm::vec4 eye_position[2];
    glm::vec4 sun_direction;
    glm::vec4 sun_color;
    glm::vec4 sky_color;
    glm::vec4 ground_color;
    glm::vec4 sun_opening;
    glm::vec4 sun_facades;
    glm::vec4 sun_params;
    glm::mat4 inv_view_proj[2];        // the deferred lighting pass rebuilds positions from depth
    VkDeviceAddress frame_address = 0; // --buffer-address uniform: this block's own address
    uint64_t pad = 0;
};

// Eye `eye` of `eyes` side by side: eye 0 is the left half [0, W/2), eye 1 the right half.
VkRect2D eye_rect(VkExtent2D extent, uint32_t eyes, uint32_t eye);

// The fraction of the width where eye 1 starts (1 when mono), for full-screen passes.
float eye_split(VkExtent2D extent, uint32_t eyes);

enum class SceneShading {
    display,   // lit and tone-mapped, sRGB-encoded by the shader for a UNORM target
    hdr,       // linear radiance, for a later tone-mapping pass
    gbuffer,   // albedo + specular, normal + shininess (two colour attachments)
    multiview, // display colours for an sRGB eye texture; the view index is the eye
};

struct ScenePipelineInfo {
    VkRenderPass render_pass = VK_NULL_HANDLE;
    const void *next = nullptr; // e.g. VkPipelineRenderingCreateInfoKHR with no render pass
    SceneShading shading = SceneShading::display;
    bool encode_srgb = false; // SceneShading::display only
    // Baked-in viewport and scissor instead of dynamic state (--static-viewports).
    const VkViewport *static_viewport = nullptr;
    const VkRect2D *static_scissor = nullptr;
};

class SceneGpu {
public:
    // With `linear_textures` the textures reach the device through linear images (linear_upload.h)
    // instead of the staging buffer. `slots`: how many sets of frame uniforms (FrameContext::slot)
    // may be in use at once; one per frame in flight, or per submission of one (OpenXR: per eye).
    // With `buffer_address` the scene's vertex shader reads the view-projection matrices through
    // the frame slot's buffer device address, in push constants (scene_address.vert) or in the
    // slot's uniform block (scene_address_uniform.vert, FrameUniforms::frame_address).
    SceneGpu(VkContext &context, const Scene &scene, const std::vector<Texture> &textures,
             bool linear_textures, uint32_t slots = frames_in_flight,
             BufferAddressMode buffer_address = BufferAddressMode::none);
    ~SceneGpu();
    SceneGpu(const SceneGpu &) = delete;
    SceneGpu &operator=(const SceneGpu &) = delete;

    VkPipeline create_pipeline(const ScenePipelineInfo &info) const;

    // Binds the pipeline, frame slot `slot`'s uniforms and the vertex and index buffers.
    void bind(VkCommandBuffer cmd, VkPipeline pipeline, uint32_t slot) const;
    // Draws scene draws [first, end) for `eye` (viewport and scissor are the caller's).
    void draw(VkCommandBuffer cmd, uint32_t eye, size_t first, size_t end) const;
    void draw(VkCommandBuffer cmd, uint32_t eye) const { draw(cmd, eye, 0, draw_count()); }
    size_t draw_count() const { return scene_.draws.size(); }

    FrameUniforms &uniforms(uint32_t slot) const { return *uniforms_[slot]; }
    // Slot `slot`'s uniform block's buffer device address (0 without --buffer-address).
    VkDeviceAddress frame_address(uint32_t slot) const {
        return frame_addresses_.empty() ? 0 : frame_addresses_[slot];
    }
    VkDescriptorSetLayout frame_layout() const { return frame_layout_; }
    VkDescriptorSet frame_set(uint32_t slot) const { return frame_sets_[slot]; }
    VkDevice device() const { return device_; }
    VkContext &context() const { return context_; }

private:
    void upload(const std::vector<Texture> &textures, bool linear_textures);
    void create_descriptors(size_t textures);
    void create_pipeline_layout();

    VkContext &context_;
    const Scene &scene_;
    VkDevice device_;

    Buffer vertices_, indices_, uniform_buffer_;
    std::vector<Image> textures_;
    VkSampler sampler_ = VK_NULL_HANDLE;
    VkDescriptorSetLayout frame_layout_ = VK_NULL_HANDLE, material_layout_ = VK_NULL_HANDLE;
    VkDescriptorPool descriptor_pool_ = VK_NULL_HANDLE;
    std::vector<VkDescriptorSet> texture_sets_;
    std::vector<VkDescriptorSet> frame_sets_;
    std::vector<FrameUniforms *> uniforms_; // persistently mapped, host-coherent
    BufferAddressMode buffer_address_ = BufferAddressMode::none;
    std::vector<VkDeviceAddress> frame_addresses_; // per slot, with buffer_address_
    mutable uint32_t bound_slot_ = 0;              // bind()'s slot, whose address draw() pushes
    VkPipelineLayout pipeline_layout_ = VK_NULL_HANDLE;
};

} // namespace atrium
