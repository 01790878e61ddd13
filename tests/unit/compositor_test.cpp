// The layer's compositor (layer/present/compositor.cpp) on the first Vulkan device (lavapipe in tests),
// driven directly, without the layer: plain images stand in for a swapchain's. Each frame
// "renders" known content into an image (signalling a semaphore, as an application's last submit
// does), composites it with two fovea tiles (one reaching past the image), and reads the result
// back after waiting on the compositor's semaphore, as the present would. Checks: the tiles are
// bit-exact (UNORM and sRGB), the rest is the top-left periphery upsampled (bilinear and
// Catmull-Rom against CPU references, within 2 of 255), slots are reused across frames, and the
// Khronos validation layer with synchronization validation, when installed, says nothing. The
// Timed variant goes the SPLITVK_STATS way: take_waits() first, and a measured composite GPU time.
// composite_periphery (the swapped split) keeps the application's foveae bit-exact and upsamples the
// agent's periphery, or the previous one for a late frame.

#include "core/gpu_timing.h"
#include "core/host_buffer.h"
#include "core/instance.h"
#include "core/swapchain.h"
#include "core/vk_util.h"
#include "present/compositor.h"
#include "split_geometry.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace splitvk {
// DeviceState owns a std::unique_ptr<Session>; the compositor never touches the session, so a
// complete (empty) type is all this binary needs to destroy a DeviceState.
class Session {};

namespace {

// 0.6 of these is 48x27: image and periphery line up every 5 pixels, so the blit skips the tiles.
constexpr uint32_t kWidth = 80, kHeight = 45;
constexpr VkExtent2D kPeriphery{(kWidth * 3 + 4) / 5, (kHeight * 3 + 4) / 5}; // ceil(0.6 W) x ceil(0.6 H)
constexpr uint32_t kImages = 2, kFrames = 5;
// How far an upsampled periphery texel may be from the exact filter, in 8-bit levels. A driver with
// 8 sub-texel bits (Vulkan's minimum, lavapipe's) may cut each axis's filter weight by up to 2^-8,
// up to a level per axis on a full-range edge, more where Catmull-Rom's taps add their cuts, and
// rounding to UNORM adds half a level. lavapipe's x86-64 build stays within 2 (at either vector
// width); its arm64 build reaches 2.00005 bilinear and 2.7 Catmull-Rom. The reference itself rounds
// the same with or without fused multiply-adds.
constexpr float kUpsampleTolerance = 3.0f;

int g_messages = 0;
VKAPI_ATTR VkBool32 VKAPI_CALL on_message(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                          VkDebugUtilsMessageTypeFlagsEXT,
                                          const VkDebugUtilsMessengerCallbackDataEXT *data, void *) {
    if (severity >= VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT) {
        ++g_messages;
        ADD_FAILURE() << "validation: " << data->pMessage;
    }
    return VK_FALSE;
}

uint32_t memory_type(const VkPhysicalDeviceMemoryProperties &props, uint32_t bits,
                     VkMemoryPropertyFlags want) {
    for (uint32_t i = 0; i < props.memoryTypeCount; ++i)
        if ((bits & (1u << i)) && (props.memoryTypes[i].propertyFlags & want) == want) return i;
    return UINT32_MAX;
}

float srgb_to_linear(float v) {
    return v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f);
}
float linear_to_srgb(float l) {
    l = std::clamp(l, 0.0f, 1.0f);
    return l <= 0.0031308f ? l * 12.92f : 1.055f * std::pow(l, 1.0f / 2.4f) - 0.055f;
}

// The Catmull-Rom weights of the four texels around a point `f` past the second one's centre.
void catmull_rom_weights(float f, float w[4]) {
    w[0] = f * (-0.5f + f * (1.0f - 0.5f * f));
    w[1] = 1.0f + f * f * (-2.5f + 1.5f * f);
    w[2] = f * (0.5f + f * (2.0f - 1.5f * f));
    w[3] = f * f * (-0.5f + 0.5f * f);
}

struct Param {
    VkFormat format;
    UpsampleFilter filter;
    // SPLITVK_STATS' path: take_waits() stands in for the application's semaphores, and the
    // composite's GPU time is measured.
    bool timed = false;
};

class CompositorTest : public ::testing::TestWithParam<Param> {
protected:
    void SetUp() override {
        g_messages = 0;
        uint32_t count = 0;
        vkEnumerateInstanceLayerProperties(&count, nullptr);
        std::vector<VkLayerProperties> layers(count);
        vkEnumerateInstanceLayerProperties(&count, layers.data());
        validation_ = std::any_of(layers.begin(), layers.end(), [](const VkLayerProperties &l) {
            return std::strcmp(l.layerName, "VK_LAYER_KHRONOS_validation") == 0;
        });
        const char *layer = "VK_LAYER_KHRONOS_validation";
        // VK_KHR_surface: VK_KHR_swapchain (for the PRESENT_SRC_KHR layout) requires it.
        const char *extensions[] = {VK_KHR_SURFACE_EXTENSION_NAME, VK_EXT_DEBUG_UTILS_EXTENSION_NAME};
        VkValidationFeatureEnableEXT sync = VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT;
        VkValidationFeaturesEXT features{};
        features.sType = VK_STRUCTURE_TYPE_VALIDATION_FEATURES_EXT;
        features.enabledValidationFeatureCount = 1;
        features.pEnabledValidationFeatures = &sync;
        VkApplicationInfo app{};
        app.sType = VK_STRUCTURE_TYPE_APPLICATION_INFO;
        app.apiVersion = VK_API_VERSION_1_0; // what vkcube asks for: the compositor must cope
        VkInstanceCreateInfo info{};
        info.sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO;
        info.pApplicationInfo = &app;
        info.enabledExtensionCount = 1;
        info.ppEnabledExtensionNames = extensions;
        if (validation_) {
            info.pNext = &features;
            info.enabledLayerCount = 1;
            info.ppEnabledLayerNames = &layer;
            info.enabledExtensionCount = 2;
        }
        if (vkCreateInstance(&info, nullptr, &instance_) != VK_SUCCESS) GTEST_SKIP() << "no Vulkan instance";
        if (validation_) {
            VkDebugUtilsMessengerCreateInfoEXT messenger{};
            messenger.sType = VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT;
            messenger.messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT |
                                        VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
            messenger.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT |
                                    VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                                    VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
            messenger.pfnUserCallback = on_message;
            auto create = reinterpret_cast<PFN_vkCreateDebugUtilsMessengerEXT>(
                vkGetInstanceProcAddr(instance_, "vkCreateDebugUtilsMessengerEXT"));
            ASSERT_TRUE(create);
            ASSERT_EQ(create(instance_, &messenger, nullptr, &messenger_), VK_SUCCESS);
        }
        count = 1;
        VkPhysicalDevice physical = VK_NULL_HANDLE;
        const VkResult enumerated = vkEnumeratePhysicalDevices(instance_, &count, &physical);
        if ((enumerated != VK_SUCCESS && enumerated != VK_INCOMPLETE) || !physical)
            GTEST_SKIP() << "no Vulkan device";
        vkGetPhysicalDeviceQueueFamilyProperties(physical, &count, nullptr);
        std::vector<VkQueueFamilyProperties> families(count);
        vkGetPhysicalDeviceQueueFamilyProperties(physical, &count, families.data());
        family_ = UINT32_MAX;
        for (uint32_t i = 0; i < count && family_ == UINT32_MAX; ++i)
            if (families[i].queueFlags & VK_QUEUE_GRAPHICS_BIT) family_ = i;
        if (family_ == UINT32_MAX) GTEST_SKIP() << "no graphics queue";

        const float priority = 1.0f;
        VkDeviceQueueCreateInfo queue_info{};
        queue_info.sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO;
        queue_info.queueFamilyIndex = family_;
        queue_info.queueCount = 1;
        queue_info.pQueuePriorities = &priority;
        // VK_KHR_swapchain makes PRESENT_SRC_KHR a layout these images may be in.
        const char *swapchain = VK_KHR_SWAPCHAIN_EXTENSION_NAME;
        VkDeviceCreateInfo device_info{};
        device_info.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
        device_info.queueCreateInfoCount = 1;
        device_info.pQueueCreateInfos = &queue_info;
        device_info.enabledExtensionCount = 1;
        device_info.ppEnabledExtensionNames = &swapchain;
        VkDevice device = VK_NULL_HANDLE;
        if (vkCreateDevice(physical, &device_info, nullptr, &device) != VK_SUCCESS)
            GTEST_SKIP() << "no device with VK_KHR_swapchain";
        vkGetDeviceQueue(device, family_, 0, &queue_);

        instance_state_.handle = instance_;
        load_instance_dispatch_table(instance_state_.dispatch, instance_, vkGetInstanceProcAddr);
        device_.handle = device;
        device_.physical_device = physical;
        device_.instance = &instance_state_;
        load_device_dispatch_table(device_.dispatch, device, vkGetDeviceProcAddr);
        vkGetPhysicalDeviceMemoryProperties(physical, &device_.memory_properties);
        device_.gpu_timing = make_gpu_timing_table(); // the compositor's timed composites use it
    }

    void TearDown() override {
        if (device_.handle) {
            const VkDevice d = device_.handle;
            vkDeviceWaitIdle(d);
            for (const VkFence fence : made_.fences)
                vkDestroyFence(d, fence, nullptr);
            for (const VkSemaphore semaphore : made_.semaphores)
                vkDestroySemaphore(d, semaphore, nullptr);
            for (const VkCommandPool pool : made_.pools)
                vkDestroyCommandPool(d, pool, nullptr);
            for (const VkBuffer buffer : made_.buffers)
                vkDestroyBuffer(d, buffer, nullptr);
            for (const VkImage image : made_.images)
                vkDestroyImage(d, image, nullptr);
            for (const VkDeviceMemory memory : made_.memories)
                vkFreeMemory(d, memory, nullptr);
            vkDestroyDevice(d, nullptr);
        }
        if (messenger_) {
            auto destroy = reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(
                vkGetInstanceProcAddr(instance_, "vkDestroyDebugUtilsMessengerEXT"));
            destroy(instance_, messenger_, nullptr);
        }
        if (instance_) vkDestroyInstance(instance_, nullptr);
    }

    // Memory for `req` of a type with `properties`, freed in TearDown.
    void allocate(const VkMemoryRequirements &req, VkMemoryPropertyFlags properties, VkDeviceMemory *memory) {
        VkMemoryAllocateInfo alloc{};
        alloc.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
        alloc.allocationSize = req.size;
        alloc.memoryTypeIndex = memory_type(device_.memory_properties, req.memoryTypeBits, properties);
        ASSERT_NE(alloc.memoryTypeIndex, UINT32_MAX);
        ASSERT_EQ(vkAllocateMemory(device_.handle, &alloc, nullptr, memory), VK_SUCCESS);
        made_.memories.push_back(*memory);
    }

    // An image standing in for a swapchain's (or, of several layers, for an OpenXR runtime's eye
    // image), bound to memory of its own.
    void make_image(VkFormat format, VkExtent2D extent, uint32_t layers, VkImageUsageFlags usage,
                    VkImage *image) {
        const VkDevice d = device_.handle;
        VkImageCreateInfo info{};
        info.sType = VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO;
        info.imageType = VK_IMAGE_TYPE_2D;
        info.format = format;
        info.extent = {extent.width, extent.height, 1};
        info.mipLevels = 1;
        info.arrayLayers = layers;
        info.samples = VK_SAMPLE_COUNT_1_BIT;
        info.tiling = VK_IMAGE_TILING_OPTIMAL;
        info.usage = usage;
        ASSERT_EQ(vkCreateImage(d, &info, nullptr, image), VK_SUCCESS);
        made_.images.push_back(*image);
        VkMemoryRequirements req;
        vkGetImageMemoryRequirements(d, *image, &req);
        VkDeviceMemory memory = VK_NULL_HANDLE;
        ASSERT_NO_FATAL_FAILURE(allocate(req, 0, &memory));
        ASSERT_EQ(vkBindImageMemory(d, *image, memory, 0), VK_SUCCESS);
    }

    // The application's staging and readback buffer: host-visible, coherent, mapped.
    void make_host_buffer(VkDeviceSize bytes, VkBuffer *buffer, uint8_t **mapped) {
        const VkDevice d = device_.handle;
        VkBufferCreateInfo info{};
        info.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
        info.size = bytes;
        info.usage = VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
        ASSERT_EQ(vkCreateBuffer(d, &info, nullptr, buffer), VK_SUCCESS);
        made_.buffers.push_back(*buffer);
        VkMemoryRequirements req;
        vkGetBufferMemoryRequirements(d, *buffer, &req);
        VkDeviceMemory memory = VK_NULL_HANDLE;
        ASSERT_NO_FATAL_FAILURE(allocate(
            req, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT, &memory));
        ASSERT_EQ(vkBindBufferMemory(d, *buffer, memory, 0), VK_SUCCESS);
        void *mapped_void = nullptr;
        ASSERT_EQ(vkMapMemory(d, memory, 0, VK_WHOLE_SIZE, 0, &mapped_void), VK_SUCCESS);
        *mapped = static_cast<uint8_t *>(mapped_void);
    }

    // A resettable command buffer on the graphics queue's family, and a fence for its submits.
    void make_command_buffer(VkCommandBuffer *cb, VkFence *fence) {
        const VkDevice d = device_.handle;
        VkCommandPoolCreateInfo pool_info{};
        pool_info.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
        pool_info.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
        pool_info.queueFamilyIndex = family_;
        VkCommandPool pool = VK_NULL_HANDLE;
        ASSERT_EQ(vkCreateCommandPool(d, &pool_info, nullptr, &pool), VK_SUCCESS);
        made_.pools.push_back(pool);
        VkCommandBufferAllocateInfo cb_info{};
        cb_info.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
        cb_info.commandPool = pool;
        cb_info.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
        cb_info.commandBufferCount = 1;
        ASSERT_EQ(vkAllocateCommandBuffers(d, &cb_info, cb), VK_SUCCESS);
        VkFenceCreateInfo fence_info{};
        fence_info.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
        ASSERT_EQ(vkCreateFence(d, &fence_info, nullptr, fence), VK_SUCCESS);
        made_.fences.push_back(*fence);
    }

    // What a window's composite starts from: a swapchain of kImages images of `format`, kWidth x
    // kHeight, the application's staging buffer of one image, a command buffer with its fence, and the
    // semaphore the application's rendering signals.
    struct Window {
        SwapchainState sc;
        VkBuffer buffer = VK_NULL_HANDLE;
        uint8_t *mapped = nullptr;
        VkCommandBuffer cb = VK_NULL_HANDLE;
        VkFence fence = VK_NULL_HANDLE;
        VkSemaphore rendered = VK_NULL_HANDLE;
    };
    void make_window(VkFormat format, uintptr_t handle, Window *w) {
        w->sc.handle = reinterpret_cast<VkSwapchainKHR>(handle);
        w->sc.extent = {kWidth, kHeight};
        w->sc.format = format;
        w->sc.composable = true;
        w->sc.images.resize(kImages);
        for (VkImage &image : w->sc.images)
            ASSERT_NO_FATAL_FAILURE(make_image(format, w->sc.extent, 1, Compositor::kSwapchainUsage, &image));
        ASSERT_NO_FATAL_FAILURE(make_host_buffer(VkDeviceSize{kWidth} * kHeight * 4, &w->buffer, &w->mapped));
        ASSERT_NO_FATAL_FAILURE(make_command_buffer(&w->cb, &w->fence));
        VkSemaphoreCreateInfo semaphore_info{};
        semaphore_info.sType = VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO;
        ASSERT_EQ(vkCreateSemaphore(device_.handle, &semaphore_info, nullptr, &w->rendered), VK_SUCCESS);
        made_.semaphores.push_back(w->rendered);
    }

    // Ends w.cb and submits it, waiting on `wait` at the transfer stage and signalling `signal`, then
    // waits for it.
    void submit_and_wait(const Window &w, const VkSemaphore *wait, const VkSemaphore *signal) {
        vkEndCommandBuffer(w.cb);
        const VkPipelineStageFlags transfer_stage = VK_PIPELINE_STAGE_TRANSFER_BIT;
        VkSubmitInfo submit{};
        submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
        submit.commandBufferCount = 1;
        submit.pCommandBuffers = &w.cb;
        submit.waitSemaphoreCount = wait ? 1 : 0;
        submit.pWaitSemaphores = wait;
        submit.pWaitDstStageMask = &transfer_stage;
        submit.signalSemaphoreCount = signal ? 1 : 0;
        submit.pSignalSemaphores = signal;
        ASSERT_EQ(vkQueueSubmit(queue_, 1, &submit, w.fence), VK_SUCCESS);
        ASSERT_EQ(vkWaitForFences(device_.handle, 1, &w.fence, VK_TRUE, 10'000'000'000ull), VK_SUCCESS);
        vkResetFences(device_.handle, 1, &w.fence);
    }

    // The application's frame: `pixels` (kWidth x kHeight, 4 bytes each) copied into image `index`,
    // which ends in PRESENT_SRC_KHR with w.rendered signalled, as a present finds it.
    void render_frame(const Window &w, uint32_t index, const std::vector<uint8_t> &pixels) {
        const VkImage image = w.sc.images[index];
        std::memcpy(w.mapped, pixels.data(), pixels.size());
        VkCommandBufferBeginInfo begin{};
        begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
        vkBeginCommandBuffer(w.cb, &begin);
        const VkImageMemoryBarrier to_copy =
            colour_image_barrier(image, 0, VK_ACCESS_TRANSFER_WRITE_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                                 VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL);
        vkCmdPipelineBarrier(w.cb, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0,
                             nullptr, 0, nullptr, 1, &to_copy);
        VkBufferImageCopy whole{};
        whole.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
        whole.imageExtent = {kWidth, kHeight, 1};
        vkCmdCopyBufferToImage(w.cb, w.buffer, image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &whole);
        const VkImageMemoryBarrier to_present =
            colour_image_barrier(image, VK_ACCESS_TRANSFER_WRITE_BIT, 0, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                                 VK_IMAGE_LAYOUT_PRESENT_SRC_KHR);
        vkCmdPipelineBarrier(w.cb, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, 0, 0,
                             nullptr, 0, nullptr, 1, &to_present);
        submit_and_wait(w, nullptr, &w.rendered);
    }

    // What the make_* helpers made, destroyed in TearDown before the device (the compositor, which
    // uses them, is gone by then).
    struct Made {
        std::vector<VkImage> images;
        std::vector<VkBuffer> buffers;
        std::vector<VkDeviceMemory> memories;
        std::vector<VkCommandPool> pools;
        std::vector<VkFence> fences;
        std::vector<VkSemaphore> semaphores;
    } made_;
    bool validation_ = false;
    VkInstance instance_ = VK_NULL_HANDLE;
    VkDebugUtilsMessengerEXT messenger_ = VK_NULL_HANDLE;
    InstanceState instance_state_;
    DeviceState device_;
    uint32_t family_ = 0;
    VkQueue queue_ = VK_NULL_HANDLE;
};

// What the application rendered: smooth (so bicubic taps are not dominated by rounding) and
// different every frame.
uint8_t content(uint32_t x, uint32_t y, uint32_t c, uint32_t frame) {
    const double v = 128.0 + 100.0 * std::sin(x * 0.35 + c * 1.3 + frame) * std::cos(y * 0.27 + frame * 0.5);
    return static_cast<uint8_t>(std::lround(v));
}
uint8_t tile_byte(uint32_t x, uint32_t y, uint32_t c, uint32_t frame) {
    return static_cast<uint8_t>(x * 7 + y * 13 + c * 77 + frame * 31);
}

TEST_P(CompositorTest, TilesAreExactAndPeripheryIsUpsampled) {
    const auto [format, filter, timed] = GetParam();
    const bool srgb = format == VK_FORMAT_B8G8R8A8_SRGB;
    const VkDevice d = device_.handle;
    std::string why;
    if (!Compositor::supports(device_, format, &why)) GTEST_SKIP() << why;

    // The "swapchain" images, the application's staging/readback buffer, sync objects.
    Window window;
    ASSERT_NO_FATAL_FAILURE(make_window(format, 0x5c, &window));
    SwapchainState &sc = window.sc;
    const VkDeviceSize bytes = VkDeviceSize{kWidth} * kHeight * 4;
    const VkBuffer buffer = window.buffer;
    uint8_t *const mapped = window.mapped;
    const VkCommandBuffer cb = window.cb;
    const VkSemaphore rendered = window.rendered;

    std::string error;
    UploadPool uploads(device_); // outlives the compositor, which holds its buffers
    auto compositor = Compositor::create(device_, sc, family_, &error, filter, timed);
    ASSERT_TRUE(compositor) << error;

    const auto barrier = [&](VkImage image, VkImageLayout from, VkImageLayout to, VkAccessFlags src_access,
                             VkAccessFlags dst_access, VkPipelineStageFlags src, VkPipelineStageFlags dst) {
        VkImageMemoryBarrier b{};
        b.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER;
        b.srcAccessMask = src_access;
        b.dstAccessMask = dst_access;
        b.oldLayout = from;
        b.newLayout = to;
        b.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
        b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
        b.image = image;
        b.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
        vkCmdPipelineBarrier(cb, src, dst, 0, 0, nullptr, 0, nullptr, 1, &b);
    };
    VkBufferImageCopy whole{};
    whole.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    whole.imageExtent = {kWidth, kHeight, 1};
    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;

    std::vector<uint8_t> rendered_pixels(bytes);
    for (uint32_t frame = 0; frame < kFrames; ++frame) {
        const uint32_t index = frame % kImages;
        const VkImage image = sc.images[index];
        // The application's frame, ending in PRESENT_SRC_KHR with `rendered` signalled.
        for (uint32_t y = 0; y < kHeight; ++y)
            for (uint32_t x = 0; x < kWidth; ++x)
                for (uint32_t c = 0; c < 4; ++c)
                    rendered_pixels[(size_t{y} * kWidth + x) * 4 + c] = content(x, y, c, frame);
        ASSERT_NO_FATAL_FAILURE(render_frame(window, index, rendered_pixels));

        // Three tiles, written into upload buffers as the layer's decoder writes them: one in the
        // middle, one reaching past the right edge and one past the top-left corner (each copied
        // clipped, from inside its buffer).
        const VkRect2D rects[3] = {
            {{20, 15}, {17, 11}}, {{int32_t(kWidth) - 6, 3}, {10, 5}}, {{-4, -3}, {9, 7}}};
        std::vector<uint8_t> tile_pixels[3];
        FoveaTile tiles[3];
        for (int t = 0; t < 3; ++t) {
            tile_pixels[t].resize(size_t{rects[t].extent.width} * rects[t].extent.height * 4);
            for (uint32_t y = 0; y < rects[t].extent.height; ++y)
                for (uint32_t x = 0; x < rects[t].extent.width; ++x)
                    for (uint32_t c = 0; c < 4; ++c)
                        tile_pixels[t][(size_t{y} * rects[t].extent.width + x) * 4 + c] =
                            tile_byte(x, y, c + 4 * t, frame);
            auto upload = uploads.take(tile_pixels[t].size(), &error);
            ASSERT_TRUE(upload) << error;
            std::memcpy(upload->mapped, tile_pixels[t].data(), tile_pixels[t].size());
            uploads.flush(*upload);
            tiles[t] = {rects[t], upload->buffer, 0, upload};
        }
        VkSemaphore waits = rendered;
        if (timed) {
            VkFence done = VK_NULL_HANDLE;
            ASSERT_EQ(compositor->take_waits(queue_, index, std::span(&rendered, 1), &waits, &done),
                      VK_SUCCESS);
            ASSERT_NE(waits, rendered);
            // The fence says when the application's frame is done on the GPU: it is.
            EXPECT_EQ(vkWaitForFences(d, 1, &done, VK_TRUE, 10'000'000'000ull), VK_SUCCESS);
        }
        VkSemaphore signal = VK_NULL_HANDLE;
        ASSERT_EQ(compositor->composite(queue_, index, std::span(&waits, 1), kPeriphery, tiles, &signal),
                  VK_SUCCESS);
        ASSERT_NE(signal, VK_NULL_HANDLE);

        // What the present would show: read back after waiting on the compositor's semaphore.
        vkBeginCommandBuffer(cb, &begin);
        barrier(image, VK_IMAGE_LAYOUT_PRESENT_SRC_KHR, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, 0,
                VK_ACCESS_TRANSFER_READ_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT);
        vkCmdCopyImageToBuffer(cb, image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, buffer, 1, &whole);
        ASSERT_NO_FATAL_FAILURE(submit_and_wait(window, &signal, nullptr));
        const uint8_t *shown = mapped;

        // The tiles, byte for byte, clipped to the image.
        uint64_t tile_mismatches = 0;
        for (int t = 0; t < 3; ++t)
            for (uint32_t y = 0; y < rects[t].extent.height; ++y)
                for (uint32_t x = 0; x < rects[t].extent.width; ++x) {
                    const int64_t ix = int64_t{rects[t].offset.x} + x, iy = int64_t{rects[t].offset.y} + y;
                    if (ix < 0 || iy < 0 || ix >= kWidth || iy >= kHeight) continue;
                    if (std::memcmp(shown + (size_t(iy) * kWidth + size_t(ix)) * 4,
                                    tile_pixels[t].data() + (size_t{y} * rects[t].extent.width + x) * 4, 4))
                        ++tile_mismatches;
                }
        EXPECT_EQ(tile_mismatches, 0u) << "frame " << frame;

        // The rest: the top-left periphery of what was rendered, upsampled.
        const auto texel = [&](int x, int y, uint32_t c) {
            x = std::clamp(x, 0, int(kPeriphery.width) - 1);
            y = std::clamp(y, 0, int(kPeriphery.height) - 1);
            const float v = rendered_pixels[(size_t(y) * kWidth + x) * 4 + c] / 255.0f;
            return srgb && c < 3 ? srgb_to_linear(v) : v;
        };
        float worst = 0.0f;
        for (uint32_t y = 0; y < kHeight; ++y)
            for (uint32_t x = 0; x < kWidth; ++x) {
                bool in_tile = false;
                for (const auto &r : rects)
                    in_tile |= int(x) >= r.offset.x && int(x) < r.offset.x + int(r.extent.width) &&
                               int(y) >= r.offset.y && int(y) < r.offset.y + int(r.extent.height);
                if (in_tile) continue;
                const float px =
                    std::clamp((x + 0.5f) * kPeriphery.width / kWidth, 0.5f, kPeriphery.width - 0.5f);
                const float py =
                    std::clamp((y + 0.5f) * kPeriphery.height / kHeight, 0.5f, kPeriphery.height - 0.5f);
                const int ix = int(std::floor(px - 0.5f)), iy = int(std::floor(py - 0.5f));
                const float fx = px - 0.5f - ix, fy = py - 0.5f - iy;
                for (uint32_t c = 0; c < 4; ++c) {
                    float v = 0.0f;
                    if (filter == UpsampleFilter::CatmullRom) { // BilinearBlit: the bilinear reference
                        float wx[4], wy[4];
                        catmull_rom_weights(fx, wx);
                        catmull_rom_weights(fy, wy);
                        for (int j = 0; j < 4; ++j)
                            for (int i = 0; i < 4; ++i)
                                v += wx[i] * wy[j] * texel(ix - 1 + i, iy - 1 + j, c);
                    } else {
                        v = (texel(ix, iy, c) * (1 - fx) + texel(ix + 1, iy, c) * fx) * (1 - fy) +
                            (texel(ix, iy + 1, c) * (1 - fx) + texel(ix + 1, iy + 1, c) * fx) * fy;
                    }
                    const float expected =
                        255.0f * (srgb && c < 3 ? linear_to_srgb(v) : std::clamp(v, 0.0f, 1.0f));
                    worst = std::max(worst, std::abs(expected - shown[(size_t{y} * kWidth + x) * 4 + c]));
                }
            }
        EXPECT_LE(worst, kUpsampleTolerance)
            << "frame " << frame << ": the periphery differs from the reference";
    }

    if (timed) {
        // Frames 2 and up reused a slot after its fence: the earlier composites' times were read.
        EXPECT_GT(compositor->latest_gpu_ms(), 0.0);
        EXPECT_LT(compositor->latest_gpu_ms(), 10'000.0);
        EXPECT_EQ(latest_periphery_ms(device_), 0.0) << "no split pass was timed";
    }
    compositor.reset(); // waits for its submits
    release_gpu_timing(device_);
    if (validation_) {
        EXPECT_EQ(g_messages, 0);
    }
}

// An OpenXR runtime's eye image of two layers (one eye each, drawn with multiview): released in
// COLOR_ATTACHMENT_OPTIMAL with no semaphore (the queue orders the composite), composited with no
// signal. Each layer's periphery is its own top-left upsampled, each tile lands in its own layer
// only (the same rectangle in both layers is no overlap), and a tile for a layer the image lacks is
// dropped. Every filter: the blit per layer region, the draw one pass per layer.
TEST_P(CompositorTest, LayeredRuntimeImageGetsEachLayersTilesAndPeriphery) {
    const auto [format, filter, timed] = GetParam();
    constexpr uint32_t kLayers = 2;
    const bool srgb = format == VK_FORMAT_B8G8R8A8_SRGB;
    const VkDevice d = device_.handle;
    std::string why;
    if (!Compositor::supports(device_, format, &why, kLayers)) GTEST_SKIP() << why;

    SwapchainState sc;
    sc.handle = reinterpret_cast<VkSwapchainKHR>(uintptr_t{0x5d});
    sc.extent = {kWidth, kHeight};
    sc.format = format;
    sc.array_layers = kLayers;
    sc.composable = true;
    sc.runtime = true;
    sc.present_layout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
    VkImage image = VK_NULL_HANDLE;
    ASSERT_NO_FATAL_FAILURE(make_image(format, sc.extent, kLayers, Compositor::kSwapchainUsage, &image));
    sc.images = {image};
    // Layer after layer, as vkCmdCopyImageToBuffer of both lays them out.
    const VkDeviceSize layer_bytes = VkDeviceSize{kWidth} * kHeight * 4;
    VkBuffer buffer = VK_NULL_HANDLE;
    uint8_t *mapped = nullptr;
    ASSERT_NO_FATAL_FAILURE(make_host_buffer(layer_bytes * kLayers, &buffer, &mapped));
    VkCommandBuffer cb = VK_NULL_HANDLE;
    VkFence fence = VK_NULL_HANDLE;
    ASSERT_NO_FATAL_FAILURE(make_command_buffer(&cb, &fence));

    std::string error;
    UploadPool uploads(device_);
    auto compositor = Compositor::create(device_, sc, family_, &error, filter, timed);
    ASSERT_TRUE(compositor) << error;

    const auto barrier = [&](VkImageLayout from, VkImageLayout to, VkAccessFlags src_access,
                             VkAccessFlags dst_access) {
        VkImageMemoryBarrier b{};
        b.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER;
        b.srcAccessMask = src_access;
        b.dstAccessMask = dst_access;
        b.oldLayout = from;
        b.newLayout = to;
        b.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
        b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
        b.image = image;
        b.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, kLayers};
        vkCmdPipelineBarrier(cb, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, 0, 0,
                             nullptr, 0, nullptr, 1, &b);
    };
    VkBufferImageCopy whole{};
    whole.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, kLayers};
    whole.imageExtent = {kWidth, kHeight, 1};
    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    const auto submit_and_wait = [&] {
        VkSubmitInfo submit{};
        submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
        submit.commandBufferCount = 1;
        submit.pCommandBuffers = &cb;
        ASSERT_EQ(vkQueueSubmit(queue_, 1, &submit, fence), VK_SUCCESS);
        ASSERT_EQ(vkWaitForFences(d, 1, &fence, VK_TRUE, 10'000'000'000ull), VK_SUCCESS);
        vkResetFences(d, 1, &fence);
    };

    std::vector<uint8_t> rendered(layer_bytes * kLayers);
    for (uint32_t frame = 0; frame < 2; ++frame) {
        // The application's frame: each layer its own picture, left in COLOR_ATTACHMENT_OPTIMAL.
        for (uint32_t layer = 0; layer < kLayers; ++layer)
            for (uint32_t y = 0; y < kHeight; ++y)
                for (uint32_t x = 0; x < kWidth; ++x)
                    for (uint32_t c = 0; c < 4; ++c)
                        rendered[layer * layer_bytes + (size_t{y} * kWidth + x) * 4 + c] =
                            content(x, y, c, frame + 7 * layer);
        std::memcpy(mapped, rendered.data(), rendered.size());
        vkBeginCommandBuffer(cb, &begin);
        barrier(VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 0,
                VK_ACCESS_TRANSFER_WRITE_BIT);
        vkCmdCopyBufferToImage(cb, buffer, image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &whole);
        barrier(VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
                VK_ACCESS_TRANSFER_WRITE_BIT, VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT);
        vkEndCommandBuffer(cb);
        submit_and_wait();

        // Each layer's fovea at the same place, one more tile in layer 1, one for a layer it lacks.
        const struct {
            VkRect2D rect;
            uint32_t layer;
        } placed[4] = {{{{20, 15}, {17, 11}}, 0},
                       {{{20, 15}, {17, 11}}, 1},
                       {{{5, 30}, {8, 6}}, 1},
                       {{{50, 5}, {6, 6}}, 2}};
        std::vector<uint8_t> tile_pixels[4];
        FoveaTile tiles[4];
        for (int t = 0; t < 4; ++t) {
            const VkRect2D &r = placed[t].rect;
            tile_pixels[t].resize(size_t{r.extent.width} * r.extent.height * 4);
            for (uint32_t y = 0; y < r.extent.height; ++y)
                for (uint32_t x = 0; x < r.extent.width; ++x)
                    for (uint32_t c = 0; c < 4; ++c)
                        tile_pixels[t][(size_t{y} * r.extent.width + x) * 4 + c] =
                            tile_byte(x, y, c + 4 * t, frame);
            auto upload = uploads.take(tile_pixels[t].size(), &error);
            ASSERT_TRUE(upload) << error;
            std::memcpy(upload->mapped, tile_pixels[t].data(), tile_pixels[t].size());
            uploads.flush(*upload);
            tiles[t] = {r, upload->buffer, 0, upload, placed[t].layer};
        }
        ASSERT_EQ(compositor->composite(queue_, 0, {}, kPeriphery, tiles, nullptr), VK_SUCCESS);

        // What the runtime's barrier would hand on: read back after it on the queue.
        vkBeginCommandBuffer(cb, &begin);
        barrier(VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                VK_ACCESS_MEMORY_WRITE_BIT, VK_ACCESS_TRANSFER_READ_BIT);
        vkCmdCopyImageToBuffer(cb, image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, buffer, 1, &whole);
        vkEndCommandBuffer(cb);
        submit_and_wait();

        for (uint32_t layer = 0; layer < kLayers; ++layer) {
            const uint8_t *shown = mapped + layer * layer_bytes;
            const uint8_t *mine = rendered.data() + layer * layer_bytes;
            const auto tile_at = [&](uint32_t x, uint32_t y) -> int {
                for (int t = 0; t < 3; ++t) {
                    const VkRect2D &r = placed[t].rect;
                    if (placed[t].layer == layer && int(x) >= r.offset.x &&
                        int(x) < r.offset.x + int(r.extent.width) && int(y) >= r.offset.y &&
                        int(y) < r.offset.y + int(r.extent.height))
                        return t;
                }
                return -1;
            };
            const auto texel = [&](int x, int y, uint32_t c) {
                x = std::clamp(x, 0, int(kPeriphery.width) - 1);
                y = std::clamp(y, 0, int(kPeriphery.height) - 1);
                const float v = mine[(size_t(y) * kWidth + x) * 4 + c] / 255.0f;
                return srgb && c < 3 ? srgb_to_linear(v) : v;
            };
            uint64_t tile_mismatches = 0;
            float worst = 0.0f;
            for (uint32_t y = 0; y < kHeight; ++y)
                for (uint32_t x = 0; x < kWidth; ++x) {
                    if (const int t = tile_at(x, y); t >= 0) {
                        const VkRect2D &r = placed[t].rect;
                        const size_t at = (size_t(y - r.offset.y) * r.extent.width + (x - r.offset.x)) * 4;
                        tile_mismatches += std::memcmp(shown + (size_t{y} * kWidth + x) * 4,
                                                       tile_pixels[t].data() + at, 4) != 0;
                        continue;
                    }
                    const float px =
                        std::clamp((x + 0.5f) * kPeriphery.width / kWidth, 0.5f, kPeriphery.width - 0.5f);
                    const float py =
                        std::clamp((y + 0.5f) * kPeriphery.height / kHeight, 0.5f, kPeriphery.height - 0.5f);
                    const int ix = int(std::floor(px - 0.5f)), iy = int(std::floor(py - 0.5f));
                    const float fx = px - 0.5f - ix, fy = py - 0.5f - iy;
                    for (uint32_t c = 0; c < 4; ++c) {
                        float v = 0.0f;
                        if (filter == UpsampleFilter::CatmullRom) {
                            float wx[4], wy[4];
                            catmull_rom_weights(fx, wx);
                            catmull_rom_weights(fy, wy);
                            for (int j = 0; j < 4; ++j)
                                for (int i = 0; i < 4; ++i)
                                    v += wx[i] * wy[j] * texel(ix - 1 + i, iy - 1 + j, c);
                        } else {
                            v = (texel(ix, iy, c) * (1 - fx) + texel(ix + 1, iy, c) * fx) * (1 - fy) +
                                (texel(ix, iy + 1, c) * (1 - fx) + texel(ix + 1, iy + 1, c) * fx) * fy;
                        }
                        const float expected =
                            255.0f * (srgb && c < 3 ? linear_to_srgb(v) : std::clamp(v, 0.0f, 1.0f));
                        worst = std::max(worst, std::abs(expected - shown[(size_t{y} * kWidth + x) * 4 + c]));
                    }
                }
            EXPECT_EQ(tile_mismatches, 0u) << "frame " << frame << " layer " << layer;
            EXPECT_LE(worst, kUpsampleTolerance)
                << "frame " << frame << " layer " << layer << ": the periphery is not that layer's upsampled";
        }
    }

    compositor.reset(); // waits for its submits
    release_gpu_timing(device_);
    if (validation_) {
        EXPECT_EQ(g_messages, 0);
    }
}

// The swapped split's composite (composite_periphery): the application rendered the whole image
// (its foveae are what counts), the agent's periphery arrives as two halves of the scaled image.
// The foveae stay byte for byte what the application rendered (one reaching past the image is kept
// clipped), the rest is the agent's periphery upsampled as composite()'s is; a late frame (null
// periphery) gets the previous periphery with its own foveae, and before any periphery there is
// nothing to do (VK_NOT_READY, nothing submitted).
TEST_P(CompositorTest, PeripheryCompositeKeepsFoveaeExact) {
    const auto [format, filter, timed] = GetParam();
    const bool srgb = format == VK_FORMAT_B8G8R8A8_SRGB;
    std::string why;
    if (!Compositor::supports(device_, format, &why)) GTEST_SKIP() << why;

    Window window;
    ASSERT_NO_FATAL_FAILURE(make_window(format, 0x5e, &window));
    SwapchainState &sc = window.sc;
    const VkDeviceSize bytes = VkDeviceSize{kWidth} * kHeight * 4;
    const VkBuffer buffer = window.buffer;
    uint8_t *const mapped = window.mapped;
    const VkCommandBuffer cb = window.cb;
    const VkSemaphore rendered = window.rendered;

    std::string error;
    UploadPool uploads(device_);
    auto compositor = Compositor::create(device_, sc, family_, &error, filter, timed);
    ASSERT_TRUE(compositor) << error;

    const auto barrier = [&](VkImage image, VkImageLayout from, VkImageLayout to, VkAccessFlags src_access,
                             VkAccessFlags dst_access) {
        VkImageMemoryBarrier b{};
        b.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER;
        b.srcAccessMask = src_access;
        b.dstAccessMask = dst_access;
        b.oldLayout = from;
        b.newLayout = to;
        b.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
        b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
        b.image = image;
        b.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
        vkCmdPipelineBarrier(cb, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0,
                             nullptr, 0, nullptr, 1, &b);
    };
    VkBufferImageCopy whole{};
    whole.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    whole.imageExtent = {kWidth, kHeight, 1};
    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    const auto run = [&](const VkSemaphore *wait, const VkSemaphore *signal) {
        submit_and_wait(window, wait, signal);
    };

    // The client's foveae: two eyes, one reaching past the top-left corner.
    const VkRect2D keep[3] = {{{20, 15}, {17, 11}}, {{50, 8}, {12, 10}}, {{-4, -3}, {9, 7}}};
    const auto in_keep = [&](uint32_t x, uint32_t y) {
        for (const VkRect2D &r : keep)
            if (int(x) >= r.offset.x && int(x) < r.offset.x + int(r.extent.width) && int(y) >= r.offset.y &&
                int(y) < r.offset.y + int(r.extent.height))
                return true;
        return false;
    };
    // Frame 2 is late: its periphery is frame 1's.
    const auto late = [](uint32_t frame) { return frame == 2; };
    const auto periphery_byte = [](uint32_t x, uint32_t y, uint32_t c, uint32_t frame) {
        return content(x + 3, y + 1, c, frame + 7);
    };

    std::vector<uint8_t> rendered_pixels(bytes);
    std::vector<uint8_t> periphery_pixels(size_t{kPeriphery.width} * kPeriphery.height * 4);
    uint32_t shown_periphery = UINT32_MAX; // the frame whose periphery is the latest
    for (uint32_t frame = 0; frame < kFrames; ++frame) {
        const uint32_t index = frame % kImages;
        const VkImage image = sc.images[index];
        for (uint32_t y = 0; y < kHeight; ++y)
            for (uint32_t x = 0; x < kWidth; ++x)
                for (uint32_t c = 0; c < 4; ++c)
                    rendered_pixels[(size_t{y} * kWidth + x) * 4 + c] = tile_byte(x, y, c, frame);
        ASSERT_NO_FATAL_FAILURE(render_frame(window, index, rendered_pixels));

        VkSemaphore waits = rendered;
        if (timed) {
            VkFence done = VK_NULL_HANDLE;
            ASSERT_EQ(compositor->take_waits(queue_, index, std::span(&rendered, 1), &waits, &done),
                      VK_SUCCESS);
        }
        VkSemaphore signal = VK_NULL_HANDLE;
        if (frame == 0) {
            // No periphery yet: nothing submitted, the semaphore is the present's to wait on.
            EXPECT_EQ(
                compositor->composite_periphery(queue_, index, std::span(&waits, 1), nullptr, keep, &signal),
                VK_NOT_READY);
            EXPECT_EQ(signal, VK_NULL_HANDLE);
        }
        PeripheryImage periphery;
        periphery.extent = kPeriphery;
        if (!late(frame)) {
            // The halves, [0, w/2) and [w/2, w), each decoded into its own upload buffer.
            const uint32_t half = kPeriphery.width / 2;
            const VkRect2D parts[2] = {{{0, 0}, {half, kPeriphery.height}},
                                       {{int32_t(half), 0}, {kPeriphery.width - half, kPeriphery.height}}};
            for (const VkRect2D &part : parts) {
                std::vector<uint8_t> pixels(size_t{part.extent.width} * part.extent.height * 4);
                for (uint32_t y = 0; y < part.extent.height; ++y)
                    for (uint32_t x = 0; x < part.extent.width; ++x)
                        for (uint32_t c = 0; c < 4; ++c) {
                            const uint8_t v = periphery_byte(part.offset.x + x, y, c, frame);
                            pixels[(size_t{y} * part.extent.width + x) * 4 + c] = v;
                            periphery_pixels[(size_t{y} * kPeriphery.width + part.offset.x + x) * 4 + c] = v;
                        }
                auto upload = uploads.take(pixels.size(), &error);
                ASSERT_TRUE(upload) << error;
                std::memcpy(upload->mapped, pixels.data(), pixels.size());
                uploads.flush(*upload);
                periphery.parts.push_back({part, upload->buffer, 0, upload});
            }
            shown_periphery = frame;
        }
        ASSERT_EQ(compositor->composite_periphery(queue_, index, std::span(&waits, 1),
                                                  late(frame) ? nullptr : &periphery, keep, &signal),
                  VK_SUCCESS);
        ASSERT_NE(signal, VK_NULL_HANDLE);

        vkBeginCommandBuffer(cb, &begin);
        barrier(image, VK_IMAGE_LAYOUT_PRESENT_SRC_KHR, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, 0,
                VK_ACCESS_TRANSFER_READ_BIT);
        vkCmdCopyImageToBuffer(cb, image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, buffer, 1, &whole);
        ASSERT_NO_FATAL_FAILURE(run(&signal, nullptr));
        const uint8_t *shown = mapped;

        ASSERT_NE(shown_periphery, UINT32_MAX);
        const auto texel = [&](int x, int y, uint32_t c) {
            x = std::clamp(x, 0, int(kPeriphery.width) - 1);
            y = std::clamp(y, 0, int(kPeriphery.height) - 1);
            const float v = periphery_pixels[(size_t(y) * kPeriphery.width + x) * 4 + c] / 255.0f;
            return srgb && c < 3 ? srgb_to_linear(v) : v;
        };
        uint64_t fovea_mismatches = 0;
        float worst = 0.0f;
        for (uint32_t y = 0; y < kHeight; ++y)
            for (uint32_t x = 0; x < kWidth; ++x) {
                const size_t at = (size_t{y} * kWidth + x) * 4;
                if (in_keep(x, y)) {
                    fovea_mismatches += std::memcmp(shown + at, rendered_pixels.data() + at, 4) != 0;
                    continue;
                }
                const float px =
                    std::clamp((x + 0.5f) * kPeriphery.width / kWidth, 0.5f, kPeriphery.width - 0.5f);
                const float py =
                    std::clamp((y + 0.5f) * kPeriphery.height / kHeight, 0.5f, kPeriphery.height - 0.5f);
                const int ix = int(std::floor(px - 0.5f)), iy = int(std::floor(py - 0.5f));
                const float fx = px - 0.5f - ix, fy = py - 0.5f - iy;
                for (uint32_t c = 0; c < 4; ++c) {
                    float v = 0.0f;
                    if (filter == UpsampleFilter::CatmullRom) {
                        float wx[4], wy[4];
                        catmull_rom_weights(fx, wx);
                        catmull_rom_weights(fy, wy);
                        for (int j = 0; j < 4; ++j)
                            for (int i = 0; i < 4; ++i)
                                v += wx[i] * wy[j] * texel(ix - 1 + i, iy - 1 + j, c);
                    } else {
                        v = (texel(ix, iy, c) * (1 - fx) + texel(ix + 1, iy, c) * fx) * (1 - fy) +
                            (texel(ix, iy + 1, c) * (1 - fx) + texel(ix + 1, iy + 1, c) * fx) * fy;
                    }
                    const float expected =
                        255.0f * (srgb && c < 3 ? linear_to_srgb(v) : std::clamp(v, 0.0f, 1.0f));
                    worst = std::max(worst, std::abs(expected - shown[at + c]));
                }
            }
        EXPECT_EQ(fovea_mismatches, 0u) << "frame " << frame;
        EXPECT_LE(worst, kUpsampleTolerance)
            << "frame " << frame << ": the rest is not frame " << shown_periphery << "'s periphery upsampled";
    }

    compositor.reset(); // waits for its submits
    release_gpu_timing(device_);
    if (validation_) {
        EXPECT_EQ(g_messages, 0);
    }
}

// The swapped split's feathered seam (SPLITVK_SEAM=feather:N): the same client frame and periphery
// composited with a hard seam, with a feather of kFeather pixels, and late with that feather (the
// previous periphery). The foveae are the client's byte for byte every time. Outside each fovea's
// seam rectangle (split::seam_rect), and where the band's weight is 0, the feathered frame equals the
// hard one (the periphery upsampled, which PeripheryCompositeKeepsFoveaeExact checks); inside the
// band every colour is the client's and the periphery's mixed at the smoothstep weight of its
// distance from the fovea (in linear for sRGB), so a pixel mid-band lies strictly between the two;
// the alpha stays the periphery's. The late frame is feathered alike: it equals the fresh one.
TEST_P(CompositorTest, PeripheryCompositeFeathersTheSeam) {
    const auto [format, filter, timed] = GetParam();
    const bool srgb = format == VK_FORMAT_B8G8R8A8_SRGB;
    std::string why;
    if (!Compositor::supports(device_, format, &why)) GTEST_SKIP() << why;
    VkFormatProperties props{};
    vkGetPhysicalDeviceFormatProperties(device_.physical_device, format, &props);
    if (!(props.optimalTilingFeatures & VK_FORMAT_FEATURE_COLOR_ATTACHMENT_BLEND_BIT))
        GTEST_SKIP() << "the format cannot be blended into";
    constexpr uint32_t kFeather = 8;

    Window window;
    ASSERT_NO_FATAL_FAILURE(make_window(format, 0x5f, &window));
    SwapchainState &sc = window.sc;
    const VkDeviceSize bytes = VkDeviceSize{kWidth} * kHeight * 4;
    const VkBuffer buffer = window.buffer;
    uint8_t *const mapped = window.mapped;
    const VkCommandBuffer cb = window.cb;
    const VkSemaphore rendered = window.rendered;
    std::string error;
    UploadPool uploads(device_);
    auto compositor = Compositor::create(device_, sc, family_, &error, filter, timed);
    ASSERT_TRUE(compositor) << error;

    const auto barrier = [&](VkImage image, VkImageLayout from, VkImageLayout to, VkAccessFlags src_access,
                             VkAccessFlags dst_access) {
        const VkImageMemoryBarrier b = colour_image_barrier(image, src_access, dst_access, from, to);
        vkCmdPipelineBarrier(cb, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0,
                             nullptr, 0, nullptr, 1, &b);
    };
    VkBufferImageCopy whole{};
    whole.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    whole.imageExtent = {kWidth, kHeight, 1};
    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    const auto run = [&](const VkSemaphore *wait, const VkSemaphore *signal) {
        submit_and_wait(window, wait, signal);
    };

    // A fovea that straddles the centre, and one by the bottom-left corner whose band the image cuts.
    const VkRect2D keep[2] = {{{30, 14}, {20, 14}}, {{2, 33}, {10, 10}}};
    std::vector<uint8_t> client(bytes);
    for (uint32_t y = 0; y < kHeight; ++y)
        for (uint32_t x = 0; x < kWidth; ++x)
            for (uint32_t c = 0; c < 4; ++c)
                client[(size_t{y} * kWidth + x) * 4 + c] = tile_byte(x, y, c, 0);
    // Composites the client's frame into image `index` with `feather`, with the periphery (or late,
    // the latest), and reads the result back into *shown.
    const auto composite = [&](uint32_t index, bool late, uint32_t feather, std::vector<uint8_t> *shown) {
        const VkImage image = sc.images[index];
        ASSERT_NO_FATAL_FAILURE(render_frame(window, index, client));
        VkSemaphore waits = rendered;
        if (timed) {
            VkFence done = VK_NULL_HANDLE;
            ASSERT_EQ(compositor->take_waits(queue_, index, std::span(&rendered, 1), &waits, &done),
                      VK_SUCCESS);
        }
        PeripheryImage periphery;
        periphery.extent = kPeriphery;
        if (!late) {
            std::vector<uint8_t> pixels(size_t{kPeriphery.width} * kPeriphery.height * 4);
            for (uint32_t y = 0; y < kPeriphery.height; ++y)
                for (uint32_t x = 0; x < kPeriphery.width; ++x)
                    for (uint32_t c = 0; c < 4; ++c)
                        pixels[(size_t{y} * kPeriphery.width + x) * 4 + c] = content(x, y, c, 3);
            auto upload = uploads.take(pixels.size(), &error);
            ASSERT_TRUE(upload) << error;
            std::memcpy(upload->mapped, pixels.data(), pixels.size());
            uploads.flush(*upload);
            periphery.parts.push_back({{{0, 0}, kPeriphery}, upload->buffer, 0, upload});
        }
        VkSemaphore signal = VK_NULL_HANDLE;
        ASSERT_EQ(compositor->composite_periphery(queue_, index, std::span(&waits, 1),
                                                  late ? nullptr : &periphery, keep, &signal, feather),
                  VK_SUCCESS);
        vkBeginCommandBuffer(cb, &begin);
        barrier(image, VK_IMAGE_LAYOUT_PRESENT_SRC_KHR, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, 0,
                VK_ACCESS_TRANSFER_READ_BIT);
        vkCmdCopyImageToBuffer(cb, image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, buffer, 1, &whole);
        ASSERT_NO_FATAL_FAILURE(run(&signal, nullptr));
        shown->assign(mapped, mapped + bytes);
    };
    std::vector<uint8_t> hard, feathered, late;
    ASSERT_NO_FATAL_FAILURE(composite(0, false, 0, &hard));
    ASSERT_NO_FATAL_FAILURE(composite(1, false, kFeather, &feathered));
    ASSERT_NO_FATAL_FAILURE(composite(0, true, kFeather, &late));

    const auto linear = [&](float byte) { return srgb ? srgb_to_linear(byte / 255.0f) : byte / 255.0f; };
    const auto encoded = [&](float l) {
        return 255.0f * (srgb ? linear_to_srgb(l) : std::clamp(l, 0.0f, 1.0f));
    };
    uint64_t fovea_mismatches = 0, outside_mismatches = 0, band_pixels = 0, mid_band = 0,
             mid_band_between = 0;
    float worst = 0.0f;
    for (uint32_t y = 0; y < kHeight; ++y)
        for (uint32_t x = 0; x < kWidth; ++x) {
            const size_t at = (size_t{y} * kWidth + x) * 4;
            float w = 0.0f;
            bool in_fovea = false;
            for (const VkRect2D &f : keep) {
                const VkRect2D seam = split::seam_rect(f, sc.extent, kFeather);
                const auto inside = [&](const VkRect2D &r) {
                    return int(x) >= r.offset.x && int(x) < r.offset.x + int(r.extent.width) &&
                           int(y) >= r.offset.y && int(y) < r.offset.y + int(r.extent.height);
                };
                in_fovea = in_fovea || inside(f);
                if (!inside(seam)) continue;
                const float cx = x + 0.5f, cy = y + 0.5f;
                const float dx = std::max({f.offset.x - cx, cx - (f.offset.x + f.extent.width), 0.0f});
                const float dy = std::max({f.offset.y - cy, cy - (f.offset.y + f.extent.height), 0.0f});
                const float t = std::clamp(1.0f - std::sqrt(dx * dx + dy * dy) / kFeather, 0.0f, 1.0f);
                w = std::max(w, t * t * (3.0f - 2.0f * t));
            }
            if (in_fovea) {
                fovea_mismatches += std::memcmp(hard.data() + at, client.data() + at, 4) != 0;
                fovea_mismatches += std::memcmp(feathered.data() + at, client.data() + at, 4) != 0;
                continue;
            }
            if (w <= 0.0f) {
                outside_mismatches += std::memcmp(hard.data() + at, feathered.data() + at, 4) != 0;
                continue;
            }
            ++band_pixels;
            outside_mismatches += feathered[at + 3] != hard[at + 3]; // the periphery's alpha
            for (uint32_t c = 0; c < 3; ++c) {
                const float periphery = hard[at + c], mine = client[at + c], shown = feathered[at + c];
                const float expected = encoded(linear(mine) * w + linear(periphery) * (1.0f - w));
                worst = std::max(worst, std::abs(expected - shown));
                if (w > 0.25f && w < 0.75f && std::abs(mine - periphery) >= 16.0f) {
                    ++mid_band;
                    mid_band_between +=
                        shown > std::min(mine, periphery) && shown < std::max(mine, periphery);
                }
            }
        }
    EXPECT_EQ(fovea_mismatches, 0u);
    EXPECT_EQ(outside_mismatches, 0u) << "the feather reached past its band";
    EXPECT_GT(band_pixels, 300u);
    EXPECT_LE(worst, 2.0f) << "the band is not the smoothstep blend of client and periphery";
    EXPECT_GT(mid_band, 50u);
    EXPECT_EQ(mid_band_between, mid_band) << "mid-band pixels not strictly between client and periphery";
    size_t late_mismatches = 0;
    for (size_t i = 0; i < late.size(); ++i)
        late_mismatches += late[i] != feathered[i];
    EXPECT_EQ(late_mismatches, 0u) << "a late frame is not feathered alike";

    compositor.reset(); // waits for its submits
    release_gpu_timing(device_);
    if (validation_) {
        EXPECT_EQ(g_messages, 0);
    }
}

// The upsample's bands: together with the tiles they cover every pixel of the image exactly once.
TEST(PeripheryBands, CoverTheImageAroundTheTilesExactlyOnce) {
    const auto tile = [](int32_t x, int32_t y, uint32_t w, uint32_t h) {
        VkBufferImageCopy c{};
        c.imageOffset = {x, y, 0};
        c.imageExtent = {w, h, 1};
        return c;
    };
    struct Case {
        VkExtent2D image;
        std::vector<VkBufferImageCopy> tiles;
        size_t bands; // the stereo layout needs 5: above, left, between, right, below
    };
    const Case cases[] = {
        {{64, 48}, {}, 1},
        {{2400, 1080}, {tile(344, 360, 512, 360), tile(1544, 360, 512, 360)}, 5},
        {{2400, 1080}, {tile(944, 360, 512, 360)}, 4},
        {{64, 48}, {tile(0, 0, 10, 10), tile(54, 38, 10, 10)}, 3}, // corners
        {{64, 48}, {tile(5, 5, 10, 20), tile(20, 10, 10, 20), tile(40, 0, 24, 48)}, 0},
        {{64, 48}, {tile(0, 0, 64, 48)}, 0}, // nothing left to draw
    };
    for (const Case &c : cases) {
        const auto bands = periphery_bands(c.image, c.tiles);
        if (c.bands) {
            EXPECT_EQ(bands.size(), c.bands);
        }
        std::vector<int> hits(size_t{c.image.width} * c.image.height);
        for (const VkRect2D &b : bands) {
            ASSERT_GT(b.extent.width * b.extent.height, 0u);
            ASSERT_LE(b.offset.x + b.extent.width, c.image.width);
            ASSERT_LE(b.offset.y + b.extent.height, c.image.height);
            for (uint32_t y = 0; y < b.extent.height; ++y)
                for (uint32_t x = 0; x < b.extent.width; ++x)
                    ++hits[size_t{b.offset.y + y} * c.image.width + b.offset.x + x];
        }
        for (const VkBufferImageCopy &t : c.tiles)
            for (uint32_t y = 0; y < t.imageExtent.height; ++y)
                for (uint32_t x = 0; x < t.imageExtent.width; ++x)
                    ++hits[size_t(t.imageOffset.y + y) * c.image.width + t.imageOffset.x + x];
        EXPECT_EQ(std::count(hits.begin(), hits.end(), 1), std::ptrdiff_t(hits.size()))
            << c.tiles.size() << " tiles in " << c.image.width << "x" << c.image.height;
    }
}

// Not a test: what a composite costs on this device, against vkCmdBlitImage with a linear filter
// doing the same upsample, at SPLITVK_COST_SIZE (WxH, default 2400x1080) with the stereo foveae
// (512x360 per 1200x1080 eye, scaled with the image). Run by hand:
//   build/bin/splitvk_compositor_tests --gtest_also_run_disabled_tests --gtest_filter='*Cost*'
// Prints the best of kRuns wall times from submit to fence (lavapipe: the GPU work itself).
TEST_P(CompositorTest, DISABLED_Cost) {
    const auto [format, filter, timed] = GetParam();
    if (format != VK_FORMAT_B8G8R8A8_UNORM || timed) GTEST_SKIP() << "one format is enough";
    uint32_t width = 2400, height = 1080;
    if (const char *size = std::getenv("SPLITVK_COST_SIZE")) std::sscanf(size, "%ux%u", &width, &height);
    const VkDevice d = device_.handle;
    constexpr int kRuns = 12;
    const VkExtent2D periphery{(width * 3 + 4) / 5, (height * 3 + 4) / 5};
    SwapchainState sc;
    sc.handle = reinterpret_cast<VkSwapchainKHR>(uintptr_t{0x5d});
    sc.extent = {width, height};
    sc.format = format;
    sc.composable = true;
    VkImage image = VK_NULL_HANDLE, small = VK_NULL_HANDLE;
    ASSERT_NO_FATAL_FAILURE(make_image(format, sc.extent, 1, Compositor::kSwapchainUsage, &image));
    ASSERT_NO_FATAL_FAILURE(make_image(
        format, periphery, 1, VK_IMAGE_USAGE_TRANSFER_SRC_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT, &small));
    sc.images = {image};
    VkCommandBuffer cb = VK_NULL_HANDLE;
    VkFence fence = VK_NULL_HANDLE;
    ASSERT_NO_FATAL_FAILURE(make_command_buffer(&cb, &fence));
    const auto submit_and_wait = [&](VkSemaphore wait) {
        const VkPipelineStageFlags stage = VK_PIPELINE_STAGE_ALL_COMMANDS_BIT;
        VkSubmitInfo submit{};
        submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
        submit.waitSemaphoreCount = wait ? 1 : 0;
        submit.pWaitSemaphores = &wait;
        submit.pWaitDstStageMask = &stage;
        submit.commandBufferCount = wait ? 0 : 1;
        submit.pCommandBuffers = &cb;
        ASSERT_EQ(vkQueueSubmit(queue_, 1, &submit, fence), VK_SUCCESS);
        ASSERT_EQ(vkWaitForFences(d, 1, &fence, VK_TRUE, 60'000'000'000ull), VK_SUCCESS);
        vkResetFences(d, 1, &fence);
    };
    const auto barrier = [&](VkImage target, VkImageLayout from, VkImageLayout to) {
        VkImageMemoryBarrier b{};
        b.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER;
        b.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
        b.dstAccessMask = VK_ACCESS_TRANSFER_READ_BIT | VK_ACCESS_TRANSFER_WRITE_BIT;
        b.oldLayout = from;
        b.newLayout = to;
        b.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
        b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
        b.image = target;
        b.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
        vkCmdPipelineBarrier(cb, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0,
                             nullptr, 0, nullptr, 1, &b);
    };
    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    vkBeginCommandBuffer(cb, &begin);
    barrier(image, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_PRESENT_SRC_KHR);
    barrier(small, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
    vkEndCommandBuffer(cb);
    ASSERT_NO_FATAL_FAILURE(submit_and_wait(VK_NULL_HANDLE));

    std::string error;
    auto compositor = Compositor::create(device_, sc, family_, &error, filter);
    ASSERT_TRUE(compositor) << error;
    // The default foveae: 512x360 centred in each half, scaled with the image.
    const uint32_t fw = 512 * width / 2400, fh = 360 * height / 1080;
    const VkRect2D rects[2] = {{{int32_t(width / 4 - fw / 2), int32_t(height / 2 - fh / 2)}, {fw, fh}},
                               {{int32_t(3 * width / 4 - fw / 2), int32_t(height / 2 - fh / 2)}, {fw, fh}}};
    UploadPool uploads(device_);
    auto upload = uploads.take(VkDeviceSize{fw} * fh * 4, &error);
    ASSERT_TRUE(upload) << error;
    std::memset(upload->mapped, 0x7f, size_t{fw} * fh * 4);
    uploads.flush(*upload);
    const FoveaTile tiles[2] = {{rects[0], upload->buffer, 0, upload}, {rects[1], upload->buffer, 0, upload}};
    using Clock = std::chrono::steady_clock;
    const auto best = [&](auto &&run) {
        double ms = 1e9;
        for (int i = 0; i < kRuns; ++i) {
            const auto start = Clock::now();
            run();
            ms = std::min(ms, std::chrono::duration<double, std::milli>(Clock::now() - start).count());
        }
        return ms;
    };
    const auto composite = [&](std::span<const FoveaTile> with) {
        VkSemaphore signal = VK_NULL_HANDLE;
        ASSERT_EQ(compositor->composite(queue_, 0, {}, periphery, with, &signal), VK_SUCCESS);
        submit_and_wait(signal);
    };
    const double whole = best([&] { composite({}); });
    const double around = best([&] { composite(tiles); });
    const double blit = best([&] {
        vkBeginCommandBuffer(cb, &begin);
        barrier(image, VK_IMAGE_LAYOUT_PRESENT_SRC_KHR, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL);
        VkImageBlit region{};
        region.srcSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
        region.srcOffsets[1] = {int32_t(periphery.width), int32_t(periphery.height), 1};
        region.dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
        region.dstOffsets[1] = {int32_t(width), int32_t(height), 1};
        vkCmdBlitImage(cb, small, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, image,
                       VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region, VK_FILTER_LINEAR);
        barrier(image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_PRESENT_SRC_KHR);
        vkEndCommandBuffer(cb);
        submit_and_wait(VK_NULL_HANDLE);
    });
    // The swapped split's: the agent's periphery in two halves around the client's foveae, and a late
    // frame's (the latest periphery again, nothing uploaded).
    const uint32_t half = periphery.width / 2;
    auto part = uploads.take(VkDeviceSize{periphery.width - half} * periphery.height * 4, &error);
    ASSERT_TRUE(part) << error;
    std::memset(part->mapped, 0x3f, size_t{periphery.width - half} * periphery.height * 4);
    uploads.flush(*part);
    PeripheryImage agent;
    agent.extent = periphery;
    agent.parts = {{{{0, 0}, {half, periphery.height}}, part->buffer, 0, part},
                   {{{int32_t(half), 0}, {periphery.width - half, periphery.height}}, part->buffer, 0, part}};
    const auto composite_periphery = [&](const PeripheryImage *with, uint32_t feather) {
        VkSemaphore signal = VK_NULL_HANDLE;
        ASSERT_EQ(compositor->composite_periphery(queue_, 0, {}, with, rects, &signal, feather), VK_SUCCESS);
        submit_and_wait(signal);
    };
    const double swapped = best([&] { composite_periphery(&agent, 0); });
    const double swapped_late = best([&] { composite_periphery(nullptr, 0); });
    // The default seam (SPLITVK_SEAM=feather:16).
    const double feathered = best([&] { composite_periphery(&agent, 16); });
    std::printf("cost %ux%u filter %d: composite, whole image %.2f ms; around the foveae with tiles %.2f ms; "
                "vkCmdBlitImage (linear) alone %.2f ms; composite_periphery %.2f ms, late %.2f ms, "
                "feather:16 %.2f ms\n",
                width, height, int(filter), whole, around, blit, swapped, swapped_late, feathered);
    compositor.reset(); // before the upload pool, whose buffer its last tiles hold
}

// The blit's regions: around the tiles (shrunk to the scale's period) and each scaled exactly as
// the whole image, or the whole image in one where the scale has no short period.
TEST(BlitRegions, ScaleExactlyAndSkipTheTiles) {
    const auto tile = [](int32_t x, int32_t y, uint32_t w, uint32_t h) {
        VkBufferImageCopy c{};
        c.imageOffset = {x, y, 0};
        c.imageExtent = {w, h, 1};
        return c;
    };
    const std::vector<VkBufferImageCopy> stereo = {tile(344, 360, 512, 360), tile(1544, 360, 512, 360)};
    struct Case {
        VkExtent2D image, periphery;
        size_t regions;
        uint64_t skipped; // pixels no region writes
    };
    const Case cases[] = {
        // 344..856 shrinks to 345..855, 1544..2056 to 1545..2055; 360..720 stays.
        {{2400, 1080}, {1440, 648}, 5, 2ull * 510 * 360},
        {{2400, 1080}, {1441, 648}, 1, 0}, // no short period across
    };
    for (const Case &c : cases) {
        const auto regions = blit_regions(c.image, c.periphery, stereo);
        EXPECT_EQ(regions.size(), c.regions);
        uint64_t written = 0;
        for (const VkImageBlit &r : regions) {
            const int64_t dw = r.dstOffsets[1].x - r.dstOffsets[0].x,
                          dh = r.dstOffsets[1].y - r.dstOffsets[0].y;
            const int64_t sw = r.srcOffsets[1].x - r.srcOffsets[0].x,
                          sh = r.srcOffsets[1].y - r.srcOffsets[0].y;
            ASSERT_GT(dw, 0);
            ASSERT_GT(dh, 0);
            // The region's scale and position are the whole image's.
            EXPECT_EQ(sw * c.image.width, dw * c.periphery.width);
            EXPECT_EQ(sh * c.image.height, dh * c.periphery.height);
            EXPECT_EQ(int64_t{r.srcOffsets[0].x} * c.image.width,
                      int64_t{r.dstOffsets[0].x} * c.periphery.width);
            EXPECT_EQ(int64_t{r.srcOffsets[0].y} * c.image.height,
                      int64_t{r.dstOffsets[0].y} * c.periphery.height);
            written += uint64_t(dw) * uint64_t(dh);
        }
        EXPECT_EQ(written, uint64_t{c.image.width} * c.image.height - c.skipped);
    }
}

INSTANTIATE_TEST_SUITE_P(Formats, CompositorTest,
                         ::testing::Values(Param{VK_FORMAT_B8G8R8A8_UNORM, UpsampleFilter::Bilinear},
                                           Param{VK_FORMAT_B8G8R8A8_SRGB, UpsampleFilter::Bilinear},
                                           Param{VK_FORMAT_B8G8R8A8_UNORM, UpsampleFilter::CatmullRom},
                                           Param{VK_FORMAT_B8G8R8A8_SRGB, UpsampleFilter::CatmullRom},
                                           Param{VK_FORMAT_B8G8R8A8_UNORM, UpsampleFilter::Bilinear, true},
                                           Param{VK_FORMAT_B8G8R8A8_UNORM, UpsampleFilter::BilinearBlit},
                                           Param{VK_FORMAT_B8G8R8A8_SRGB, UpsampleFilter::BilinearBlit}),
                         [](const auto &test) {
                             return std::string(test.param.format == VK_FORMAT_B8G8R8A8_SRGB ? "Srgb"
                                                                                             : "Unorm") +
                                    (test.param.filter == UpsampleFilter::CatmullRom     ? "CatmullRom"
                                     : test.param.filter == UpsampleFilter::BilinearBlit ? "BilinearBlit"
                                                                                         : "Bilinear") +
                                    (test.param.timed ? "Timed" : "");
                         });

} // namespace
} // namespace splitvk
