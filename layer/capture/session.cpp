// The replication session of one VkDevice: connect, handshake, the global command stream.

#include "capture/session.h"

#include "capture/capture.h"
#include "capture/content_snapshot.h"
#include "capture/descriptor_set.h"
#include "capture/memory.h"
#include "capture/resource.h"
#include "core/device.h"
#include "core/image.h"
#include "core/instance.h"
#include "core/layer_settings.h"
#include "core/physical_device.h"
#include "core/queue.h"
#include "log.h"

#include <algorithm>
#include <chrono>
#include <utility>

namespace splitvk {
namespace {

using namespace std::chrono_literals;

// A full send queue (128 MiB) means the agent is not keeping up; wait this long, then give up.
constexpr auto kSendWait = 2000ms;
constexpr auto kCloseFlush = 500ms;

// The line for an agent that will not be used: it refused the session (its words start the
// error), or this side refused its certificate (TLS: the error says what changed).
void warn_refused(const std::string &address, const std::string &error) {
    if (error.starts_with("server rejected the session"))
        SPLITVK_WARN("splitvk-agent at %s refused the session (%s); running unsplit", address.c_str(),
                     error.c_str());
    else
        SPLITVK_WARN("splitvk-agent at %s is not trusted (%s); running unsplit", address.c_str(),
                     error.c_str());
}

} // namespace

void CaptureHooks::skipped_structure(VkStructureType stype, const char *parent) {
    // The loader's own chain links in vkCreateDevice's pNext are not the application's.
    if (stype == VK_STRUCTURE_TYPE_LOADER_INSTANCE_CREATE_INFO ||
        stype == VK_STRUCTURE_TYPE_LOADER_DEVICE_CREATE_INFO)
        return;
    std::lock_guard lock(mutex_);
    if (seen_.emplace(static_cast<uint32_t>(stype), true).second)
        SPLITVK_WARN(
            "cannot forward structure type %u in the pNext chain of %s; the agent replays without it",
            static_cast<unsigned>(stype), parent);
}

bool CaptureHooks::has_immutable_samplers(VkDescriptorSet set, uint32_t binding) {
    return device_ && set_binding_has_immutable_samplers(*device_, set, binding);
}

void CaptureHooks::chain_truncated(const char *parent) {
    std::lock_guard lock(mutex_);
    if (!truncation_logged_)
        SPLITVK_WARN("a pNext chain of %s is too long or loops; the agent gets it cut", parent);
    truncation_logged_ = true;
}

std::string Session::agent_label(const Agent &agent) const {
    std::lock_guard lock(label_mutex_);
    return agent.address;
}

std::string Session::agents_label() const {
    std::lock_guard lock(label_mutex_);
    std::string label;
    for (const auto &agent : agents_)
        label += (label.empty() ? "" : "+") + agent->address;
    return label;
}

uint64_t Session::first_replayed_frame() const {
    uint64_t first = UINT64_MAX;
    for (const auto &agent : agents_)
        if (agent->live.load(std::memory_order_relaxed))
            first = std::min(first, agent->first_replayed_frame.load(std::memory_order_relaxed));
    return first == UINT64_MAX ? 0 : first;
}

protocol::Result<AgentLink> Session::connect_agent(Agent &agent, bool *final) {
    protocol::Hello hello = base_hello(settings_, client_name_);
    hello.client_gpu_name = client_gpu_name_;
    hello.device_envelope = envelope_wire_;
    std::set<std::string> excluding, in_use;
    {
        std::lock_guard lock(label_mutex_);
        if (!agent.went_away.empty()) excluding.insert(agent.went_away);
        // Every other place's agent, connected or not yet adopted: an eye's agent is its own.
        for (const auto &other : agents_)
            if (other.get() != &agent && other->live.load()) in_use.insert(other->address);
    }
    {
        std::lock_guard lock(reconnect_mutex_);
        for (const auto &other : agents_)
            if (other.get() != &agent && other->pending) in_use.insert(other->pending->agent);
    }
    auto link = dial_agent(*candidates_, settings_, hello, excluding, EarlyAgent::kBrowseWait, final, in_use);
    if (link) watch_closure(agent, *link);
    return link;
}

std::string Session::early_link_mismatch(const AgentLink &link, const PhysicalDeviceState *physical) const {
    // The agent greeted at vkCreateInstance saw no envelope. When its GPU is part of the envelope
    // it honours it by construction; when it answered too late for that, check here what the
    // agent would have checked at a handshake.
    if (!physical || !physical->envelope || physical->agent_included || link.welcome.server_device.empty())
        return {};
    auto device = protocol::decode_device_description(link.welcome.server_device);
    if (!device) return {};
    const std::string why = protocol::refusal(*device, *physical->envelope);
    if (why.empty()) return {};
    return std::string(protocol::to_string(protocol::RejectReason::DeviceMismatch)) + ": " + why;
}

void Session::watch_closure(Agent &agent, AgentLink &link) {
    // A closure counts only for the connection in use: one that failed its handshake, or was
    // replaced, is not the session's business.
    link.on_closed->set([this, &agent, connection = link.connection.get()](const std::string &reason) {
        if (agent.current_connection.load() == connection) fail(agent, reason);
    });
}

void Session::adopt_locked(Agent &agent, AgentLink &&link) {
    stop_receiver(agent);
    // No connection's closure is the session's until the new one is published below: not the old
    // one's, closed here, nor the new one's before the session is ready for it.
    agent.current_connection.store(nullptr);
    if (agent.connection) agent.connection->close("replaced by a new connection");
    agent.connection = std::move(link.connection);
    if (!link.agent.empty()) {
        std::lock_guard lock(label_mutex_);
        agent.address = link.agent;
        agent.went_away.clear();
    }
    const std::string label = agent_label(agent);
    const uint64_t capabilities = link.welcome.capabilities;
    if (!(capabilities & protocol::capability::kZstdPayloads)) {
        protocol::CompressionPolicy policy;
        policy.enabled = false;
        agent.connection->set_compression(policy);
    }
    // SPLITVK_VERIFY takes one agent (the settings refuse it with more).
    verify_ = settings_.verify && (capabilities & protocol::capability::kVerifyFrames);
    if (settings_.verify && !verify_)
        SPLITVK_WARN("splitvk-agent at %s cannot verify frames; SPLITVK_VERIFY ignored", label.c_str());
    // Verification and the paper's split exclude each other (base_hello): an agent that cannot
    // render the periphery leaves a verifying client unsplit, comparing whole frames.
    const bool split = (capabilities & protocol::capability::kFoveaTiles) &&
                       (!verify_ || (capabilities & protocol::capability::kSwappedSplit));
    if (!split && verify_ && (capabilities & protocol::capability::kFoveaTiles) && !splitting())
        SPLITVK_WARN("splitvk-agent at %s cannot render the periphery (SPLITVK_CLIENT_RENDERS=fovea); "
                     "SPLITVK_VERIFY compares whole frames, unsplit",
                     label.c_str());
    // A verifying session has rows too (its frames unsplit, verification.h), so SPLITVK_STATS is
    // written whether the agent splits or verifies.
    if ((split || verify_) && !stats_) stats_ = std::make_unique<FrameStats>(settings_.stats_path);
    if (split) {
        // Which side renders what is decided by the first agent that accepts the split, and kept:
        // the client's screen-space targets are created for it (full size in the swapped split).
        if (!splitting_.exchange(true) && asks_swapped_split(settings_)) {
            if (capabilities & protocol::capability::kSwappedSplit) {
                client_renders_.store(ClientRenders::Fovea);
                stats_->set_client_renders_fovea(true);
            } else {
                SPLITVK_WARN(
                    "splitvk-agent at %s cannot render the periphery (SPLITVK_CLIENT_RENDERS=fovea); "
                    "the client renders it, and the agent the foveae",
                    label.c_str());
            }
        }
    }
    if (splitting()) {
        // A new agent's tiles are a new stream (its encoders start with an IDR): new decoders.
        if (agent.tiles) agent.tiles->stop();
        agent.tiles =
            std::make_unique<TileStream>(*uploads_, label, [this, &agent](const std::string &error) {
                fail(agent, "undecodable tiles from the agent: " + error);
            });
    }
    agent.failure_logged.store(false);
    agent.live.store(true);
    // Only now may the connection's closure reach fail(): before, it would race the tile stream
    // being replaced and the flags just set. A connection that closed meanwhile fails here.
    agent.current_connection.store(agent.connection.get());
    if (!agent.connection->is_open()) fail(agent, agent.connection->close_reason());
    if (splitting()) {
        protocol::SplitConfig config{settings_.eyes, settings_.fovea, settings_.codec, {}, {}, {}};
        // With SPLITVK_FOVEA=auto its width and height are the largest size a FramePresent may name,
        // which the agent's scissors then cover (`automatic` stays on this side).
        config.moving_gaze = settings_.gaze != GazeMode::Fixed;
        config.fovea_agents = fovea_agents(agent.index);
        if (capabilities & protocol::capability::kAgentScissor) {
            config.agent_scissor = settings_.agent_scissor;
        } else if (settings_.agent_scissor.guard) {
            SPLITVK_WARN("splitvk-agent at %s cannot scissor offscreen passes; SPLITVK_AGENT_SCISSOR ignored "
                         "(it replays them in full)",
                         label.c_str());
        }
        send_to_locked(agent, protocol::MessageType::SplitConfig, protocol::encode(config), kSendWait);
        // Right after SplitConfig, and only to an agent that granted the swapped split (a
        // reconnecting one without it was refused by run_reconnect()).
        if (client_renders() == ClientRenders::Fovea && (capabilities & protocol::capability::kSwappedSplit))
            send_to_locked(
                agent, protocol::MessageType::PeripheryConfig,
                protocol::encode(protocol::PeripheryConfig{settings_.scale, settings_.periphery_quality,
                                                           verify_, settings_.periphery_codec}),
                kSendWait);
    }
    agent.stop_receiver.store(false);
    agent.receiver = std::thread([this, &agent] { run_receiver(agent); });
    if (agents_.size() > 1)
        SPLITVK_INFO("replicating to splitvk-agent at %s for eye %u of %zu (%s, session %llu, %s)",
                     label.c_str(), agent.index + 1, agents_.size(), link.welcome.server_gpu_name.c_str(),
                     static_cast<unsigned long long>(link.welcome.session_id),
                     agent.connection->security().c_str());
    else
        SPLITVK_INFO("replicating to splitvk-agent at %s (%s, session %llu, %s)", label.c_str(),
                     link.welcome.server_gpu_name.c_str(),
                     static_cast<unsigned long long>(link.welcome.session_id),
                     agent.connection->security().c_str());
}

std::unique_ptr<Session> Session::open(const DeviceState &device, const VkDeviceCreateInfo *create_info,
                                       const std::string &application_name) {
    const LoadedSettings &loaded = layer_settings();
    if (!loaded.valid()) return nullptr;
    std::unique_ptr<Session> session(new Session());
    session->settings_ = loaded.settings;
    if (!loaded.settings.stats_path.empty())
        session->stats_ = std::make_unique<FrameStats>(loaded.settings.stats_path);
    if (loaded.settings.fovea.automatic)
        session->auto_fovea_ = std::make_unique<AutoFovea>(loaded.settings.fovea, loaded.settings.max_mbps);
    // A fixed fovea has no sizing to settle before the split's first measurement.
    if (loaded.settings.split == SplitMode::Auto)
        session->payoff_ =
            std::make_unique<SplitPayoff>(loaded.settings.fovea.automatic ? SplitPayoff::kFirstHold : 0);
    session->candidates_ = std::make_unique<AgentCandidates>(loaded.settings);
    for (uint32_t index = 0; index < loaded.settings.agents; ++index) {
        session->agents_.push_back(std::make_unique<Agent>(index));
        session->agents_.back()->address = session->candidates_->description();
    }
    Agent &first = *session->agents_.front();
    session->device_id_ = codec::handle_value(device.handle);
    session->uploads_ = std::make_unique<UploadPool>(device);
    session->hooks_.bind(device);
    session->encoder_.set_hooks(&session->hooks_);
    session->client_name_ = application_name;
    VkPhysicalDeviceProperties properties{};
    device.instance->dispatch.GetPhysicalDeviceProperties(device.physical_device, &properties);
    session->client_gpu_name_ = properties.deviceName;

    // The first log entry: the device itself, which an agent mirrors and registers the physical
    // device and device ids from. Logged before any agent is asked, so that every agent, the
    // first or a later one, gets it the same way: in the snapshot.
    VkDevice handle = device.handle;
    session->record(LiveChange::Created, session->device_id_, [&](codec::Encoder &e) {
        encode_vkCreateDevice(e, device.physical_device, create_info, nullptr, &handle);
    });

    // The application was told the envelope (physical_device.h); an agent must honour it.
    const PhysicalDeviceState *physical = physical_device_state(device.physical_device);
    if (physical) session->envelope_wire_ = physical->envelope_wire;

    // The instance greeted the agent already: take that connection if it is still open, so that
    // one application run is one session on the agent.
    bool final = false;
    protocol::Result<AgentLink> agent = protocol::Error{"no splitvk-agent answered"};
    EarlyAgent::Outcome early =
        device.instance->early_agent ? device.instance->early_agent->take() : EarlyAgent::Outcome{};
    if (early.link) {
        session->watch_closure(first, *early.link);
        if (!early.link->connection->is_open()) {
            agent = session->connect_agent(first, &final);
        } else if (const std::string why = session->early_link_mismatch(*early.link, physical);
                   !why.empty()) {
            early.link->connection->send(protocol::MessageType::Goodbye, protocol::encode_goodbye({why}));
            early.link->connection->flush(kCloseFlush);
            early.link->connection->close("device mismatch");
            agent = protocol::Error{"server rejected the session: " + why};
            final = true;
        } else {
            agent = std::move(*early.link);
        }
    } else if (early.refused) {
        agent = protocol::Error{early.error};
        final = true;
    } else {
        agent = session->connect_agent(first, &final);
    }
    // Each agent is given the log so far, alone: the first before the second is dialled, so
    // that the second is never the first's agent.
    const auto bring_in = [&session](Agent &place, AgentLink &&link) {
        std::lock_guard lock(session->mutex_);
        session->adopt_locked(place, std::move(link));
        size_t entries = 0;
        std::unordered_set<uint64_t> live_ids;
        for (auto &message : session->log_.messages(&entries, &live_ids))
            session->send_to_locked(place, message.type, std::move(message.payload), kSendWait);
    };
    if (agent) {
        bring_in(first, std::move(agent).value());
    } else if (final) {
        // An agent answered and refused (a wrong or missing token, another protocol): say so in the
        // words the reconnect path uses, not "no splitvk-agent", which sends the user looking for
        // a network problem.
        warn_refused(session->agent_label(first), agent.error());
        first.failure_logged.store(true);
    } else {
        SPLITVK_WARN("no splitvk-agent at %s (%s); running unsplit until one answers",
                     session->agent_label(first).c_str(), agent.error().c_str());
        first.failure_logged.store(true);
    }
    // An agent per eye: the other eyes' agents are dialled now too, since one brought in later costs
    // a snapshot of everything made so far. One that does not answer is looked for in the background,
    // its eye showing the periphery meanwhile; a refusal ends nothing the first eye's agent has.
    for (size_t index = 1; index < session->agents_.size() && !final; ++index) {
        Agent &place = *session->agents_[index];
        bool refused = false;
        auto link = session->connect_agent(place, &refused);
        if (link) {
            bring_in(place, std::move(link).value());
        } else {
            SPLITVK_WARN("no splitvk-agent for eye %zu at %s (%s); its foveae show the periphery until one "
                         "answers",
                         index + 1, session->candidates_->description().c_str(), link.error().c_str());
            place.failure_logged.store(true);
        }
    }
    if (!final) session->reconnector_ = std::thread([raw = session.get()] { raw->run_reconnect(); });
    return session;
}

void Session::stop_receiver(Agent &agent) {
    agent.stop_receiver.store(true);
    if (agent.receiver.joinable()) agent.receiver.join();
}

void Session::run_reconnect() {
    using namespace std::chrono_literals;
    constexpr auto kFirstRetry = 250ms;
    constexpr auto kLongestRetry = 2000ms;
    auto backoff = kFirstRetry;
    std::unique_lock lock(reconnect_mutex_);
    // The places without an agent, connected or found: what a dial is for.
    const auto vacant = [this] {
        std::vector<Agent *> places;
        for (const auto &agent : agents_)
            if (!agent->live.load() && !agent->pending) places.push_back(agent.get());
        return places;
    };
    while (!closing_) {
        if (vacant().empty() || agent_released_) {
            // Bounded: fail() notifies without reconnect_mutex_, so a wakeup between the check above
            // and this wait (an agent adopted by resync dying at once) would otherwise be lost.
            reconnect_wake_.wait_for(lock, kLongestRetry);
            backoff = kFirstRetry;
            continue;
        }
        // An agent called back (recall_agent()) is asked at once: frames pass through until it is in.
        // The agent in use just went away (fail()): dial at once, since another may be there to fail
        // over to; a dial that finds none backs off as before.
        const bool dial_now = std::exchange(connect_now_, false) | lost_agent_.exchange(false);
        if (!dial_now &&
            reconnect_wake_.wait_for(lock, backoff,
                                     [&] { return closing_ || connect_now_ || lost_agent_.load(); }) &&
            closing_)
            break;
        connect_now_ = false;
        lost_agent_.store(false);
        bool any_found = false, refused_for_good = false;
        for (Agent *place : vacant()) {
            lock.unlock();
            bool final = false;
            auto agent = connect_agent(*place, &final);
            lock.lock();
            if (closing_) return;
            // Let go while it was being asked (release_agent()): frames pass through without it.
            if (agent_released_) break;
            if (!agent) {
                if (final) {
                    warn_refused(agent_label(*place), agent.error());
                    refused_for_good = true;
                    break;
                }
                continue;
            }
            // The swapped split is for the session's life: its command buffers are recorded cut and
            // its screen-space targets full size, which only an agent that renders the periphery can
            // serve.
            if (client_renders() == ClientRenders::Fovea &&
                !(agent->welcome.capabilities & protocol::capability::kSwappedSplit)) {
                if (!std::exchange(place->swapped_refusal_logged, true))
                    SPLITVK_WARN(
                        "splitvk-agent at %s cannot render the periphery, which this session's client "
                        "leaves to the agent (SPLITVK_CLIENT_RENDERS=fovea); not brought in, the "
                        "client renders whole frames",
                        agent_label(*place).c_str());
                agent->connection->send(
                    protocol::MessageType::Goodbye,
                    protocol::encode_goodbye({"the client's swapped split needs the periphery"}));
                agent->connection->flush(kCloseFlush);
                agent->connection->close("cannot render the periphery");
                continue;
            }
            place->swapped_refusal_logged = false;
            std::string went_away;
            std::chrono::steady_clock::time_point went_away_at;
            {
                std::lock_guard label_lock(label_mutex_);
                went_away = place->went_away;
                went_away_at = place->went_away_at;
            }
            const std::string eye =
                agents_.size() > 1 ? " for eye " + std::to_string(place->index + 1) : std::string();
            // Another agent than the one that went away: the failover, in one line.
            if (!went_away.empty() && went_away != agent->agent)
                SPLITVK_WARN(
                    "failover: splitvk-agent %s went away; %s answered%s and joins at the next present",
                    went_away.c_str(), agent->agent.c_str(), eye.c_str());
            else
                SPLITVK_INFO("splitvk-agent at %s answered%s; it joins at the next present",
                             agent->agent.c_str(), eye.c_str());
            place->pending = std::move(agent).value();
            place->reconnected_at = std::chrono::steady_clock::now();
            place->pending_in_place_of = went_away;
            place->pending_loss_at = went_away_at;
            place->resync_pending.store(true, std::memory_order_release);
            any_found = true;
        }
        if (refused_for_good) break;
        backoff = any_found ? kFirstRetry : std::min(backoff * 2, kLongestRetry);
    }
}

void Session::resync(DeviceState &device, VkQueue queue, uint64_t frame) {
    // The places whose new agent waits, with what the reconnector found for them.
    struct Joining {
        Agent *place;
        AgentLink link;
        std::chrono::steady_clock::time_point answered, lost_at;
        std::string in_place_of;
    };
    std::vector<Joining> joining;
    {
        std::lock_guard lock(reconnect_mutex_);
        for (const auto &agent : agents_) {
            if (!agent->resync_pending.exchange(false) || !agent->pending) continue;
            joining.push_back({agent.get(), std::move(*agent->pending), agent->reconnected_at,
                               agent->pending_loss_at, std::move(agent->pending_in_place_of)});
            agent->pending.reset();
        }
    }
    if (joining.empty()) return;
    const auto start = std::chrono::steady_clock::now();
    // The snapshot is what the app's submits so far have made: let them finish.
    device.dispatch.QueueWaitIdle(queue);
    resync_mapped_shadows(device);

    // Under the session lock nothing is logged or sent by other threads: the snapshot is exact.
    std::lock_guard lock(mutex_);
    const auto idle = std::chrono::steady_clock::now();
    ContentSnapshot contents;
    std::string error;
    const bool read_back =
        snapshot_contents(device, queue, queue_family_of(device, queue), &contents, &error);
    const auto readback_done = std::chrono::steady_clock::now();
    if (!read_back)
        SPLITVK_WARN(
            "cannot read back buffer and image contents for the new agent (%s); its frames may differ",
            error.c_str());
    if (contents.screen_space_images)
        SPLITVK_INFO("snapshot: %llu screen-space targets left out (every frame rewrites them, and here they "
                     "are scaled)",
                     static_cast<unsigned long long>(contents.screen_space_images));
    // What is pending is in the log, and so in the snapshot; the agents already in get it now, the
    // joining ones in their snapshot.
    flush_locked();
    size_t entries = 0;
    std::unordered_set<uint64_t> live_ids;
    std::vector<LiveMessage> snapshot = log_.messages(&entries, &live_ids);
    for (auto &message : contents.messages)
        snapshot.push_back(std::move(message));
    codec::Encoder descriptors;
    descriptors.set_hooks(&hooks_);
    size_t sets = 0;
    snapshot_descriptor_contents(device, live_ids, descriptors, &sets);
    if (descriptors.size() != 0) snapshot.push_back({protocol::MessageType::Commands, descriptors.take()});
    std::vector<std::vector<uint8_t>> streams;
    snapshot_command_buffers(device, live_ids, streams);
    const size_t command_buffers = streams.size();
    for (auto &stream : streams)
        snapshot.push_back({protocol::MessageType::Commands, std::move(stream)});
    size_t bytes = 0;
    for (const LiveMessage &message : snapshot)
        bytes += message.payload.size();
    const bool recalled = recalled_.exchange(false);
    for (size_t i = 0; i < joining.size(); ++i) {
        Joining &join = joining[i];
        Agent &agent = *join.place;
        adopt_locked(agent, std::move(join.link));
        // The last one joining takes the snapshot itself, the others a copy.
        send_all_locked(agent,
                        i + 1 == joining.size() ? std::move(snapshot) : std::vector<LiveMessage>(snapshot));
        agent.first_replayed_frame.store(frame + 1);
        agent.joined_agent_answered = join.answered;
        agent.joined_in_place_of = std::move(join.in_place_of);
        agent.joined_after_loss_at = join.lost_at;
        agent.awaiting_first_tiles.store(true);
        agent.first_split_frame_pending.store(true);
        const auto now = std::chrono::steady_clock::now();
        const auto ms = [](auto from, auto to) {
            return std::chrono::duration<double, std::milli>(to - from).count();
        };
        const std::string eye =
            agents_.size() > 1 ? " for eye " + std::to_string(agent.index + 1) : std::string();
        // Where the resync's time goes: waiting for the next present, the queue to
        // drain, the readback, and encoding and queueing the snapshot.
        // An agent that came back as asked is news only at info; any other is a change the user is told.
        log(recalled ? LogLevel::Info : LogLevel::Warn,
            "splitvk-agent at %s brought in at frame %llu%s: %zu objects, %llu buffers, %llu images, %zu "
            "descriptor sets, %zu command buffers, %.1f MiB in %.0f ms (%.0f ms after it answered; "
            "%.0f ms to the present, %.0f idle, %.0f readback, %.0f encode and queue)",
            agent_label(agent).c_str(), static_cast<unsigned long long>(frame), eye.c_str(), entries,
            static_cast<unsigned long long>(contents.buffers),
            static_cast<unsigned long long>(contents.images), sets, command_buffers,
            static_cast<double>(bytes) / (1 << 20), ms(start, now), ms(join.answered, now),
            ms(join.answered, start), ms(start, idle), ms(idle, readback_done), ms(readback_done, now));
    }
}

Session::~Session() {
    {
        std::lock_guard lock(reconnect_mutex_);
        closing_ = true;
    }
    reconnect_wake_.notify_all();
    if (reconnector_.joinable()) reconnector_.join();
    for (const auto &agent : agents_) {
        stop_receiver(*agent);
        if (agent->tiles) agent->tiles->stop();
        agent->current_connection.store(nullptr);
        if (agent->connection) agent->connection->close();
    }
}

Session::FrameSizing Session::size_frame(int64_t xr_frame, double frame_ms) {
    FrameSizing sizing;
    if (!auto_fovea_) return sizing;
    if (xr_frame < 0) return {auto_fovea_->size(), true, frame_ms};
    std::lock_guard lock(sizing_mutex_);
    if (xr_frame == sized_xr_frame_) return {xr_frame_size_, false, 0};
    const auto now = std::chrono::steady_clock::now();
    sizing.heard = true;
    if (xr_frame_start_ != std::chrono::steady_clock::time_point{})
        sizing.frame_ms = std::chrono::duration<double, std::milli>(now - xr_frame_start_).count();
    xr_frame_start_ = now;
    sized_xr_frame_ = xr_frame;
    xr_frame_size_ = sizing.size = auto_fovea_->size();
    return sizing;
}

double Session::frame_interval_ms() {
    const auto now = std::chrono::steady_clock::now();
    const double ms = last_present_ == std::chrono::steady_clock::time_point{}
                          ? 0.0
                          : std::chrono::duration<double, std::milli>(now - last_present_).count();
    last_present_ = now;
    return ms;
}

namespace {

// Presents the application may make after its present was answered VK_ERROR_OUT_OF_DATE_KHR before
// the layer concludes it will not recreate its swapchain.
constexpr uint32_t kSwitchPatience = 30;

SplitPayoff::Mode payoff_mode(bool passing_through) {
    return passing_through ? SplitPayoff::Mode::PassThrough : SplitPayoff::Mode::Split;
}

size_t scaled_targets_alive(const DeviceState &device) {
    size_t scaled = 0;
    for_each_image(device, [&](VkImage, const ImageState &image) { scaled += image.screen_space; });
    return scaled;
}

} // namespace

void Session::observe_payoff(const DeviceState &device, double frame_ms,
                             const split::FrameFoveaSize &fovea_size) {
    if (!payoff_ || client_renders() == ClientRenders::Fovea) return;
    bool release = false, recall = false;
    {
        std::lock_guard lock(payoff_mutex_);
        observe_payoff_locked(device, frame_ms, fovea_size, release, recall);
    }
    if (release) release_agent();
    if (recall) recall_agent();
}

void Session::observe_payoff_locked(const DeviceState &device, double frame_ms,
                                    const split::FrameFoveaSize &fovea_size, bool &release, bool &recall) {
    if (payoff_->settled()) return;
    const bool through = passing_through();
    if (std::exchange(check_kept_targets_, false)) {
        // Targets made scaled for the split and still alive would be drawn at the periphery's size
        // and read by passes that are not scaled any more: such an application cannot pass through.
        if (const size_t kept = scaled_targets_alive(device)) {
            SPLITVK_WARN("SPLITVK_SPLIT=auto: the application kept %zu screen-space target(s) made for the "
                         "split through its swapchain's recreation, so its frames cannot pass through; the "
                         "split stays on",
                         kept);
            payoff_->settle(SplitPayoff::Mode::Split);
            wanted_pass_through_ = false;
            passing_through_.store(false);
            payoff_out_of_date_.store(true); // recorded unscaled since the switch: record again
            recall = true;                   // let go at the switch: the split needs it back
            return;
        }
    }
    if (switch_awaits_agent_) {
        // A probe of the split waits for the agent it called back: resync() brought it in at this
        // present, before this call, or frames go on passing through.
        if (!live()) return;
        switch_awaits_agent_ = false;
        wanted_pass_through_ = false;
        presents_since_switch_ = 0;
        payoff_out_of_date_.store(true);
        return;
    }
    if (wanted_pass_through_ != through) {
        if (++presents_since_switch_ > kSwitchPatience) {
            SPLITVK_WARN(
                "SPLITVK_SPLIT=auto: the application did not recreate its swapchain when its present "
                "was answered VK_ERROR_OUT_OF_DATE_KHR; its frames stay %s",
                through ? "passed through" : "split");
            payoff_->settle(payoff_mode(through));
            wanted_pass_through_ = through;
            release = through; // passing through for good: no agent is needed
        }
        return;
    }
    const bool steady = fovea_size == std::exchange(payoff_fovea_size_, fovea_size);
    const auto decided = payoff_->observe(payoff_mode(through), frame_ms, steady);
    if (!decided) return;
    const bool to_pass_through = decided->to == SplitPayoff::Mode::PassThrough;
    const bool switching = to_pass_through != through;
    if (decided->probe) {
        SPLITVK_INFO(
            "SPLITVK_SPLIT=auto: frames take %.1f ms %s; measuring them %s (the application's present "
            "answers VK_ERROR_OUT_OF_DATE_KHR once)",
            through ? decided->native_ms : decided->split_ms, through ? "passed through" : "split",
            to_pass_through ? "passed through" : "split");
    } else if (to_pass_through) {
        SPLITVK_INFO("SPLITVK_SPLIT=auto: the split does not pay here (%.1f ms a frame split, %.1f ms passed "
                     "through): frames pass through, and the split is measured again now and then",
                     decided->split_ms, decided->native_ms);
    } else {
        SPLITVK_INFO("SPLITVK_SPLIT=auto: the split pays (%.1f ms a frame split, %.1f ms passed through): "
                     "frames are split",
                     decided->split_ms, decided->native_ms);
    }
    // A verdict for passing through lets the agent go once the frames pass through; a probe of
    // passing through keeps it, since the split may win the probe.
    release_when_passing_through_ = to_pass_through && !decided->probe;
    if (!switching) {
        if (release_when_passing_through_) release = true;
        return;
    }
    if (!to_pass_through && !live()) {
        switch_awaits_agent_ = true;
        recall = true;
        return;
    }
    wanted_pass_through_ = to_pass_through;
    presents_since_switch_ = 0;
    payoff_out_of_date_.store(true);
}

void Session::swapchain_recreated() {
    if (!payoff_) return;
    bool release = false;
    {
        std::lock_guard lock(payoff_mutex_);
        if (wanted_pass_through_ == passing_through()) return;
        passing_through_.store(wanted_pass_through_);
        check_kept_targets_ = wanted_pass_through_;
        release = wanted_pass_through_ && release_when_passing_through_;
        SPLITVK_INFO(wanted_pass_through_ ? "SPLITVK_SPLIT=auto: frames pass through from this swapchain on"
                                          : "SPLITVK_SPLIT=auto: frames are split from this swapchain on");
    }
    // The frames drawn split before this swapchain have had their tiles (the present thread was
    // drained before its recreation): the agent has nothing more to do for this device.
    if (release) release_agent();
}

void Session::release_agent() {
    {
        std::lock_guard lock(reconnect_mutex_);
        agent_released_ = true;
        // One that answered meanwhile is let go as well, unadopted.
        for (const auto &agent : agents_) {
            agent->pending.reset();
            agent->resync_pending.store(false);
        }
    }
    std::vector<std::shared_ptr<protocol::Connection>> connections;
    {
        std::lock_guard lock(mutex_);
        if (!live()) return;
        // Its closure is not the agent going away, and nothing more is sent: from here the device is
        // one without an agent, its calls logged for the snapshot that brings an agent back.
        for (const auto &agent : agents_) {
            if (!agent->live.exchange(false)) continue;
            agent->current_connection.store(nullptr);
            if (agent->tiles) agent->tiles->abandon();
            connections.push_back(agent->connection);
        }
    }
    // Outside the session lock, which every captured call takes: the flush may wait for the link.
    // Nothing replaces the connections meanwhile: only resync() does, with an agent the reconnector
    // brings in, and it brings none in while the agents are let go.
    for (const auto &connection : connections) {
        connection->send(protocol::MessageType::Goodbye,
                         protocol::encode_goodbye({"the client's frames pass through (SPLITVK_SPLIT=auto)"}));
        connection->flush(kCloseFlush);
        connection->close("frames pass through");
    }
    SPLITVK_INFO("SPLITVK_SPLIT=auto: splitvk-agent at %s let go while frames pass through; it is called "
                 "back when the split is measured again",
                 agents_label().c_str());
}

void Session::recall_agent() {
    {
        std::lock_guard lock(reconnect_mutex_);
        if (!agent_released_) return;
        agent_released_ = false;
        connect_now_ = true;
    }
    recalled_.store(true);
    SPLITVK_INFO("SPLITVK_SPLIT=auto: calling splitvk-agent at %s back to measure the split again",
                 agents_label().c_str());
    reconnect_wake_.notify_all();
}

void Session::run_receiver(Agent &agent) {
    using protocol::MessageType;
    // The connection this thread was started for: adopt_locked() joins the thread before it replaces
    // agent.connection.
    protocol::Connection &connection = *agent.connection;
    while (!agent.stop_receiver.load()) {
        auto message = connection.receive(100ms);
        if (!message) {
            if (!connection.is_open()) break; // on_closed has reported it
            continue;
        }
        switch (static_cast<MessageType>(message->type)) {
        case MessageType::Tiles:
            if (agent.tiles) {
                std::string error;
                if (!agent.tiles->accept(std::move(message->payload), &error)) {
                    fail(agent, "malformed Tiles from the agent: " + error);
                    return;
                }
            }
            break;
        case MessageType::VerifyFrame: {
            std::lock_guard lock(verify_mutex_);
            verify_frames_.push_back(std::move(message->payload));
            if (verify_frames_.size() > 16) verify_frames_.pop_front(); // nobody is comparing them
            verify_ready_.notify_all();
            break;
        }
        case MessageType::Goodbye: {
            const auto bye = protocol::decode_goodbye(message->payload);
            fail(agent, bye ? "it said: " + bye->message : std::string("it said goodbye"));
            return;
        }
        default:
            break; // Pong and the like
        }
    }
}

const char *Session::fallback() const {
    if (client_renders() == ClientRenders::Fovea)
        return "the client renders whole frames from now on (frames recorded cut show the last periphery)";
    return splitting_ ? "the periphery alone fills the frames from now on" : "running unsplit from now on";
}

// Whether the receiver or a send notices first, losing the agent ends alike: one line, nothing more
// is sent, a present waiting for tiles stops waiting, and the reconnector (asleep while the session
// is live) starts looking for a new agent.
void Session::fail(Agent &agent, const std::string &reason) {
    agent.live.store(false);
    {
        // The reconnector dials another agent first, if there is one.
        std::lock_guard lock(label_mutex_);
        // The first loss since an agent was adopted: a failed redial is no new loss.
        if (agent.went_away.empty()) agent.went_away_at = std::chrono::steady_clock::now();
        agent.went_away = agent.address;
    }
    // Without reconnect_mutex_ (fail() is reached under the session's locks): a wakeup lost between
    // the reconnector's check and its wait costs at most its backoff.
    lost_agent_.store(true);
    if (agent.tiles) agent.tiles->abandon();
    reconnect_wake_.notify_all();
    if (!agent.failure_logged.exchange(true)) {
        if (client_renders() == ClientRenders::Fovea) force_out_of_date_.store(true);
        // An agent per eye: the other eyes go on with theirs.
        if (agents_.size() > 1 && live())
            SPLITVK_WARN(
                "splitvk-agent at %s went away (%s); eye %u's foveae show the periphery until another "
                "agent is brought in",
                agent_label(agent).c_str(), reason.c_str(), agent.index + 1);
        else
            SPLITVK_WARN("splitvk-agent at %s went away (%s); %s", agent_label(agent).c_str(), reason.c_str(),
                         fallback());
    }
}

bool Session::abandon() {
    if (abandoned_.exchange(true)) return false;
    {
        std::lock_guard lock(reconnect_mutex_);
        closing_ = true; // the reconnector ends; close() or the destructor joins it
        for (const auto &agent : agents_) {
            agent->pending.reset();
            agent->resync_pending.store(false);
        }
    }
    if (client_renders() == ClientRenders::Fovea) force_out_of_date_.store(true);
    for (const auto &agent : agents_) {
        agent->failure_logged.store(true);
        agent->live.store(false);
        if (agent->tiles) agent->tiles->abandon();
    }
    reconnect_wake_.notify_all();
    return true;
}

void Session::send_metadata_logged(protocol::MessageType type, std::vector<uint8_t> &&payload,
                                   uint64_t holder, std::span<const uint64_t> killers) {
    std::lock_guard lock(mutex_);
    const uint64_t ids[] = {holder};
    log_.add(std::vector<uint8_t>(payload), ids, killers, type);
    flush_locked();
    send_locked(type, std::move(payload));
}

void Session::forget(std::span<const uint64_t> ids) {
    std::lock_guard lock(mutex_);
    for (uint64_t id : ids)
        log_.forget(id);
}

std::vector<LiveMessage> Session::object_log(size_t *entries, std::unordered_set<uint64_t> *live_ids) {
    std::lock_guard lock(mutex_);
    return log_.messages(entries, live_ids);
}

size_t Session::live_object_count() {
    std::lock_guard lock(mutex_);
    return log_.size();
}

void Session::send_locked(protocol::MessageType type, std::vector<uint8_t> &&payload) {
    send_locked(type, std::move(payload), kSendWait);
}

void Session::send_locked(protocol::MessageType type, std::vector<uint8_t> &&payload,
                          std::chrono::milliseconds wait) {
    // Every connected agent but the last gets a copy: with one agent, nothing is copied.
    Agent *last = nullptr;
    for (const auto &agent : agents_) {
        if (!agent->live.load(std::memory_order_relaxed)) continue;
        if (last) send_to_locked(*last, type, std::vector<uint8_t>(payload), wait);
        last = agent.get();
    }
    if (last) send_to_locked(*last, type, std::move(payload), wait);
}

void Session::send_to_locked(Agent &agent, protocol::MessageType type, std::vector<uint8_t> &&payload,
                             std::chrono::milliseconds wait) {
    if (!agent.live.load(std::memory_order_relaxed)) return;
    note_send_locked(agent, agent.connection->send_owned(type, std::move(payload), wait));
}

void Session::send_all_locked(Agent &agent, std::vector<LiveMessage> &&messages) {
    if (!agent.live.load()) return;
    // Every core the client has: the app is held at this present until the snapshot is queued.
    const unsigned workers = std::clamp(std::thread::hardware_concurrency(), 1u, 4u);
    note_send_locked(agent, agent.connection->send_all(std::move(messages), kSendWait, workers));
}

// A message the link would not take ends that agent's session: it would replay a stream with a hole.
void Session::note_send_locked(Agent &agent, protocol::SendResult result) {
    if (result == protocol::SendResult::Queued) return;
    std::string reason = protocol::to_string(result);
    if (result == protocol::SendResult::Closed) reason = agent.connection->close_reason();
    fail(agent, "cannot send: " + reason);
}

void Session::send_frame_present(protocol::FramePresent message) {
    std::lock_guard lock(mutex_);
    flush_locked();
    const uint32_t flags = message.flags;
    for (const auto &agent : agents_) {
        // The frame a resync brought this agent in at: its submits reached it in no stream, nor will
        // its tiles.
        message.flags = flags;
        if (message.frame < agent->first_replayed_frame.load()) message.flags |= protocol::kPresentNoTiles;
        send_to_locked(*agent, protocol::MessageType::FramePresent, protocol::encode(message), kSendWait);
    }
}

void Session::flush_locked() {
    if (encoder_.size() == 0) return;
    send_locked(protocol::MessageType::Commands, encoder_.take());
}

void Session::flush() {
    std::lock_guard lock(mutex_);
    flush_locked();
}

void Session::send_commands(std::span<const uint8_t> payload) {
    const bool room = wait_for_room(payload.size());
    std::lock_guard lock(mutex_);
    flush_locked();
    send_locked(protocol::MessageType::Commands, std::vector<uint8_t>(payload.begin(), payload.end()),
                room ? kSendWait : 0ms);
}

void Session::send_metadata(protocol::MessageType type, std::vector<uint8_t> &&payload) {
    const bool room = wait_for_room(payload.size());
    std::lock_guard lock(mutex_);
    flush_locked();
    send_locked(type, std::move(payload), room ? kSendWait : 0ms);
}

bool Session::wait_for_room(size_t bytes) {
    std::vector<std::shared_ptr<protocol::Connection>> connections;
    {
        std::lock_guard lock(mutex_);
        for (const auto &agent : agents_)
            if (agent->live.load() && agent->connection) connections.push_back(agent->connection);
        bytes += encoder_.size();
    }
    // The slowest link sets the pace: every agent replays every message.
    bool room = true;
    for (const auto &connection : connections)
        room = connection->wait_for_room(bytes, kSendWait) && room;
    return room;
}

std::optional<std::vector<uint8_t>> Session::receive_verify_frame(std::chrono::milliseconds timeout) {
    std::unique_lock lock(verify_mutex_);
    if (!verify_ready_.wait_for(lock, timeout, [&] { return !verify_frames_.empty(); })) return std::nullopt;
    auto payload = std::move(verify_frames_.front());
    verify_frames_.pop_front();
    return payload;
}

void Session::close() {
    {
        std::lock_guard lock(reconnect_mutex_);
        closing_ = true;
    }
    reconnect_wake_.notify_all();
    if (reconnector_.joinable()) reconnector_.join();
    {
        std::lock_guard lock(mutex_);
        flush_locked();
        for (const auto &agent : agents_) {
            agent->live.store(false);
            agent->failure_logged.store(true);
        }
    }
    for (const auto &agent : agents_) {
        agent->current_connection.store(nullptr); // closing it is not the agent going away
        if (agent->connection) agent->connection->flush(kCloseFlush);
        const protocol::ConnectionStats stats =
            agent->connection ? agent->connection->stats() : protocol::ConnectionStats{};
        // Presents: every window present and every OpenXR release of an image (depth swapchains' too).
        SPLITVK_INFO("session to %s: %llu presents, %.2f ms comparing memory, %llu messages, %llu payload "
                     "bytes, %llu bytes on the wire",
                     agent_label(*agent).c_str(), static_cast<unsigned long long>(current_frame()),
                     static_cast<double>(memory_compare_ns.load()) / 1e6,
                     static_cast<unsigned long long>(stats.messages_sent),
                     static_cast<unsigned long long>(stats.payload_bytes_sent),
                     static_cast<unsigned long long>(stats.wire_bytes_sent));
        stop_receiver(*agent);
        if (agent->tiles) agent->tiles->stop();
    }
    // The present thread and the compositors let go of their tiles before (forget_device_objects):
    // the pool's buffers can be freed while the device exists.
    if (uploads_) uploads_->close();
    for (const auto &agent : agents_)
        if (agent->connection) agent->connection->close("the application destroyed the device");
}

} // namespace splitvk

namespace splitvk {

LiveSnapshot build_live_snapshot(DeviceState &device) {
    LiveSnapshot snapshot;
    if (!device.session) return snapshot;
    std::unordered_set<uint64_t> live;
    snapshot.messages = device.session->object_log(&snapshot.objects, &live);

    codec::Encoder descriptors;
    descriptors.set_hooks(device.session->hooks());
    snapshot_descriptor_contents(device, live, descriptors, &snapshot.descriptor_sets);
    if (descriptors.size() != 0)
        snapshot.messages.push_back({protocol::MessageType::Commands, descriptors.take()});

    std::vector<std::vector<uint8_t>> streams;
    snapshot_command_buffers(device, live, streams);
    snapshot.command_buffers = streams.size();
    for (auto &stream : streams)
        snapshot.messages.push_back({protocol::MessageType::Commands, std::move(stream)});
    for (const LiveMessage &message : snapshot.messages)
        snapshot.bytes += message.payload.size();
    return snapshot;
}

namespace {

// Replays a snapshot's handle changes the way a fresh agent's HandleTable would, without a GPU:
// every command decodes (so every id it names resolves) in the order given.
class HandleReplay : public codec::CommandVisitor {
public:
    explicit HandleReplay(codec::HandleTable &table) : table_(table) {}
    std::string error;

    bool unhandled(codec::VkCommandId) override { return true; }
#define SPLITVK_APPLY(name)                                                                                  \
    bool name(const codec::Decoded_##name &cmd) override {                                                   \
        return codec::apply_handle_changes(table_, cmd, &error);                                             \
    }
    SPLITVK_APPLY(vkAllocateCommandBuffers)
    SPLITVK_APPLY(vkAllocateDescriptorSets)
    SPLITVK_APPLY(vkAllocateMemory)
    SPLITVK_APPLY(vkCreateBuffer)
    SPLITVK_APPLY(vkCreateBufferView)
    SPLITVK_APPLY(vkCreateCommandPool)
    SPLITVK_APPLY(vkCreateComputePipelines)
    SPLITVK_APPLY(vkCreateDescriptorPool)
    SPLITVK_APPLY(vkCreateDescriptorSetLayout)
    SPLITVK_APPLY(vkCreateDescriptorUpdateTemplate)
    SPLITVK_APPLY(vkCreateDevice)
    SPLITVK_APPLY(vkCreateEvent)
    SPLITVK_APPLY(vkCreateFence)
    SPLITVK_APPLY(vkCreateFramebuffer)
    SPLITVK_APPLY(vkCreateGraphicsPipelines)
    SPLITVK_APPLY(vkCreateImage)
    SPLITVK_APPLY(vkCreateImageView)
    SPLITVK_APPLY(vkCreatePipelineCache)
    SPLITVK_APPLY(vkCreatePipelineLayout)
    SPLITVK_APPLY(vkCreateQueryPool)
    SPLITVK_APPLY(vkCreateRenderPass)
    SPLITVK_APPLY(vkCreateRenderPass2)
    SPLITVK_APPLY(vkCreateSampler)
    SPLITVK_APPLY(vkCreateSamplerYcbcrConversion)
    SPLITVK_APPLY(vkCreateSemaphore)
    SPLITVK_APPLY(vkCreateShaderModule)
    SPLITVK_APPLY(vkDestroyDescriptorSetLayout)
    SPLITVK_APPLY(vkDestroyPipelineCache)
    SPLITVK_APPLY(vkDestroyPipelineLayout)
    SPLITVK_APPLY(vkDestroyRenderPass)
    SPLITVK_APPLY(vkDestroyShaderModule)
    SPLITVK_APPLY(vkGetDeviceQueue)
    SPLITVK_APPLY(vkGetDeviceQueue2)
#undef SPLITVK_APPLY

private:
    codec::HandleTable &table_;
};

// Empty when the snapshot replays with every id resolved; else the first error.
std::string check_replay(const LiveSnapshot &snapshot, uint64_t physical_device_id, uint64_t device_id) {
    codec::HandleTable table;
    HandleReplay replay(table);
    // The agent picks its own physical device for the client's (what vkCreateDevice names).
    table.insert(physical_device_id, VK_OBJECT_TYPE_PHYSICAL_DEVICE, physical_device_id);
    for (const LiveMessage &message : snapshot.messages) {
        if (message.type == protocol::MessageType::SwapchainImages) {
            auto images = protocol::decode_swapchain_images(message.payload);
            if (!images) return "SwapchainImages: " + images.error();
            for (uint64_t id : images->image_ids)
                if (!table.insert(id, VK_OBJECT_TYPE_IMAGE, id, 0, &replay.error)) return replay.error;
            continue;
        }
        if (message.type == protocol::MessageType::ImageLayouts) {
            auto layouts = protocol::decode_image_layouts(message.payload);
            if (!layouts) return "ImageLayouts: " + layouts.error();
            const auto *image = table.find(layouts->image_id);
            if (!image || image->type != VK_OBJECT_TYPE_IMAGE) return "ImageLayouts before its image";
            continue;
        }
        if (message.type == protocol::MessageType::BufferAddress) {
            auto address = protocol::decode_buffer_address(message.payload);
            if (!address) return "BufferAddress: " + address.error();
            const auto *buffer = table.find(address->buffer_id);
            if (!buffer || buffer->type != VK_OBJECT_TYPE_BUFFER) return "BufferAddress before its buffer";
            continue;
        }
        codec::Arena arena;
        codec::Decoder decoder(message.payload, table, arena);
        while (!decoder.at_end()) {
            if (!codec::dispatch_decoded(decoder, replay))
                return decoder.ok() ? replay.error : decoder.error();
        }
    }
    if (!table.find(device_id)) return "the device is not in the snapshot";
    return {};
}

} // namespace

void log_live_state(DeviceState &device, const char *when) {
    if (!device.session || !log_enabled(LogLevel::Debug)) return;
    const LiveSnapshot snapshot = build_live_snapshot(device);
    const std::string error =
        check_replay(snapshot, codec::handle_value(device.physical_device), device.session->device_id());
    SPLITVK_DEBUG(
        "live-state log %s: %zu objects, %zu descriptor sets, %zu command buffers, %zu bytes, replay %s%s",
        when, snapshot.objects, snapshot.descriptor_sets, snapshot.command_buffers, snapshot.bytes,
        error.empty() ? "ok" : "FAILED: ", error.c_str());
}

} // namespace splitvk
