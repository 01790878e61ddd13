#pragma once

// The client's half of the tile path (docs/architecture.md §2 and §5): Tiles messages from the agent are
// decoded on the layer's own threads, one per eye, so that eyes decode in parallel and each eye's
// decoder (a stateful stream: P-frames reference that eye's previous frame) is used by one thread
// in order. vkQueuePresentKHR then takes its own frame's tiles (lockstep: frame N is composited
// with the tiles of frame N, never older ones), waiting at most SPLITVK_TILE_WAIT.
//
// Each tile is decoded straight into a buffer of the device's UploadPool (persistently mapped
// host-visible memory), which the composite copies the tile's rect from on the GPU: no copy on the
// CPU between the decoder and the GPU.
//
// Every Tiles message is decoded, also one that arrives after its present gave up on it: the next
// frame's P-frames reference it. Frames older than the one a present asked for are dropped.
//
// The swapped split (SPLITVK_CLIENT_RENDERS=fovea): a Tiles message holds the parts of the agent's
// downsampled periphery instead (kTilePeriphery), decoded alike, part i by thread i; only their
// decoders accept lossy data. The first decoded part is logged (info): the stream's codec, profile and
// chroma, and whether a hardware decoder (VA-API, NVDEC) or software decodes it.

#include "core/host_buffer.h"
#include "metadata.h" // Tiles, AgentTimings
#include "tile_codec.h"

#include <vulkan/vulkan.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace splitvk {

struct DecodedTile {
    VkRect2D rect{};
    uint32_t layer = 0; // the image's array layer (a layered OpenXR eye image)
    // rect.extent.width * height * texel_bytes bytes from offset 0, rows packed, written by the host
    // and flushed; the pool's again once every holder has let go.
    std::shared_ptr<const HostBuffer> upload;
    // What the tile's header declared and it decoded to (4 or 8): the compositor copies a tile only
    // into an image of that texel size (tile_format.h).
    uint32_t texel_bytes = 4;
};

// One frame's tiles as decoded, with what the statistics need.
struct FrameTiles {
    uint64_t frame = 0;
    uint64_t swapchain_id = 0;
    uint32_t image_index = 0;
    std::vector<DecodedTile> tiles;
    protocol::AgentTimings agent;
    uint64_t bytes = 0;                             // the Tiles payload as received
    std::chrono::steady_clock::time_point received; // the whole message was read
    std::chrono::steady_clock::duration decode{};   // the slowest eye
    bool failed = false;                            // a tile did not decode (logged)
    bool invalid = false; // the agent could not render this frame correctly (kTilesInvalid)
    // The swapped split: the tiles are the parts of the agent's downsampled periphery
    // (kTilePeriphery; their rects in the scaled image, decoded accepting lossy data), and
    // `periphery_extent` the scaled image they cover (the parts' bounding box).
    bool periphery = false;
    VkExtent2D periphery_extent{};
    std::string agent_address; // the agent that sent them ("host:port"): SPLITVK_STATS' agent column
};

class TileStream {
public:
    // `on_error` is called (on a decoder thread) with one line when the agent sent something that
    // cannot be decoded; the session then stops splitting. `uploads` outlives the stream. `agent`
    // names the agent whose tiles these are, in every frame's FrameTiles.
    TileStream(UploadPool &uploads, std::string agent, std::function<void(const std::string &)> on_error);
    ~TileStream();
    TileStream(const TileStream &) = delete;
    TileStream &operator=(const TileStream &) = delete;

    // The session's receive thread: one Tiles payload. False (nothing queued) when it is malformed.
    bool accept(std::vector<uint8_t> &&payload, std::string *error);

    // vkQueuePresentKHR: frame `frame`'s decoded tiles, waiting until `deadline`. nullptr when they
    // are late, and then also when they failed to decode. Drops every older frame.
    std::shared_ptr<const FrameTiles> take(uint64_t frame, std::chrono::steady_clock::time_point deadline);

    // Whether frame `frame`'s tiles are all decoded, waiting until `deadline`; unlike take() it
    // gives up on nothing, so a present can wait in slices and look at other things in between.
    bool wait_ready(uint64_t frame, std::chrono::steady_clock::time_point deadline);

    // Stops the decoder threads (also makes take() return at once) and lets go of every frame it
    // holds, so that their upload buffers go back to the pool.
    void stop();
    // The agent went away: take() returns at once from now on. Callable from any thread, also a
    // decoder's own (it joins nothing).
    void abandon();

private:
    struct Pending {
        std::shared_ptr<FrameTiles> frame;
        size_t remaining = 0; // tiles not decoded yet
        std::vector<protocol::EncodedTile> encoded;
        std::chrono::steady_clock::duration slowest{};
    };
    struct EyeJob {
        std::shared_ptr<Pending> pending;
        size_t tile = 0;
    };
    struct EyeDecoder {
        std::thread thread;
        std::deque<EyeJob> jobs; // under mutex_
        // Decoder thread only.
        uint32_t width = 0, height = 0, texel_bytes = 4;
        TileCodec codec = TileCodec::X264;
        bool accept_lossy = false; // a periphery part's decoder; a fovea's never accepts lossy tiles
        std::unique_ptr<tiles::TileDecoder> decoder;
    };

    void run_eye(size_t eye);
    void decode_tile(EyeDecoder &eye, const EyeJob &job);

    UploadPool &uploads_;
    const std::string agent_;
    std::function<void(const std::string &)> on_error_;
    std::mutex mutex_;
    std::condition_variable changed_;
    bool stopping_ = false;
    std::vector<std::unique_ptr<EyeDecoder>> eyes_;
    std::map<uint64_t, std::shared_ptr<Pending>> frames_; // by frame number, complete or not
    uint64_t oldest_wanted_ = 0;                          // frames before this are dropped on arrival
    std::atomic<bool> periphery_described_{false};        // the periphery's decoder was logged
};

} // namespace splitvk
