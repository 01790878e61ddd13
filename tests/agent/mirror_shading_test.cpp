// Mirror windows on the agent: a command buffer that copies out of a swapchain image (an OpenXR eye
// image blitted into a desktop window's) has its split passes into that image replayed whole, since
// the copy's destination takes its foveae from wherever the copy reads. The agent's Replayer replays
// encoded streams on the real GPU (lavapipe here); the driver's vkCmdSetScissor and
// vkCmdEndRenderPass are wrapped (and still called) to see which scissor each pass ended with.
#include "devices.h"
#include "log.h"
#include "replayer.h"
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
                   kRenderPass = 0x5000, kSwapchain = 0x6000, kEyeImage = 0x6100, kOtherImage = 0x6200,
                   kTarget = 0x7000, kTargetMemory = 0x7100, kBuffer = 0x7200, kBufferMemory = 0x7300,
                   kViews = 0x8000, kFramebuffers = 0x9000, kCommandBuffers = 0xa000;
constexpr uint32_t kWidth = 256, kHeight = 128;
constexpr VkRect2D kFull = {{0, 0}, {kWidth, kHeight}};

bool operator==(const VkRect2D &a, const VkRect2D &b) {
    return a.offset.x == b.offset.x && a.offset.y == b.offset.y && a.extent.width == b.extent.width &&
           a.extent.height == b.extent.height;
}

// What the driver was given: scissor 0 as last set, and its value at each render pass's end.
PFN_vkCmdSetScissor g_set_scissor = nullptr;
PFN_vkCmdEndRenderPass g_end_render_pass = nullptr;
VkRect2D g_scissor{};
std::vector<VkRect2D> g_pass_scissors;

VKAPI_ATTR void VKAPI_CALL record_set_scissor(VkCommandBuffer cb, uint32_t first, uint32_t count,
                                              const VkRect2D *scissors) {
    if (first == 0 && count > 0) g_scissor = scissors[0];
    g_set_scissor(cb, first, count, scissors);
}

VKAPI_ATTR void VKAPI_CALL record_end_render_pass(VkCommandBuffer cb) {
    g_pass_scissors.push_back(g_scissor);
    g_end_render_pass(cb);
}

class MirrorShading : public testing::Test {
protected:
    void SetUp() override {
        std::string error;
        const std::vector<GpuInfo> gpus = enumerate_gpus(&error);
        ASSERT_FALSE(gpus.empty()) << error;
        // The limit guard holds the replay to this GPU's own limits.
        replayer = std::make_unique<Replayer>(1, MemoryLimits{}, gpus[0].description);
        Replayer &r = *replayer;
        ASSERT_TRUE(r.init(0, false, &error)) << error;
        // Split frames as after the client's SplitConfig (eyes=1: one fovea at the centre), with the
        // offscreen guard on; set before any command, as SplitConfig is.
        r.fovea().configure(EyeMode::One, FoveaSize{}, AgentScissor{true, 8});
        r.fovea().set_enabled(true);

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

        VkBufferCreateInfo buffer{};
        buffer.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
        buffer.size = VkDeviceSize{kWidth} * kHeight * 4;
        buffer.usage = VK_BUFFER_USAGE_TRANSFER_DST_BIT;
        VkBuffer b = id<VkBuffer>(kBuffer);
        codec::encode_vkCreateBuffer(e, dev, &buffer, nullptr, &b);
        VkMemoryAllocateInfo alloc{};
        alloc.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
        alloc.allocationSize = 1 << 20; // the client's size and type index mean nothing to the agent
        VkDeviceMemory buffer_memory = id<VkDeviceMemory>(kBufferMemory);
        codec::encode_vkAllocateMemory(e, dev, &alloc, nullptr, &buffer_memory);
        codec::encode_vkBindBufferMemory(e, dev, b, buffer_memory, 0);
        ASSERT_TRUE(replay(e));
        // Now that the device's commands are loaded: see what reaches the driver.
        g_set_scissor = r.vk.CmdSetScissor;
        g_end_render_pass = r.vk.CmdEndRenderPass;
        r.vk.CmdSetScissor = record_set_scissor;
        r.vk.CmdEndRenderPass = record_end_render_pass;

        protocol::SwapchainImages swapchain;
        swapchain.device_id = kDevice;
        swapchain.swapchain_id = kSwapchain;
        swapchain.width = kWidth;
        swapchain.height = kHeight;
        swapchain.format = VK_FORMAT_R8G8B8A8_UNORM;
        swapchain.usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT;
        swapchain.image_ids = {kEyeImage, kOtherImage};
        ASSERT_TRUE(r.swapchain_images(swapchain, &error)) << error;

        // A screen-space target (the swapchain's extent, drawn and sampled), created after the
        // swapchain as the client classifies it.
        VkImageCreateInfo image{};
        image.sType = VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO;
        image.imageType = VK_IMAGE_TYPE_2D;
        image.format = VK_FORMAT_R8G8B8A8_UNORM;
        image.extent = {kWidth, kHeight, 1};
        image.mipLevels = 1;
        image.arrayLayers = 1;
        image.samples = VK_SAMPLE_COUNT_1_BIT;
        image.tiling = VK_IMAGE_TILING_OPTIMAL;
        image.usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT;
        VkImage target = id<VkImage>(kTarget);
        codec::encode_vkCreateImage(e, dev, &image, nullptr, &target);
        VkDeviceMemory target_memory = id<VkDeviceMemory>(kTargetMemory);
        codec::encode_vkAllocateMemory(e, dev, &alloc, nullptr, &target_memory);
        codec::encode_vkBindImageMemory(e, dev, target, target_memory, 0);
        const uint64_t images[] = {kEyeImage, kOtherImage, kTarget};
        for (size_t i = 0; i < 3; ++i) {
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

    // Command buffer `n`, allocated at `level` (unless `allocate` is false: it was) and begun (a
    // secondary for use outside a pass).
    VkCommandBuffer begin(codec::Encoder &e, uint64_t n,
                          VkCommandBufferLevel level = VK_COMMAND_BUFFER_LEVEL_PRIMARY,
                          bool allocate = true) {
        VkCommandBufferAllocateInfo allocate_info{};
        allocate_info.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
        allocate_info.commandPool = id<VkCommandPool>(kPool);
        allocate_info.level = level;
        allocate_info.commandBufferCount = 1;
        VkCommandBuffer cb = id<VkCommandBuffer>(kCommandBuffers + n);
        if (allocate) codec::encode_vkAllocateCommandBuffers(e, id<VkDevice>(kDevice), &allocate_info, &cb);
        VkCommandBufferInheritanceInfo inheritance{};
        inheritance.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_INHERITANCE_INFO;
        VkCommandBufferBeginInfo info{};
        info.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
        if (level == VK_COMMAND_BUFFER_LEVEL_SECONDARY) info.pInheritanceInfo = &inheritance;
        codec::encode_vkBeginCommandBuffer(e, cb, &info, level);
        return cb;
    }

    // The app's full-image viewport and scissor, then a pass into framebuffer `n` (0: the eye
    // image, 1: the swapchain's other image, 2: the screen-space target).
    static void set_state(codec::Encoder &e, VkCommandBuffer cb) {
        const VkViewport viewport{0, 0, float(kWidth), float(kHeight), 0, 1};
        codec::encode_vkCmdSetViewport(e, cb, 0, 1, &viewport);
        codec::encode_vkCmdSetScissor(e, cb, 0, 1, &kFull);
    }
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
    static void copy_eye_image_out(codec::Encoder &e, VkCommandBuffer cb) {
        VkBufferImageCopy region{};
        region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
        region.imageExtent = {kWidth, kHeight, 1};
        codec::encode_vkCmdCopyImageToBuffer(e, cb, id<VkImage>(kEyeImage),
                                             VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, id<VkBuffer>(kBuffer), 1,
                                             &region);
    }
    void end_and_submit(codec::Encoder &e, VkCommandBuffer cb) {
        codec::encode_vkEndCommandBuffer(e, cb);
        VkSubmitInfo submit{};
        submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
        submit.commandBufferCount = 1;
        submit.pCommandBuffers = &cb;
        codec::encode_vkQueueSubmit(e, id<VkQueue>(kQueue), 1, &submit, VK_NULL_HANDLE);
    }

    // The scissor each pass of `record`'s command buffer ended with.
    template <class Record>
    std::vector<VkRect2D> pass_scissors(Record &&record) {
        g_pass_scissors.clear();
        codec::Encoder e;
        record(e);
        replay(e);
        return g_pass_scissors;
    }

    std::unique_ptr<Replayer> replayer;
};

bool inside(const VkRect2D &inner, const VkRect2D &outer) {
    return inner.offset.x >= outer.offset.x && inner.offset.y >= outer.offset.y &&
           inner.offset.x + int64_t{inner.extent.width} <= outer.offset.x + int64_t{outer.extent.width} &&
           inner.offset.y + int64_t{inner.extent.height} <= outer.offset.y + int64_t{outer.extent.height};
}

TEST_F(MirrorShading, PassesIntoACopiedSwapchainImageAreShadedWhole) {
    set_log_level(LogLevel::Info);
    testing::internal::CaptureStderr();
    // The mirror's frame: the eye image drawn, then copied out. The swapchain's other image and the
    // screen-space target are drawn in the same command buffer.
    const auto mirrored = pass_scissors([&](codec::Encoder &e) {
        const VkCommandBuffer cb = begin(e, 0);
        set_state(e, cb);
        pass(e, cb, 0);
        pass(e, cb, 1);
        copy_eye_image_out(e, cb);
        pass(e, cb, 0); // a pass after the copy is in the same command buffer all the same
        end_and_submit(e, cb);
    });
    const std::string log = testing::internal::GetCapturedStderr();
    const auto mirrored_foveae = replayer->fovea().take_drawn_foveae(kEyeImage);
    const auto other_foveae = replayer->fovea().take_drawn_foveae(kOtherImage);

    // The same passes in a command buffer that copies nothing out.
    const auto plain = pass_scissors([&](codec::Encoder &e) {
        const VkCommandBuffer cb = begin(e, 1);
        set_state(e, cb);
        pass(e, cb, 0);
        pass(e, cb, 1);
        end_and_submit(e, cb);
    });
    const auto plain_foveae = replayer->fovea().take_drawn_foveae(kEyeImage);

    ASSERT_EQ(mirrored.size(), 3u);
    EXPECT_TRUE(mirrored[0] == kFull);
    EXPECT_TRUE(mirrored[2] == kFull);
    // The other image keeps its fovea scissor: narrower than the image, at the fovea.
    ASSERT_EQ(plain.size(), 2u);
    EXPECT_FALSE(plain[0] == kFull);
    EXPECT_TRUE(inside(plain[0], kFull));
    EXPECT_TRUE(mirrored[1] == plain[1]);
    EXPECT_FALSE(mirrored[1] == kFull);

    // The foveae reported are those of the viewports drawn with, copied out or not.
    ASSERT_EQ(mirrored_foveae.size(), 1u);
    ASSERT_EQ(plain_foveae.size(), 1u);
    EXPECT_TRUE(mirrored_foveae[0].rect == plain_foveae[0].rect);
    EXPECT_EQ(mirrored_foveae[0].layer, plain_foveae[0].layer);
    ASSERT_EQ(other_foveae.size(), 1u);
    // The fovea is what the scissored pass shaded.
    EXPECT_TRUE(inside(plain_foveae[0].rect, plain[0]));

    const std::string line = "fovea shading: swapchain image 0x6100 is copied out of in its command buffer; "
                             "its passes are shaded whole";
    const size_t at = log.find(line);
    EXPECT_NE(at, std::string::npos) << log;
    EXPECT_EQ(log.find(line, at + 1), std::string::npos) << "said once: " << log;
}

// A secondary that copies the eye image out, executed after the primary drew it: the secondary was
// recorded first, so its prescan tells the primary's.
TEST_F(MirrorShading, ACopyInAnExecutedSecondaryCounts) {
    codec::Encoder recording;
    const VkCommandBuffer secondary = begin(recording, 2, VK_COMMAND_BUFFER_LEVEL_SECONDARY);
    copy_eye_image_out(recording, secondary);
    codec::encode_vkEndCommandBuffer(recording, secondary);
    ASSERT_TRUE(replay(recording));
    const auto scissors = pass_scissors([&](codec::Encoder &e) {
        const VkCommandBuffer cb = begin(e, 3);
        set_state(e, cb);
        pass(e, cb, 0);
        pass(e, cb, 1);
        codec::encode_vkCmdExecuteCommands(e, cb, 1, &secondary);
        end_and_submit(e, cb);
    });
    ASSERT_EQ(scissors.size(), 2u);
    EXPECT_TRUE(scissors[0] == kFull);
    EXPECT_FALSE(scissors[1] == kFull);
}

// A command buffer recorded again without the copy is scissored again.
TEST_F(MirrorShading, ARecordingWithoutTheCopyIsScissored) {
    const auto record = [&](bool copy, bool first) {
        return pass_scissors([&](codec::Encoder &e) {
            const VkCommandBuffer cb = begin(e, 4, VK_COMMAND_BUFFER_LEVEL_PRIMARY, first);
            set_state(e, cb);
            pass(e, cb, 0);
            if (copy) copy_eye_image_out(e, cb);
            end_and_submit(e, cb);
        });
    };
    const auto copied = record(true, true);
    const auto again = record(false, false);
    ASSERT_EQ(copied.size(), 1u);
    ASSERT_EQ(again.size(), 1u);
    EXPECT_TRUE(copied[0] == kFull);
    EXPECT_FALSE(again[0] == kFull);
}

// SPLITVK_AGENT_SCISSOR=guard:N cuts passes into screen-space targets around the foveae of the
// swapchain image; where that image is copied out, its copy's foveae read it elsewhere too.
TEST_F(MirrorShading, GuardedPassesOfACommandBufferThatCopiesOutRunWhole) {
    const auto record = [&](uint64_t n, bool copy) {
        return pass_scissors([&](codec::Encoder &e) {
            const VkCommandBuffer cb = begin(e, n);
            set_state(e, cb);
            pass(e, cb, 2);
            pass(e, cb, 0);
            if (copy) copy_eye_image_out(e, cb);
            end_and_submit(e, cb);
        });
    };
    const auto guarded = record(5, false);
    const auto copied = record(6, true);
    ASSERT_EQ(guarded.size(), 2u);
    ASSERT_EQ(copied.size(), 2u);
    EXPECT_FALSE(guarded[0] == kFull);
    EXPECT_TRUE(inside(guarded[0], kFull));
    EXPECT_TRUE(copied[0] == kFull);
    EXPECT_TRUE(copied[1] == kFull);
}

} // namespace
} // namespace splitvk::agent
