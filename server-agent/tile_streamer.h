#pragma once

// The fovea path of a presented frame on the agent (docs/architecture.md §2 and §5).
//
// At FramePresent the replay thread records a copy of the frame's fovea rects into host memory
// and submits it on the replay queue, behind the frame's own submits (queue order is the only
// ordering needed: the agent replays every submit on that one queue). Then it goes on replaying
// the next frame at once. A worker thread waits for the copy, encodes each eye on its own thread
// (one encoder per eye, as each eye is a stream of its own: x264 P-frames reference the previous
// frame of the same eye) and sends the Tiles message.
//
// The swapped split (set_periphery): the parts (split::periphery_parts) of the frame's periphery
// are read back, encoded (lossily for 8-bit colour) and sent as tiles flagged kTilePeriphery, the
// parts on parallel threads as the eyes are. The periphery is the presented window image's top-left
// Frame::periphery where the frame was drawn scaled (periphery_scaling.h), read in place; otherwise
// the image is blitted to Frame::periphery with a linear filter into the slot's own scaled image.
// A lossy periphery travels in the session's SPLITVK_PERIPHERY_CODEC (4:2:0 H.264 or HEVC, or x264's
// RGB), a lossless one in x264's RGB.
//
// Every buffer and region is sized by the image's own format (tile_texel_bytes(), 4 or 8 bytes a
// texel) and checked against its own extent and layers, whatever the client declared: a frame whose
// format tiles cannot carry, or whose foveae do not lie in the image, is read back not at all and
// sent as kTilesInvalid (the client then shows its periphery), said once. 8-byte tiles travel with
// zstd where the session asked for x264, which takes 4-byte texels only.
//
// Staging: kSlots frames may be in flight between the replay thread and the worker, each with
// its own command buffer, fences and host buffer. When all are busy, present() waits for the
// oldest (bounded), which is the back-pressure that keeps the agent from running ahead of its
// encoder.

#include "metadata.h"
#include "split_geometry.h"
#include "tile_codec.h"
#include "vulkan_context.h"

#include <vulkan/vulkan.h>

#include <array>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace splitvk::agent {

class TileStreamer {
public:
    // Sends one encoded Tiles payload; false when it could not be queued (the session then ends).
    using Send = std::function<bool(std::vector<uint8_t> &&payload, std::string *error)>;

    TileStreamer(VulkanContext &context, Send send);
    ~TileStreamer();
    TileStreamer(const TileStreamer &) = delete;
    TileStreamer &operator=(const TileStreamer &) = delete;

    void set_codec(TileCodec codec) { codec_ = codec; }
    // The swapped split's periphery quality and codec; frames with a periphery extent are encoded
    // with them.
    void set_periphery(PeripheryQuality quality, PeripheryCodec codec) {
        periphery_quality_ = quality;
        periphery_codec_ = codec;
    }

    struct Frame {
        uint64_t frame = 0;
        uint64_t swapchain_id = 0;
        uint32_t image_index = 0;
        VkImage image = VK_NULL_HANDLE; // left in `layout` by the frame's submits
        VkImageLayout layout = VK_IMAGE_LAYOUT_PRESENT_SRC_KHR;
        // The image as it is: what the read-back is sized by and checked against.
        VkFormat format = VK_FORMAT_UNDEFINED;
        VkExtent2D extent{};
        uint32_t layers = 1;
        std::vector<split::LayerFovea> foveae; // may be empty: an empty Tiles message
        // The swapped split: the scaled extent the image is sent at; foveae are then ignored
        // (present() fills them with the periphery's parts). {0, 0}: the foveae.
        VkExtent2D periphery{};
        // The swapped split's periphery was drawn scaled into the image's top-left `periphery`
        // (periphery_scaling.h): read back in place. Otherwise the full-size picture is downsampled.
        bool periphery_in_place = false;
        tiles::TileQuality quality; // what present() chose for this frame's tiles
        // The swapped split: the codec present() chose for the periphery; unset: the session's.
        std::optional<TileCodec> periphery_codec;
        uint32_t texel_bytes = 0; // present(): tile_texel_bytes(format) of a frame it reads back
        bool invalid = false;     // limit_guard.h, or unreadable: sent as kTilesInvalid, no tiles
        std::chrono::steady_clock::time_point first_submit{}; // of the frame: draw time without timestamps
        std::chrono::steady_clock::time_point present{};      // FramePresent received
    };

    // Replay thread, before the first submit of a frame: submits a timestamp the frame's draw time
    // starts at (the end is written ahead of the fovea copy in present()). The draw time in Tiles is
    // then GPU time: from the GPU starting the frame's first submit to finishing its last.
    void frame_started();

    // Replay thread: submits the frame's fovea copy and hands it to the worker. False with one line
    // in `error` when the copy cannot be submitted, or the worker has failed.
    bool present(Frame frame, std::string *error);

private:
    static constexpr size_t kSlots = 3;
    // Timestamp pairs (begin, end) of frames, used in turn: more than the frames the replay thread
    // can be ahead of the worker that reads them (kSlots and the one being replayed).
    static constexpr uint32_t kTimedFrames = 8;

    struct TimedFrame {
        VkCommandBuffer begin = VK_NULL_HANDLE; // resets the pair, writes the first timestamp
        VkCommandBuffer end = VK_NULL_HANDLE;   // the second after the frame's work; both to stamps_
    };

    struct Slot {
        VkCommandBuffer command_buffer = VK_NULL_HANDLE;
        VkFence drawn = VK_NULL_HANDLE;  // the frame's own work is done
        VkFence copied = VK_NULL_HANDLE; // the fovea copy is in host memory
        HostBuffer staging;
        TransferImage scaled; // the swapped split's downsampled image
        bool busy = false;    // owned by the worker until it has sent the frame
        Frame frame;
        int32_t timed = -1; // the frame's timestamp pair, -1 without one
    };

    // One eye's stream: encoders are stateful, so an eye keeps its encoder while its size and the
    // codec stay the same.
    struct EyeStream {
        uint32_t width = 0, height = 0, texel_bytes = 4;
        TileCodec codec = TileCodec::X264;
        tiles::TileQuality quality;
        std::unique_ptr<tiles::TileEncoder> encoder;
    };

    bool ensure_pool(std::string *error);
    bool create_slot(Slot &slot, std::string *error);
    bool ensure_buffer(Slot &slot, VkDeviceSize bytes, std::string *error);
    void destroy_slot(Slot &slot);
    void record_copy(Slot &slot);
    // The swapped split: the scaled image, the filter and the parts of a periphery frame. False with
    // one line in `error` when its format cannot be blitted; *skip when its tiles are not 4 bytes a
    // texel (sent as an empty Tiles, said once).
    bool prepare_periphery(Slot &slot, Frame &frame, bool *skip, std::string *error);
    // Empties a frame whose image cannot be read back as asked (its format, or a fovea outside the
    // image) and marks it invalid, with one line the first time. Returns whether it was readable.
    bool check_readable(Frame &frame);
    // The codec of a stream of `texel_bytes` texels: the session's, or zstd for 8-byte texels where
    // the session's is x264 (said once).
    TileCodec stream_codec(const Frame &frame);
    void run_worker();
    bool encode_and_send(Slot &slot, std::string *error);
    bool wait_fence(VkFence fence);
    bool create_timing(); // false: no timestamps on this queue, the draw time stays wall time
    uint32_t timed_draw_us(uint32_t pair);

    VulkanContext &context_;
    Send send_;
    TileCodec codec_ = TileCodec::X264;
    PeripheryQuality periphery_quality_;
    PeripheryCodec periphery_codec_ = PeripheryCodec::H264;
    VkFilter periphery_filter_ = VK_FILTER_LINEAR;
    VkFormat periphery_format_ = VK_FORMAT_UNDEFINED; // the one periphery_filter_ is for
    bool lossless_format_logged_ = false;
    bool unsupported_format_logged_ = false;
    bool unreadable_logged_ = false; // check_readable()
    bool wide_codec_logged_ = false; // stream_codec(), worker thread
    VkCommandPool pool_ = VK_NULL_HANDLE;
    std::array<Slot, kSlots> slots_{};
    size_t next_slot_ = 0;
    std::vector<EyeStream> eyes_; // worker thread only

    // GPU draw time (frame_started()); made at the first frame, replay thread.
    bool timing_tried_ = false;
    VkQueryPool queries_ = VK_NULL_HANDLE;
    HostBuffer stamps_; // each pair's two timestamps, copied there by the pair's `end`
    double timestamp_period_ns_ = 0;
    uint64_t timestamp_mask_ = 0;
    std::array<TimedFrame, kTimedFrames> timed_{};
    uint32_t next_timed_ = 0;
    int32_t started_ = -1; // frame_started()'s pair, for the next present()

    std::mutex mutex_;
    std::condition_variable changed_;
    std::deque<Slot *> queue_; // handed to the worker, in frame order
    std::optional<std::string> worker_error_;
    bool stopping_ = false;
    std::thread worker_;
};

} // namespace splitvk::agent
