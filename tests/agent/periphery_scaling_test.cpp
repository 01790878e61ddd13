// The swapped split's periphery on the agent (periphery_scaling.h): a pass into a window's swapchain
// image is drawn into its top-left scaled rectangle, with the rectangles the client's own scaled
// passes take (split::scaled_pass_rect), so the agent shades s² of the pixels it used to; passes into
// other images, and every pass of a verifying client's session, are replayed as recorded. The
// agent's Replayer replays encoded streams on the real GPU (lavapipe here); the driver's
// vkCmdBeginRenderPass, vkCmdSetViewport and vkCmdSetScissor are wrapped (and still called) to see
// what the passes were drawn with.
#include "devices.h"
#include "log.h"
#include "replayer.h"
#include "split_geometry.h"
#include "vk_codec.h"

#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace splitvk::agent {
namespace {

template <class H>
H id(uint64_t v) {
    return codec::to_handle<H>(v);
}

constexpr uint64_t kPhysicalDevice = 0x1000, kDevice = 0x2000, kQueue = 0x3000, kPool = 0x4000,
                   kRenderPass = 0x5000, kSwapchain = 0x6000, kImage = 0x6100, kTarget = 0x7000,
                   kTargetMemory = 0x7100, kViews = 0x8000, kFramebuffers = 0x9000, kCommandBuffers = 0xa000;
// Odd sizes: the scaled extent rounds up on both axes.
constexpr uint32_t kWidth = 301, kHeight = 171;
constexpr double kScale = 0.6;
constexpr VkRect2D kFull = {{0, 0}, {kWidth, kHeight}};

bool operator==(const VkRect2D &a, const VkRect2D &b) {
    return a.offset.x == b.offset.x && a.offset.y == b.offset.y && a.extent.width == b.extent.width &&
           a.extent.height == b.extent.height;
}

// What the driver was given: each pass's render area, and the viewport and scissor 0 in effect at
// its end.
struct Pass {
    VkRect2D area{};
    VkViewport viewport{};
    VkRect2D scissor{};
};
PFN_vkCmdBeginRenderPass g_begin_render_pass = nullptr;
PFN_vkCmdEndRenderPass g_end_render_pass = nullptr;
PFN_vkCmdSetViewport g_set_viewport = nullptr;
PFN_vkCmdSetScissor g_set_scissor = nullptr;
Pass g_current;
std::vector<Pass> g_passes;

VKAPI_ATTR void VKAPI_CALL record_begin_render_pass(VkCommandBuffer cb, const VkRenderPassBeginInfo *begin,
                                                    VkSubpassContents contents) {
    g_current.area = begin->renderArea;
    g_begin_render_pass(cb, begin, contents);
}
VKAPI_ATTR void VKAPI_CALL record_end_render_pass(VkCommandBuffer cb) {
    g_passes.push_back(g_current);
    g_end_render_pass(cb);
}
VKAPI_ATTR void VKAPI_CALL record_set_viewport(VkCommandBuffer cb, uint32_t first, uint32_t count,
                                               const VkViewport *viewports) {
    if (first == 0 && count > 0) g_current.viewport = viewports[0];
    g_set_viewport(cb, first, count, viewports);
}
VKAPI_ATTR void VKAPI_CALL record_set_scissor(VkCommandBuffer cb, uint32_t first, uint32_t count,
                                              const VkRect2D *scissors) {
    if (first == 0 && count > 0) g_current.scissor = scissors[0];
    g_set_scissor(cb, first, count, scissors);
}

class PeripheryScalingTest : public testing::Test {
protected:
    // `whole_frames`: the session of a verifying client.
    void start(bool whole_frames) {
        std::string error;
        const std::vector<GpuInfo> gpus = enumerate_gpus(&error);
        ASSERT_FALSE(gpus.empty()) << error;
        replayer = std::make_unique<Replayer>(1, MemoryLimits{}, gpus[0].description);
        Replayer &r = *replayer;
        ASSERT_TRUE(r.init(0, false, &error)) << error;
        // As after the client's SplitConfig and PeripheryConfig, before any command.
        r.fovea().set_enabled(false);
        r.scaling().configure(kScale, whole_frames);

        codec::Encoder e;
        const float priority = 1.0f;
        VkDeviceQueueCreateInfo queue{};
        queue.sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO;
        queue.queueCount = 1;
        queue.pQueuePriorities = &priority;
        VkDeviceCreateInfo device{};
        device.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
        device.queueCreateInfoCount = 1;
        device.pQueueCreateInfos = &queue;
        VkDevice dev = id<VkDevice>(kDevice);
        codec::encode_vkCreateDevice(e, id<VkPhysicalDevice>(kPhysicalDevice), &device, nullptr, &dev);
        VkQueue q = id<VkQueue>(kQueue);
        codec::encode_vkGetDeviceQueue(e, dev, 0, 0, &q);
        VkCommandPoolCreateInfo pool{};
        pool.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
        pool.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
        VkCommandPool p = id<VkCommandPool>(kPool);
        codec::encode_vkCreateCommandPool(e, dev, &pool, nullptr, &p);

        VkAttachmentDescription attachment{};
        attachment.format = VK_FORMAT_R8G8B8A8_UNORM;
        attachment.samples = VK_SAMPLE_COUNT_1_BIT;
        attachment.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
        attachment.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
        attachment.stencilLoadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
        attachment.stencilStoreOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
        attachment.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
        attachment.finalLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
        const VkAttachmentReference color{0, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
        VkSubpassDescription subpass{};
        subpass.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
        subpass.colorAttachmentCount = 1;
        subpass.pColorAttachments = &color;
        VkRenderPassCreateInfo rp{};
        rp.sType = VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO;
        rp.attachmentCount = 1;
        rp.pAttachments = &attachment;
        rp.subpassCount = 1;
        rp.pSubpasses = &subpass;
        VkRenderPass render_pass = id<VkRenderPass>(kRenderPass);
        codec::encode_vkCreateRenderPass(e, dev, &rp, nullptr, &render_pass);
        ASSERT_TRUE(replay(e));
        g_begin_render_pass = r.vk.CmdBeginRenderPass;
        g_end_render_pass = r.vk.CmdEndRenderPass;
        g_set_viewport = r.vk.CmdSetViewport;
        g_set_scissor = r.vk.CmdSetScissor;
        r.vk.CmdBeginRenderPass = record_begin_render_pass;
        r.vk.CmdEndRenderPass = record_end_render_pass;
        r.vk.CmdSetViewport = record_set_viewport;
        r.vk.CmdSetScissor = record_set_scissor;

        protocol::SwapchainImages swapchain;
        swapchain.device_id = kDevice;
        swapchain.swapchain_id = kSwapchain;
        swapchain.width = kWidth;
        swapchain.height = kHeight;
        swapchain.format = VK_FORMAT_R8G8B8A8_UNORM;
        swapchain.usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT;
        swapchain.image_ids = {kImage};
        ASSERT_TRUE(r.swapchain_images(swapchain, &error)) << error;

        // A screen-space target (the swapchain's extent): the agent keeps it full size
        // (split::scales_screen_space_targets), and its passes too.
        VkImageCreateInfo image{};
        image.sType = VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO;
        image.imageType = VK_IMAGE_TYPE_2D;
        image.format = VK_FORMAT_R8G8B8A8_UNORM;
        image.extent = {kWidth, kHeight, 1};
        image.mipLevels = 1;
        image.arrayLayers = 1;
        image.samples = VK_SAMPLE_COUNT_1_BIT;
        image.tiling = VK_IMAGE_TILING_OPTIMAL;
        image.usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT |
                      VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
        VkImage target = id<VkImage>(kTarget);
        codec::encode_vkCreateImage(e, dev, &image, nullptr, &target);
        VkMemoryAllocateInfo alloc{};
        alloc.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
        alloc.allocationSize = 1 << 20; // the client's size and type index mean nothing to the agent
        VkDeviceMemory target_memory = id<VkDeviceMemory>(kTargetMemory);
        codec::encode_vkAllocateMemory(e, dev, &alloc, nullptr, &target_memory);
        codec::encode_vkBindImageMemory(e, dev, target, target_memory, 0);
        const uint64_t images[] = {kImage, kTarget};
        for (size_t i = 0; i < 2; ++i) {
            VkImageViewCreateInfo view{};
            view.sType = VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO;
            view.image = id<VkImage>(images[i]);
            view.viewType = VK_IMAGE_VIEW_TYPE_2D;
            view.format = VK_FORMAT_R8G8B8A8_UNORM;
            view.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
            VkImageView v = id<VkImageView>(kViews + i);
            codec::encode_vkCreateImageView(e, dev, &view, nullptr, &v);
            VkFramebufferCreateInfo framebuffer{};
            framebuffer.sType = VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO;
            framebuffer.renderPass = render_pass;
            framebuffer.attachmentCount = 1;
            framebuffer.pAttachments = &v;
            framebuffer.width = kWidth;
            framebuffer.height = kHeight;
            framebuffer.layers = 1;
            VkFramebuffer f = id<VkFramebuffer>(kFramebuffers + i);
            codec::encode_vkCreateFramebuffer(e, dev, &framebuffer, nullptr, &f);
        }
        ASSERT_TRUE(replay(e));
    }

    bool replay(codec::Encoder &e) {
        std::string error;
        const std::vector<uint8_t> payload = e.take();
        const bool ok = replayer->replay(payload, &error);
        EXPECT_TRUE(ok) << error;
        return ok;
    }

    // Primary `n`, allocated and begun, with the app's full-image viewport and scissor set.
    static VkCommandBuffer begin(codec::Encoder &e, uint64_t n) {
        VkCommandBufferAllocateInfo allocate_info{};
        allocate_info.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
        allocate_info.commandPool = id<VkCommandPool>(kPool);
        allocate_info.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
        allocate_info.commandBufferCount = 1;
        VkCommandBuffer cb = id<VkCommandBuffer>(kCommandBuffers + n);
        codec::encode_vkAllocateCommandBuffers(e, id<VkDevice>(kDevice), &allocate_info, &cb);
        VkCommandBufferBeginInfo info{};
        info.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
        codec::encode_vkBeginCommandBuffer(e, cb, &info, VK_COMMAND_BUFFER_LEVEL_PRIMARY);
        const VkViewport viewport{0, 0, float(kWidth), float(kHeight), 0, 1};
        codec::encode_vkCmdSetViewport(e, cb, 0, 1, &viewport);
        codec::encode_vkCmdSetScissor(e, cb, 0, 1, &kFull);
        return cb;
    }
    // A pass into framebuffer `n` (0: the swapchain image, 1: the screen-space target).
    static void pass(codec::Encoder &e, VkCommandBuffer cb, uint64_t n) {
        const VkClearValue clear{};
        VkRenderPassBeginInfo begin{};
        begin.sType = VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO;
        begin.renderPass = id<VkRenderPass>(kRenderPass);
        begin.framebuffer = id<VkFramebuffer>(kFramebuffers + n);
        begin.renderArea = kFull;
        begin.clearValueCount = 1;
        begin.pClearValues = &clear;
        codec::encode_vkCmdBeginRenderPass(e, cb, &begin, VK_SUBPASS_CONTENTS_INLINE);
        codec::encode_vkCmdEndRenderPass(e, cb);
    }
    static void end_and_submit(codec::Encoder &e, VkCommandBuffer cb) {
        codec::encode_vkEndCommandBuffer(e, cb);
        VkSubmitInfo submit{};
        submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
        submit.commandBufferCount = 1;
        submit.pCommandBuffers = &cb;
        codec::encode_vkQueueSubmit(e, id<VkQueue>(kQueue), 1, &submit, VK_NULL_HANDLE);
    }
    // The passes of `record`'s command buffer as the driver drew them.
    template <class Record>
    std::vector<Pass> passes(Record &&record) {
        g_passes.clear();
        codec::Encoder e;
        record(e);
        replay(e);
        return g_passes;
    }

    std::unique_ptr<Replayer> replayer;
};

uint64_t pixels(const VkRect2D &r) {
    return uint64_t{r.extent.width} * r.extent.height;
}

TEST_F(PeripheryScalingTest, PassesIntoTheSwapchainImageAreDrawnScaled) {
    ASSERT_NO_FATAL_FAILURE(start(false));
    set_log_level(LogLevel::Info);
    testing::internal::CaptureStderr();
    const auto drawn = passes([&](codec::Encoder &e) {
        const VkCommandBuffer cb = begin(e, 0);
        pass(e, cb, 1); // the screen-space target first, as a frame's offscreen pass
        pass(e, cb, 0);
        pass(e, cb, 1); // and after it: the app's state is back
        end_and_submit(e, cb);
    });
    const std::string log = testing::internal::GetCapturedStderr();
    ASSERT_EQ(drawn.size(), 3u);

    // Into the swapchain image: the client's scaled rectangles (its paper split draws the same).
    const VkExtent2D scaled = split::scaled_extent({kWidth, kHeight}, kScale);
    EXPECT_EQ(scaled.width, 181u); // ceil(301 * 0.6)
    EXPECT_EQ(scaled.height, 103u);
    const VkRect2D periphery{{0, 0}, scaled};
    EXPECT_TRUE(drawn[1].area == periphery);
    EXPECT_TRUE(drawn[1].area == split::scaled_pass_rect(kFull, {kWidth, kHeight}, kScale));
    EXPECT_TRUE(drawn[1].scissor == periphery);
    EXPECT_FLOAT_EQ(drawn[1].viewport.width, float(scaled.width));
    EXPECT_FLOAT_EQ(drawn[1].viewport.height, float(scaled.height));
    // It shades s² of the image's pixels: what the periphery's draw saves over the full-size one.
    EXPECT_LT(pixels(drawn[1].area), pixels(kFull) * 37 / 100);
    // Into the screen-space target, before and after: as recorded.
    for (size_t i : {size_t{0}, size_t{2}}) {
        EXPECT_TRUE(drawn[i].area == kFull) << i;
        EXPECT_TRUE(drawn[i].scissor == kFull) << i;
        EXPECT_FLOAT_EQ(drawn[i].viewport.width, float(kWidth)) << i;
    }
    // The frame's periphery is the image's top-left rectangle: read in place.
    EXPECT_EQ(replayer->scaling().take_frame(kImage), PeripheryScaling::Frame::Scaled);
    EXPECT_EQ(replayer->scaling().take_frame(kImage), PeripheryScaling::Frame::Whole) << "taken once";
    EXPECT_NE(log.find("swapped split: passes into 301x171 swapchain images are drawn at 181x103"),
              std::string::npos)
        << log;
}

// A verifying client compares with the agent's frame: every pass replays whole.
TEST_F(PeripheryScalingTest, AVerifyingClientsFramesAreReplayedWhole) {
    ASSERT_NO_FATAL_FAILURE(start(true));
    EXPECT_FALSE(replayer->scaling().enabled());
    const auto drawn = passes([&](codec::Encoder &e) {
        const VkCommandBuffer cb = begin(e, 0);
        pass(e, cb, 0);
        end_and_submit(e, cb);
    });
    ASSERT_EQ(drawn.size(), 1u);
    EXPECT_TRUE(drawn[0].area == kFull);
    EXPECT_TRUE(drawn[0].scissor == kFull);
    EXPECT_FLOAT_EQ(drawn[0].viewport.width, float(kWidth));
    EXPECT_EQ(replayer->scaling().take_frame(kImage), PeripheryScaling::Frame::Whole);
}

// A copy into the swapchain image writes it at full size: alone, the frame is downsampled as before;
// with a scaled pass in the same frame, it has no consistent periphery.
TEST_F(PeripheryScalingTest, AFullSizeWriteMakesTheFrameWholeOrMixed) {
    ASSERT_NO_FATAL_FAILURE(start(false));
    const auto copy = [](codec::Encoder &e, VkCommandBuffer cb) {
        VkImageCopy region{};
        region.srcSubresource = region.dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
        region.extent = {kWidth, kHeight, 1};
        codec::encode_vkCmdCopyImage(e, cb, id<VkImage>(kTarget), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                                     id<VkImage>(kImage), VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
    };
    passes([&](codec::Encoder &e) {
        const VkCommandBuffer cb = begin(e, 0);
        pass(e, cb, 1);
        copy(e, cb);
        end_and_submit(e, cb);
    });
    EXPECT_EQ(replayer->scaling().take_frame(kImage), PeripheryScaling::Frame::Whole);
    passes([&](codec::Encoder &e) {
        const VkCommandBuffer cb = begin(e, 1);
        pass(e, cb, 0);
        pass(e, cb, 1);
        copy(e, cb);
        end_and_submit(e, cb);
    });
    EXPECT_EQ(replayer->scaling().take_frame(kImage), PeripheryScaling::Frame::Mixed);
}

} // namespace
} // namespace splitvk::agent
