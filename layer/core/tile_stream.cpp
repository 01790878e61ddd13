#include "core/tile_stream.h"

#include "log.h"
#include "wire.h"

#include <algorithm>

namespace splitvk {

using Clock = std::chrono::steady_clock;

namespace {

// A tile is at most a whole 16384² image; the wire cap on a message is lower still.
constexpr uint32_t kMaxTileBytes = protocol::kDefaultMaxPayload;
// Frames kept while nobody takes them (an app that stopped presenting, or a flood of late ones).
constexpr size_t kMaxKeptFrames = 8;

} // namespace

TileStream::TileStream(UploadPool &uploads, std::string agent,
                       std::function<void(const std::string &)> on_error)
    : uploads_(uploads), agent_(std::move(agent)), on_error_(std::move(on_error)) {}

TileStream::~TileStream() {
    stop();
}

void TileStream::stop() {
    {
        std::lock_guard lock(mutex_);
        stopping_ = true;
    }
    changed_.notify_all();
    for (auto &eye : eyes_)
        if (eye->thread.joinable()) eye->thread.join();
    std::lock_guard lock(mutex_);
    frames_.clear();
    for (auto &eye : eyes_)
        eye->jobs.clear();
}

void TileStream::abandon() {
    {
        std::lock_guard lock(mutex_);
        stopping_ = true;
    }
    changed_.notify_all();
}

bool TileStream::accept(std::vector<uint8_t> &&payload, std::string *error) {
    auto decoded = protocol::decode_tiles(payload, kMaxTileBytes);
    if (!decoded) {
        *error = decoded.error();
        return false;
    }
    auto pending = std::make_shared<Pending>();
    pending->frame = std::make_shared<FrameTiles>();
    FrameTiles &frame = *pending->frame;
    frame.agent_address = agent_;
    frame.frame = decoded->frame;
    frame.swapchain_id = decoded->swapchain_id;
    frame.image_index = decoded->image_index;
    frame.agent = decoded->timings;
    frame.invalid = (decoded->flags & protocol::kTilesInvalid) != 0;
    frame.bytes = payload.size();
    frame.received = Clock::now();
    frame.tiles.resize(decoded->tiles.size());
    for (size_t i = 0; i < decoded->tiles.size(); ++i) {
        const auto &t = decoded->tiles[i];
        frame.tiles[i].rect = {{static_cast<int32_t>(t.x), static_cast<int32_t>(t.y)}, {t.width, t.height}};
        frame.tiles[i].layer = t.array_layer;
        // decode_tiles refuses a message that mixes periphery and fovea tiles.
        if (t.flags & protocol::kTilePeriphery) {
            frame.periphery = true;
            frame.periphery_extent.width = std::max(frame.periphery_extent.width, t.x + t.width);
            frame.periphery_extent.height = std::max(frame.periphery_extent.height, t.y + t.height);
        }
    }
    pending->remaining = decoded->tiles.size();
    pending->encoded = std::move(decoded->tiles);

    {
        std::lock_guard lock(mutex_);
        if (stopping_) return true;
        // A frame its present gave up on is still decoded (its eyes' next frames reference it),
        // but nobody will take it.
        if (frame.frame >= oldest_wanted_) frames_[frame.frame] = pending;
        while (frames_.size() > kMaxKeptFrames)
            frames_.erase(frames_.begin());
        // Tile i of every frame is eye i's stream: the same decoder thread, in arrival order.
        for (size_t i = 0; i < pending->encoded.size(); ++i) {
            if (i == eyes_.size()) {
                eyes_.push_back(std::make_unique<EyeDecoder>());
                eyes_.back()->thread = std::thread([this, i] { run_eye(i); });
            }
            eyes_[i]->jobs.push_back({pending, i});
        }
    }
    changed_.notify_all();
    return true;
}

void TileStream::run_eye(size_t index) {
    EyeDecoder *eye = nullptr;
    {
        std::lock_guard lock(mutex_);
        eye = eyes_[index].get(); // the vector may grow, the EyeDecoder does not move
    }
    for (;;) {
        EyeJob job;
        {
            std::unique_lock lock(mutex_);
            changed_.wait(lock, [&] { return stopping_ || !eye->jobs.empty(); });
            if (stopping_) return;
            job = std::move(eye->jobs.front());
            eye->jobs.pop_front();
        }
        decode_tile(*eye, job);
    }
}

void TileStream::decode_tile(EyeDecoder &eye, const EyeJob &job) {
    const protocol::EncodedTile &encoded = job.pending->encoded[job.tile];
    DecodedTile &out = job.pending->frame->tiles[job.tile];
    const auto start = Clock::now();
    std::string error;
    bool ok = true;
    // Only a periphery part may be lossy (the agent's downsampled periphery): a fovea tile must come
    // bit-exact, so its decoder refuses lossy data.
    const bool accept_lossy = (encoded.flags & protocol::kTilePeriphery) != 0;
    // The decoder and the memory are sized by what the tile says of itself; the compositor then
    // copies it only into an image whose texels are that size.
    const uint32_t texel_bytes = tiles::peek_texel_bytes(encoded.data);
    if (texel_bytes == 0) {
        error = "a tile with a malformed header";
        ok = false;
        eye.decoder.reset();
    } else if (!eye.decoder || eye.width != encoded.width || eye.height != encoded.height ||
               eye.texel_bytes != texel_bytes || eye.codec != encoded.codec ||
               eye.accept_lossy != accept_lossy) {
        eye.width = encoded.width;
        eye.height = encoded.height;
        eye.texel_bytes = texel_bytes;
        eye.codec = encoded.codec;
        eye.accept_lossy = accept_lossy;
        eye.decoder = tiles::make_tile_decoder(encoded.codec, encoded.width, encoded.height, texel_bytes,
                                               &error, accept_lossy);
        ok = eye.decoder != nullptr;
    }
    std::shared_ptr<const HostBuffer> upload;
    if (ok) {
        upload = uploads_.take(VkDeviceSize{encoded.width} * encoded.height * texel_bytes, &error);
        ok = upload != nullptr;
        // Without memory to decode into, the stream's reference is lost: restart it too.
        if (!ok) {
            error = "no upload memory for the tile: " + error;
            eye.decoder.reset();
        }
    }
    if (ok) {
        ok = eye.decoder->decode(encoded.data, upload->mapped, &error);
        // A stream that failed is restarted at the agent's next keyframe.
        if (!ok) eye.decoder.reset();
    }
    if (ok) {
        // Host writes before the composite's vkQueueSubmit are visible to its copy once flushed.
        uploads_.flush(*upload);
        out.upload = std::move(upload);
        out.texel_bytes = texel_bytes;
        // One line per session says what the periphery is and what decodes it (the hardware
        // decoder, or software and why).
        if (accept_lossy && !periphery_described_.exchange(true))
            SPLITVK_INFO("periphery: %s", eye.decoder->description().c_str());
    }
    const auto took = Clock::now() - start;

    bool complete = false;
    {
        std::lock_guard lock(mutex_);
        Pending &pending = *job.pending;
        pending.slowest = std::max(pending.slowest, took);
        if (!ok) pending.frame->failed = true;
        complete = --pending.remaining == 0;
        if (complete) {
            pending.frame->decode = pending.slowest;
            pending.encoded.clear(); // the encoded bytes are not needed any more
        }
    }
    if (!ok)
        on_error_("frame " + std::to_string(job.pending->frame->frame) + ", eye " + std::to_string(job.tile) +
                  ": " + error);
    if (complete) changed_.notify_all();
}

bool TileStream::wait_ready(uint64_t frame, Clock::time_point deadline) {
    std::unique_lock lock(mutex_);
    return changed_.wait_until(lock, deadline, [&] {
        if (stopping_) return true;
        const auto it = frames_.find(frame);
        return it != frames_.end() && it->second->remaining == 0;
    });
}

std::shared_ptr<const FrameTiles> TileStream::take(uint64_t frame, Clock::time_point deadline) {
    std::unique_lock lock(mutex_);
    oldest_wanted_ = std::max(oldest_wanted_, frame);
    // Older frames were given up on by their presents; their decoders keep them alive while needed.
    frames_.erase(frames_.begin(), frames_.lower_bound(frame));
    auto ready = [&] {
        if (stopping_) return true;
        const auto it = frames_.find(frame);
        return it != frames_.end() && it->second->remaining == 0;
    };
    const bool arrived = changed_.wait_until(lock, deadline, ready) && !stopping_;
    oldest_wanted_ = frame + 1;
    if (!arrived) return nullptr;
    const auto it = frames_.find(frame);
    std::shared_ptr<FrameTiles> tiles = it->second->frame;
    frames_.erase(it);
    if (tiles->failed) return nullptr;
    return tiles;
}

} // namespace splitvk
