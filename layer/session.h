#pragma once

// One replication session per VkDevice (DESIGN §2-3, issue 3): the TCP connection to
// splitvk-agent and the device's global command stream.
//
// Opened at vkCreateDevice; when no agent answers, the layer logs one line and the device runs
// unsplit (no Session at all, so every hook costs one pointer check). When the agent goes away
// mid-run the session stops capturing (live() turns false, one line) and the layer passes
// through from then on.
//
// Ordering. Everything the layer sends for a device goes through this object under one mutex:
// device-level calls are encoded into a pending batch of the global stream (record()), and every
// other message (a command buffer's stream, MemoryData, a submit, frame marks) first flushes that
// batch. Since encoding and enqueueing happen under the same lock, the agent sees messages in the
// order the calls returned, across threads.
//
// Live-state log (DESIGN §3, replayed by the reliability issue): the encoded creation of every
// live object created by a single-handle vkCreate* (keyed by the client's id, dropped at its
// vkDestroy*/vkFree*), the last recorded stream of each command buffer (command_buffer.cpp), and
// the latest encoded update of each descriptor set written through a template. Bounded by the
// live objects themselves: nothing is kept for destroyed ones.

#include "../protocol/session.h" // the metadata messages (same file name as this one)
#include "transport.h"
#include "vk_codec.h"

#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <unordered_map>
#include <vector>

namespace splitvk {

struct DeviceState;

enum class LiveChange { Unchanged, Created, Destroyed };

// What the codec reports while encoding: an extension structure it cannot forward is logged
// once per structure type (DESIGN §3: "logs once when an app uses something it cannot forward").
class CaptureHooks : public codec::EncodeHooks {
public:
    void skipped_structure(VkStructureType stype, const char *parent) override;
    void chain_truncated(const char *parent) override;
    bool has_immutable_samplers(VkDescriptorSet set, uint32_t binding) override;

private:
    std::mutex mutex_;
    std::unordered_map<uint32_t, bool> seen_;
    bool truncation_logged_ = false;
};

class Session {
public:
    // Connects and handshakes, then sends the encoded vkCreateDevice. nullptr (after one warning
    // line) when there is no usable agent.
    static std::unique_ptr<Session> open(const DeviceState &device, const VkDeviceCreateInfo *create_info,
                                         const std::string &application_name);
    ~Session();

    bool live() const { return live_.load(std::memory_order_relaxed); }
    bool verify() const { return verify_; }
    codec::EncodeHooks *hooks() { return &hooks_; }
    uint64_t device_id() const { return device_id_; }

    // Encodes one device-level call into the global stream (`encode(Encoder&)`), in call order.
    template <class F>
    void record(LiveChange change, uint64_t id, F &&encode) {
        std::lock_guard lock(mutex_);
        if (!live()) return;
        const size_t start = encoder_.size();
        encode(encoder_);
        note_live_change(change, id, start);
        if (encoder_.size() >= kBatchLimit) flush_locked();
    }

    // Sends the pending global batch, then `payload` as one Commands message.
    void send_commands(std::span<const uint8_t> payload);
    // Sends the pending global batch, then one metadata message.
    void send_metadata(protocol::MessageType type, std::vector<uint8_t> &&payload);
    // Sends the pending global batch.
    void flush();

    // Under the session lock: encodes with a scratch encoder and sends as one Commands message
    // after the pending batch (submits: they must follow the MemoryData sent for them).
    template <class F>
    void send_encoded(F &&encode) {
        std::lock_guard lock(mutex_);
        if (!live()) return;
        flush_locked();
        codec::Encoder scratch;
        scratch.set_hooks(&hooks_);
        encode(scratch);
        send_locked(protocol::MessageType::Commands, scratch.take());
    }

    // Queue mode: the next message from the agent, if any (never blocks), or waits at most
    // `timeout` for one.
    std::optional<protocol::Message> receive(std::chrono::milliseconds timeout);

    // vkDestroyDevice: sends what is pending, waits briefly for it to leave, and closes.
    void close();

    // Frame numbers: from 0 per device, in present order. FrameBegin names the frame the next
    // present will close; vkQueuePresentKHR takes it.
    uint64_t current_frame() const { return frame_.load(std::memory_order_relaxed); }
    uint64_t take_frame() { return frame_.fetch_add(1, std::memory_order_relaxed); }

    // Time the application's threads spent comparing mapped memory at submits (memory.cpp).
    std::atomic<uint64_t> memory_compare_ns{0};

    // SPLITVK_VERIFY=full: frames compared and pixels that differed (present.cpp).
    std::atomic<uint64_t> verified_frames{0};
    std::atomic<uint64_t> mismatching_pixels{0};

    // Live-state log of command buffers' streams (command_buffer.cpp keeps the bytes).
    size_t live_object_count();

    // Stops capturing after a failure, with one line.
    void fail(const std::string &reason);

private:
    Session() = default;
    static constexpr size_t kBatchLimit = size_t{1} << 20;

    void flush_locked();
    void send_locked(protocol::MessageType type, std::vector<uint8_t> &&payload);
    void note_live_change(LiveChange change, uint64_t id, size_t start);

    std::mutex mutex_;
    std::atomic<bool> live_{false};
    std::atomic<bool> failure_logged_{false};
    std::atomic<uint64_t> frame_{0};
    bool verify_ = false;
    uint64_t device_id_ = 0;
    std::string address_;
    std::unique_ptr<protocol::Connection> connection_;
    CaptureHooks hooks_;
    codec::Encoder encoder_;
    std::unordered_map<uint64_t, std::vector<uint8_t>> live_objects_;
};

} // namespace splitvk
