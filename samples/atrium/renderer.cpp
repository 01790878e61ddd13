#include "renderer.h"

#include "vk_util.h"

#include <cstdio>
#include <cstring>

namespace atrium {

namespace {

// Lighting, linear RGB.
const glm::vec3 to_sun = glm::normalize(glm::vec3(0.38f, 0.88f, 0.28f));
const glm::vec3 sun_color(2.6f, 2.4f, 2.1f);
const glm::vec3 sky_ambient(0.30f, 0.36f, 0.46f);
const glm::vec3 ground_ambient(0.17f, 0.14f, 0.11f);

} // namespace

void set_lighting(FrameUniforms &u, const Scene &scene) {
    u.sun_direction = glm::vec4(to_sun, 0.0f);
    u.sun_color = glm::vec4(sun_color, 1.0f);
    u.sky_color = glm::vec4(sky_ambient, 1.0f);
    u.ground_color = glm::vec4(ground_ambient, 1.0f);
    const SunOcclusion &occlusion = scene.sun_occlusion;
    u.sun_opening = occlusion.enabled ? occlusion.opening : glm::vec4(1.0f, 0.0f, 0.0f, 0.0f);
    u.sun_facades = occlusion.facades;
    u.sun_params = glm::vec4(occlusion.roof_height, 0.0f, 0.0f, 0.0f);
}

Renderer::Renderer(VkContext &context, Swapchain &swapchain, const Scene &scene,
                   const std::vector<Texture> &textures, const CameraPath &camera,
                   const RendererOptions &options)
    : context_(context), swapchain_(swapchain), scene_(scene), camera_(camera), options_(options),
      device_(context.device()),
      scene_gpu_(context, scene, textures, options.linear_textures, frames_in_flight, options.buffer_address),
      path_(make_render_path(scene_gpu_, swapchain, options)) {
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
    path_.reset();
    context_.destroy(readback_);
}

void Renderer::create_targets() {
    for (size_t i = 0; i < swapchain_.images().size(); ++i) {
        VkSemaphoreCreateInfo semaphore{};
        semaphore.sType = VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO;
        rendered_.push_back(VK_NULL_HANDLE);
        ATRIUM_VK_CHECK(vkCreateSemaphore(device_, &semaphore, nullptr, &rendered_.back()));
    }
    path_->create_targets();
}

void Renderer::destroy_targets() {
    path_->destroy_targets();
    for (VkSemaphore s : rendered_)
        vkDestroySemaphore(device_, s, nullptr);
    rendered_.clear();
}

void Renderer::recreate_swapchain() {
    wait_idle();
    destroy_targets();
    swapchain_.recreate();
    create_targets();
}

void Renderer::wait_idle() {
    ATRIUM_VK_CHECK(vkDeviceWaitIdle(device_));
}

void Renderer::update_uniforms(uint32_t slot, uint64_t frame) {
    const VkExtent2D extent = swapchain_.extent();
    FrameUniforms u{};
    for (uint32_t eye = 0; eye < options_.eyes; ++eye) {
        const uint32_t width = eye_rect(extent, options_.eyes, eye).extent.width;
        const EyeView view = camera_.eye_view(frame, eye, options_.eyes, float(width) / float(extent.height));
        u.view_proj[eye] = view.view_proj;
        u.eye_position[eye] = glm::vec4(view.position, 1.0f);
        u.inv_view_proj[eye] = glm::inverse(view.view_proj);
    }
    if (options_.eyes == 1) {
        u.view_proj[1] = u.view_proj[0];
        u.eye_position[1] = u.eye_position[0];
        u.inv_view_proj[1] = u.inv_view_proj[0];
    }
    set_lighting(u, scene_);
    u.frame_address = scene_gpu_.frame_address(slot);
    std::memcpy(&scene_gpu_.uniforms(slot), &u, sizeof(u));
}

void Renderer::record(uint32_t slot, uint32_t image, bool readback) {
    const VkExtent2D extent = swapchain_.extent();
    VkCommandBuffer cmd = slots_[slot].commands;
    ATRIUM_VK_CHECK(vkResetCommandPool(device_, slots_[slot].pool, 0));
    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    ATRIUM_VK_CHECK(vkBeginCommandBuffer(cmd, &begin));
    path_->record({cmd, slot, image, readback});

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
            std::fprintf(stderr,
                         "atrium: frame %llu: vkAcquireNextImageKHR returned %s; recreating the swapchain\n",
                         static_cast<unsigned long long>(frame), vk_result_name(r));
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
    update_uniforms(slot_index_, frame);
    record(slot_index_, image, readback);

    const VkPipelineStageFlags wait_stage = path_->acquire_stage();
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
    if (r == VK_ERROR_OUT_OF_DATE_KHR || r == VK_SUBOPTIMAL_KHR || stale) {
        // Which call said so: a layer that presents later (splitvk) must still tell the truth.
        std::fprintf(stderr, "atrium: frame %llu: %s returned %s; recreating the swapchain\n",
                     static_cast<unsigned long long>(frame),
                     r != VK_SUCCESS ? "vkQueuePresentKHR" : "vkAcquireNextImageKHR",
                     vk_result_name(r != VK_SUCCESS ? r : VK_SUBOPTIMAL_KHR));
        recreate_swapchain();
    } else {
        ATRIUM_VK_CHECK(r);
    }
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
