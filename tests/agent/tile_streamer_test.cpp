// The agent's tile streamer on the real GPU (lavapipe here): a frame's tiles leave as soon as that
// frame's own work and read-back are done, whatever the GPU is doing for the frames after it. The
// next frame's work is held on the GPU by an event only the test sets, so the outcome is an order
// of events, not a time: a streamer whose send waited for the device to go idle (reading its
// timestamps with vkGetQueryPoolResults, which lavapipe answers after a vkDeviceWaitIdle) would
// hold frame 0's tiles until the test released frame 1, and a client in lockstep would show frames
// in pairs, one long and one short.
#include "metadata.h"
#include "tile_codec.h"
#include "tile_streamer.h"
#include "vulkan_context.h"
#include "wire.h"

#include <chrono>
#include <condition_variable>
#include <mutex>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace splitvk::agent {
namespace {

using namespace std::chrono_literals;

// Large enough that the clear of frame 0 takes measurable GPU time on lavapipe.
constexpr uint32_t kSize = 2048;
constexpr VkRect2D kFovea = {{64, 32}, {32, 16}};
constexpr VkClearColorValue kColour = {{0.2f, 0.4f, 0.6f, 1.0f}};
// A hang bound, never reached when the streamer behaves: the tiles come within milliseconds.
constexpr auto kTilesBound = 20s;

class TileStreamerTest : public testing::Test {
protected:
    void SetUp() override {
        std::string error;
        ASSERT_TRUE(ctx.create_instance(0, false, 1, &error)) << error;
        const float priority = 1.0f;
        VkDeviceQueueCreateInfo queue{};
        queue.sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO;
        queue.queueCount = 1;
        queue.pQueuePriorities = &priority;
        VkDeviceCreateInfo device{};
        device.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
        device.queueCreateInfoCount = 1;
        device.pQueueCreateInfos = &queue;
        ASSERT_EQ(ctx.create_device(device, &error), VK_SUCCESS) << error;

        // The image a client's swapchain image becomes on the agent, made by the agent's own
        // helper.
        ASSERT_TRUE(ctx.create_transfer_image(VK_FORMAT_R8G8B8A8_UNORM, {kSize, kSize}, &target, &error))
            << error;

        VkCommandPoolCreateInfo pool_info{};
        pool_info.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
        pool_info.queueFamilyIndex = ctx.queue_family;
        ASSERT_EQ(vkCreateCommandPool(ctx.device, &pool_info, nullptr, &pool), VK_SUCCESS);
        VkCommandBufferAllocateInfo cb_info{};
        cb_info.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
        cb_info.commandPool = pool;
        cb_info.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
        cb_info.commandBufferCount = 2;
        VkCommandBuffer cbs[2] = {};
        ASSERT_EQ(vkAllocateCommandBuffers(ctx.device, &cb_info, cbs), VK_SUCCESS);
        clear = cbs[0];
        held = cbs[1];
        VkEventCreateInfo event_info{};
        event_info.sType = VK_STRUCTURE_TYPE_EVENT_CREATE_INFO;
        ASSERT_EQ(vkCreateEvent(ctx.device, &event_info, nullptr, &release), VK_SUCCESS);

        record_clear();
        record_held();
    }

    void TearDown() override {
        if (!ctx.device) return;
        if (release) vkSetEvent(ctx.device, release); // whatever failed, frame 1's work may finish
        vkQueueWaitIdle(ctx.queue);
        streamer.reset();
        if (release) vkDestroyEvent(ctx.device, release, nullptr);
        if (pool) vkDestroyCommandPool(ctx.device, pool, nullptr);
        ctx.destroy(target);
    }

    // Frame 0's work: the whole image cleared, left in TRANSFER_SRC_OPTIMAL as if presented there.
    void record_clear() {
        VkCommandBufferBeginInfo begin{};
        begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
        vkBeginCommandBuffer(clear, &begin);
        VkImageMemoryBarrier barrier{};
        barrier.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER;
        barrier.dstAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
        barrier.oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;
        barrier.newLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
        barrier.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
        barrier.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
        barrier.image = target.image;
        barrier.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
        vkCmdPipelineBarrier(clear, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0,
                             nullptr, 0, nullptr, 1, &barrier);
        vkCmdClearColorImage(clear, target.image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, &kColour, 1,
                             &barrier.subresourceRange);
        barrier.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
        barrier.dstAccessMask = VK_ACCESS_TRANSFER_READ_BIT;
        barrier.oldLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
        barrier.newLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
        vkCmdPipelineBarrier(clear, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0,
                             nullptr, 0, nullptr, 1, &barrier);
        vkEndCommandBuffer(clear);
    }

    // Frame 1's work: nothing the GPU can finish before the host sets `release`.
    void record_held() {
        VkCommandBufferBeginInfo begin{};
        begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
        vkBeginCommandBuffer(held, &begin);
        vkCmdWaitEvents(held, 1, &release, VK_PIPELINE_STAGE_HOST_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0,
                        nullptr, 0, nullptr, 0, nullptr);
        vkEndCommandBuffer(held);
    }

    void submit(VkCommandBuffer cb) {
        VkSubmitInfo info{};
        info.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
        info.commandBufferCount = 1;
        info.pCommandBuffers = &cb;
        ASSERT_EQ(vkQueueSubmit(ctx.queue, 1, &info, VK_NULL_HANDLE), VK_SUCCESS);
    }

    TileStreamer::Frame frame(uint64_t number) const {
        TileStreamer::Frame f;
        f.frame = number;
        f.swapchain_id = 1;
        f.image = target.image;
        f.layout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
        f.format = VK_FORMAT_R8G8B8A8_UNORM;
        f.extent = {kSize, kSize};
        f.foveae = {{0, kFovea}};
        f.first_submit = f.present = std::chrono::steady_clock::now();
        return f;
    }

    // The Tiles payloads sent so far, waiting until there are `count` or the bound has passed.
    std::vector<std::vector<uint8_t>> sent_tiles(size_t count) {
        std::unique_lock lock(mutex);
        sent_changed.wait_for(lock, kTilesBound, [&] { return sent.size() >= count; });
        return sent;
    }

    VulkanContext ctx;
    std::unique_ptr<TileStreamer> streamer;
    TransferImage target;
    VkCommandPool pool = VK_NULL_HANDLE;
    VkCommandBuffer clear = VK_NULL_HANDLE, held = VK_NULL_HANDLE;
    VkEvent release = VK_NULL_HANDLE;
    std::mutex mutex;
    std::condition_variable sent_changed;
    std::vector<std::vector<uint8_t>> sent;
};

TEST_F(TileStreamerTest, FramesTilesLeaveWhileTheNextFrameIsStillOnTheGpu) {
    streamer = std::make_unique<TileStreamer>(ctx, [&](std::vector<uint8_t> &&payload, std::string *) {
        std::lock_guard lock(mutex);
        sent.push_back(std::move(payload));
        sent_changed.notify_all();
        return true;
    });
    streamer->set_codec(TileCodec::Raw);
    std::string error;
    // Frame 0 as the replay thread runs it: its first submit, then its FramePresent.
    streamer->frame_started();
    submit(clear);
    ASSERT_TRUE(streamer->present(frame(0), &error)) << error;
    // Frame 1's first submit follows at once, as the client's next frame does in a pipeline.
    streamer->frame_started();
    submit(held);

    const auto tiles = sent_tiles(1);
    ASSERT_EQ(tiles.size(), 1u) << "frame 0's tiles did not leave while frame 1's work was held on the GPU";
    const auto message = protocol::decode_tiles(tiles[0], protocol::kDefaultMaxPayload);
    ASSERT_TRUE(message.ok()) << message.error();
    EXPECT_EQ(message->frame, 0u);
    // Its GPU draw time was read (the clear of kSize² texels), not left at 0.
    EXPECT_GT(message->timings.draw_us, 0u);
    ASSERT_EQ(message->tiles.size(), 1u);
    const protocol::EncodedTile &tile = message->tiles[0];
    ASSERT_EQ(tile.width, kFovea.extent.width);
    ASSERT_EQ(tile.height, kFovea.extent.height);
    auto decoder = tiles::make_tile_decoder(TileCodec::Raw, tile.width, tile.height, 4, &error, false);
    ASSERT_TRUE(decoder) << error;
    std::vector<uint8_t> pixels(size_t{tile.width} * tile.height * 4);
    ASSERT_TRUE(decoder->decode(tile.data, pixels.data(), &error)) << error;
    // kColour as UNORM bytes: 0.2, 0.4, 0.6 and 1.0 of 255.
    for (size_t i = 0; i < pixels.size(); i += 4) {
        ASSERT_EQ(pixels[i + 0], 51) << "texel " << i / 4;
        ASSERT_EQ(pixels[i + 1], 102) << "texel " << i / 4;
        ASSERT_EQ(pixels[i + 2], 153) << "texel " << i / 4;
        ASSERT_EQ(pixels[i + 3], 255) << "texel " << i / 4;
    }
}

} // namespace
} // namespace splitvk::agent
