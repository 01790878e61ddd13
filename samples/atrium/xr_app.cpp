#include "xr_app.h"

#include "camera.h"
#include "frame_stats.h"
#include "obj_loader.h"
#include "passes.h"
#include "renderer.h"
#include "scene.h"
#include "scene_gpu.h"
#include "textures.h"
#include "vk_context.h"
#include "xcb_window.h"

#include <vulkan/vulkan.h>
#define XR_USE_GRAPHICS_API_VULKAN
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <openxr/openxr.h>
#include <openxr/openxr_platform.h>

namespace atrium {

namespace {

constexpr uint32_t texture_size = 512; // as on the desktop (main.cpp)
constexpr uint32_t view_count = 2;     // XR_VIEW_CONFIGURATION_TYPE_PRIMARY_STEREO
constexpr XrViewConfigurationType view_type = XR_VIEW_CONFIGURATION_TYPE_PRIMARY_STEREO;

std::string xr_result_name(XrInstance instance, XrResult result) {
    char name[XR_MAX_RESULT_STRING_SIZE] = {};
    if (instance != XR_NULL_HANDLE && xrResultToString(instance, result, name) == XR_SUCCESS) return name;
    switch (result) { // what the loader answers before there is an instance
    case XR_ERROR_RUNTIME_UNAVAILABLE:
        return "XR_ERROR_RUNTIME_UNAVAILABLE";
    case XR_ERROR_RUNTIME_FAILURE:
        return "XR_ERROR_RUNTIME_FAILURE";
    case XR_ERROR_INSTANCE_LOST:
        return "XR_ERROR_INSTANCE_LOST";
    case XR_ERROR_INITIALIZATION_FAILED:
        return "XR_ERROR_INITIALIZATION_FAILED";
    case XR_ERROR_API_VERSION_UNSUPPORTED:
        return "XR_ERROR_API_VERSION_UNSUPPORTED";
    case XR_ERROR_EXTENSION_NOT_PRESENT:
        return "XR_ERROR_EXTENSION_NOT_PRESENT";
    default:
        return "XrResult " + std::to_string(int(result));
    }
}

// An OpenXR input or output structure: zeroed, with its type.
template <typename T>
T xr(XrStructureType type) {
    T s{};
    s.type = type;
    return s;
}

// Throws Error("<call> failed: XR_ERROR_...") unless the call succeeded.
void xr_check(XrInstance instance, XrResult result, const char *call) {
    if (XR_FAILED(result)) throw Error(std::string(call) + " failed: " + xr_result_name(instance, result));
}

#define ATRIUM_XR_CHECK(instance, call) xr_check((instance), (call), #call)

// An OpenXR handle destroyed with its owner.
template <typename Handle, XrResult(XRAPI_PTR *destroy)(Handle)>
struct XrOwned {
    Handle handle = XR_NULL_HANDLE;
    XrOwned() = default;
    XrOwned(const XrOwned &) = delete;
    XrOwned &operator=(const XrOwned &) = delete;
    ~XrOwned() {
        if (handle != XR_NULL_HANDLE) destroy(handle);
    }
};

template <typename F>
F instance_proc(XrInstance instance, const char *name) {
    PFN_xrVoidFunction function = nullptr;
    if (XR_FAILED(xrGetInstanceProcAddr(instance, name, &function)) || !function)
        throw Error(std::string("the OpenXR runtime has no ") + name);
    return reinterpret_cast<F>(function);
}

// Runtime values with float noise (Monado composes the head pose and its inverse to locate the
// views in VIEW space, and the noise's sign varies) rounded to 10 micrometres and 10 microradians:
// the same on every run. Adding +0 turns a rounded -0 into +0.
float quantize(float value) {
    return float(std::round(double(value) * 1e5) / 1e5) + 0.0f;
}

// Where eye `view` (located in VIEW space: relative to the head) is, and its field of view.
HeadEye head_eye(const XrView &view) {
    const XrQuaternionf &q = view.pose.orientation;
    const XrVector3f &p = view.pose.position;
    const glm::quat orientation =
        glm::normalize(glm::quat(quantize(q.w), quantize(q.x), quantize(q.y), quantize(q.z)));
    HeadEye eye;
    eye.eye_to_head =
        glm::translate(glm::mat4(1.0f), glm::vec3(quantize(p.x), quantize(p.y), quantize(p.z))) *
        glm::mat4_cast(orientation);
    eye.tan_left = std::tan(quantize(view.fov.angleLeft));
    eye.tan_right = std::tan(quantize(view.fov.angleRight));
    eye.tan_up = std::tan(quantize(view.fov.angleUp));
    eye.tan_down = std::tan(quantize(view.fov.angleDown));
    return eye;
}

XrFovf rendered_fov(const XrFovf &fov) {
    return {quantize(fov.angleLeft), quantize(fov.angleRight), quantize(fov.angleUp),
            quantize(fov.angleDown)};
}

bool views_valid(const XrViewState &state) {
    const XrViewStateFlags both = XR_VIEW_STATE_ORIENTATION_VALID_BIT | XR_VIEW_STATE_POSITION_VALID_BIT;
    return (state.viewStateFlags & both) == both;
}

const char *format_name(VkFormat format) {
    switch (format) {
    case VK_FORMAT_R8G8B8A8_SRGB:
        return "R8G8B8A8_SRGB";
    case VK_FORMAT_B8G8R8A8_SRGB:
        return "B8G8R8A8_SRGB";
    case VK_FORMAT_R8G8B8A8_UNORM:
        return "R8G8B8A8_UNORM";
    case VK_FORMAT_B8G8R8A8_UNORM:
        return "B8G8R8A8_UNORM";
    case VK_FORMAT_R16G16B16A16_UNORM:
        return "R16G16B16A16_UNORM";
    case VK_FORMAT_R16G16B16A16_SFLOAT:
        return "R16G16B16A16_SFLOAT";
    default:
        return "?";
    }
}

// --multiview: both eyes in one VK_KHR_multiview pass (view mask 0b11) straight into the layers
// of the runtime's two-layer eye image, with the multiview path's scene pipeline (its shader
// writes display colours for an sRGB target, the view index naming the eye).
class XrMultiviewPass {
public:
    XrMultiviewPass(const SceneGpu &scene, const Swapchain &images) : scene_(scene), images_(images) {
        RenderPassInfo pass;
        pass.colors = {Attachment{images.format(), VK_ATTACHMENT_LOAD_OP_CLEAR, VK_ATTACHMENT_STORE_OP_STORE,
                                  VK_IMAGE_LAYOUT_UNDEFINED, images.final_layout()}};
        pass.depth = Attachment{depth_format, VK_ATTACHMENT_LOAD_OP_CLEAR, VK_ATTACHMENT_STORE_OP_DONT_CARE,
                                VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL};
        pass.view_mask = (1u << view_count) - 1;
        pass_ = create_render_pass(scene.device(), pass);
        ScenePipelineInfo pipeline;
        pipeline.render_pass = pass_;
        pipeline.shading = SceneShading::multiview;
        pipeline_ = scene.create_pipeline(pipeline);
        depth_ = create_target(scene.context(), images.extent(), depth_format,
                               VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT, view_count);
        for (VkImageView view : images.views())
            framebuffers_.push_back(
                create_framebuffer(scene.device(), pass_, {view, depth_.view}, images.extent()));
    }
    ~XrMultiviewPass() {
        for (VkFramebuffer framebuffer : framebuffers_)
            vkDestroyFramebuffer(scene_.device(), framebuffer, nullptr);
        scene_.context().destroy(depth_);
        vkDestroyPipeline(scene_.device(), pipeline_, nullptr);
        vkDestroyRenderPass(scene_.device(), pass_, nullptr);
    }
    XrMultiviewPass(const XrMultiviewPass &) = delete;
    XrMultiviewPass &operator=(const XrMultiviewPass &) = delete;

    void record(VkCommandBuffer cmd, uint32_t slot, uint32_t image) const {
        std::vector<VkClearValue> clears(2);
        clears[0].color = sky_clear(images_.format());
        clears[1].depthStencil = {1.0f, 0};
        begin_pass(cmd, pass_, framebuffers_[image], images_.extent(), clears);
        scene_.bind(cmd, pipeline_, slot);
        set_viewport(cmd, {{0, 0}, images_.extent()});
        scene_.draw(cmd, 0);
        vkCmdEndRenderPass(cmd);
    }

private:
    static constexpr VkFormat depth_format = VK_FORMAT_D32_SFLOAT;
    const SceneGpu &scene_;
    const Swapchain &images_;
    VkRenderPass pass_ = VK_NULL_HANDLE;
    VkPipeline pipeline_ = VK_NULL_HANDLE;
    Image depth_;
    std::vector<VkFramebuffer> framebuffers_;
};

// --xr-mirror: a desktop window that shows the left eye, mirrored as engines do it. In the frame's
// command buffer, after the eye is drawn and before its image goes back to the runtime, the eye is
// blitted into the window's swapchain image, which is presented once the eye image is released.
class XrMirror {
public:
    // The window's swapchain is sRGB where the eye image holds linear colours, so that the blit
    // encodes them for the display, and UNORM where it holds display colours already.
    XrMirror(VkContext &context, VkFormat eye_format, VkExtent2D eye_extent)
        : context_(context), eye_extent_(eye_extent),
          swapchain_(context, {takes_linear(eye_format) ? VK_FORMAT_B8G8R8A8_SRGB : VK_FORMAT_B8G8R8A8_UNORM,
                               VK_PRESENT_MODE_MAILBOX_KHR, false, true}) {
        VkFormatProperties eye{}, window{};
        vkGetPhysicalDeviceFormatProperties(context.physical_device(), eye_format, &eye);
        vkGetPhysicalDeviceFormatProperties(context.physical_device(), swapchain_.format(), &window);
        if (!(eye.optimalTilingFeatures & VK_FORMAT_FEATURE_BLIT_SRC_BIT) ||
            !(window.optimalTilingFeatures & VK_FORMAT_FEATURE_BLIT_DST_BIT))
            throw Error(std::string("--xr-mirror: ") + context.properties().deviceName +
                        " cannot blit the eye images into the window");
        VkSemaphoreCreateInfo semaphore{};
        semaphore.sType = VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO;
        for (VkSemaphore &s : acquired_)
            ATRIUM_VK_CHECK(vkCreateSemaphore(context.device(), &semaphore, nullptr, &s));
        create_rendered();
    }
    ~XrMirror() {
        destroy_rendered();
        for (VkSemaphore s : acquired_)
            vkDestroySemaphore(context_.device(), s, nullptr);
    }
    XrMirror(const XrMirror &) = delete;
    XrMirror &operator=(const XrMirror &) = delete;

    VkExtent2D extent() const { return swapchain_.extent(); }

    // A window image for the frame in `slot`, whose previous submission is done; the submission
    // that blits into it waits for acquired(slot) at the transfer stage and signals rendered().
    void acquire(uint32_t slot) {
        for (;;) {
            if (out_of_date_) recreate();
            const VkResult r = vkAcquireNextImageKHR(context_.device(), swapchain_.handle(), UINT64_MAX,
                                                     acquired_[slot], VK_NULL_HANDLE, &image_);
            if (r == VK_SUCCESS || r == VK_SUBOPTIMAL_KHR) return;
            if (r != VK_ERROR_OUT_OF_DATE_KHR) ATRIUM_VK_CHECK(r);
            out_of_date_ = true;
        }
    }
    VkSemaphore acquired(uint32_t slot) const { return acquired_[slot]; }
    VkSemaphore rendered() const { return rendered_[image_]; }

    // The blit of the eye at the origin of layer 0 of `eye` (in COLOR_ATTACHMENT_OPTIMAL, as the
    // frame's last pass leaves it, and again afterwards) into the acquired window image.
    void record(VkCommandBuffer cmd, VkImage eye) const {
        VkImageMemoryBarrier to_blit[2]{};
        for (VkImageMemoryBarrier &b : to_blit) {
            b.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER;
            b.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
            b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
            b.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
        }
        to_blit[0].srcAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
        to_blit[0].dstAccessMask = VK_ACCESS_TRANSFER_READ_BIT;
        to_blit[0].oldLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
        to_blit[0].newLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
        to_blit[0].image = eye;
        to_blit[1].dstAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
        to_blit[1].oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;
        to_blit[1].newLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
        to_blit[1].image = swapchain_.images()[image_];
        // The window image's transition waits for the acquire semaphore, waited for at TRANSFER.
        vkCmdPipelineBarrier(cmd,
                             VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
                             VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0, nullptr, 0, nullptr, 2, to_blit);

        const VkExtent2D window = swapchain_.extent();
        VkImageBlit blit{};
        blit.srcSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
        blit.srcOffsets[1] = {int32_t(eye_extent_.width), int32_t(eye_extent_.height), 1};
        blit.dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
        blit.dstOffsets[1] = {int32_t(window.width), int32_t(window.height), 1};
        const bool same_size = window.width == eye_extent_.width && window.height == eye_extent_.height;
        vkCmdBlitImage(cmd, eye, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, swapchain_.images()[image_],
                       VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &blit,
                       same_size ? VK_FILTER_NEAREST : VK_FILTER_LINEAR);

        VkImageMemoryBarrier after[2] = {to_blit[0], to_blit[1]};
        after[0].srcAccessMask = VK_ACCESS_TRANSFER_READ_BIT;
        after[0].dstAccessMask = VK_ACCESS_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
        after[0].oldLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
        after[0].newLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
        after[1].srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
        after[1].dstAccessMask = 0;
        after[1].oldLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
        after[1].newLayout = VK_IMAGE_LAYOUT_PRESENT_SRC_KHR;
        vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT,
                             VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT |
                                 VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT,
                             0, 0, nullptr, 0, nullptr, 2, after);
    }

    void present() {
        const VkSwapchainKHR swapchain = swapchain_.handle();
        VkPresentInfoKHR info{};
        info.sType = VK_STRUCTURE_TYPE_PRESENT_INFO_KHR;
        info.waitSemaphoreCount = 1;
        info.pWaitSemaphores = &rendered_[image_];
        info.swapchainCount = 1;
        info.pSwapchains = &swapchain;
        info.pImageIndices = &image_;
        const VkResult r = vkQueuePresentKHR(context_.queue(), &info);
        if (r == VK_ERROR_OUT_OF_DATE_KHR || r == VK_SUBOPTIMAL_KHR)
            out_of_date_ = true;
        else
            ATRIUM_VK_CHECK(r);
    }

private:
    void create_rendered() {
        VkSemaphoreCreateInfo semaphore{};
        semaphore.sType = VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO;
        rendered_.resize(swapchain_.images().size());
        for (VkSemaphore &s : rendered_)
            ATRIUM_VK_CHECK(vkCreateSemaphore(context_.device(), &semaphore, nullptr, &s));
    }
    void destroy_rendered() {
        for (VkSemaphore s : rendered_)
            vkDestroySemaphore(context_.device(), s, nullptr);
        rendered_.clear();
    }
    void recreate() {
        ATRIUM_VK_CHECK(vkDeviceWaitIdle(context_.device()));
        destroy_rendered();
        swapchain_.recreate();
        create_rendered();
        out_of_date_ = false;
    }

    VkContext &context_;
    VkExtent2D eye_extent_;
    Swapchain swapchain_;
    VkSemaphore acquired_[frames_in_flight]{};
    std::vector<VkSemaphore> rendered_; // per window image: waited for by its present
    uint32_t image_ = 0;
    bool out_of_date_ = false;
};

// A command buffer, the fence of its last submission, and the uniforms slot it draws with.
struct Submission {
    VkDevice device = VK_NULL_HANDLE;
    VkCommandPool pool = VK_NULL_HANDLE;
    VkCommandBuffer commands = VK_NULL_HANDLE;
    VkFence done = VK_NULL_HANDLE;

    Submission(VkDevice device_, uint32_t queue_family) : device(device_) {
        VkCommandPoolCreateInfo pool_info{};
        pool_info.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
        pool_info.flags = VK_COMMAND_POOL_CREATE_TRANSIENT_BIT;
        pool_info.queueFamilyIndex = queue_family;
        ATRIUM_VK_CHECK(vkCreateCommandPool(device, &pool_info, nullptr, &pool));
        VkCommandBufferAllocateInfo alloc{};
        alloc.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
        alloc.commandPool = pool;
        alloc.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
        alloc.commandBufferCount = 1;
        ATRIUM_VK_CHECK(vkAllocateCommandBuffers(device, &alloc, &commands));
        VkFenceCreateInfo fence{};
        fence.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
        fence.flags = VK_FENCE_CREATE_SIGNALED_BIT;
        ATRIUM_VK_CHECK(vkCreateFence(device, &fence, nullptr, &done));
    }
    ~Submission() {
        vkDestroyFence(device, done, nullptr);
        vkDestroyCommandPool(device, pool, nullptr);
    }
    Submission(const Submission &) = delete;
    Submission &operator=(const Submission &) = delete;
};

class XrApp {
public:
    XrApp(const Options &options, const volatile std::sig_atomic_t *stop) : options_(options), stop_(stop) {}
    ~XrApp() {
        if (context_) vkDeviceWaitIdle(context_->device());
        // Members go in reverse: the Vulkan objects, the runtime's swapchains, the session, the
        // device and instance, the XrInstance.
    }
    XrApp(const XrApp &) = delete;
    XrApp &operator=(const XrApp &) = delete;

    int run();

private:
    void create_instance();
    void create_vulkan();
    void create_session();
    void create_actions();
    void create_swapchains();
    void create_renderer();
    // Polls the runtime's events; false once the session is over.
    bool poll_events();
    // One frame of the loop (xrWaitFrame .. xrEndFrame); true when it rendered `frame`.
    bool frame_loop_iteration(uint64_t frame);
    void render_eyes(uint64_t frame, const XrView (&head_views)[view_count]);
    // The runtime's views, and the size of swapchain i's eye image (each eye's rectangle).
    std::vector<XrViewConfigurationView> configuration_views() const;
    VkExtent2D eye_extent(const std::vector<XrViewConfigurationView> &views, uint32_t i) const;

    const Options &options_;
    const volatile std::sig_atomic_t *stop_;
    const bool multiview_ = options_.multiview;
    const bool side_by_side_ = options_.side_by_side;
    const uint32_t swapchain_count_ = multiview_ || side_by_side_ ? 1 : view_count;

    XrOwned<XrInstance, xrDestroyInstance> instance_;
    XrSystemId system_ = XR_NULL_SYSTEM_ID;
    std::string runtime_, system_name_;
    XrEnvironmentBlendMode blend_mode_ = XR_ENVIRONMENT_BLEND_MODE_OPAQUE;
    PFN_xrGetVulkanGraphicsRequirements2KHR get_requirements_ = nullptr;
    PFN_xrCreateVulkanInstanceKHR create_vk_instance_ = nullptr;
    PFN_xrGetVulkanGraphicsDevice2KHR get_vk_device_ = nullptr;
    PFN_xrCreateVulkanDeviceKHR create_vk_device_ = nullptr;

    std::optional<XcbWindow> mirror_window_; // outlives the surface of context_
    std::optional<VkContext> context_;
    XrOwned<XrSession, xrDestroySession> session_;
    XrOwned<XrSpace, xrDestroySpace> world_space_, head_space_; // LOCAL (or STAGE), VIEW
    XrOwned<XrActionSet, xrDestroyActionSet> action_set_;       // its one action goes with it
    const char *world_space_name_ = "LOCAL";
    XrSessionState state_ = XR_SESSION_STATE_UNKNOWN;
    bool running_ = false, exit_requested_ = false, views_reported_ = false;

    VkFormat format_ = VK_FORMAT_UNDEFINED;
    VkExtent2D extents_[view_count]{}; // each eye's
    // Per eye, or [0] alone: with 2 layers (multiview), or twice an eye's width (side by side).
    XrOwned<XrSwapchain, xrDestroySwapchain> swapchains_[view_count];
    std::vector<std::unique_ptr<Swapchain>> images_; // views onto their images

    std::optional<Scene> scene_;
    std::optional<CameraPath> camera_;
    std::optional<SceneGpu> scene_gpu_;
    std::vector<std::unique_ptr<RenderPath>> paths_; // per eye
    std::unique_ptr<XrMultiviewPass> multiview_pass_;
    std::unique_ptr<XrMirror> mirror_;
    std::vector<std::unique_ptr<Submission>> submissions_; // [frame slot * swapchains + swapchain]
    uint32_t frame_slot_ = 0;
};

void XrApp::create_instance() {
    uint32_t count = 0;
    const XrResult listed = xrEnumerateInstanceExtensionProperties(nullptr, 0, &count, nullptr);
    if (XR_FAILED(listed))
        throw Error("no OpenXR runtime (xrEnumerateInstanceExtensionProperties: " +
                    xr_result_name(XR_NULL_HANDLE, listed) +
                    "; is XR_RUNTIME_JSON or the active runtime set?)");
    std::vector<XrExtensionProperties> extensions(count,
                                                  xr<XrExtensionProperties>(XR_TYPE_EXTENSION_PROPERTIES));
    ATRIUM_XR_CHECK(XR_NULL_HANDLE,
                    xrEnumerateInstanceExtensionProperties(nullptr, count, &count, extensions.data()));
    if (std::none_of(extensions.begin(), extensions.end(), [](const XrExtensionProperties &e) {
            return std::strcmp(e.extensionName, XR_KHR_VULKAN_ENABLE2_EXTENSION_NAME) == 0;
        }))
        throw Error("the OpenXR runtime does not offer " XR_KHR_VULKAN_ENABLE2_EXTENSION_NAME);

    const char *enabled[] = {XR_KHR_VULKAN_ENABLE2_EXTENSION_NAME};
    XrInstanceCreateInfo info = xr<XrInstanceCreateInfo>(XR_TYPE_INSTANCE_CREATE_INFO);
    std::strcpy(info.applicationInfo.applicationName, "splitvk-atrium");
    info.applicationInfo.applicationVersion = 1;
    std::strcpy(info.applicationInfo.engineName, "splitvk-atrium");
    info.applicationInfo.apiVersion = XR_MAKE_VERSION(1, 0, 0);
    info.enabledExtensionCount = 1;
    info.enabledExtensionNames = enabled;
    const XrResult created = xrCreateInstance(&info, &instance_.handle);
    if (XR_FAILED(created))
        throw Error("no usable OpenXR runtime (xrCreateInstance: " + xr_result_name(XR_NULL_HANDLE, created) +
                    ")");
    const XrInstance instance = instance_.handle;
    XrInstanceProperties properties = xr<XrInstanceProperties>(XR_TYPE_INSTANCE_PROPERTIES);
    ATRIUM_XR_CHECK(instance, xrGetInstanceProperties(instance, &properties));
    runtime_ = std::string(properties.runtimeName) + " " +
               std::to_string(XR_VERSION_MAJOR(properties.runtimeVersion)) + "." +
               std::to_string(XR_VERSION_MINOR(properties.runtimeVersion)) + "." +
               std::to_string(XR_VERSION_PATCH(properties.runtimeVersion));

    XrSystemGetInfo system_info = xr<XrSystemGetInfo>(XR_TYPE_SYSTEM_GET_INFO);
    system_info.formFactor = XR_FORM_FACTOR_HEAD_MOUNTED_DISPLAY;
    const XrResult system = xrGetSystem(instance, &system_info, &system_);
    if (system == XR_ERROR_FORM_FACTOR_UNAVAILABLE || system == XR_ERROR_FORM_FACTOR_UNSUPPORTED)
        throw Error("the OpenXR runtime has no head-mounted display (xrGetSystem: " +
                    xr_result_name(instance, system) + ")");
    ATRIUM_XR_CHECK(instance, system);
    XrSystemProperties system_properties = xr<XrSystemProperties>(XR_TYPE_SYSTEM_PROPERTIES);
    ATRIUM_XR_CHECK(instance, xrGetSystemProperties(instance, system_, &system_properties));
    system_name_ = system_properties.systemName;

    uint32_t configs = 0;
    ATRIUM_XR_CHECK(instance, xrEnumerateViewConfigurations(instance, system_, 0, &configs, nullptr));
    std::vector<XrViewConfigurationType> types(configs);
    ATRIUM_XR_CHECK(instance,
                    xrEnumerateViewConfigurations(instance, system_, configs, &configs, types.data()));
    if (std::find(types.begin(), types.end(), view_type) == types.end())
        throw Error(system_name_ + " has no stereo view configuration (PRIMARY_STEREO)");
    uint32_t modes = 0;
    ATRIUM_XR_CHECK(instance,
                    xrEnumerateEnvironmentBlendModes(instance, system_, view_type, 0, &modes, nullptr));
    std::vector<XrEnvironmentBlendMode> blend(modes);
    ATRIUM_XR_CHECK(instance, xrEnumerateEnvironmentBlendModes(instance, system_, view_type, modes, &modes,
                                                               blend.data()));
    if (blend.empty()) throw Error(system_name_ + " has no environment blend mode");
    blend_mode_ = std::find(blend.begin(), blend.end(), XR_ENVIRONMENT_BLEND_MODE_OPAQUE) != blend.end()
                      ? XR_ENVIRONMENT_BLEND_MODE_OPAQUE
                      : blend.front();

    get_requirements_ = instance_proc<PFN_xrGetVulkanGraphicsRequirements2KHR>(
        instance, "xrGetVulkanGraphicsRequirements2KHR");
    create_vk_instance_ = instance_proc<PFN_xrCreateVulkanInstanceKHR>(instance, "xrCreateVulkanInstanceKHR");
    get_vk_device_ =
        instance_proc<PFN_xrGetVulkanGraphicsDevice2KHR>(instance, "xrGetVulkanGraphicsDevice2KHR");
    create_vk_device_ = instance_proc<PFN_xrCreateVulkanDeviceKHR>(instance, "xrCreateVulkanDeviceKHR");
}

void XrApp::create_vulkan() {
    const XrInstance instance = instance_.handle;
    XrGraphicsRequirementsVulkan2KHR requirements =
        xr<XrGraphicsRequirementsVulkan2KHR>(XR_TYPE_GRAPHICS_REQUIREMENTS_VULKAN2_KHR);
    ATRIUM_XR_CHECK(instance, get_requirements_(instance, system_, &requirements));
    const XrVersion vulkan_1_1 = XR_MAKE_VERSION(1, 1, 0);
    if (requirements.minApiVersionSupported > vulkan_1_1)
        throw Error("the OpenXR runtime needs Vulkan " +
                    std::to_string(XR_VERSION_MAJOR(requirements.minApiVersionSupported)) + "." +
                    std::to_string(XR_VERSION_MINOR(requirements.minApiVersionSupported)) +
                    "; splitvk-atrium uses 1.1");

    VkCreators creators;
    creators.create_instance = [&](const VkInstanceCreateInfo &info) {
        XrVulkanInstanceCreateInfoKHR create =
            xr<XrVulkanInstanceCreateInfoKHR>(XR_TYPE_VULKAN_INSTANCE_CREATE_INFO_KHR);
        create.systemId = system_;
        create.pfnGetInstanceProcAddr = &vkGetInstanceProcAddr;
        create.vulkanCreateInfo = &info;
        VkInstance vk_instance = VK_NULL_HANDLE;
        VkResult vk_result = VK_SUCCESS;
        ATRIUM_XR_CHECK(instance, create_vk_instance_(instance, &create, &vk_instance, &vk_result));
        if (vk_result != VK_SUCCESS)
            throw Error(std::string("no usable Vulkan driver (xrCreateVulkanInstanceKHR: vkCreateInstance ") +
                        vk_result_name(vk_result) + ")");
        return vk_instance;
    };
    creators.physical_device = [&](VkInstance vk_instance) {
        XrVulkanGraphicsDeviceGetInfoKHR get =
            xr<XrVulkanGraphicsDeviceGetInfoKHR>(XR_TYPE_VULKAN_GRAPHICS_DEVICE_GET_INFO_KHR);
        get.systemId = system_;
        get.vulkanInstance = vk_instance;
        VkPhysicalDevice device = VK_NULL_HANDLE;
        ATRIUM_XR_CHECK(instance, get_vk_device_(instance, &get, &device));
        if (device == VK_NULL_HANDLE) throw Error("the OpenXR runtime named no Vulkan device");
        return device;
    };
    creators.create_device = [&](VkPhysicalDevice physical, const VkDeviceCreateInfo &info) {
        XrVulkanDeviceCreateInfoKHR create =
            xr<XrVulkanDeviceCreateInfoKHR>(XR_TYPE_VULKAN_DEVICE_CREATE_INFO_KHR);
        create.systemId = system_;
        create.pfnGetInstanceProcAddr = &vkGetInstanceProcAddr;
        create.vulkanPhysicalDevice = physical;
        create.vulkanCreateInfo = &info;
        VkDevice device = VK_NULL_HANDLE;
        VkResult vk_result = VK_SUCCESS;
        ATRIUM_XR_CHECK(instance, create_vk_device_(instance, &create, &device, &vk_result));
        vk_check(vk_result, "xrCreateVulkanDeviceKHR: vkCreateDevice");
        return device;
    };
    if (options_.xr_mirror) {
        const VkExtent2D size = eye_extent(configuration_views(), 0);
        mirror_window_.emplace(size.width, size.height, "splitvk-atrium mirror");
    }
    context_.emplace(creators, options_.dynamic_rendering, multiview_,
                     mirror_window_ ? &*mirror_window_ : nullptr);
}

void XrApp::create_session() {
    const XrInstance instance = instance_.handle;
    XrGraphicsBindingVulkan2KHR binding =
        xr<XrGraphicsBindingVulkan2KHR>(XR_TYPE_GRAPHICS_BINDING_VULKAN2_KHR);
    binding.instance = context_->instance();
    binding.physicalDevice = context_->physical_device();
    binding.device = context_->device();
    binding.queueFamilyIndex = context_->queue_family();
    binding.queueIndex = 0;
    XrSessionCreateInfo info = xr<XrSessionCreateInfo>(XR_TYPE_SESSION_CREATE_INFO);
    info.next = &binding;
    info.systemId = system_;
    ATRIUM_XR_CHECK(instance, xrCreateSession(instance, &info, &session_.handle));

    uint32_t count = 0;
    ATRIUM_XR_CHECK(instance, xrEnumerateReferenceSpaces(session_.handle, 0, &count, nullptr));
    std::vector<XrReferenceSpaceType> spaces(count);
    ATRIUM_XR_CHECK(instance, xrEnumerateReferenceSpaces(session_.handle, count, &count, spaces.data()));
    XrReferenceSpaceCreateInfo space = xr<XrReferenceSpaceCreateInfo>(XR_TYPE_REFERENCE_SPACE_CREATE_INFO);
    space.poseInReferenceSpace.orientation.w = 1.0f;
    if (std::find(spaces.begin(), spaces.end(), XR_REFERENCE_SPACE_TYPE_LOCAL) != spaces.end()) {
        space.referenceSpaceType = XR_REFERENCE_SPACE_TYPE_LOCAL;
    } else if (std::find(spaces.begin(), spaces.end(), XR_REFERENCE_SPACE_TYPE_STAGE) != spaces.end()) {
        space.referenceSpaceType = XR_REFERENCE_SPACE_TYPE_STAGE;
        world_space_name_ = "STAGE";
    } else {
        throw Error("the OpenXR runtime offers neither a LOCAL nor a STAGE reference space");
    }
    ATRIUM_XR_CHECK(instance, xrCreateReferenceSpace(session_.handle, &space, &world_space_.handle));
    space.referenceSpaceType = XR_REFERENCE_SPACE_TYPE_VIEW; // every runtime has it
    ATRIUM_XR_CHECK(instance, xrCreateReferenceSpace(session_.handle, &space, &head_space_.handle));
}

// Input, as applications have it: a pose action for the left hand's grip on the Khronos simple
// controller, attached to the session and synchronised every frame. Atrium draws nothing with it; an
// OpenXR layer that adds actions of its own (splitvk's eye gaze) has to ride along with it.
void XrApp::create_actions() {
    const XrInstance instance = instance_.handle;
    XrActionSetCreateInfo set = xr<XrActionSetCreateInfo>(XR_TYPE_ACTION_SET_CREATE_INFO);
    std::strcpy(set.actionSetName, "atrium");
    std::strcpy(set.localizedActionSetName, "atrium");
    ATRIUM_XR_CHECK(instance, xrCreateActionSet(instance, &set, &action_set_.handle));
    XrActionCreateInfo action = xr<XrActionCreateInfo>(XR_TYPE_ACTION_CREATE_INFO);
    std::strcpy(action.actionName, "left_hand");
    std::strcpy(action.localizedActionName, "left hand");
    action.actionType = XR_ACTION_TYPE_POSE_INPUT;
    XrAction hand = XR_NULL_HANDLE;
    ATRIUM_XR_CHECK(instance, xrCreateAction(action_set_.handle, &action, &hand));
    XrPath profile = XR_NULL_PATH, grip = XR_NULL_PATH;
    ATRIUM_XR_CHECK(instance,
                    xrStringToPath(instance, "/interaction_profiles/khr/simple_controller", &profile));
    ATRIUM_XR_CHECK(instance, xrStringToPath(instance, "/user/hand/left/input/grip/pose", &grip));
    const XrActionSuggestedBinding binding{hand, grip};
    XrInteractionProfileSuggestedBinding suggested =
        xr<XrInteractionProfileSuggestedBinding>(XR_TYPE_INTERACTION_PROFILE_SUGGESTED_BINDING);
    suggested.interactionProfile = profile;
    suggested.countSuggestedBindings = 1;
    suggested.suggestedBindings = &binding;
    ATRIUM_XR_CHECK(instance, xrSuggestInteractionProfileBindings(instance, &suggested));
    XrSessionActionSetsAttachInfo attach =
        xr<XrSessionActionSetsAttachInfo>(XR_TYPE_SESSION_ACTION_SETS_ATTACH_INFO);
    attach.countActionSets = 1;
    attach.actionSets = &action_set_.handle;
    ATRIUM_XR_CHECK(instance, xrAttachSessionActionSets(session_.handle, &attach));
}

std::vector<XrViewConfigurationView> XrApp::configuration_views() const {
    const XrInstance instance = instance_.handle;
    uint32_t count = 0;
    ATRIUM_XR_CHECK(instance,
                    xrEnumerateViewConfigurationViews(instance, system_, view_type, 0, &count, nullptr));
    std::vector<XrViewConfigurationView> views(count,
                                               xr<XrViewConfigurationView>(XR_TYPE_VIEW_CONFIGURATION_VIEW));
    ATRIUM_XR_CHECK(instance, xrEnumerateViewConfigurationViews(instance, system_, view_type, count, &count,
                                                                views.data()));
    if (count != view_count) throw Error(system_name_ + " has " + std::to_string(count) + " views, not 2");
    return views;
}

VkExtent2D XrApp::eye_extent(const std::vector<XrViewConfigurationView> &views, uint32_t i) const {
    if (options_.eye_width) { // --xr-eye-size: any size up to the system's maximum
        const uint32_t max_width = std::min(views[0].maxImageRectWidth, views[1].maxImageRectWidth);
        const uint32_t max_height = std::min(views[0].maxImageRectHeight, views[1].maxImageRectHeight);
        if (options_.eye_width > max_width || options_.eye_height > max_height)
            throw Error("--xr-eye-size " + std::to_string(options_.eye_width) + "x" +
                        std::to_string(options_.eye_height) + ": " + system_name_ + " takes at most " +
                        std::to_string(max_width) + "x" + std::to_string(max_height));
        return {options_.eye_width, options_.eye_height};
    }
    // One image for both eyes has the larger of their recommended sizes.
    uint32_t width = views[i].recommendedImageRectWidth, height = views[i].recommendedImageRectHeight;
    if (multiview_ || side_by_side_) {
        width = std::max(width, views[1].recommendedImageRectWidth);
        height = std::max(height, views[1].recommendedImageRectHeight);
    }
    return {width, height};
}

void XrApp::create_swapchains() {
    const XrInstance instance = instance_.handle;
    const std::vector<XrViewConfigurationView> views = configuration_views();

    uint32_t formats = 0;
    ATRIUM_XR_CHECK(instance, xrEnumerateSwapchainFormats(session_.handle, 0, &formats, nullptr));
    std::vector<int64_t> offered(formats);
    ATRIUM_XR_CHECK(instance,
                    xrEnumerateSwapchainFormats(session_.handle, formats, &formats, offered.data()));
    const auto is_offered = [&](VkFormat format) {
        return std::find(offered.begin(), offered.end(), int64_t(format)) != offered.end();
    };
    if (options_.xr_format != VK_FORMAT_UNDEFINED) {
        if (!is_offered(options_.xr_format))
            throw Error(std::string("--xr-format: the OpenXR runtime offers no ") +
                        format_name(options_.xr_format) + " swapchain format");
        format_ = options_.xr_format;
    } else {
        // An 8-bit RGBA or BGRA format, sRGB first: the runtime then reads what it expects. The
        // scene shaders encode sRGB themselves into a UNORM image, but the multiview one does not.
        for (VkFormat wanted : {VK_FORMAT_R8G8B8A8_SRGB, VK_FORMAT_B8G8R8A8_SRGB, VK_FORMAT_R8G8B8A8_UNORM,
                                VK_FORMAT_B8G8R8A8_UNORM}) {
            if (multiview_ && !is_srgb(wanted)) continue;
            if (is_offered(wanted)) {
                format_ = wanted;
                break;
            }
        }
        if (format_ == VK_FORMAT_UNDEFINED)
            throw Error(multiview_ ? "the OpenXR runtime offers no 8-bit sRGB RGBA or BGRA swapchain format"
                                   : "the OpenXR runtime offers no 8-bit RGBA or BGRA swapchain format");
    }

    for (uint32_t i = 0; i < swapchain_count_; ++i) {
        const VkExtent2D eye = eye_extent(views, i);
        const uint32_t width = eye.width, height = eye.height;
        XrSwapchainCreateInfo info = xr<XrSwapchainCreateInfo>(XR_TYPE_SWAPCHAIN_CREATE_INFO);
        // The mirror blits from the eye images.
        info.usageFlags = XR_SWAPCHAIN_USAGE_COLOR_ATTACHMENT_BIT |
                          (options_.xr_mirror ? XR_SWAPCHAIN_USAGE_TRANSFER_SRC_BIT : 0);
        info.format = format_;
        info.sampleCount = 1;
        info.width = side_by_side_ ? 2 * width : width;
        info.height = height;
        info.faceCount = 1;
        info.arraySize = multiview_ ? view_count : 1;
        info.mipCount = 1;
        ATRIUM_XR_CHECK(instance, xrCreateSwapchain(session_.handle, &info, &swapchains_[i].handle));
        extents_[i] = {width, height};
        if (multiview_ || side_by_side_) extents_[1] = extents_[0];

        uint32_t images = 0;
        ATRIUM_XR_CHECK(instance, xrEnumerateSwapchainImages(swapchains_[i].handle, 0, &images, nullptr));
        std::vector<XrSwapchainImageVulkan2KHR> vk_images(
            images, xr<XrSwapchainImageVulkan2KHR>(XR_TYPE_SWAPCHAIN_IMAGE_VULKAN2_KHR));
        ATRIUM_XR_CHECK(instance, xrEnumerateSwapchainImages(
                                      swapchains_[i].handle, images, &images,
                                      reinterpret_cast<XrSwapchainImageBaseHeader *>(vk_images.data())));
        std::vector<VkImage> handles;
        for (const XrSwapchainImageVulkan2KHR &image : vk_images)
            handles.push_back(image.image);
        images_.push_back(std::make_unique<Swapchain>(*context_, format_, VkExtent2D{info.width, info.height},
                                                      handles, multiview_ ? view_count : 1));
    }
}

void XrApp::create_renderer() {
    scene_.emplace(options_.model_path.empty() ? build_atrium() : load_obj(options_.model_path));
    camera_.emplace(CameraPath::for_scene(*scene_));
    {
        const unsigned threads = std::clamp(std::thread::hardware_concurrency(), 1u, 8u);
        const std::vector<Texture> textures = generate_textures(texture_size, threads);
        // Per eye, each eye's submission draws with its own uniforms.
        scene_gpu_.emplace(*context_, *scene_, textures, options_.linear_textures,
                           frames_in_flight * swapchain_count_);
    }
    if (multiview_) {
        multiview_pass_ = std::make_unique<XrMultiviewPass>(*scene_gpu_, *images_[0]);
    } else if (side_by_side_) {
        // Both eyes a stereo frame of the path into the one image, as in a window.
        RendererOptions stereo{2,
                               std::nullopt,
                               options_.static_viewports,
                               options_.clear_depth_per_eye,
                               options_.dynamic_rendering,
                               options_.linear_textures,
                               options_.path};
        paths_.push_back(make_render_path(*scene_gpu_, *images_[0], stereo));
        paths_.back()->create_targets();
    } else {
        // Each eye is a mono frame of the path into its own image.
        RendererOptions eye_options{1,
                                    std::nullopt,
                                    options_.static_viewports,
                                    options_.clear_depth_per_eye,
                                    options_.dynamic_rendering,
                                    options_.linear_textures,
                                    options_.path};
        for (uint32_t eye = 0; eye < view_count; ++eye) {
            paths_.push_back(make_render_path(*scene_gpu_, *images_[eye], eye_options));
            paths_.back()->create_targets();
        }
    }
    if (options_.xr_mirror) mirror_ = std::make_unique<XrMirror>(*context_, format_, extents_[0]);
    for (uint32_t i = 0; i < frames_in_flight * swapchain_count_; ++i)
        submissions_.push_back(std::make_unique<Submission>(context_->device(), context_->queue_family()));
}

bool XrApp::poll_events() {
    const XrInstance instance = instance_.handle;
    for (;;) {
        XrEventDataBuffer event = xr<XrEventDataBuffer>(XR_TYPE_EVENT_DATA_BUFFER);
        const XrResult r = xrPollEvent(instance, &event);
        if (r == XR_EVENT_UNAVAILABLE) return true;
        ATRIUM_XR_CHECK(instance, r);
        if (event.type == XR_TYPE_EVENT_DATA_INSTANCE_LOSS_PENDING)
            throw Error("the OpenXR runtime is going away (instance loss pending)");
        if (event.type != XR_TYPE_EVENT_DATA_SESSION_STATE_CHANGED) continue;
        const auto &changed = reinterpret_cast<const XrEventDataSessionStateChanged &>(event);
        state_ = changed.state;
        switch (state_) {
        case XR_SESSION_STATE_READY: {
            XrSessionBeginInfo begin = xr<XrSessionBeginInfo>(XR_TYPE_SESSION_BEGIN_INFO);
            begin.primaryViewConfigurationType = view_type;
            ATRIUM_XR_CHECK(instance, xrBeginSession(session_.handle, &begin));
            running_ = true;
            break;
        }
        case XR_SESSION_STATE_STOPPING:
            ATRIUM_XR_CHECK(instance, xrEndSession(session_.handle));
            running_ = false;
            break;
        case XR_SESSION_STATE_EXITING:
        case XR_SESSION_STATE_LOSS_PENDING:
            return false;
        default:
            break;
        }
    }
}

void XrApp::render_eyes(uint64_t frame, const XrView (&head_views)[view_count]) {
    const XrInstance instance = instance_.handle;
    const HeadEye eyes[view_count] = {head_eye(head_views[0]), head_eye(head_views[1])};
    for (uint32_t sc = 0; sc < swapchain_count_; ++sc) {
        const uint32_t slot = frame_slot_ * swapchain_count_ + sc;
        Submission &submission = *submissions_[slot];
        ATRIUM_VK_CHECK(vkWaitForFences(context_->device(), 1, &submission.done, VK_TRUE, UINT64_MAX));

        // The eye's (per eye: in both entries, as a mono frame has it) or both eyes' views.
        FrameUniforms u{};
        for (uint32_t i = 0; i < 2; ++i) {
            const EyeView view = camera_->head_eye_view(frame, eyes[swapchain_count_ == 1 ? i : sc]);
            u.view_proj[i] = view.view_proj;
            u.eye_position[i] = glm::vec4(view.position, 1.0f);
            u.inv_view_proj[i] = glm::inverse(view.view_proj);
        }
        set_lighting(u, *scene_);
        std::memcpy(&scene_gpu_->uniforms(slot), &u, sizeof(u));

        const XrSwapchain swapchain = swapchains_[sc].handle;
        uint32_t image = 0;
        XrSwapchainImageAcquireInfo acquire =
            xr<XrSwapchainImageAcquireInfo>(XR_TYPE_SWAPCHAIN_IMAGE_ACQUIRE_INFO);
        ATRIUM_XR_CHECK(instance, xrAcquireSwapchainImage(swapchain, &acquire, &image));
        XrSwapchainImageWaitInfo wait = xr<XrSwapchainImageWaitInfo>(XR_TYPE_SWAPCHAIN_IMAGE_WAIT_INFO);
        wait.timeout = XR_INFINITE_DURATION;
        ATRIUM_XR_CHECK(instance, xrWaitSwapchainImage(swapchain, &wait));

        // The left eye is mirrored: it is the first swapchain's, alone or with the right eye.
        const bool mirrored = mirror_ && sc == 0;
        if (mirrored) mirror_->acquire(frame_slot_);

        VkCommandBuffer cmd = submission.commands;
        ATRIUM_VK_CHECK(vkResetCommandPool(context_->device(), submission.pool, 0));
        VkCommandBufferBeginInfo begin{};
        begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
        begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
        ATRIUM_VK_CHECK(vkBeginCommandBuffer(cmd, &begin));
        if (multiview_)
            multiview_pass_->record(cmd, slot, image);
        else
            paths_[sc]->record({cmd, slot, image, false});
        if (mirrored) mirror_->record(cmd, images_[sc]->images()[image]);
        ATRIUM_VK_CHECK(vkEndCommandBuffer(cmd));
        ATRIUM_VK_CHECK(vkResetFences(context_->device(), 1, &submission.done));
        VkSubmitInfo submit{};
        submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
        submit.commandBufferCount = 1;
        submit.pCommandBuffers = &cmd;
        const VkSemaphore acquired = mirrored ? mirror_->acquired(frame_slot_) : VK_NULL_HANDLE;
        const VkSemaphore rendered = mirrored ? mirror_->rendered() : VK_NULL_HANDLE;
        const VkPipelineStageFlags wait_stage = VK_PIPELINE_STAGE_TRANSFER_BIT;
        if (mirrored) {
            submit.waitSemaphoreCount = 1;
            submit.pWaitSemaphores = &acquired;
            submit.pWaitDstStageMask = &wait_stage;
            submit.signalSemaphoreCount = 1;
            submit.pSignalSemaphores = &rendered;
        }
        ATRIUM_VK_CHECK(vkQueueSubmit(context_->queue(), 1, &submit, submission.done));

        XrSwapchainImageReleaseInfo release =
            xr<XrSwapchainImageReleaseInfo>(XR_TYPE_SWAPCHAIN_IMAGE_RELEASE_INFO);
        ATRIUM_XR_CHECK(instance, xrReleaseSwapchainImage(swapchain, &release));
        if (mirrored) mirror_->present();
    }
    frame_slot_ = (frame_slot_ + 1) % frames_in_flight;
}

bool XrApp::frame_loop_iteration(uint64_t frame) {
    const XrInstance instance = instance_.handle;
    // The input of the frame (XR_SESSION_NOT_FOCUSED, a success, until the runtime focuses the session).
    const XrActiveActionSet active{action_set_.handle, XR_NULL_PATH};
    XrActionsSyncInfo sync = xr<XrActionsSyncInfo>(XR_TYPE_ACTIONS_SYNC_INFO);
    sync.countActiveActionSets = 1;
    sync.activeActionSets = &active;
    ATRIUM_XR_CHECK(instance, xrSyncActions(session_.handle, &sync));
    XrFrameWaitInfo wait = xr<XrFrameWaitInfo>(XR_TYPE_FRAME_WAIT_INFO);
    XrFrameState frame_state = xr<XrFrameState>(XR_TYPE_FRAME_STATE);
    ATRIUM_XR_CHECK(instance, xrWaitFrame(session_.handle, &wait, &frame_state));
    XrFrameBeginInfo begin = xr<XrFrameBeginInfo>(XR_TYPE_FRAME_BEGIN_INFO);
    ATRIUM_XR_CHECK(instance, xrBeginFrame(session_.handle, &begin));

    // The eyes relative to the head (what is rendered: offset and field of view), and in the world
    // space (the pose the projection layer reports to the compositor).
    XrView head_views[view_count] = {xr<XrView>(XR_TYPE_VIEW), xr<XrView>(XR_TYPE_VIEW)};
    XrView world_views[view_count] = {xr<XrView>(XR_TYPE_VIEW), xr<XrView>(XR_TYPE_VIEW)};
    bool render = frame_state.shouldRender && !exit_requested_;
    if (render) {
        XrViewLocateInfo locate = xr<XrViewLocateInfo>(XR_TYPE_VIEW_LOCATE_INFO);
        locate.viewConfigurationType = view_type;
        locate.displayTime = frame_state.predictedDisplayTime;
        XrViewState head_state = xr<XrViewState>(XR_TYPE_VIEW_STATE), world_state = head_state;
        uint32_t count = 0;
        locate.space = head_space_.handle;
        ATRIUM_XR_CHECK(instance,
                        xrLocateViews(session_.handle, &locate, &head_state, view_count, &count, head_views));
        locate.space = world_space_.handle;
        ATRIUM_XR_CHECK(
            instance, xrLocateViews(session_.handle, &locate, &world_state, view_count, &count, world_views));
        render = views_valid(head_state) && views_valid(world_state);
    }

    XrCompositionLayerProjectionView projection_views[view_count];
    XrCompositionLayerProjection projection =
        xr<XrCompositionLayerProjection>(XR_TYPE_COMPOSITION_LAYER_PROJECTION);
    const XrCompositionLayerBaseHeader *layers[] = {
        reinterpret_cast<XrCompositionLayerBaseHeader *>(&projection)};
    if (render) {
        if (!views_reported_) {
            // What the pictures take from the runtime, once: the eyes relative to the head.
            for (uint32_t eye = 0; eye < view_count; ++eye) {
                const XrVector3f &p = head_views[eye].pose.position;
                const XrFovf fov = rendered_fov(head_views[eye].fov);
                std::printf(
                    "xr: eye %u at (%.5f, %.5f, %.5f) m from the head, fov left %.3f right %.3f up %.3f "
                    "down %.3f deg\n",
                    eye, double(quantize(p.x)), double(quantize(p.y)), double(quantize(p.z)),
                    glm::degrees(double(fov.angleLeft)), glm::degrees(double(fov.angleRight)),
                    glm::degrees(double(fov.angleUp)), glm::degrees(double(fov.angleDown)));
            }
            std::fflush(stdout);
            views_reported_ = true;
        }
        render_eyes(frame, head_views);
        for (uint32_t eye = 0; eye < view_count; ++eye) {
            XrCompositionLayerProjectionView &view = projection_views[eye];
            view = xr<XrCompositionLayerProjectionView>(XR_TYPE_COMPOSITION_LAYER_PROJECTION_VIEW);
            view.pose = world_views[eye].pose;
            view.fov = rendered_fov(head_views[eye].fov);
            view.subImage.swapchain = swapchains_[swapchain_count_ == 1 ? 0 : eye].handle;
            const int32_t x = side_by_side_ ? int32_t(eye * extents_[0].width) : 0;
            view.subImage.imageRect = {{x, 0}, {int32_t(extents_[eye].width), int32_t(extents_[eye].height)}};
            view.subImage.imageArrayIndex = multiview_ ? eye : 0;
        }
        projection.space = world_space_.handle;
        projection.viewCount = view_count;
        projection.views = projection_views;
    }
    XrFrameEndInfo end = xr<XrFrameEndInfo>(XR_TYPE_FRAME_END_INFO);
    end.displayTime = frame_state.predictedDisplayTime;
    end.environmentBlendMode = blend_mode_;
    end.layerCount = render ? 1 : 0;
    end.layers = layers;
    ATRIUM_XR_CHECK(instance, xrEndFrame(session_.handle, &end));
    return render;
}

int XrApp::run() {
    create_instance();
    create_vulkan();
    create_session();
    create_actions();
    create_swapchains();
    create_renderer();
    std::printf("atrium: %s triangles, %u textures, %ux%u per eye, path %s\n",
                with_thousands(scene_->triangle_count()).c_str(), texture_count, extents_[0].width,
                extents_[0].height, multiview_ ? "multiview" : path_name(options_.path));
    std::printf("xr: %s, %s, %s space, %s, %s\n", runtime_.c_str(), system_name_.c_str(), world_space_name_,
                format_name(format_),
                multiview_      ? "one swapchain of 2 layers (multiview)"
                : side_by_side_ ? "one swapchain, the eyes side by side"
                                : "one swapchain per eye");
    if (mirror_)
        std::printf("xr: the left eye mirrored into a %ux%u window\n", mirror_->extent().width,
                    mirror_->extent().height);
    std::fflush(stdout);

    // xrEndFrame-to-xrEndFrame CPU time of the rendered frames; frame 0 counts from the loop's start.
    std::vector<double> frame_ms;
    auto last = std::chrono::steady_clock::now();
    uint64_t frame = 0;     // the next frame to render
    bool announced = false; // --hold: 'holding frame N-1' printed
    bool finished = false;  // all frames rendered, or stopped by a signal
    for (;;) {
        if (!poll_events()) break;
        const bool closed = mirror_window_ && mirror_window_->close_requested();
        finished = *stop_ || closed || (frame >= options_.frames && !options_.hold);
        if (finished && !exit_requested_) {
            if (!running_) break; // no session to end
            ATRIUM_XR_CHECK(instance_.handle, xrRequestExitSession(session_.handle));
            exit_requested_ = true;
        }
        if (!running_) { // wait for the runtime to make the session ready
            std::this_thread::sleep_for(std::chrono::milliseconds(5));
            continue;
        }
        // With --hold, frame N-1 again and again once N frames are done.
        const uint64_t shown = std::min<uint64_t>(frame, options_.frames - 1);
        if (!frame_loop_iteration(shown)) continue;
        if (frame < options_.frames) {
            const auto now = std::chrono::steady_clock::now();
            frame_ms.push_back(std::chrono::duration<double, std::milli>(now - last).count());
            last = now;
            if (++frame == options_.frames) {
                std::printf("%s\n", format_frame_times(summarize(frame_ms)).c_str());
                std::fflush(stdout);
            }
        } else if (!announced) {
            // The runtime has had frame N-1 twice: it is on its display.
            std::printf("holding frame %llu\n", static_cast<unsigned long long>(shown));
            std::fflush(stdout);
            announced = true;
        }
    }
    if (!finished) {
        std::fprintf(
            stderr, "splitvk-atrium: the OpenXR runtime ended the session after %llu of %llu frames\n",
            static_cast<unsigned long long>(frame), static_cast<unsigned long long>(options_.frames));
        return 1;
    }
    if (!options_.frame_times_path.empty()) {
        std::FILE *file = std::fopen(options_.frame_times_path.c_str(), "w");
        if (!file) throw Error("--frame-times: cannot write " + options_.frame_times_path);
        std::fprintf(file, "frame,ms\n");
        for (size_t i = 0; i < frame_ms.size(); ++i)
            std::fprintf(file, "%zu,%.3f\n", i, frame_ms[i]);
        if (std::fclose(file) != 0) throw Error("--frame-times: cannot write " + options_.frame_times_path);
    }
    return 0;
}

} // namespace

int run_xr(const Options &options, const volatile std::sig_atomic_t *stop) {
    XrApp app(options, stop);
    return app.run();
}

} // namespace atrium
