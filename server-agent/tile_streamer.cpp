#include "tile_streamer.h"

#include "log.h"
#include "periphery.h"
#include "tile_format.h"
#include "vk_format_info.h"

#include <algorithm>
#include <cstring>
#include <utility>

namespace splitvk::agent {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

namespace {

constexpr uint64_t kFenceWaitNs = 30'000'000'000; // a frame that long is a lost GPU, not a slow one
constexpr auto kSlotWait = 30s;

std::string rect_text(const split::LayerFovea &fovea) {
    const VkRect2D &r = fovea.rect;
    return std::to_string(r.extent.width) + "x" + std::to_string(r.extent.height) + " at " +
           std::to_string(r.offset.x) + "," + std::to_string(r.offset.y) + " in layer " +
           std::to_string(fovea.layer);
}

bool inside(const split::LayerFovea &fovea, VkExtent2D extent, uint32_t layers) {
    const VkRect2D &r = fovea.rect;
    return fovea.layer < layers && r.offset.x >= 0 && r.offset.y >= 0 && r.extent.width > 0 &&
           r.extent.height > 0 && uint64_t(r.offset.x) + r.extent.width <= extent.width &&
           uint64_t(r.offset.y) + r.extent.height <= extent.height;
}

uint32_t micros(Clock::duration d) {
    const auto us = std::chrono::duration_cast<std::chrono::microseconds>(d).count();
    return static_cast<uint32_t>(std::clamp<int64_t>(us, 0, UINT32_MAX));
}

} // namespace

TileStreamer::TileStreamer(VulkanContext &context, Send send) : context_(context), send_(std::move(send)) {}

TileStreamer::~TileStreamer() {
    {
        std::lock_guard lock(mutex_);
        stopping_ = true;
    }
    changed_.notify_all();
    if (worker_.joinable()) worker_.join();
    if (!context_.device) return;
    for (Slot &slot : slots_)
        destroy_slot(slot);
    if (queries_) vkDestroyQueryPool(context_.device, queries_, nullptr);
    context_.destroy(stamps_);
    if (pool_) vkDestroyCommandPool(context_.device, pool_, nullptr);
}

bool TileStreamer::create_timing() {
    const VkDevice device = context_.device;
    uint32_t families = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(context_.physical_device, &families, nullptr);
    std::vector<VkQueueFamilyProperties> properties(families);
    vkGetPhysicalDeviceQueueFamilyProperties(context_.physical_device, &families, properties.data());
    VkPhysicalDeviceProperties device_properties{};
    vkGetPhysicalDeviceProperties(context_.physical_device, &device_properties);
    const uint32_t bits =
        context_.queue_family < families ? properties[context_.queue_family].timestampValidBits : 0;
    if (bits == 0 || device_properties.limits.timestampPeriod <= 0) return false;
    timestamp_period_ns_ = device_properties.limits.timestampPeriod;
    timestamp_mask_ = bits >= 64 ? ~uint64_t{0} : (uint64_t{1} << bits) - 1;
    std::string error;
    if (!ensure_pool(&error)) return false;
    VkQueryPoolCreateInfo query_info{};
    query_info.sType = VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO;
    query_info.queryType = VK_QUERY_TYPE_TIMESTAMP;
    query_info.queryCount = 2 * kTimedFrames;
    if (vkCreateQueryPool(device, &query_info, nullptr, &queries_) != VK_SUCCESS) return false;
    if (!context_.create_readback_buffer(2 * kTimedFrames * sizeof(uint64_t), &stamps_, &error)) return false;
    VkCommandBufferAllocateInfo alloc{};
    alloc.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
    alloc.commandPool = pool_;
    alloc.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    alloc.commandBufferCount = 1;
    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    // Recorded once: a pair is submitted again only after the worker has read it (kTimedFrames).
    for (uint32_t i = 0; i < kTimedFrames; ++i) {
        TimedFrame &t = timed_[i];
        if (vkAllocateCommandBuffers(device, &alloc, &t.begin) != VK_SUCCESS ||
            vkAllocateCommandBuffers(device, &alloc, &t.end) != VK_SUCCESS)
            return false;
        vkBeginCommandBuffer(t.begin, &begin);
        vkCmdResetQueryPool(t.begin, queries_, 2 * i, 2);
        vkCmdWriteTimestamp(t.begin, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, queries_, 2 * i);
        vkEndCommandBuffer(t.begin);
        vkBeginCommandBuffer(t.end, &begin);
        vkCmdWriteTimestamp(t.end, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, queries_, 2 * i + 1);
        // The GPU copies the pair into host memory, which the worker reads once the frame's `drawn`
        // fence has signalled. vkGetQueryPoolResults instead may wait for the whole device to go
        // idle (lavapipe's does), and the next frame's work is queued by then: each frame's tiles
        // would wait for the next frame's draw.
        vkCmdCopyQueryPoolResults(t.end, queries_, 2 * i, 2, stamps_.buffer, 2 * i * sizeof(uint64_t),
                                  sizeof(uint64_t), VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT);
        VkMemoryBarrier to_host{};
        to_host.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
        to_host.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
        to_host.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
        vkCmdPipelineBarrier(t.end, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_HOST_BIT, 0, 1,
                             &to_host, 0, nullptr, 0, nullptr);
        vkEndCommandBuffer(t.end);
    }
    return true;
}

void TileStreamer::frame_started() {
    if (!timing_tried_) {
        timing_tried_ = true;
        if (!create_timing()) {
            if (queries_) vkDestroyQueryPool(context_.device, queries_, nullptr);
            queries_ = VK_NULL_HANDLE;
            context_.destroy(stamps_);
            SPLITVK_INFO("tiles: no timestamps on the agent's queue; the draw time is wall time");
        }
    }
    if (!queries_) return;
    const uint32_t pair = next_timed_;
    VkSubmitInfo submit{};
    submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
    submit.commandBufferCount = 1;
    submit.pCommandBuffers = &timed_[pair].begin;
    if (vkQueueSubmit(context_.queue, 1, &submit, VK_NULL_HANDLE) != VK_SUCCESS) return;
    next_timed_ = (next_timed_ + 1) % kTimedFrames;
    started_ = static_cast<int32_t>(pair);
}

uint32_t TileStreamer::timed_draw_us(uint32_t pair) {
    // After the frame's `drawn` fence: the pair's copy has completed.
    context_.invalidate(stamps_);
    uint64_t stamps[2] = {};
    std::memcpy(stamps, stamps_.mapped + 2 * pair * sizeof(uint64_t), sizeof(stamps));
    const uint64_t ticks = ((stamps[1] & timestamp_mask_) - (stamps[0] & timestamp_mask_)) & timestamp_mask_;
    return static_cast<uint32_t>(std::min<double>(ticks * timestamp_period_ns_ / 1000.0, UINT32_MAX));
}

bool TileStreamer::ensure_pool(std::string *error) {
    if (pool_) return true;
    VkCommandPoolCreateInfo pool_info{};
    pool_info.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
    pool_info.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
    pool_info.queueFamilyIndex = context_.queue_family;
    if (const VkResult r = vkCreateCommandPool(context_.device, &pool_info, nullptr, &pool_);
        r != VK_SUCCESS) {
        *error = std::string("tile command pool: ") + vk_result_name(r);
        return false;
    }
    return true;
}

bool TileStreamer::create_slot(Slot &slot, std::string *error) {
    const VkDevice device = context_.device;
    if (!ensure_pool(error)) return false;
    VkCommandBufferAllocateInfo alloc{};
    alloc.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
    alloc.commandPool = pool_;
    alloc.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    alloc.commandBufferCount = 1;
    VkResult r = vkAllocateCommandBuffers(device, &alloc, &slot.command_buffer);
    VkFenceCreateInfo fence_info{};
    fence_info.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
    if (r == VK_SUCCESS) r = vkCreateFence(device, &fence_info, nullptr, &slot.drawn);
    if (r == VK_SUCCESS) r = vkCreateFence(device, &fence_info, nullptr, &slot.copied);
    if (r != VK_SUCCESS) {
        *error = std::string("tile staging slot: ") + vk_result_name(r);
        return false;
    }
    return true;
}

bool TileStreamer::ensure_buffer(Slot &slot, VkDeviceSize bytes, std::string *error) {
    if (slot.staging.size >= bytes) return true;
    context_.destroy(slot.staging);
    return context_.create_readback_buffer(bytes, &slot.staging, error);
}

void TileStreamer::destroy_slot(Slot &slot) {
    const VkDevice device = context_.device;
    context_.destroy(slot.staging);
    context_.destroy(slot.scaled);
    if (slot.drawn) vkDestroyFence(device, slot.drawn, nullptr);
    if (slot.copied) vkDestroyFence(device, slot.copied, nullptr);
    // The command buffer goes with the pool.
    slot = Slot{};
}

void TileStreamer::record_copy(Slot &slot) {
    vkResetCommandBuffer(slot.command_buffer, 0);
    std::vector<VkBufferImageCopy> regions;
    VkDeviceSize offset = 0;
    for (const auto &[layer, rect] : slot.frame.foveae) {
        VkBufferImageCopy region{};
        region.bufferOffset = offset; // tightly packed, one rect after the other
        region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, layer, 1};
        region.imageOffset = {rect.offset.x, rect.offset.y, 0};
        region.imageExtent = {rect.extent.width, rect.extent.height, 1};
        regions.push_back(region);
        offset += VkDeviceSize{rect.extent.width} * rect.extent.height * slot.frame.texel_bytes;
    }
    if (slot.frame.periphery.width > 0 && !slot.frame.periphery_in_place)
        VulkanContext::record_present_downsample(slot.command_buffer, slot.frame.image, slot.frame.layout,
                                                 slot.frame.extent, slot.scaled, periphery_filter_,
                                                 slot.staging, regions);
    else
        VulkanContext::record_present_readback(slot.command_buffer, slot.frame.image, slot.frame.layout,
                                               slot.staging, regions);
}

bool TileStreamer::prepare_periphery(Slot &slot, Frame &frame, bool *skip, std::string *error) {
    *skip = false;
    // The periphery is downsampled and may be coded lossily, as colour: 4-byte texels only.
    if (frame.texel_bytes != 4) {
        if (!unsupported_format_logged_)
            SPLITVK_INFO("tiles: the periphery of %s is not sent (not 4 bytes a texel); the client "
                         "shows its foveae over the last periphery it has",
                         format_name(frame.format));
        unsupported_format_logged_ = true;
        *skip = true;
        return true;
    }
    if (frame.periphery_in_place) {
        // Drawn scaled into the image's top-left: its parts are read in place, with no blit.
    } else if (frame.format != periphery_format_) {
        if (!context_.blit_filter(frame.format, &periphery_filter_)) {
            *error = std::string("the periphery of ") + format_name(frame.format) +
                     " cannot be blitted on this GPU";
            return false;
        }
        periphery_format_ = frame.format;
        if (periphery_filter_ != VK_FILTER_LINEAR)
            SPLITVK_INFO("tiles: %s cannot be filtered linearly on this GPU; the periphery is "
                         "downsampled with the nearest filter",
                         format_name(frame.format));
    }
    if (!frame.periphery_in_place &&
        (slot.scaled.format != frame.format || slot.scaled.extent.width != frame.periphery.width ||
         slot.scaled.extent.height != frame.periphery.height)) {
        context_.destroy(slot.scaled);
        if (!context_.create_transfer_image(frame.format, frame.periphery, &slot.scaled, error)) return false;
    }
    frame.foveae.clear();
    for (const VkRect2D &part : split::periphery_parts(frame.periphery))
        frame.foveae.push_back({0, part});
    // Lossy only where x264 codes the bytes as colour; lossless (as asked or not) otherwise.
    const bool lossy = !periphery_quality_.lossless && split::periphery_lossy_format(frame.format);
    if (!periphery_quality_.lossless && !lossy && !lossless_format_logged_) {
        SPLITVK_INFO("tiles: the periphery of %s travels losslessly (lossy is for 8-bit RGBA/BGRA)",
                     format_name(frame.format));
        lossless_format_logged_ = true;
    }
    frame.quality =
        lossy ? tiles::TileQuality{false, periphery_quality_.crf, split::periphery_blue_first(frame.format)}
              : tiles::TileQuality{};
    if (lossy) frame.periphery_codec = split::periphery_tile_codec(periphery_codec_);
    return true;
}

bool TileStreamer::check_readable(Frame &frame) {
    if (frame.foveae.empty() && frame.periphery.width == 0) return true;
    std::string why;
    if (frame.texel_bytes == 0) {
        why = std::string(format_name(frame.format)) + " is not a format tiles carry";
    } else if (frame.periphery.width == 0) {
        for (const split::LayerFovea &fovea : frame.foveae)
            if (!inside(fovea, frame.extent, frame.layers)) {
                why = "a fovea of " + rect_text(fovea) + " is outside the image (" +
                      std::to_string(frame.extent.width) + "x" + std::to_string(frame.extent.height) +
                      " in " + std::to_string(frame.layers) + " layer(s))";
                break;
            }
    }
    if (why.empty()) return true;
    if (!unreadable_logged_)
        SPLITVK_WARN("tiles: frame %llu: %s; it is not read back, and its tiles go as invalid (the client "
                     "shows its periphery); said once",
                     static_cast<unsigned long long>(frame.frame), why.c_str());
    unreadable_logged_ = true;
    frame.foveae.clear();
    frame.periphery = {};
    frame.invalid = true;
    return false;
}

TileCodec TileStreamer::stream_codec(const Frame &frame) {
    if (frame.texel_bytes != 8 || codec_ != TileCodec::X264) return codec_;
    if (!wide_codec_logged_)
        SPLITVK_INFO("tiles: %s has 8-byte texels, which x264 does not take: its tiles travel with zstd",
                     format_name(frame.format));
    wide_codec_logged_ = true;
    return TileCodec::Zstd;
}

bool TileStreamer::present(Frame frame, std::string *error) {
    Slot &slot = slots_[next_slot_];
    {
        std::unique_lock lock(mutex_);
        if (!changed_.wait_for(lock, kSlotWait, [&] { return !slot.busy || worker_error_; })) {
            *error = "tile encoder stalled: no staging slot free for 30 s";
            return false;
        }
        if (worker_error_) {
            *error = *worker_error_;
            return false;
        }
    }
    if (!slot.command_buffer && !create_slot(slot, error)) return false;
    frame.texel_bytes = tile_texel_bytes(frame.format);
    if (check_readable(frame) && frame.periphery.width > 0) {
        bool skip = false;
        if (!prepare_periphery(slot, frame, &skip, error)) return false;
        if (skip) frame.periphery = {};
    }

    VkDeviceSize bytes = 0;
    for (const auto &[layer, rect] : frame.foveae)
        bytes += VkDeviceSize{rect.extent.width} * rect.extent.height * frame.texel_bytes;
    slot.frame = std::move(frame);
    VkFence fences[] = {slot.drawn, slot.copied};
    vkResetFences(context_.device, 2, fences);
    slot.timed = std::exchange(started_, -1);

    // A submit signals `drawn` when everything before it on the queue, the frame's own work, has
    // completed; with timestamps it writes the end of the frame's GPU draw time.
    VkSubmitInfo drawn{};
    drawn.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
    if (slot.timed >= 0) {
        drawn.commandBufferCount = 1;
        drawn.pCommandBuffers = &timed_[static_cast<uint32_t>(slot.timed)].end;
    }
    VkResult r = vkQueueSubmit(context_.queue, 1, &drawn, slot.drawn);
    if (r == VK_SUCCESS && bytes > 0) {
        if (!ensure_buffer(slot, bytes, error)) return false;
        record_copy(slot);
        VkSubmitInfo submit{};
        submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
        submit.commandBufferCount = 1;
        submit.pCommandBuffers = &slot.command_buffer;
        r = vkQueueSubmit(context_.queue, 1, &submit, slot.copied);
    } else if (r == VK_SUCCESS) {
        r = vkQueueSubmit(context_.queue, 0, nullptr, slot.copied);
    }
    if (r != VK_SUCCESS) {
        *error = std::string("tile readback submit: ") + vk_result_name(r);
        return false;
    }
    {
        std::lock_guard lock(mutex_);
        slot.busy = true;
        queue_.push_back(&slot);
        if (!worker_.joinable()) worker_ = std::thread([this] { run_worker(); });
    }
    changed_.notify_all();
    next_slot_ = (next_slot_ + 1) % kSlots;
    return true;
}

bool TileStreamer::wait_fence(VkFence fence) {
    return vkWaitForFences(context_.device, 1, &fence, VK_TRUE, kFenceWaitNs) == VK_SUCCESS;
}

void TileStreamer::run_worker() {
    for (;;) {
        Slot *slot = nullptr;
        {
            std::unique_lock lock(mutex_);
            changed_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
            if (queue_.empty()) return; // stopping, nothing left
            slot = queue_.front();
            queue_.pop_front();
        }
        std::string error;
        const bool ok = encode_and_send(*slot, &error);
        {
            std::lock_guard lock(mutex_);
            slot->busy = false;
            if (!ok && !worker_error_) worker_error_ = std::move(error);
        }
        changed_.notify_all();
    }
}

bool TileStreamer::encode_and_send(Slot &slot, std::string *error) {
    const Frame &frame = slot.frame;
    if (!wait_fence(slot.drawn)) {
        *error = "frame " + std::to_string(frame.frame) + ": the GPU did not finish the frame";
        return false;
    }
    const auto drawn = Clock::now();
    if (!wait_fence(slot.copied)) {
        *error = "frame " + std::to_string(frame.frame) + ": the fovea readback did not finish";
        return false;
    }
    const auto copied = Clock::now();
    context_.invalidate(slot.staging);

    protocol::Tiles message;
    message.frame = frame.frame;
    message.swapchain_id = frame.swapchain_id;
    message.image_index = frame.image_index;
    message.format = static_cast<uint32_t>(frame.format);
    if (frame.invalid) message.flags |= protocol::kTilesInvalid;
    message.tiles.resize(frame.foveae.size());
    if (eyes_.size() < frame.foveae.size()) eyes_.resize(frame.foveae.size());

    // Each eye is its own stream with its own encoder: encode them on parallel threads (the first
    // on this one) and join before sending, so a frame's tiles travel as one message.
    std::vector<std::string> errors(frame.foveae.size());
    const TileCodec codec = frame.periphery_codec  ? *frame.periphery_codec
                            : frame.foveae.empty() ? codec_
                                                   : stream_codec(frame);
    auto encode_eye = [&](size_t eye, const uint8_t *pixels) {
        const VkRect2D &rect = frame.foveae[eye].rect;
        EyeStream &stream = eyes_[eye];
        if (!stream.encoder || stream.width != rect.extent.width || stream.height != rect.extent.height ||
            stream.texel_bytes != frame.texel_bytes || stream.codec != codec ||
            stream.quality != frame.quality) {
            stream = EyeStream{
                rect.extent.width, rect.extent.height, frame.texel_bytes, codec, frame.quality, nullptr};
            stream.encoder = tiles::make_tile_encoder(codec, rect.extent.width, rect.extent.height,
                                                      frame.texel_bytes, &errors[eye], frame.quality);
            if (!stream.encoder) return;
        }
        protocol::EncodedTile &tile = message.tiles[eye];
        tile.x = static_cast<uint32_t>(rect.offset.x);
        tile.y = static_cast<uint32_t>(rect.offset.y);
        tile.width = rect.extent.width;
        tile.height = rect.extent.height;
        tile.array_layer = frame.foveae[eye].layer;
        tile.codec = codec;
        bool keyframe = false;
        if (!stream.encoder->encode(pixels, tile.data, &keyframe, &errors[eye])) {
            stream.encoder.reset(); // the next frame starts a new stream with a keyframe
            return;
        }
        if (keyframe) tile.flags |= protocol::kTileKeyframe;
        if (frame.periphery.width > 0) tile.flags |= protocol::kTilePeriphery;
    };
    std::vector<std::thread> threads;
    const uint8_t *base = slot.staging.mapped;
    size_t offset = 0;
    std::vector<const uint8_t *> pixels;
    for (const auto &[layer, rect] : frame.foveae) {
        pixels.push_back(base + offset);
        offset += size_t{rect.extent.width} * rect.extent.height * frame.texel_bytes;
    }
    for (size_t eye = 1; eye < frame.foveae.size(); ++eye)
        threads.emplace_back(encode_eye, eye, pixels[eye]);
    if (!frame.foveae.empty()) encode_eye(0, pixels[0]);
    for (auto &t : threads)
        t.join();
    const auto encoded = Clock::now();
    for (size_t eye = 0; eye < errors.size(); ++eye)
        if (!errors[eye].empty()) {
            *error =
                "frame " + std::to_string(frame.frame) + ", eye " + std::to_string(eye) + ": " + errors[eye];
            return false;
        }

    message.timings.draw_us = slot.timed >= 0 ? timed_draw_us(static_cast<uint32_t>(slot.timed))
                              : frame.first_submit == Clock::time_point{}
                                  ? 0
                                  : micros(drawn - frame.first_submit);
    message.timings.readback_us = micros(copied - drawn);
    message.timings.encode_us = micros(encoded - copied);
    message.timings.present_to_send_us = micros(Clock::now() - frame.present);
    return send_(protocol::encode(message), error);
}

} // namespace splitvk::agent
