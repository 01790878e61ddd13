#pragma once

// One replication session per VkDevice (docs/architecture.md §2-3): the connections to splitvk-agent
// (SPLITVK_AGENTS of them, one per eye with 2: Session::Agent) and the device's global command stream.
//
// Opened at vkCreateDevice, with or without an agent (only invalid settings leave a device with no
// Session at all, so that every hook costs one pointer check). The session captures into the
// live-state log whether or not an agent is connected; live() says whether one is, and only then
// is anything sent. Without an agent the device runs unsplit (one line) until one answers; once an
// agent has accepted the split, the device splits for the rest of its life.
//
// Reconnection (docs/architecture.md §3, the live-state log). A thread of the session's connects with backoff
// whenever no agent is connected: at vkCreateDevice if none answered (late join), or after the agent went
// away (one line). A new agent is brought in at the next vkQueuePresentKHR, on the app's thread, which owns
// the present queue for the duration of the call: resync() waits for the queue, reads back the contents of
// every live buffer and image (resource.h), and sends the split settings and the live-state snapshot
// (objects, contents, descriptors, command buffers) before anything else. A Reject for a bad token or version
// ends the retries (one line): the device stays unsplit.
//
// Ordering. Everything the layer sends for a device goes through this object under one mutex:
// device-level calls are encoded into a pending batch of the global stream (record()), and every
// other message (a command buffer's stream, MemoryData, a submit, frame marks) first flushes that
// batch. Since encoding and enqueueing happen under the same lock, the agent sees messages in the
// order the calls returned, across threads.
//
// Live-state log (live_state_log.h): the session keeps it and changes it under the mutex above,
// in the same critical section as it encodes the call, so that the log's order is the stream's.

#include "capture/live_state_log.h"
#include "core/agent_candidates.h"
#include "core/agent_link.h"
#include "core/physical_device.h"
#include "core/tile_stream.h"
#include "metadata.h" // the metadata messages
#include "model/fovea_size.h"
#include "model/frame_difference.h"
#include "model/split_payoff.h"
#include "model/stats.h"
#include "transport.h"
#include "vk_codec.h"

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <thread>
#include <unordered_map>
#include <unordered_set>
#include <vector>

namespace splitvk {

struct DeviceState;

// What the codec reports while encoding: an extension structure it cannot forward is logged
// once per structure type (docs/architecture.md §3: "logs once when an app uses something it cannot
// forward").
class CaptureHooks : public codec::EncodeHooks {
public:
    // The device whose descriptor sets has_immutable_samplers() looks at; set before any encoding.
    void bind(const DeviceState &device) { device_ = &device; }
    void skipped_structure(VkStructureType stype, const char *parent) override;
    void chain_truncated(const char *parent) override;
    bool has_immutable_samplers(VkDescriptorSet set, uint32_t binding) override;

private:
    const DeviceState *device_ = nullptr;
    std::mutex mutex_;
    std::unordered_map<uint32_t, bool> seen_;
    bool truncation_logged_ = false;
};

class Session {
public:
    // One agent the session replicates to. SPLITVK_AGENTS of them, one per eye with 2: each replays
    // the whole stream and sends the foveae protocol::FoveaAgents gives its index (docs/architecture.md
    // §6). Each has its own connection, tiles and reconnection, so that an agent that goes away or is
    // late costs only its own eye. Owned by the session for its life; the lock that guards a field is
    // named beside it.
    struct Agent {
        explicit Agent(uint32_t place) : index(place) {}
        const uint32_t index;
        std::atomic<bool> live{false};
        std::atomic<bool> failure_logged{false};
        // The connection whose closure means this agent went away: a late report from one that failed
        // its handshake or was replaced is ignored.
        std::atomic<protocol::Connection *> current_connection{nullptr};
        // Under mutex_; shared with a sender waiting for room in its queue (wait_for_room) outside it.
        std::shared_ptr<protocol::Connection> connection;
        std::unique_ptr<TileStream> tiles; // split mode: this agent's decoded tiles
        std::atomic<bool> stop_receiver{false};
        std::thread receiver;
        // Under label_mutex_: agent_label(), the agent that went away until another is adopted, and when.
        std::string address;
        std::string went_away;
        std::chrono::steady_clock::time_point went_away_at{};
        // Under reconnect_mutex_: what the reconnector found for this place, and when.
        std::optional<AgentLink> pending;
        std::chrono::steady_clock::time_point reconnected_at{};
        std::string pending_in_place_of;                         // went_away then
        std::chrono::steady_clock::time_point pending_loss_at{}; // went_away_at then
        // The swapped split refused a reconnecting agent that cannot render the periphery: said once
        // until an agent is brought in.
        bool swapped_refusal_logged = false;
        std::atomic<bool> resync_pending{false};
        // The first frame whose submits this agent replays, and when it answered: set by resync() on the
        // app's thread before any present that reads them (present thread).
        std::atomic<uint64_t> first_replayed_frame{0};
        std::chrono::steady_clock::time_point joined_agent_answered{};
        // The agent the joined one replaced (empty for a late join: none went away) and when that one
        // went away: the failover time is from then.
        std::string joined_in_place_of;
        std::chrono::steady_clock::time_point joined_after_loss_at{};
        // True once per resync: for the first frame composited with the joined agent's tiles.
        std::atomic<bool> awaiting_first_tiles{false};
        // True for the first split frame an agent replays after it (re)joined: it may wait longer.
        std::atomic<bool> first_split_frame_pending{true};
    };

    // Logs the encoded vkCreateDevice and connects; without an agent (one warning line) it keeps
    // trying in the background. nullptr only when the settings are invalid.
    static std::unique_ptr<Session> open(const DeviceState &device, const VkDeviceCreateInfo *create_info,
                                         const std::string &application_name);
    ~Session();

    // Whether any agent is connected: then every call is sent, to each agent that is.
    bool live() const {
        for (const auto &agent : agents_)
            if (agent->live.load(std::memory_order_relaxed)) return true;
        return false;
    }
    // The agents, SPLITVK_AGENTS of them, whichever are connected (Agent::live); and which foveae
    // agent `index` sends.
    std::span<const std::unique_ptr<Agent>> agents() const { return agents_; }
    protocol::FoveaAgents fovea_agents(uint32_t index) const {
        return {index, static_cast<uint32_t>(agents_.size())};
    }
    bool verify() const { return verify_; }
    // The device renders split: split passes are scaled and presents composite. Set when
    // an agent first accepts the split and kept for the session's life, also while no agent is
    // connected (the centre then comes from the periphery), so command buffers recorded scaled are
    // always composited.
    bool splitting() const { return splitting_.load(std::memory_order_relaxed); }
    // The swapped split (SPLITVK_CLIENT_RENDERS=fovea): Fovea once the first agent that
    // accepted the split granted kSwappedSplit, for the session's life; Periphery otherwise.
    ClientRenders client_renders() const { return client_renders_.load(std::memory_order_relaxed); }
    // The client cuts its passes to the foveae and leaves the periphery to the agent: the swapped
    // split, while an agent is live to render that periphery.
    bool cutting() const { return client_renders() == ClientRenders::Fovea && live(); }
    const Settings &settings() const { return settings_; }
    // Per-frame statistics.
    FrameStats &stats() { return *stats_; }
    // Whether frames are recorded: SPLITVK_STATS names a file (from the start, so that frames unsplit
    // or without an agent have rows too), or an agent has split or verified (the summary alone).
    bool has_stats() const { return stats_ != nullptr; }
    // SPLITVK_STATS: when the application's acquires returned (FrameRecord::frame_latency_ms).
    AcquireTimes &acquire_times() { return acquire_times_; }
    // SPLITVK_FOVEA=auto: the size of every frame's foveae (fovea_size.h); nullptr otherwise.
    AutoFovea *auto_fovea() { return auto_fovea_.get(); }
    // SPLITVK_FOVEA=auto: the size the frame being presented takes, and whether the sizing hears its
    // times, with the frame time it hears them against. A window's present takes the current size
    // and is heard against `frame_ms`. Every eye image of one OpenXR frame (`xr_frame` >= 0) takes the
    // size its first image took, so that both eyes of a frame match, and only that first image is
    // heard, against the time since the previous frame's first image: a swapchain per eye would
    // otherwise count each frame twice, once with the short gap between its eyes.
    struct FrameSizing {
        split::FrameFoveaSize size; // unset without auto
        bool heard = false;
        double frame_ms = 0;
    };
    FrameSizing size_frame(int64_t xr_frame, double frame_ms);
    // Milliseconds since the previous call (0 the first time): present-to-present frame time.
    double frame_interval_ms();

    // SPLITVK_SPLIT=auto, the default, where the split does not pay (split_payoff.h): the device then creates
    // its targets and records its passes as if it did not split (split_recording(), split.h), and its frames
    // go to the screen as drawn, with no tiles asked for. A switch either way is asked for by answering the
    // application's present with VK_ERROR_OUT_OF_DATE_KHR (take_payoff_out_of_date()), and takes effect when
    // it recreates its swapchain (swapchain_recreated()): its targets are made again, and its command buffers
    // recorded, for the new mode.
    bool passing_through() const { return passing_through_.load(std::memory_order_relaxed); }
    // Whether the application's presents are timed for it (observe_payoff()).
    bool judges_payoff() const { return payoff_ != nullptr; }
    // A window's present on the application's thread (not an OpenXR eye image: a runtime's swapchain
    // is never recreated on request), with its time since the previous one.
    // `fovea_size`: the size the present's frame asked for.
    void observe_payoff(const DeviceState &device, double frame_ms, const split::FrameFoveaSize &fovea_size);
    // vkCreateSwapchainKHR: a switch asked for takes effect.
    //
    // While frames pass through by verdict (not while passing through is only being measured), the
    // agent is let go (a Goodbye, the connection closed): the device runs exactly as it does with no
    // agent, capturing into the live-state log and sending nothing, so that a frame passed through
    // costs what a frame without an agent does, and the agent serves nobody for nothing. A probe of the
    // split calls the agent back first (the reconnector, then resync() with the live-state snapshot at
    // a present) and asks the application to switch only once the agent is in; until then frames pass
    // through, and an agent that does not answer keeps them so.
    void swapchain_recreated();
    // A switch was asked for since the last call: the application's present answers
    // VK_ERROR_OUT_OF_DATE_KHR. True once per switch.
    bool take_payoff_out_of_date() { return payoff_out_of_date_.exchange(false); }
    codec::EncodeHooks *hooks() { return &hooks_; }
    uint64_t device_id() const { return device_id_; }

    // Encodes one device-level call into the global stream (`encode(Encoder&)`), in call order.
    // Logged whether or not an agent is connected; sent only when one is.
    template <class F>
    void record(LiveChange change, uint64_t id, F &&encode) {
        std::lock_guard lock(mutex_);
        const size_t start = encoder_.size();
        encode(encoder_);
        log_.note_change(change, id, encoder_.data().subspan(start));
        after_record_locked();
    }

    // As record(), for a call that makes one log entry held by every id in `holders` (dropped
    // when the last of them is forgotten) and dropped at once when any of `killers` is.
    template <class F>
    void record_logged(std::span<const uint64_t> holders, std::span<const uint64_t> killers, F &&encode) {
        std::lock_guard lock(mutex_);
        const size_t start = encoder_.size();
        encode(encoder_);
        const auto bytes = encoder_.data().subspan(start);
        log_.add(std::vector<uint8_t>(bytes.begin(), bytes.end()), holders, killers);
        after_record_locked();
    }

    // Objects gone without a call of their own (freed command buffers and descriptor sets, a
    // pool's children at its destroy or reset): they let go of their log entries.
    void forget(std::span<const uint64_t> ids);

    // The object part of the live-state log, in creation order (one payload), and the ids that
    // are live in it (what descriptor contents and streams may name).
    std::vector<LiveMessage> object_log(size_t *entries, std::unordered_set<uint64_t> *live_ids);

    // send_metadata() for a message that is also a log entry held by `holder` (SwapchainImages).
    // With `killers` (as record_logged()), the entry is one more of an object that holds entries
    // already (a linear image's ImageLayouts, after its vkCreateImage), not a new object.
    void send_metadata_logged(protocol::MessageType type, std::vector<uint8_t> &&payload, uint64_t holder,
                              std::span<const uint64_t> killers = {});

    // Sends the pending global batch, then `payload` as one Commands message.
    void send_commands(std::span<const uint8_t> payload);
    // Sends the pending global batch, then one metadata message.
    void send_metadata(protocol::MessageType type, std::vector<uint8_t> &&payload);
    // Sends the pending global batch.
    void flush();
    // Sends the pending global batch, then `message` to every connected agent, each told to send no
    // tiles for a frame before the first whose submits it replays (kPresentNoTiles).
    void send_frame_present(protocol::FramePresent message);

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

    // The next VerifyFrame payload from the agent, waiting at most `timeout` (0: never blocks).
    std::optional<std::vector<uint8_t>> receive_verify_frame(std::chrono::milliseconds timeout);

    // vkDestroyDevice: sends what is pending, waits briefly for it to leave, and closes.
    void close();

    // Frame numbers: from 0 per device, in present order. FrameBegin names the frame the next
    // present will close; vkQueuePresentKHR takes it.
    uint64_t current_frame() const { return frame_.load(std::memory_order_relaxed); }
    uint64_t take_frame() { return frame_.fetch_add(1, std::memory_order_relaxed); }

    // Time the application's threads spent comparing mapped memory at submits (memory.cpp).
    std::atomic<uint64_t> memory_compare_ns{0};

    // SPLITVK_VERIFY=full: frames compared and pixels that differed where they must not (every
    // pixel, or the foveae of a frame with the swapped split's periphery; verification.cpp).
    std::atomic<uint64_t> verified_frames{0};
    std::atomic<uint64_t> verified_whole_frames{0}; // of those, every pixel of which must have matched
    std::atomic<uint64_t> mismatching_pixels{0};
    std::atomic<uint64_t> compared_pixels{0};    // every layer of each verified image, mismatching included
    std::atomic<uint32_t> largest_difference{0}; // of one colour channel, over every verified frame
    std::atomic<uint64_t> difference_sum{0};     // of every differing pixel's colour channels
    // The swapped split: every verified frame that showed the agent's periphery, against native.
    PeripheryScore periphery_score;

    // Split mode (present.cpp): frames composited, and those whose tiles came too late (or not at
    // all) and whose centre is the periphery's.
    std::atomic<uint64_t> composited_frames{0};
    std::atomic<uint64_t> late_frames{0};
    std::atomic<uint64_t> invalid_frames{0}; // the agent flagged them: its GPU could not honour them
    // Split mode (present.cpp): frames a live agent replays whose presented image a split pass drew,
    // and those it replays with none; the second with none of the first gets one warning.
    std::atomic<uint64_t> split_frames{0};
    std::atomic<uint64_t> unsplit_frames{0};
    std::atomic<bool> unsplit_warned{false};
    // Split mode (present.cpp): said once that most split frames come late.
    std::atomic<bool> late_warned{false};

    // Entries in the object part of the live-state log.
    size_t live_object_count();

    // The agent went away (one line): nothing is sent until a new one is brought in. In the swapped
    // split cutting() turns false with it, and the next present answers VK_ERROR_OUT_OF_DATE_KHR
    // once (take_forced_out_of_date()).
    void fail(Agent &agent, const std::string &reason);
    // An exception inside the layer (entry_boundary.h) left the capture stream or the layer's state
    // with a hole an agent would replay: the agent is dropped and none is brought in again, for the
    // session's life; its frames show what fallback() says. No line of its own (the boundary's says
    // it). True for the call that ended the replication, false after.
    bool abandon();
    // What the application gets once no agent serves the session, for log lines.
    const char *fallback() const;
    // The swapped split lost its agent since the last call: the application's next present answers
    // VK_ERROR_OUT_OF_DATE_KHR, so that an application that records its command buffers once (cut
    // to the foveae) recreates its swapchain and records them again, whole. True once per loss.
    bool take_forced_out_of_date() { return force_out_of_date_.exchange(false); }

    // A new agent has connected and waits for the snapshot: the next present calls resync().
    bool resync_pending() const {
        for (const auto &agent : agents_)
            if (agent->resync_pending.load(std::memory_order_acquire)) return true;
        return false;
    }
    // On the app's thread, inside vkQueuePresentKHR on `queue`: brings the new agent in (see the
    // top of this file). Frame `frame`'s own submits reached no agent, so it has no tiles.
    void resync(DeviceState &device, VkQueue queue, uint64_t frame);
    // The first frame whose submits some connected agent replays (Agent::first_replayed_frame).
    uint64_t first_replayed_frame() const;

private:
    Session() = default;
    static constexpr size_t kBatchLimit = size_t{1} << 20;

    void flush_locked();
    // After an encode into the global batch: sent in batches when an agent is connected, dropped
    // (it is in the log) when none is.
    void after_record_locked() {
        if (!live())
            (void)encoder_.take();
        else if (encoder_.size() >= kBatchLimit)
            flush_locked();
    }
    // Connects and handshakes with an agent of SPLITVK_SERVER's (agent_candidates.h), the device
    // envelope in the Hello; after the one in use went away, another if there is one. *final when
    // retrying cannot help.
    // For `agent`'s place: never an agent another place uses.
    protocol::Result<AgentLink> connect_agent(Agent &agent, bool *final);
    // The agent in use or last used in `agent`'s place (its label), or what SPLITVK_SERVER names before
    // any answered: what every line about the agent names. Any thread.
    std::string agent_label(const Agent &agent) const;
    // Every place's, joined by '+' (the session's lines).
    std::string agents_label() const;
    // Reports `link`'s closure to `agent` while it is that agent's connection.
    void watch_closure(Agent &agent, AgentLink &link);
    // Why the agent greeted at vkCreateInstance cannot serve this device's envelope; empty if it can.
    std::string early_link_mismatch(const AgentLink &link, const PhysicalDeviceState *physical) const;
    // Makes `link` the connection of `agent`'s place (under mutex_): receiver thread, tile stream, the
    // split's configuration.
    void adopt_locked(Agent &agent, AgentLink &&link);
    void stop_receiver(Agent &agent);
    void run_reconnect();
    // SPLITVK_SPLIT=auto's verdict to pass frames through: the agent is told goodbye and let go
    // (swapchain_recreated()). Never under payoff_mutex_: it flushes to the agent.
    void release_agent();
    // observe_payoff() under payoff_mutex_: what to do with the agent after it, in `release`/`recall`.
    void observe_payoff_locked(const DeviceState &device, double frame_ms,
                               const split::FrameFoveaSize &fovea_size, bool &release, bool &recall);
    // A probe of the split: the reconnector brings an agent in again.
    void recall_agent();
    // The agent's messages, on a thread of the layer's: Tiles to the decoders, VerifyFrame to
    // receive_verify_frame(), Goodbye ends the session.
    void run_receiver(Agent &agent);
    // To every connected agent.
    void send_locked(protocol::MessageType type, std::vector<uint8_t> &&payload);
    void send_locked(protocol::MessageType type, std::vector<uint8_t> &&payload,
                     std::chrono::milliseconds wait);
    // To `agent` alone: what only it needs (its split's configuration, its snapshot).
    void send_to_locked(Agent &agent, protocol::MessageType type, std::vector<uint8_t> &&payload,
                        std::chrono::milliseconds wait);
    // Waits, with no lock held, until the connection has room for `bytes` and the pending batch,
    // so that a large message waits for a slow link before it takes mutex_ rather than while it
    // holds it. False if the room did not come in time.
    bool wait_for_room(size_t bytes);
    // A snapshot, to `agent` alone: compressed on every core.
    void send_all_locked(Agent &agent, std::vector<LiveMessage> &&messages);
    void note_send_locked(Agent &agent, protocol::SendResult result);

    std::mutex mutex_;
    std::vector<std::unique_ptr<Agent>> agents_; // made by open(), SPLITVK_AGENTS of them
    std::atomic<bool> abandoned_{false};         // abandon()
    std::atomic<uint64_t> frame_{0};
    bool verify_ = false;
    std::atomic<bool> splitting_{false};
    std::atomic<ClientRenders> client_renders_{ClientRenders::Periphery};
    std::atomic<bool> force_out_of_date_{false}; // take_forced_out_of_date()
    Settings settings_;
    uint64_t device_id_ = 0;
    std::unique_ptr<AgentCandidates> candidates_;
    mutable std::mutex label_mutex_; // the agents' labels
    std::string client_name_;
    std::string client_gpu_name_;
    std::vector<uint8_t> envelope_wire_; // the device envelope the app was told, encoded; empty: unchecked
    CaptureHooks hooks_;
    codec::Encoder encoder_;
    LiveStateLog log_; // under mutex_, changed with each encode into encoder_

    std::unique_ptr<UploadPool> uploads_; // what the agents' tiles decode into; made by open()
    std::unique_ptr<FrameStats> stats_;
    AcquireTimes acquire_times_;
    std::unique_ptr<AutoFovea> auto_fovea_;
    std::atomic<bool> passing_through_{false}; // passing_through()
    std::atomic<bool> payoff_out_of_date_{false};
    std::mutex payoff_mutex_; // what follows: presents may come from several threads
    std::unique_ptr<SplitPayoff> payoff_;
    bool wanted_pass_through_ = false; // the switch asked for, until the application follows it
    uint32_t presents_since_switch_ = 0;
    split::FrameFoveaSize payoff_fovea_size_;   // the previous present's
    bool check_kept_targets_ = false;           // at the first present after switching to pass through
    bool release_when_passing_through_ = false; // the switch to pass through is a verdict: let the agent go
    bool switch_awaits_agent_ = false;          // a probe of the split, asked for once the agent is back
    std::mutex sizing_mutex_;                   // the OpenXR frame being sized, below
    int64_t sized_xr_frame_ = -1;
    split::FrameFoveaSize xr_frame_size_;
    std::chrono::steady_clock::time_point xr_frame_start_{};
    std::chrono::steady_clock::time_point last_present_{};
    std::mutex verify_mutex_;
    std::condition_variable verify_ready_;
    std::deque<std::vector<uint8_t>> verify_frames_;

    // Reconnection: the thread, what it found, and when.
    std::mutex reconnect_mutex_;
    std::condition_variable reconnect_wake_;
    bool closing_ = false; // under reconnect_mutex_
    // SPLITVK_SPLIT=auto let the agent go while frames pass through: the reconnector waits until a probe
    // of the split calls it back (recall_agent()). Under reconnect_mutex_.
    bool agent_released_ = false;
    bool connect_now_ = false;            // under reconnect_mutex_: called back, so no backoff
    std::atomic<bool> lost_agent_{false}; // fail() to the reconnector: dial at once, no backoff
    std::atomic<bool> recalled_{false};   // the next resync brings back an agent let go, as asked
    std::thread reconnector_;
};

// The live-state log of `device` as Commands payloads in replay order (session.h). Empty without
// a session.
LiveSnapshot build_live_snapshot(DeviceState &device);

// SPLITVK_LOG_LEVEL=debug: one line with the snapshot's size, after checking that it decodes in
// order with every id resolved (codec HandleTable, as a fresh agent would).
void log_live_state(DeviceState &device, const char *when);

} // namespace splitvk
