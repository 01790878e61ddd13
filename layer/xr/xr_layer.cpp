// XR_APILAYER_SPLITVK_split_render: the OpenXR API layer (docs/architecture.md §9), in the same library as
// the Vulkan layer, so that both see one process's state.
//
// An OpenXR application never presents to a window: it renders each eye into images of an
// XrSwapchain, which the runtime created on the application's VkDevice (Monado imports them from
// its service with external memory), hands each back with xrReleaseSwapchainImage, and ends the
// frame with xrEndFrame. The Vulkan side cannot tell those images from any other; this layer tells
// it:
//   xrCreateSession            the session's VkDevice and queue (XR_KHR_vulkan_enable / enable2);
//   xrCreateSwapchain          adds the usage the compositor needs to colour swapchains;
//   xrEnumerateSwapchainImages the images become a swapchain of the split (swapchain.h,
//                              register_runtime_swapchain): passes into them are split passes;
//   xrAcquireSwapchainImage    FrameBegin;
//   xrReleaseSwapchainImage    the frame ends here, before the runtime's release: the agent's foveae
//                              are composited into the image on the application's queue, so that the
//                              runtime's own barrier (which hands it to VK_QUEUE_FAMILY_EXTERNAL)
//                              finds it finished (present.h, end_runtime_frame);
//   xrEndFrame                 each eye, from the projection views: which swapchain, array layer and
//                              sub-image rectangle hold it, and its field of view; its fovea sits at
//                              the projection of the view direction within that rectangle from the
//                              next frame on (SwapchainView; real headsets' fields of view are
//                              asymmetric). A layered swapchain drawn with multiview holds an eye per
//                              layer, a side-by-side one two rectangles of one layer;
//   xrDestroySwapchain         the swapchain leaves the split before the runtime destroys its images.
// With SPLITVK_GAZE=openxr, also xrSuggestInteractionProfileBindings, xrAttachSessionActionSets,
// xrSyncActions, xrWaitFrame and xrBeginFrame: the layer's eye-gaze action rides along with the
// application's (xr_gaze.h), and each frame's foveae go where the eyes look. With fifo:PATH, the
// pipe's left and right points go to views 0 and 1 at xrBeginFrame.
// Everything else goes straight to the next layer or the runtime. Where the Vulkan layer is not on
// the session's device (it was disabled, or has no agent), this layer only forwards.

#include "xr/xr_layer.h"

#include "core/agent_link.h"
#include "core/device.h"
#include "core/layer_settings.h"
#include "core/swapchain.h"
#include "log.h"
#include "model/frame_deadline.h"
#include "model/gaze.h"
#include "present/present.h"
#include "present/swapchain.h"
#include "vk/entry_boundary.h"
#include "xr/xr_gaze.h"
#include "xr/xr_loader_interface.h"

#include <vulkan/vulkan.h>
#define XR_USE_GRAPHICS_API_VULKAN
#define XR_USE_TIMESPEC
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <ctime> // timespec, before openxr_platform.h (XR_USE_TIMESPEC)
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

#include <openxr/openxr.h>
#include <openxr/openxr_platform.h>

namespace splitvk::xr {
namespace {

constexpr char kApiLayerName[] = "XR_APILAYER_SPLITVK_split_render";

struct SessionState;
struct SwapchainState;

// The next layer's (or the runtime's) functions this layer calls, per XrInstance, and its sessions.
struct InstanceState {
    PFN_xrGetInstanceProcAddr get_instance_proc_addr = nullptr;
    PFN_xrDestroyInstance destroy_instance = nullptr;
    PFN_xrCreateSession create_session = nullptr;
    PFN_xrDestroySession destroy_session = nullptr;
    PFN_xrCreateSwapchain create_swapchain = nullptr;
    PFN_xrDestroySwapchain destroy_swapchain = nullptr;
    PFN_xrEnumerateSwapchainImages enumerate_swapchain_images = nullptr;
    PFN_xrAcquireSwapchainImage acquire_swapchain_image = nullptr;
    PFN_xrReleaseSwapchainImage release_swapchain_image = nullptr;
    PFN_xrEndFrame end_frame = nullptr;
    PFN_xrWaitFrame wait_frame = nullptr;
    PFN_xrBeginFrame begin_frame = nullptr;
    // SPLITVK_GAZE=openxr where the runtime took XR_EXT_eye_gaze_interaction; null otherwise.
    std::unique_ptr<InstanceGaze> gaze;
    XrInstance handle = XR_NULL_HANDLE;
    // XR_KHR_convert_timespec_time, where the runtime has it: each frame's display time on the
    // layer's clock (WaitFrame). Null otherwise: frames wait for tiles as a window's present does.
    PFN_xrConvertTimeToTimespecTimeKHR convert_time = nullptr;
    // The application did not enable it itself: its functions stay hidden from it.
    bool convert_time_hidden = false;
    // Under g_mutex, as is every session's state.
    std::unordered_map<XrSession, std::unique_ptr<SessionState>> sessions;
};

// A frame xrWaitFrame gave the application: when the call returned, where the frame's latency
// starts (stats.h: frame_latency_ms), and its predicted display time and period, the deadline of its
// tile waits (frame_deadline.h).
struct WaitedFrame {
    std::chrono::steady_clock::time_point returned{};
    deadline::FrameDisplay display;
};

struct SessionState {
    InstanceState *instance = nullptr;
    // The Vulkan layer's state of the session's device; null where splitvk is not on it.
    DeviceState *device = nullptr;
    VkQueue queue = VK_NULL_HANDLE;
    uint64_t ended_frames = 0; // xrEndFrame calls: the OpenXR frame a release belongs to (stats.h)
    // The runtime's eye gaze where its system tracks the eyes (SPLITVK_GAZE=openxr); null otherwise.
    std::unique_ptr<SessionGaze> gaze;
    // Where views 0 and 1 look in the frame begun last (from `gaze` or a SPLITVK_GAZE pipe).
    ViewGaze view_gaze;
    // Frames waited for and not begun yet, oldest first (xrWaitFrame may run ahead on another
    // thread), and the frame begun, until its xrEndFrame; a frame begun over it was discarded.
    std::deque<WaitedFrame> waited;
    std::optional<WaitedFrame> begun;
    // The shortest predictedDisplayPeriod so far: the display's refresh period. Monado reports the
    // application's own period instead, a multiple of the refresh period once its frames take
    // longer, tile waits included; bounding the waits by that would let them grow with it.
    XrDuration refresh_period = 0;
    bool deadline_said = false;
    // Its swapchains, under g_mutex (destroying a session destroys them).
    std::unordered_map<XrSwapchain, std::unique_ptr<SwapchainState>> swapchains;
};

// More frames waited for than begun: a runtime blocks xrWaitFrame before this.
constexpr size_t kMaxWaitedFrames = 4;

// An eye of a swapchain and the projection view that placed it there (views 0 and 1 are the left
// and right eye for the gaze sources).
struct EyeOfView {
    uint32_t layer = 0;
    VkRect2D rect{};
    uint32_t view = 0;
};

struct SwapchainState {
    SessionState *session = nullptr;
    InstanceState *instance = nullptr;
    XrSwapchainCreateInfo info{}; // next cleared; usage as created, the layer's bits included
    // The split's state of this swapchain once its images are known; null when not registered.
    splitvk::SwapchainState *split = nullptr;
    // Acquired and not yet released, oldest first: OpenXR releases in acquisition order.
    std::deque<uint32_t> acquired;
    // The eyes the projection views placed in its images so far (split::note_runtime_eye), each sent
    // to the agent (protocol::SwapchainView) as it changed: what both sides place the foveae with.
    std::vector<split::RuntimeEye> eyes;
    std::vector<EyeOfView> eye_views; // the view of each of `eyes`, by layer and rectangle
    // The first projection view that named this swapchain at the latest xrEndFrame that named it; -1
    // before one (stats.h: xr_view).
    int32_t first_view = -1;
};

// The layer's table: each instance holds its sessions, each session its swapchains. An
// application has an instance and a session or two, so a session or swapchain is found by a walk
// over them. Calls down are made without the lock: a runtime may call back into the application's
// Vulkan device, and so into the Vulkan layer, on the same thread.
std::mutex g_mutex;
std::unordered_map<XrInstance, std::unique_ptr<InstanceState>> g_instances;

// Under g_mutex.
SessionState *find_session_locked(XrSession session) {
    for (const auto &[handle, instance] : g_instances)
        if (const auto it = instance->sessions.find(session); it != instance->sessions.end())
            return it->second.get();
    return nullptr;
}

// Under g_mutex.
SwapchainState *find_swapchain_locked(XrSwapchain swapchain) {
    for (const auto &[handle, instance] : g_instances)
        for (const auto &[session, state] : instance->sessions)
            if (const auto it = state->swapchains.find(swapchain); it != state->swapchains.end())
                return it->second.get();
    return nullptr;
}

// The XR usage the compositor needs on an eye image, as Compositor::kSwapchainUsage in Vulkan terms.
constexpr XrSwapchainUsageFlags kCompositorUsage = XR_SWAPCHAIN_USAGE_TRANSFER_SRC_BIT |
                                                   XR_SWAPCHAIN_USAGE_TRANSFER_DST_BIT |
                                                   XR_SWAPCHAIN_USAGE_COLOR_ATTACHMENT_BIT;

VkImageUsageFlags vulkan_usage(XrSwapchainUsageFlags usage) {
    VkImageUsageFlags out = 0;
    if (usage & XR_SWAPCHAIN_USAGE_COLOR_ATTACHMENT_BIT) out |= VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT;
    if (usage & XR_SWAPCHAIN_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT)
        out |= VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT;
    if (usage & XR_SWAPCHAIN_USAGE_UNORDERED_ACCESS_BIT) out |= VK_IMAGE_USAGE_STORAGE_BIT;
    if (usage & XR_SWAPCHAIN_USAGE_TRANSFER_SRC_BIT) out |= VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
    if (usage & XR_SWAPCHAIN_USAGE_TRANSFER_DST_BIT) out |= VK_IMAGE_USAGE_TRANSFER_DST_BIT;
    if (usage & XR_SWAPCHAIN_USAGE_SAMPLED_BIT) out |= VK_IMAGE_USAGE_SAMPLED_BIT;
    return out;
}

InstanceState *find_instance(XrInstance instance) {
    std::lock_guard lock(g_mutex);
    const auto it = g_instances.find(instance);
    return it == g_instances.end() ? nullptr : it->second.get();
}

template <class F>
bool load(InstanceState &s, XrInstance instance, const char *name, F *out) {
    PFN_xrVoidFunction function = nullptr;
    if (XR_FAILED(s.get_instance_proc_addr(instance, name, &function)) || !function) return false;
    *out = reinterpret_cast<F>(function);
    return true;
}

// The session's graphics binding, where it is Vulkan's (XR_KHR_vulkan_enable's structure is also
// XR_KHR_vulkan_enable2's: XrGraphicsBindingVulkan2KHR is an alias with the same type).
const XrGraphicsBindingVulkanKHR *vulkan_binding(const XrSessionCreateInfo &info) {
    for (auto *s = static_cast<const XrBaseInStructure *>(info.next); s; s = s->next)
        if (s->type == XR_TYPE_GRAPHICS_BINDING_VULKAN_KHR)
            return reinterpret_cast<const XrGraphicsBindingVulkanKHR *>(s);
    return nullptr;
}

// The swapchain's state and its session's, for the calls that need both.
bool find_swapchain(XrSwapchain swapchain, SwapchainState **out, SessionState **session) {
    std::lock_guard lock(g_mutex);
    SwapchainState *found = find_swapchain_locked(swapchain);
    if (!found) return false;
    *out = found;
    *session = found->session;
    return true;
}

VkSwapchainKHR split_key(XrSwapchain swapchain) {
    // XrSwapchain is a pointer-sized handle of the runtime's: no VkSwapchainKHR of this process has
    // the same value, since both name distinct live objects of the same address space.
    return reinterpret_cast<VkSwapchainKHR>(swapchain);
}

// The gaze of one of a swapchain's frames as FramePresent carries it: the points of the image's
// first two eyes (in `eyes`' order, which the agent holds too), each its view's. Fixed unless every
// one of those eyes has a view with a point this frame.
split::Gaze image_gaze(const std::vector<split::RuntimeEye> &eyes, const std::vector<EyeOfView> &eye_views,
                       const ViewGaze &view_gaze) {
    split::Gaze gaze;
    gaze.fixed = false;
    for (size_t i = 0; i < eyes.size() && i < std::size(gaze.eyes); ++i) {
        const auto of = std::find_if(eye_views.begin(), eye_views.end(), [&](const EyeOfView &e) {
            return e.layer == eyes[i].layer && e.rect.offset.x == eyes[i].rect.offset.x &&
                   e.rect.offset.y == eyes[i].rect.offset.y &&
                   e.rect.extent.width == eyes[i].rect.extent.width &&
                   e.rect.extent.height == eyes[i].rect.extent.height;
        });
        if (of == eye_views.end() || of->view >= view_gaze.size() || !view_gaze[of->view]) return {};
        gaze.eyes[i] = *view_gaze[of->view];
    }
    return eyes.empty() ? split::Gaze{} : gaze;
}

void forget_swapchain(XrSwapchain swapchain) {
    std::unique_ptr<SwapchainState> state;
    SessionState *session = nullptr;
    {
        std::lock_guard lock(g_mutex);
        SwapchainState *found = find_swapchain_locked(swapchain);
        if (!found) return;
        session = found->session;
        state = std::move(session->swapchains.at(swapchain));
        session->swapchains.erase(swapchain);
    }
    if (state->split && session->device) unregister_runtime_swapchain(*session->device, split_key(swapchain));
}

// ------------------------------------------------------------------------------------ entry points

XRAPI_ATTR XrResult XRAPI_CALL DestroyInstance(XrInstance instance) {
    std::unique_ptr<InstanceState> state;
    {
        std::lock_guard lock(g_mutex);
        const auto it = g_instances.find(instance);
        if (it == g_instances.end()) return XR_ERROR_HANDLE_INVALID;
        state = std::move(it->second);
        g_instances.erase(it);
    }
    return state->destroy_instance(instance);
}

XRAPI_ATTR XrResult XRAPI_CALL CreateSession(XrInstance instance, const XrSessionCreateInfo *info,
                                             XrSession *session) {
    InstanceState *state = find_instance(instance);
    if (!state) return XR_ERROR_HANDLE_INVALID;
    const XrResult result = state->create_session(instance, info, session);
    if (XR_FAILED(result)) return result;
    auto s = std::make_unique<SessionState>();
    s->instance = state;
    if (const XrGraphicsBindingVulkanKHR *binding = info ? vulkan_binding(*info) : nullptr) {
        s->device = find_device(dispatch_key(binding->device));
        if (s->device && s->device->session) {
            s->device->dispatch.GetDeviceQueue(binding->device, binding->queueFamilyIndex,
                                               binding->queueIndex, &s->queue);
            SPLITVK_INFO("OpenXR session: eye images of its Vulkan device are split (queue family %u)",
                         binding->queueFamilyIndex);
        } else {
            // No splitvk on that device (disabled there, or no agent was configured): forward only.
            s->device = nullptr;
            SPLITVK_INFO("OpenXR session: its Vulkan device is not splitvk's; frames pass through");
        }
    }
    if (s->device && state->gaze) {
        if (state->gaze->system_supports(info->systemId))
            s->gaze = std::make_unique<SessionGaze>(*session, *state->gaze);
        else
            SPLITVK_WARN(
                "SPLITVK_GAZE=openxr: the runtime's system does not track the eyes; the foveae stay at "
                "the view directions");
    }
    std::lock_guard lock(g_mutex);
    state->sessions[*session] = std::move(s);
    return result;
}

XRAPI_ATTR XrResult XRAPI_CALL DestroySession(XrSession session) {
    InstanceState *instance = nullptr;
    std::vector<XrSwapchain> swapchains;
    {
        std::lock_guard lock(g_mutex);
        const SessionState *state = find_session_locked(session);
        if (!state) return XR_ERROR_HANDLE_INVALID;
        instance = state->instance;
        for (const auto &[handle, swapchain] : state->swapchains)
            swapchains.push_back(handle);
    }
    // Destroying a session destroys its swapchains: they leave the split first.
    for (XrSwapchain swapchain : swapchains)
        forget_swapchain(swapchain);
    const XrResult result = instance->destroy_session(session);
    std::lock_guard lock(g_mutex);
    instance->sessions.erase(session);
    return result;
}

XRAPI_ATTR XrResult XRAPI_CALL CreateSwapchain(XrSession session, const XrSwapchainCreateInfo *info,
                                               XrSwapchain *swapchain) {
    SessionState *s = nullptr;
    {
        std::lock_guard lock(g_mutex);
        s = find_session_locked(session);
        if (!s) return XR_ERROR_HANDLE_INVALID;
    }
    XrSwapchainCreateInfo created = *info;
    XrResult result = XR_ERROR_VALIDATION_FAILURE;
    // Colour swapchains of a split device get the compositor's usage; the application never sees it
    // (no OpenXR call returns a swapchain's usage). A runtime that refuses it gets the application's.
    if (s->device && (info->usageFlags & XR_SWAPCHAIN_USAGE_COLOR_ATTACHMENT_BIT) &&
        (info->usageFlags & kCompositorUsage) != kCompositorUsage) {
        created.usageFlags |= kCompositorUsage;
        result = s->instance->create_swapchain(session, &created, swapchain);
        if (XR_FAILED(result)) {
            SPLITVK_INFO("OpenXR: the runtime refused transfer usage on a swapchain (%d); retrying without",
                         static_cast<int>(result));
            created.usageFlags = info->usageFlags;
        }
    }
    if (created.usageFlags == info->usageFlags)
        result = s->instance->create_swapchain(session, info, swapchain);
    if (XR_FAILED(result)) return result;
    auto state = std::make_unique<SwapchainState>();
    state->session = s;
    state->instance = s->instance;
    state->info = created;
    state->info.next = nullptr;
    std::lock_guard lock(g_mutex);
    s->swapchains[*swapchain] = std::move(state);
    return result;
}

XRAPI_ATTR XrResult XRAPI_CALL DestroySwapchain(XrSwapchain swapchain) {
    SwapchainState *state = nullptr;
    SessionState *session = nullptr;
    if (!find_swapchain(swapchain, &state, &session)) return XR_ERROR_HANDLE_INVALID;
    InstanceState *instance = state->instance;
    // Before the runtime destroys the images: the agent must stop naming them first.
    forget_swapchain(swapchain);
    return instance->destroy_swapchain(swapchain);
}

XRAPI_ATTR XrResult XRAPI_CALL EnumerateSwapchainImages(XrSwapchain swapchain, uint32_t capacity,
                                                        uint32_t *count, XrSwapchainImageBaseHeader *images) {
    SwapchainState *state = nullptr;
    SessionState *session = nullptr;
    if (!find_swapchain(swapchain, &state, &session)) return XR_ERROR_HANDLE_INVALID;
    const XrResult result = state->instance->enumerate_swapchain_images(swapchain, capacity, count, images);
    if (XR_FAILED(result) || capacity == 0 || !images || !session || !session->device || state->split)
        return result;
    if (images->type != XR_TYPE_SWAPCHAIN_IMAGE_VULKAN_KHR) return result;
    const auto *vulkan = reinterpret_cast<const XrSwapchainImageVulkanKHR *>(images);
    RuntimeSwapchain runtime;
    runtime.extent = {state->info.width, state->info.height};
    runtime.format = static_cast<VkFormat>(state->info.format);
    // The Vulkan layer adds TRANSFER_SRC to every image it creates (resource.cpp).
    runtime.usage = vulkan_usage(state->info.usageFlags) | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
    runtime.array_layers = state->info.arraySize;
    for (uint32_t i = 0; i < *count; ++i)
        runtime.images.push_back(vulkan[i].image);
    // Multisampled or mipmapped eye images are replicated but not split: the compositor writes
    // single-sampled level 0 only.
    if (state->info.sampleCount > 1 || state->info.mipCount > 1)
        runtime.usage &= ~VK_IMAGE_USAGE_TRANSFER_DST_BIT;
    state->split = register_runtime_swapchain(*session->device, split_key(swapchain), runtime);
    return result;
}

XRAPI_ATTR XrResult XRAPI_CALL AcquireSwapchainImage(XrSwapchain swapchain,
                                                     const XrSwapchainImageAcquireInfo *info,
                                                     uint32_t *index) {
    SwapchainState *state = nullptr;
    SessionState *session = nullptr;
    if (!find_swapchain(swapchain, &state, &session)) return XR_ERROR_HANDLE_INVALID;
    const XrResult result = state->instance->acquire_swapchain_image(swapchain, info, index);
    if (XR_FAILED(result) || !state->split || !session || !session->device) return result;
    {
        std::lock_guard lock(g_mutex);
        state->acquired.push_back(*index);
    }
    begin_runtime_frame(*session->device, *state->split, *index);
    return result;
}

XRAPI_ATTR XrResult XRAPI_CALL ReleaseSwapchainImage(XrSwapchain swapchain,
                                                     const XrSwapchainImageReleaseInfo *info) {
    SwapchainState *state = nullptr;
    SessionState *session = nullptr;
    if (!find_swapchain(swapchain, &state, &session)) return XR_ERROR_HANDLE_INVALID;
    if (state->split && session && session->device && session->queue) {
        bool acquired = false;
        uint32_t index = 0;
        std::vector<split::RuntimeEye> eyes;
        split::Gaze gaze;
        uint64_t xr_frame = 0;
        int32_t xr_view = -1;
        deadline::FrameDisplay display; // unknown for a release outside xrBeginFrame..xrEndFrame
        {
            std::lock_guard lock(g_mutex);
            if (!state->acquired.empty()) {
                index = state->acquired.front();
                state->acquired.pop_front();
                acquired = true;
            }
            eyes = state->eyes;
            gaze = image_gaze(eyes, state->eye_views, session->view_gaze);
            xr_frame = session->ended_frames;
            xr_view = state->first_view;
            if (session->begun) {
                auto &first = session->begun->display.first_release;
                if (!first) first = std::chrono::steady_clock::now();
                display = session->begun->display;
            }
        }
        // The application's rendering of this image has been submitted; the runtime's release
        // barrier has not: the composite goes between them on the queue.
        if (acquired)
            end_runtime_frame(*session->device, session->queue, *state->split, index, eyes, gaze, xr_frame,
                              xr_view, display);
    }
    return state->instance->release_swapchain_image(swapchain, info);
}

// A projection view's eye, where its swapchain is one this layer splits: the array layer and
// sub-image rectangle that hold it (the whole image of a swapchain per eye, a layer of one drawn
// with multiview, a half of a side-by-side one) and its field of view.
void note_projection_view(const XrCompositionLayerProjectionView &view, uint32_t view_index) {
    SwapchainState *state = nullptr;
    SessionState *session = nullptr;
    if (!find_swapchain(view.subImage.swapchain, &state, &session) || !state->split || !session ||
        !session->device)
        return;
    const XrRect2Di &rect = view.subImage.imageRect;
    protocol::SwapchainView sent;
    sent.angle_left = view.fov.angleLeft;
    sent.angle_right = view.fov.angleRight;
    sent.angle_up = view.fov.angleUp;
    sent.angle_down = view.fov.angleDown;
    sent.array_layer = view.subImage.imageArrayIndex;
    // What the agent would refuse (protocol::decode_swapchain_view, SwapchainImages::note_eye) is not
    // sent, once said: the foveae stay where they were. The runtime itself rejects such a frame.
    constexpr float kHalfPi = 1.5707963f;
    bool valid = rect.offset.x >= 0 && rect.offset.y >= 0 && rect.extent.width > 0 &&
                 rect.extent.height > 0 &&
                 uint64_t(rect.offset.x) + uint64_t(rect.extent.width) <= state->info.width &&
                 uint64_t(rect.offset.y) + uint64_t(rect.extent.height) <= state->info.height &&
                 view.subImage.imageArrayIndex < state->info.arraySize;
    for (float a : {sent.angle_left, sent.angle_right, sent.angle_up, sent.angle_down})
        valid = valid && std::isfinite(a) && a > -kHalfPi && a < kHalfPi;
    valid = valid && sent.angle_right > sent.angle_left && sent.angle_up > sent.angle_down;
    if (!valid) {
        static std::once_flag said;
        std::call_once(said, [&] {
            SPLITVK_INFO(
                "OpenXR: a projection view's sub-image (layer %u, %d,%d %dx%d of %ux%u, %u layers) or "
                "field of view is out of range; its eye's fovea stays where it was",
                view.subImage.imageArrayIndex, rect.offset.x, rect.offset.y, rect.extent.width,
                rect.extent.height, state->info.width, state->info.height, state->info.arraySize);
        });
        return;
    }
    sent.x = uint32_t(rect.offset.x);
    sent.y = uint32_t(rect.offset.y);
    sent.width = uint32_t(rect.extent.width);
    sent.height = uint32_t(rect.extent.height);
    // As the agent reads the message (Replayer::swapchain_view): the floats sent, the rectangle as sent.
    split::RuntimeEye eye;
    eye.layer = sent.array_layer;
    eye.rect = {{int32_t(sent.x), int32_t(sent.y)}, {sent.width, sent.height}};
    eye.fov = {sent.angle_left, sent.angle_right, sent.angle_up, sent.angle_down};
    {
        std::lock_guard lock(g_mutex);
        // Which view drew where is the layer's own business (the agent needs the eyes only).
        std::erase_if(state->eye_views, [&](const EyeOfView &e) {
            return e.layer == eye.layer && split::intersect(e.rect, eye.rect).extent.width > 0 &&
                   split::intersect(e.rect, eye.rect).extent.height > 0;
        });
        state->eye_views.push_back({eye.layer, eye.rect, view_index});
        if (!split::note_runtime_eye(state->eyes, eye)) return;
        // What the swapped split cuts the passes recorded from now on by.
        set_runtime_eyes(*state->split, state->eyes);
    }
    send_runtime_view(*session->device, *state->split, sent);
}

XRAPI_ATTR XrResult XRAPI_CALL EndFrame(XrSession session, const XrFrameEndInfo *info) {
    InstanceState *instance = nullptr;
    SessionGaze *gaze = nullptr;
    SessionState *state = nullptr;
    uint64_t ended = 0;
    std::optional<WaitedFrame> begun;
    {
        std::lock_guard lock(g_mutex);
        state = find_session_locked(session);
        if (!state) return XR_ERROR_HANDLE_INVALID;
        instance = state->instance;
        gaze = state->gaze.get();
        ended = state->ended_frames;
        begun = std::exchange(state->begun, std::nullopt);
        // The releases from here on belong to the next frame.
        ++state->ended_frames;
        // Which eye each swapchain's images hold, for the stats: the first view naming it.
        std::unordered_map<XrSwapchain, int32_t> first_view;
        for (uint32_t i = 0; info && i < info->layerCount; ++i) {
            const XrCompositionLayerBaseHeader *layer = info->layers[i];
            if (!layer || layer->type != XR_TYPE_COMPOSITION_LAYER_PROJECTION) continue;
            const auto *projection = reinterpret_cast<const XrCompositionLayerProjection *>(layer);
            for (uint32_t v = 0; v < projection->viewCount; ++v)
                first_view.emplace(projection->views[v].subImage.swapchain, static_cast<int32_t>(v));
        }
        for (const auto &[swapchain, view] : first_view)
            if (const auto s = state->swapchains.find(swapchain); s != state->swapchains.end())
                s->second->first_view = view;
    }
    // The views this frame was rendered with place the next frames' foveae (this frame's eye images
    // were released, and composited, before xrEndFrame).
    for (uint32_t i = 0; info && i < info->layerCount; ++i) {
        const XrCompositionLayerBaseHeader *layer = info->layers[i];
        if (!layer || layer->type != XR_TYPE_COMPOSITION_LAYER_PROJECTION) continue;
        const auto *projection = reinterpret_cast<const XrCompositionLayerProjection *>(layer);
        for (uint32_t v = 0; v < projection->viewCount; ++v)
            note_projection_view(projection->views[v], v);
    }
    if (gaze)
        for (uint32_t i = 0; info && i < info->layerCount; ++i) {
            const XrCompositionLayerBaseHeader *layer = info->layers[i];
            if (!layer || layer->type != XR_TYPE_COMPOSITION_LAYER_PROJECTION) continue;
            const auto *projection = reinterpret_cast<const XrCompositionLayerProjection *>(layer);
            gaze->note_views(projection->space, info->displayTime, projection->views, projection->viewCount);
            break;
        }
    const XrResult result = instance->end_frame(session, info);
    if (state->device) {
        // A frame the runtime refused was not submitted: its rows carry no latency.
        std::optional<double> latency_ms;
        if (XR_SUCCEEDED(result) && begun)
            latency_ms =
                std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - begun->returned)
                    .count();
        finish_runtime_frame(*state->device, ended, latency_ms);
    }
    return result;
}

// ------------------------------------------------------------------------- eye gaze (xr_gaze.h)

SessionState *find_session(XrSession session) {
    std::lock_guard lock(g_mutex);
    return find_session_locked(session);
}

XRAPI_ATTR XrResult XRAPI_CALL
SuggestInteractionProfileBindings(XrInstance instance, const XrInteractionProfileSuggestedBinding *info) {
    InstanceState *state = find_instance(instance);
    if (!state) return XR_ERROR_HANDLE_INVALID;
    if (!info) return XR_ERROR_VALIDATION_FAILURE;
    return state->gaze->suggest(*info);
}

XRAPI_ATTR XrResult XRAPI_CALL AttachSessionActionSets(XrSession session,
                                                       const XrSessionActionSetsAttachInfo *info) {
    SessionState *state = find_session(session);
    if (!state) return XR_ERROR_HANDLE_INVALID;
    const GazeDispatch &vk = state->instance->gaze->dispatch();
    // A second attach is the application's own error, for it to see as the runtime reports it.
    const XrActionSet ours = state->gaze && !state->gaze->is_attached() && info
                                 ? state->instance->gaze->prepare_attach()
                                 : XR_NULL_HANDLE;
    if (!ours) return vk.attach_action_sets(session, info);
    std::vector<XrActionSet> sets(info->actionSets, info->actionSets + info->countActionSets);
    sets.push_back(ours);
    XrSessionActionSetsAttachInfo with_ours = *info;
    with_ours.countActionSets = static_cast<uint32_t>(sets.size());
    with_ours.actionSets = sets.data();
    const XrResult result = vk.attach_action_sets(session, &with_ours);
    if (XR_SUCCEEDED(result)) {
        state->gaze->attached();
        return result;
    }
    // Whatever the runtime has against the layer's set, the application's attach must not fail for it.
    // Left unattached, the session's gaze stays fixed (SessionGaze::locate) and its syncs go down as
    // they are; it is not destroyed, since the frame calls may be using it on other threads.
    SPLITVK_WARN("SPLITVK_GAZE=openxr: the runtime would not attach the eye-gaze action (XrResult %d); the "
                 "foveae stay at the view directions",
                 static_cast<int>(result));
    return vk.attach_action_sets(session, info);
}

XRAPI_ATTR XrResult XRAPI_CALL SyncActions(XrSession session, const XrActionsSyncInfo *info) {
    SessionState *state = find_session(session);
    if (!state) return XR_ERROR_HANDLE_INVALID;
    const GazeDispatch &vk = state->instance->gaze->dispatch();
    if (!state->gaze || !state->gaze->is_attached() || !info) return vk.sync_actions(session, info);
    // Only the sets the application names are active until its next sync: the layer's set is named
    // with them, every time.
    std::vector<XrActiveActionSet> active(info->activeActionSets,
                                          info->activeActionSets + info->countActiveActionSets);
    active.push_back({state->instance->gaze->action_set(), XR_NULL_PATH});
    XrActionsSyncInfo with_ours = *info;
    with_ours.countActiveActionSets = static_cast<uint32_t>(active.size());
    with_ours.activeActionSets = active.data();
    const XrResult result = vk.sync_actions(session, &with_ours);
    // An error of the application's own making is for it to see, as the runtime reports it alone.
    return XR_FAILED(result) ? vk.sync_actions(session, info) : result;
}

// A frame's display time on the layer's clock. An XrTime is the runtime's own clock, with an epoch
// and rate of its choosing; XR_KHR_convert_timespec_time converts it exactly to CLOCK_MONOTONIC,
// which is read beside steady_clock here. A clock offset taken at xrWaitFrame's return would need the
// runtime's "now", which OpenXR does not give without that extension or another like it: the return
// is at a wake-up time of the runtime's choosing, not a known distance before the display.
deadline::FrameDisplay frame_display(const InstanceState &instance, XrTime time, XrDuration period) {
    deadline::FrameDisplay display;
    display.period = std::chrono::nanoseconds(std::max<XrDuration>(period, 0));
    timespec at{};
    if (!instance.convert_time || time <= 0 || XR_FAILED(instance.convert_time(instance.handle, time, &at)))
        return display;
    timespec monotonic_now{};
    const auto now = std::chrono::steady_clock::now();
    if (clock_gettime(CLOCK_MONOTONIC, &monotonic_now) == 0)
        display.time = deadline::from_monotonic(at, monotonic_now, now);
    return display;
}

XRAPI_ATTR XrResult XRAPI_CALL WaitFrame(XrSession session, const XrFrameWaitInfo *info,
                                         XrFrameState *frame) {
    SessionState *state = find_session(session);
    if (!state) return XR_ERROR_HANDLE_INVALID;
    const XrResult result = state->instance->wait_frame(session, info, frame);
    if (XR_SUCCEEDED(result) && frame) {
        WaitedFrame waited;
        waited.returned = std::chrono::steady_clock::now();
        XrDuration refresh_period = 0;
        {
            std::lock_guard lock(g_mutex);
            if (frame->predictedDisplayPeriod > 0 &&
                (state->refresh_period == 0 || frame->predictedDisplayPeriod < state->refresh_period))
                state->refresh_period = frame->predictedDisplayPeriod;
            refresh_period = state->refresh_period;
        }
        waited.display = frame_display(*state->instance, frame->predictedDisplayTime, refresh_period);
        std::lock_guard lock(g_mutex);
        if (waited.display.time && state->device && layer_settings().settings.xr_deadline &&
            !std::exchange(state->deadline_said, true))
            SPLITVK_INFO("OpenXR: eye images wait for their tiles until their display time allows (display "
                         "period %.1f ms), at most SPLITVK_TILE_WAIT",
                         std::chrono::duration<double, std::milli>(waited.display.period).count());
        if (state->waited.size() == kMaxWaitedFrames) state->waited.pop_front();
        state->waited.push_back(waited);
    }
    if (XR_SUCCEEDED(result) && frame && state->gaze) state->gaze->frame_waited(frame->predictedDisplayTime);
    return result;
}

XRAPI_ATTR XrResult XRAPI_CALL BeginFrame(XrSession session, const XrFrameBeginInfo *info) {
    SessionState *state = find_session(session);
    if (!state) return XR_ERROR_HANDLE_INVALID;
    // The display time of the frame this begins: xrWaitFrame, perhaps on another thread, may
    // already be waiting for the next one once the runtime returns.
    const XrTime predicted = state->gaze ? state->gaze->predicted() : 0;
    const XrResult result = state->instance->begin_frame(session, info);
    if (XR_SUCCEEDED(result)) {
        std::lock_guard lock(g_mutex);
        if (!state->waited.empty()) {
            state->begun = state->waited.front();
            state->waited.pop_front();
        }
    }
    if (XR_FAILED(result) || !state->device) return result;
    // The frame's gaze, before the application renders it: its releases place the foveae with it.
    ViewGaze view_gaze;
    if (state->gaze) {
        view_gaze = state->gaze->locate(predicted);
    } else if (const Settings &settings = layer_settings().settings; settings.gaze == GazeMode::Fifo) {
        const split::Gaze fifo = gaze::frame_gaze(settings);
        if (!fifo.fixed) view_gaze = {fifo.eyes[0], fifo.eyes[1]};
    }
    std::lock_guard lock(g_mutex);
    state->view_gaze = view_gaze;
    return result;
}

XRAPI_ATTR XrResult XRAPI_CALL GetInstanceProcAddr(XrInstance instance, const char *name,
                                                   PFN_xrVoidFunction *function);

XRAPI_ATTR XrResult XRAPI_CALL CreateApiLayerInstance(const XrInstanceCreateInfo *info,
                                                      const XrApiLayerCreateInfo *layer_info,
                                                      XrInstance *instance);

// The exception boundary (entry_boundary.h) of every function this layer hands out: `Function`
// inside a try block, named `Name` in the error line, with the split of the device its first
// argument leads to (a session's, or its swapchain's session's) ended by an exception.
template <size_t N>
struct EntryName {
    constexpr EntryName(const char (&text)[N]) { std::copy_n(text, N, name); }
    char name[N];
};

template <class Handle>
DeviceState *device_of(Handle) {
    return nullptr;
}
DeviceState *device_of(XrSession session) {
    std::lock_guard lock(g_mutex);
    const SessionState *state = find_session_locked(session);
    return state ? state->device : nullptr;
}
DeviceState *device_of(XrSwapchain swapchain) {
    std::lock_guard lock(g_mutex);
    const SwapchainState *state = find_swapchain_locked(swapchain);
    return state ? state->session->device : nullptr;
}

template <auto Function, EntryName Name>
struct Boundary;
template <class First, class... Rest, XrResult (*Function)(First, Rest...), EntryName Name>
struct Boundary<Function, Name> {
    static XRAPI_ATTR XrResult XRAPI_CALL call(First first, Rest... rest) {
        try {
            const XrResult result = Function(first, rest...);
            test_throw_point(Name.name);
            return result;
        } catch (...) {
            static std::atomic<bool> said{false};
            constexpr bool creates = std::string_view(Name.name).starts_with("xrCreate");
            return entry_threw(Name.name, device_of(first), EntryReturns::XrResult, creates, said)
                       ? XR_ERROR_OUT_OF_MEMORY
                       : XR_ERROR_RUNTIME_FAILURE;
        }
    }
};

struct Intercepted {
    const char *name;
    PFN_xrVoidFunction function;
};
template <auto Function, EntryName Name>
Intercepted intercepted() {
    return {Name.name, reinterpret_cast<PFN_xrVoidFunction>(&Boundary<Function, Name>::call)};
}

const Intercepted kIntercepted[] = {
    intercepted<GetInstanceProcAddr, "xrGetInstanceProcAddr">(),
    intercepted<DestroyInstance, "xrDestroyInstance">(),
    intercepted<CreateSession, "xrCreateSession">(),
    intercepted<DestroySession, "xrDestroySession">(),
    intercepted<CreateSwapchain, "xrCreateSwapchain">(),
    intercepted<DestroySwapchain, "xrDestroySwapchain">(),
    intercepted<EnumerateSwapchainImages, "xrEnumerateSwapchainImages">(),
    intercepted<AcquireSwapchainImage, "xrAcquireSwapchainImage">(),
    intercepted<ReleaseSwapchainImage, "xrReleaseSwapchainImage">(),
    intercepted<EndFrame, "xrEndFrame">(),
    intercepted<WaitFrame, "xrWaitFrame">(),
    intercepted<BeginFrame, "xrBeginFrame">(),
};
// The eye gaze's, handed out only for instances that have it: their InstanceState::gaze is never null.
const Intercepted kInterceptedForGaze[] = {
    intercepted<SuggestInteractionProfileBindings, "xrSuggestInteractionProfileBindings">(),
    intercepted<AttachSessionActionSets, "xrAttachSessionActionSets">(),
    intercepted<SyncActions, "xrSyncActions">(),
};
// What the loader is handed at negotiation, inside the same boundary.
const auto kGetInstanceProcAddr = &Boundary<GetInstanceProcAddr, "xrGetInstanceProcAddr">::call;
const auto kCreateApiLayerInstance = &Boundary<CreateApiLayerInstance, "xrCreateApiLayerInstance">::call;

XRAPI_ATTR XrResult XRAPI_CALL GetInstanceProcAddr(XrInstance instance, const char *name,
                                                   PFN_xrVoidFunction *function) {
    if (!name || !function) return XR_ERROR_VALIDATION_FAILURE;
    InstanceState *state = find_instance(instance);
    const auto ours = [&](const Intercepted &i) {
        // Ours only where the runtime has it too (an absent function must stay absent).
        if (state && state->get_instance_proc_addr(instance, name, function) != XR_SUCCESS)
            return XR_ERROR_FUNCTION_UNSUPPORTED;
        *function = i.function;
        return XR_SUCCESS;
    };
    for (const Intercepted &i : kIntercepted)
        if (std::strcmp(name, i.name) == 0) return ours(i);
    for (const Intercepted &i : kInterceptedForGaze)
        if (state && state->gaze && std::strcmp(name, i.name) == 0) return ours(i);
    // An extension the layer enabled for itself is not the application's to call.
    if (state && state->convert_time_hidden &&
        (std::strcmp(name, "xrConvertTimeToTimespecTimeKHR") == 0 ||
         std::strcmp(name, "xrConvertTimespecTimeToTimeKHR") == 0)) {
        *function = nullptr;
        return XR_ERROR_FUNCTION_UNSUPPORTED;
    }
    if (!state) {
        *function = nullptr;
        return XR_ERROR_HANDLE_INVALID;
    }
    return state->get_instance_proc_addr(instance, name, function);
}

XRAPI_ATTR XrResult XRAPI_CALL CreateApiLayerInstance(const XrInstanceCreateInfo *info,
                                                      const XrApiLayerCreateInfo *layer_info,
                                                      XrInstance *instance) {
    if (!layer_info || !layer_info->nextInfo ||
        std::strncmp(layer_info->nextInfo->layerName, kApiLayerName, XR_MAX_API_LAYER_NAME_SIZE) != 0) {
        SPLITVK_ERROR("%s: the OpenXR loader gave a chain that is not this layer's", kApiLayerName);
        return XR_ERROR_INITIALIZATION_FAILED;
    }
    // The settings (and so the log level) of the process, parsed once, as the Vulkan layer does.
    static_cast<void>(layer_settings());
    const XrApiLayerNextInfo &next = *layer_info->nextInfo;
    XrApiLayerCreateInfo down = *layer_info;
    down.nextInfo = next.next;
    // Extensions the layer needs beside the application's, where it did not enable them itself:
    // XR_KHR_convert_timespec_time (each frame's display time, the deadline of its tile waits) and,
    // with SPLITVK_GAZE=openxr, the eye-gaze one. A runtime that lacks one refuses the instance: it is
    // made with fewer, down to the application's own, which it never notices.
    std::vector<const char *> extensions;
    if (info)
        extensions.assign(info->enabledExtensionNames,
                          info->enabledExtensionNames + info->enabledExtensionCount);
    const auto has = [](const std::vector<const char *> &list, const char *name) {
        return std::any_of(list.begin(), list.end(),
                           [&](const char *e) { return e && std::strcmp(e, name) == 0; });
    };
    const bool wants_gaze = layer_settings().settings.gaze == GazeMode::OpenXR && info;
    const bool app_converts = has(extensions, XR_KHR_CONVERT_TIMESPEC_TIME_EXTENSION_NAME);
    std::vector<const char *> added;
    if (info && !app_converts) added.push_back(XR_KHR_CONVERT_TIMESPEC_TIME_EXTENSION_NAME);
    if (wants_gaze && !has(extensions, XR_EXT_EYE_GAZE_INTERACTION_EXTENSION_NAME))
        added.push_back(XR_EXT_EYE_GAZE_INTERACTION_EXTENSION_NAME);
    XrResult result = XR_ERROR_EXTENSION_NOT_PRESENT;
    std::vector<const char *> enabled;
    // Every subset of `added`, the largest first (bit i: added[i]).
    for (uint32_t mask = (1u << added.size()) - 1;; --mask) {
        enabled = extensions;
        for (size_t i = 0; i < added.size(); ++i)
            if (mask & (1u << i)) enabled.push_back(added[i]);
        if (mask == 0) {
            result = next.nextCreateApiLayerInstance(info, &down, instance);
            break;
        }
        XrInstanceCreateInfo with_ours = *info;
        with_ours.enabledExtensionCount = static_cast<uint32_t>(enabled.size());
        with_ours.enabledExtensionNames = enabled.data();
        result = next.nextCreateApiLayerInstance(&with_ours, &down, instance);
        if (result != XR_ERROR_EXTENSION_NOT_PRESENT) break;
    }
    bool gaze = wants_gaze && has(enabled, XR_EXT_EYE_GAZE_INTERACTION_EXTENSION_NAME);
    if (wants_gaze && !gaze && XR_SUCCEEDED(result))
        SPLITVK_WARN(
            "SPLITVK_GAZE=openxr: the OpenXR runtime lacks %s; the foveae stay at the view directions",
            XR_EXT_EYE_GAZE_INTERACTION_EXTENSION_NAME);
    if (XR_SUCCEEDED(result) && !has(enabled, XR_KHR_CONVERT_TIMESPEC_TIME_EXTENSION_NAME))
        SPLITVK_INFO("OpenXR: the runtime lacks %s: eye images wait for their tiles up to SPLITVK_TILE_WAIT, "
                     "whatever their display time",
                     XR_KHR_CONVERT_TIMESPEC_TIME_EXTENSION_NAME);
    if (XR_FAILED(result)) return result;

    auto state = std::make_unique<InstanceState>();
    state->handle = *instance;
    state->get_instance_proc_addr = next.nextGetInstanceProcAddr;
    const bool loaded =
        load(*state, *instance, "xrDestroyInstance", &state->destroy_instance) &&
        load(*state, *instance, "xrCreateSession", &state->create_session) &&
        load(*state, *instance, "xrDestroySession", &state->destroy_session) &&
        load(*state, *instance, "xrCreateSwapchain", &state->create_swapchain) &&
        load(*state, *instance, "xrDestroySwapchain", &state->destroy_swapchain) &&
        load(*state, *instance, "xrEnumerateSwapchainImages", &state->enumerate_swapchain_images) &&
        load(*state, *instance, "xrAcquireSwapchainImage", &state->acquire_swapchain_image) &&
        load(*state, *instance, "xrReleaseSwapchainImage", &state->release_swapchain_image) &&
        load(*state, *instance, "xrEndFrame", &state->end_frame) &&
        load(*state, *instance, "xrWaitFrame", &state->wait_frame) &&
        load(*state, *instance, "xrBeginFrame", &state->begin_frame);
    if (!loaded) {
        SPLITVK_ERROR("%s: the runtime lacks a core OpenXR function; instance not created", kApiLayerName);
        if (state->destroy_instance) state->destroy_instance(*instance);
        return XR_ERROR_INITIALIZATION_FAILED;
    }
    if (has(enabled, XR_KHR_CONVERT_TIMESPEC_TIME_EXTENSION_NAME) &&
        !load(*state, *instance, "xrConvertTimeToTimespecTimeKHR", &state->convert_time))
        state->convert_time = nullptr;
    state->convert_time_hidden = !app_converts;
    if (gaze) {
        GazeDispatch dispatch;
        if (dispatch.load(next.nextGetInstanceProcAddr, *instance))
            state->gaze = std::make_unique<InstanceGaze>(*instance, dispatch);
        else
            SPLITVK_WARN(
                "SPLITVK_GAZE=openxr: the runtime lacks an action function; the foveae stay at the view "
                "directions");
    }
    SPLITVK_INFO("%s active in '%s'", kApiLayerName, info ? info->applicationInfo.applicationName : "?");
    std::lock_guard lock(g_mutex);
    g_instances[*instance] = std::move(state);
    return result;
}

} // namespace
} // namespace splitvk::xr

namespace splitvk::xr {
namespace {

XrResult negotiate(const XrNegotiateLoaderInfo *loader_info, const char *layer_name,
                   XrNegotiateApiLayerRequest *request) {
    if (!loader_info || !request || loader_info->structType != XR_LOADER_INTERFACE_STRUCT_LOADER_INFO ||
        loader_info->structVersion != XR_LOADER_INFO_STRUCT_VERSION ||
        loader_info->structSize != sizeof(XrNegotiateLoaderInfo) ||
        request->structType != XR_LOADER_INTERFACE_STRUCT_API_LAYER_REQUEST ||
        request->structVersion != XR_API_LAYER_INFO_STRUCT_VERSION ||
        request->structSize != sizeof(XrNegotiateApiLayerRequest))
        return XR_ERROR_INITIALIZATION_FAILED;
    if (layer_name && std::strcmp(layer_name, kApiLayerName) != 0) return XR_ERROR_INITIALIZATION_FAILED;
    if (loader_info->minInterfaceVersion > XR_CURRENT_LOADER_API_LAYER_VERSION ||
        loader_info->maxInterfaceVersion < XR_CURRENT_LOADER_API_LAYER_VERSION)
        return XR_ERROR_INITIALIZATION_FAILED;
    // SPLITVK_DISABLE keeps splitvk out however it was enabled (the Vulkan layer declines the same way).
    if (splitvk::disabled_by_environment()) return XR_ERROR_INITIALIZATION_FAILED;
    request->layerInterfaceVersion = XR_CURRENT_LOADER_API_LAYER_VERSION;
    request->layerApiVersion = XR_CURRENT_API_VERSION;
    request->getInstanceProcAddr = kGetInstanceProcAddr;
    request->createApiLayerInstance = kCreateApiLayerInstance;
    return XR_SUCCESS;
}

} // namespace
} // namespace splitvk::xr

// Its exception boundary is written out here: it is in no table.
extern "C" __attribute__((visibility("default"))) XrResult XRAPI_CALL xrNegotiateLoaderApiLayerInterface(
    const XrNegotiateLoaderInfo *loader_info, const char *layer_name, XrNegotiateApiLayerRequest *request) {
    try {
        return splitvk::xr::negotiate(loader_info, layer_name, request);
    } catch (...) {
        static std::atomic<bool> said{false};
        return splitvk::entry_threw("xrNegotiateLoaderApiLayerInterface", nullptr,
                                    splitvk::EntryReturns::XrResult, false, said)
                   ? XR_ERROR_OUT_OF_MEMORY
                   : XR_ERROR_RUNTIME_FAILURE;
    }
}
