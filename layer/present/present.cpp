// Acquire and present: frame marks (docs/architecture.md §2), split mode's composite (docs/architecture.md
// §4) and SPLITVK_VERIFY=full.
//
// vkAcquireNextImageKHR/2KHR -> FrameBegin{frame, swapchain, image}; vkQueuePresentKHR ->
// FramePresent{frame, queue, flags, images}, frames counted from 0 per device in present order.
//
// Overlap (docs/architecture.md §4). A split frame needs the agent's tiles of that same frame before it can
// be composited and shown, and waiting for them on the application's thread would stall the application for
// the agent's whole path. So vkQueuePresentKHR only takes the frame: it sends FramePresent, submits an empty
// batch on the present queue that waits on the application's present semaphores and signals a semaphore of
// the compositor's for that swapchain image (Compositor::take_waits; per-image objects, the Mesa overlay's
// scheme), hands the frame to the device's present thread and returns. The present thread waits for the
// frame's own tiles (lockstep: frame N is composited with frame N's tiles or, late, with the periphery alone,
// never with older tiles), composites on the same queue (the submit waits on the taken semaphore) and
// presents. The application meanwhile records and submits frame N+1.
//  - Depth: at most SPLITVK_PRESENT_DEPTH frames are in the layer; a present beyond that waits
//    for room. 0 (the default: a frame waits behind no earlier one, the least latency) keeps
//    everything on the application's thread, as do presents with
//    pNext, of several swapchains, unsplit frames and verification (each first drains the thread,
//    so presents reach the driver in the application's order).
//  - Queues: the thread uses the application's queue, so every queue operation takes the queue's
//    lock (queue.cpp, lock_queue()); the thread holds it only to submit and to present, never
//    while it waits for tiles.
//  - Images: a frame in the thread holds its image past the application's present, so the layer
//    adds that many images to the swapchain (swapchain.cpp) and vkAcquireNextImageKHR waits for the
//    thread when an acquire would otherwise hold more images than the surface allows.
//  - Order: image indices are the driver's to assign, and the driver picks among the images it
//    has been given back, so an acquire made while the thread still holds a frame may get another
//    image than it would without the layer (lavapipe's X11 WSI hands out the lowest free image: 0
//    every frame natively). An application that uses its images in an order of its own
//    (gfxrecon-replay --use-captured-swapchain-indices draws into the captured image and presents
//    the acquired one) then draws into an image it did not acquire. A submit that does so
//    (order_swapchain_writes) waits for the thread if the thread still holds that image, and marks
//    the swapchain: its acquires from then on wait until the thread has presented every frame of
//    it (before_acquire), so the driver picks as it would natively. The frame at hand is presented
//    here: composited in the image drawn, copied into the image presented (never an image the
//    layer did not fill), and the agent told the image drawn.
//  - Results: the thread's real present result (VK_SUBOPTIMAL_KHR, VK_ERROR_OUT_OF_DATE_KHR,
//    surface or device lost) is kept per swapchain, worst first, and returned by the
//    application's next present or acquire of that swapchain (an error at acquire is returned
//    without acquiring).
//  - Draining: vkQueueWaitIdle, vkDeviceWaitIdle, swapchain recreation and destruction wait for
//    the thread's frames; vkDestroyDevice ends the thread. Each frame is bounded by
//    SPLITVK_TILE_WAIT, and an agent that goes away ends the wait at once (TileStream::abandon),
//    so none of this can hang: the frame shows the periphery.
//
// Verification (SPLITVK_VERIFY=full): verification.h; presents that verify stay on the
// application's thread. In the swapped split the frame is read back after its composite, as shown.

#include "present/present.h"

#include "capture/capture.h"
#include "capture/session.h"
#include "capture/split.h"
#include "core/gpu_timing.h"
#include "core/queue.h"
#include "core/swapchain.h"
#include "core/vk_util.h"
#include "layer_entry_points.h"
#include "log.h"
#include "model/gaze.h"
#include "model/stats.h"
#include "periphery.h"
#include "present/compositor.h"
#include "present/verification.h"
#include "vk_result_name.h"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <map>
#include <mutex>
#include <span>
#include <string>
#include <thread>
#include <unordered_map>
#include <utility>
#include <vector>

namespace splitvk {
namespace {

using namespace std::chrono_literals;
constexpr uint64_t kFenceWaitNs = 5'000'000'000; // the layer's own copy

// How often a tile wait looks whether the GPU has finished the application's frame (exposed_wait_ms).
constexpr auto kExposurePoll = 1ms;

// The part of a tile wait during which the GPU had finished the application's frame: `done` (a
// fence of Compositor::take_waits) is looked at every kExposurePoll while the tiles are awaited.
struct Exposure {
    DeviceState *device = nullptr;
    VkFence done = VK_NULL_HANDLE;
    std::chrono::steady_clock::time_point since{}; // when `done` was first seen signalled
    bool seen = false;

    void look() {
        if (seen || !done) return;
        seen = device->dispatch.GetFenceStatus(device->handle, done) == VK_SUCCESS;
        if (seen) since = std::chrono::steady_clock::now();
    }
};

// Split frames of a live agent before late ones may be called the rule rather than a stall.
constexpr uint64_t kFramesBeforeLateVerdict = 30;

// Once, when most frames the agent replays come late: the user pays for an agent that does not
// keep up and sees the periphery alone, so the line says why and what helps.
void warn_if_late_dominates(Session &session, uint64_t late, uint32_t wait_ms, bool by_display) {
    const uint64_t split = session.split_frames.load();
    if (split < kFramesBeforeLateVerdict || late * 2 <= split || session.late_warned.exchange(true)) return;
    // Under the OpenXR deadline a longer wait is not the user's to choose: the display time ends it.
    const std::string within = by_display ? std::string("in time for their display")
                                          : "within SPLITVK_TILE_WAIT=" + std::to_string(wait_ms) + " ms";
    const char *longer_wait =
        by_display ? "" : ", a longer SPLITVK_TILE_WAIT (the application waits for the agent)";
    SPLITVK_WARN(
        "split: %llu of %llu split frames came late (no tiles %s): the agent does not keep up with this "
        "application, so most frames show the periphery alone while it still renders them. What helps: "
        "SPLITVK_AGENT_SCISSOR=guard:N (the agent cuts its offscreen passes to the foveae), a smaller "
        "SPLITVK_FOVEA%s, or an agent on a faster GPU or a nearer link",
        static_cast<unsigned long long>(late), static_cast<unsigned long long>(split), within.c_str(),
        longer_wait);
}

double ms_between(std::chrono::steady_clock::time_point from, std::chrono::steady_clock::time_point to) {
    return std::max(0.0, std::chrono::duration<double, std::milli>(to - from).count());
}

// Split mode: the frame's own tiles, waiting at most SPLITVK_TILE_WAIT (longer for the first split
// frame after an agent joined), and with a display time (an OpenXR frame's) only while the frame
// can still be composited, at `cost`, and handed to the runtime in time (deadline::tile_wait). They
// must cover exactly the foveae the frame's split passes drew, or in the swapped split
// (`periphery_parts` given) be the periphery in exactly those parts; anything else counts as late.
//
// An agent per eye (SPLITVK_AGENTS): each connected agent owes the foveae protocol::FoveaAgents gives
// it, and its tiles are taken, and checked, alone; what came in time is composited, and an eye whose
// agent is late, gone or flagged shows the periphery, the frame then counted late (or invalid).
std::shared_ptr<const FrameTiles> frame_tiles(Session &session, uint64_t frame, const SplitFrame &split,
                                              Exposure &exposure, const deadline::FrameDisplay &display,
                                              deadline::Clock::duration cost, uint32_t first_eye,
                                              const std::vector<VkRect2D> *periphery_parts = nullptr) {
    // What a frame without its tiles shows instead.
    const char *instead =
        periphery_parts ? "its periphery is the previous frame's" : "its centre is the periphery's";
    const bool several = session.agents().size() > 1;
    // The agents this frame's tiles come from: connected, and replaying the frame's submits (one that
    // joined after them sends none), each with the foveae it owes.
    struct Owed {
        Session::Agent *agent;
        std::vector<split::LayerFovea> foveae;
    };
    std::vector<Owed> owed;
    bool first_split_frame = false;
    for (const auto &agent : session.agents()) {
        if (!agent->live.load() || !agent->tiles || frame < agent->first_replayed_frame.load()) continue;
        Owed o{agent.get(), {}};
        const protocol::FoveaAgents owns = session.fovea_agents(agent->index);
        for (size_t i = 0; i < split.foveae.size(); ++i)
            if (owns.owns(first_eye + i)) o.foveae.push_back(split.foveae[i]);
        // The periphery has one agent; an agent owes nothing of a frame with fewer foveae than eyes.
        if (!periphery_parts && o.foveae.empty()) continue;
        first_split_frame = agent->first_split_frame_pending.exchange(false) || first_split_frame;
        owed.push_back(std::move(o));
    }
    // No agent, or one that joined after this frame's submits: the periphery alone.
    if (owed.empty()) return nullptr;
    deadline::TileWaitInput input;
    input.display = display;
    input.now = std::chrono::steady_clock::now();
    input.composite_cost = cost;
    input.tile_wait = std::chrono::milliseconds(session.settings().tile_wait_ms);
    input.first_split_frame = first_split_frame;
    const auto wait = deadline::tile_wait(input);
    const auto wait_ms = static_cast<uint32_t>(std::chrono::ceil<std::chrono::milliseconds>(wait).count());
    // The display time, not SPLITVK_TILE_WAIT, ended the wait.
    const bool by_display = !input.first_split_frame && display.time && wait < input.tile_wait;
    const auto deadline = input.now + wait;
    const auto all_ready = [&](std::chrono::steady_clock::time_point until) {
        for (const Owed &o : owed)
            if (!o.agent->tiles->wait_ready(frame, until)) return false;
        return true;
    };
    exposure.look();
    while (!exposure.seen && exposure.done &&
           !all_ready(std::min(deadline, std::chrono::steady_clock::now() + kExposurePoll)) &&
           std::chrono::steady_clock::now() < deadline)
        exposure.look();
    const auto same = [](const VkRect2D &a, const VkRect2D &b) {
        return a.offset.x == b.offset.x && a.offset.y == b.offset.y && a.extent.width == b.extent.width &&
               a.extent.height == b.extent.height;
    };
    std::vector<std::shared_ptr<const FrameTiles>> came;
    bool flagged = false;
    std::string late_why;
    for (const Owed &o : owed) {
        Session::Agent &agent = *o.agent;
        auto tiles = agent.tiles->take(frame, deadline);
        if (tiles && tiles->invalid) {
            // Never a wrong fovea on screen: the agent says its GPU could not draw this frame as the
            // client asked (server-agent/limit_guard.h), so its foveae stay the periphery's.
            flagged = true;
            continue;
        }
        bool match = false;
        if (periphery_parts) {
            match = tiles && tiles->periphery && tiles->tiles.size() == periphery_parts->size();
            for (size_t i = 0; match && i < periphery_parts->size(); ++i)
                match = tiles->tiles[i].layer == 0 && same((*periphery_parts)[i], tiles->tiles[i].rect);
        } else {
            match = tiles && !tiles->periphery && tiles->tiles.size() == o.foveae.size();
            for (size_t i = 0; match && i < o.foveae.size(); ++i)
                match = o.foveae[i].layer == tiles->tiles[i].layer &&
                        same(o.foveae[i].rect, tiles->tiles[i].rect);
        }
        if (match) {
            if (agent.awaiting_first_tiles.exchange(false)) {
                const auto now = std::chrono::steady_clock::now();
                const std::string eye = several ? "; eye " + std::to_string(agent.index + 1) : std::string();
                if (agent.joined_in_place_of.empty())
                    SPLITVK_INFO(
                        "frame %llu: the first split frame from the agent that joined, %.0f ms after it "
                        "answered%s",
                        static_cast<unsigned long long>(frame), ms_between(agent.joined_agent_answered, now),
                        eye.c_str());
                else
                    SPLITVK_INFO(
                        "frame %llu: the first split frame from the agent that joined, %.0f ms after it "
                        "answered, %.0f ms after splitvk-agent at %s went away%s",
                        static_cast<unsigned long long>(frame), ms_between(agent.joined_agent_answered, now),
                        ms_between(agent.joined_after_loss_at, now), agent.joined_in_place_of.c_str(),
                        eye.c_str());
            }
            came.push_back(std::move(tiles));
            continue;
        }
        if (!late_why.empty()) continue; // one reason per line
        late_why = tiles ? (periphery_parts ? "the agent's periphery does not match the frame's"
                                            : "the agent's tiles do not match the frame's foveae")
                   : !agent.live.load() ? "the agent went away before its tiles came"
                   : by_display         ? "no tiles from the agent in time for its display (" +
                                      std::to_string(wait_ms) + " ms were left)"
                                : "no tiles from the agent within " + std::to_string(wait_ms) + " ms";
        if (several) late_why = "eye " + std::to_string(agent.index + 1) + ": " + late_why;
    }
    if (flagged) {
        const uint64_t invalid = session.invalid_frames.fetch_add(1);
        if (invalid % 100 == 0)
            SPLITVK_WARN(
                "frame %llu: the agent's GPU could not render it correctly (its log says why); %s (%llu "
                "such frames)",
                static_cast<unsigned long long>(frame), instead,
                static_cast<unsigned long long>(invalid + 1));
    }
    if (!late_why.empty()) {
        const uint64_t late = session.late_frames.fetch_add(1);
        // One line for the first late frame, then one per hundred: a stalled agent must not flood.
        if (late % 100 == 0)
            SPLITVK_WARN("frame %llu: %s; %s (%llu such frames)", static_cast<unsigned long long>(frame),
                         late_why.c_str(),
                         several && !came.empty() ? "that eye's centre is the periphery's" : instead,
                         static_cast<unsigned long long>(late + 1));
        if (session.live())
            warn_if_late_dominates(session, late + 1, session.settings().tile_wait_ms, by_display);
    }
    if (came.size() <= 1) return came.empty() ? nullptr : std::move(came.front());
    // The eyes' tiles as one frame's: their tiles, bytes and agents together, the slowest agent's times.
    auto merged = std::make_shared<FrameTiles>(*came.front());
    for (size_t i = 1; i < came.size(); ++i) {
        const FrameTiles &more = *came[i];
        merged->tiles.insert(merged->tiles.end(), more.tiles.begin(), more.tiles.end());
        merged->bytes += more.bytes;
        merged->received = std::max(merged->received, more.received);
        merged->decode = std::max(merged->decode, more.decode);
        merged->agent_address += "+" + more.agent_address;
        protocol::AgentTimings &t = merged->agent;
        t.draw_us = std::max(t.draw_us, more.agent.draw_us);
        t.readback_us = std::max(t.readback_us, more.agent.readback_us);
        t.encode_us = std::max(t.encode_us, more.agent.encode_us);
        t.present_to_send_us = std::max(t.present_to_send_us, more.agent.present_to_send_us);
    }
    return merged;
}

// The rectangles of a frame's foveae in its image's first layer: what the swapped split's composite
// keeps of the client's pixels, and what its verification compares exactly.
std::vector<VkRect2D> first_layer_foveae(const SplitFrame &split) {
    std::vector<VkRect2D> rects;
    for (const split::LayerFovea &fovea : split.foveae)
        if (fovea.layer == 0) rects.push_back(fovea.rect);
    return rects;
}

// Whether a frame's passes were cut to its foveae (the swapped split), so that its periphery is the
// agent's to fill. An OpenXR eye image's passes are cut only where its image has one layer
// (capture/render_pass.cpp: cut_runtime_target).
bool frame_cut(const SwapchainState *swapchain, const SplitFrame &split) {
    return swapchain && split.split && split.cut && !split.foveae.empty();
}

// A split frame on its way from the application's present to the driver's.
struct SplitPresent {
    VkQueue queue = VK_NULL_HANDLE;
    const SwapchainState *swapchain = nullptr;
    uint32_t image_index = 0;
    SplitFrame split;
    // The swapped split: the frame's passes were cut to its foveae, so the agent's periphery goes
    // around them (Compositor::composite_periphery). Decided at the application's present.
    bool cut = false;
    // A cut frame keeps the client's foveae. Not an OpenXR eye image whose passes were cut by other
    // eyes than its foveae are placed by (its views changed between its recording and its release):
    // its foveae may lie where the client drew nothing, and it shows the agent's periphery alone.
    bool keep_foveae = true;
    // Presented while the session passes frames through (Session::passing_through()): drawn split
    // before the switch, it has no tiles to wait for, and shows the periphery alone.
    bool passing_through = false;
    uint64_t frame = 0;
    std::chrono::steady_clock::time_point sent{};   // FramePresent
    double frame_ms = 0;                            // Session::frame_interval_ms() at the app's present
    double present_call_ms = 0;                     // the app's present, when the thread has the frame
    std::chrono::steady_clock::time_point called{}; // the app's present began
    // The application's acquire of the presented image returned (FrameRecord::frame_latency_ms).
    std::optional<std::chrono::steady_clock::time_point> acquired;
    Session::FrameSizing sizing; // SPLITVK_FOVEA=auto
    // An OpenXR eye image's display time: its tiles are awaited only while it can still meet it.
    deadline::FrameDisplay display;
    int64_t xr_frame = -1; // an OpenXR eye image's (FrameRecord::xr_frame)
    int32_t xr_view = -1;
    uint32_t first_eye = 0; // FramePresent::first_eye
    // Asynchronous: take_waits() has consumed the application's semaphores into `taken`, whose
    // batch signals `done`.
    Compositor *compositor = nullptr;
    VkSemaphore taken = VK_NULL_HANDLE;
    VkFence done = VK_NULL_HANDLE;
};

// Split mode: waits for the frame's tiles and composites them over the upsampled periphery on
// `p.queue`. `waits`: the application's present semaphores (synchronous) or {p.taken}. Returns
// the semaphore the present must wait on instead of `waits`, or VK_NULL_HANDLE when `waits` are
// untouched (the present then goes ahead as the app asked). `lock`: take the queue's lock around
// the submits (the present thread; the application's thread holds it already). `held`: the
// frame's SPLITVK_STATS row is left there for the caller to complete (verification measures the
// frame after its present) and record, instead of being recorded here.
VkSemaphore composite_split_frame(DeviceState &dev, SplitPresent &p, std::span<const VkSemaphore> waits,
                                  bool lock, FrameRecord *held = nullptr) {
    using Clock = std::chrono::steady_clock;
    Session &session = *dev.session;
    FrameRecord record;
    record.frame = p.frame;
    record.frame_ms = p.frame_ms;
    record.xr_frame = p.xr_frame;
    record.xr_view = p.xr_view;
    if (!p.split.foveae.empty()) record.fovea = p.split.foveae.front().rect;
    const bool stats = !session.settings().stats_path.empty();
    AutoFovea *sizing = session.auto_fovea();

    Compositor *compositor = p.compositor;
    if (!compositor) compositor = compositor_for(dev, *p.swapchain, queue_family_of(dev, p.queue), stats);
    // Synchronous, only for the CSV and the fovea's sizing: the application's semaphores go to an
    // empty submit of the compositor's, whose fence tells when the GPU has finished the frame
    // (exposed_wait_ms).
    Exposure exposure{&dev};
    VkSemaphore taken = p.taken;
    if (stats || sizing) exposure.done = p.done;
    // A runtime's image has no semaphores to take (swapchain.h: the queue orders it).
    if (!taken && (stats || sizing) && compositor && !p.swapchain->runtime &&
        compositor->take_waits(p.queue, p.image_index, waits, &taken, &exposure.done) == VK_SUCCESS)
        waits = {&taken, 1};

    const auto wait_start = Clock::now();
    const uint64_t invalid_before = session.invalid_frames.load();
    const uint64_t late_before = session.late_frames.load();
    // The swapped split: a frame whose passes ran whole (before an agent was there to render the
    // periphery, or after it went) is shown as drawn, and no tiles are awaited for it.
    const bool swapped = session.client_renders() == ClientRenders::Fovea;
    std::vector<VkRect2D> parts;
    if (p.cut)
        parts = split::periphery_parts(split::scaled_extent(p.swapchain->extent, session.settings().scale));
    // Keeps the pixels alive through composite().
    const auto tiles = (swapped && !p.cut) || p.passing_through
                           ? nullptr
                           : frame_tiles(session, p.frame, p.split, exposure, p.display,
                                         p.display.time ? p.swapchain->composite_cost.estimate()
                                                        : deadline::Clock::duration::zero(),
                                         p.first_eye, p.cut ? &parts : nullptr);
    const auto waited = Clock::now();
    record.tile_wait_ms = ms_between(wait_start, waited);
    if (exposure.seen) record.exposed_wait_ms = ms_between(std::max(wait_start, exposure.since), waited);
    std::vector<FoveaTile> foveae;
    PeripheryImage periphery; // the swapped split's: the agent's parts
    if (tiles) {
        periphery.extent = tiles->periphery_extent;
        for (const DecodedTile &tile : tiles->tiles) {
            // Every tile of a frame that decoded has its buffer; without one, the periphery shows.
            if (!tile.upload) continue;
            // Copied by the GPU straight from where the tile was decoded (UploadPool).
            (p.cut ? periphery.parts : foveae)
                .push_back({tile.rect, tile.upload->buffer, 0, tile.upload, tile.layer, tile.texel_bytes});
            record.raw_bytes += uint64_t{tile.rect.extent.width} * tile.rect.extent.height * tile.texel_bytes;
        }
        const double decode_ms = std::chrono::duration<double, std::milli>(tiles->decode).count();
        (p.cut ? record.periphery_bytes : record.tile_bytes) = tiles->bytes;
        (p.cut ? record.periphery_decode_ms : record.decode_ms) = decode_ms;
        record.agent = tiles->agent_address;
        record.agent_draw_ms = tiles->agent.draw_us / 1000.0;
        record.agent_readback_ms = tiles->agent.readback_us / 1000.0;
        record.agent_encode_ms = tiles->agent.encode_us / 1000.0;
        record.network_ms =
            std::max(0.0, ms_between(p.sent, tiles->received) - tiles->agent.present_to_send_us / 1000.0);
    }
    // A frame the agent flagged came on time; it is not late, only not usable. With an agent per eye,
    // a frame with some of its foveae missing (their agent late, gone or not yet joined) is late.
    // A frame the swapped split drew whole awaited nothing.
    const bool whole = tiles && (p.cut || tiles->tiles.size() == p.split.foveae.size());
    record.late = (tiles ? !whole : session.invalid_frames.load() == invalid_before) && !(swapped && !p.cut);

    VkSemaphore composited = VK_NULL_HANDLE;
    if (compositor && swapped && !p.cut) {
        composited = taken; // drawn whole: presented as it is
    } else if (compositor && p.cut) {
        // The client's foveae stay, the agent's periphery goes around them, feathered into them
        // across the band the client's cut grew them by (split_settings(), as cut_scissor's);
        // late, invalid or mismatched: the previous periphery again, feathered alike (VK_NOT_READY
        // before any: as drawn).
        const std::vector<VkRect2D> keep =
            p.keep_foveae ? first_layer_foveae(p.split) : std::vector<VkRect2D>{};
        auto queue_lock = lock ? lock_queue(dev, p.queue) : std::unique_lock<std::mutex>();
        if (compositor->composite_periphery(p.queue, p.image_index, waits, tiles ? &periphery : nullptr, keep,
                                            p.swapchain->runtime ? nullptr : &composited,
                                            split_settings().seam.feather) != VK_SUCCESS)
            composited = taken;
    } else if (compositor) {
        auto queue_lock = lock ? lock_queue(dev, p.queue) : std::unique_lock<std::mutex>();
        if (compositor->composite(p.queue, p.image_index, waits, p.split.periphery, foveae,
                                  p.swapchain->runtime ? nullptr : &composited) != VK_SUCCESS)
            composited = taken; // VK_NULL_HANDLE unless take_waits() consumed the application's semaphores
    } else {
        composited = taken;
    }
    const auto composited_at = Clock::now();
    record.merge_ms = ms_between(waited, composited_at);
    record.present_call_ms = p.taken ? p.present_call_ms : ms_between(p.called, composited_at);
    record.present_to_composite_ms = ms_between(p.called, composited_at);
    if (composited && composited != taken) session.composited_frames.fetch_add(1);
    // After the composite: reading the periphery's timestamps may stall the present on some
    // drivers (gpu_timing.h), and that must not count as tile wait or merge.
    if (stats) {
        record.periphery_ms = latest_periphery_ms(dev);
        if (compositor) record.merge_gpu_ms = compositor->latest_gpu_ms();
    }
    // What the next frames' deadlines must leave for their composite: recording and submitting it,
    // and its GPU time where the timestamps are kept (SPLITVK_STATS; without them, the CPU's part).
    if (p.display.time && tiles)
        p.swapchain->composite_cost.add(std::chrono::duration_cast<deadline::Clock::duration>(
            std::chrono::duration<double, std::milli>(record.merge_ms + record.merge_gpu_ms)));
    if (held)
        *held = record;
    else
        session.stats().record(record);
    // Late for the sizing only when an agent was there with this frame and its tiles did not come:
    // frames without an agent (or before a joining one's first) say nothing about the fovea, and
    // counting them would shrink it to nothing through every reconnect.
    const bool late_from_agent = session.late_frames.load() != late_before && session.live();
    if (sizing && p.sizing.heard && !p.split.foveae.empty() && (tiles || late_from_agent)) {
        FoveaFrameCost cost;
        cost.size = p.split.fovea_size;
        cost.late = !tiles;
        cost.frame_ms = p.sizing.frame_ms;
        // A runtime's image has no semaphores to tell when the client's own work was done (no
        // fence to look at): all of its wait counts. With the fence, a wait that ended before it
        // signalled exposed nothing.
        cost.exposed_wait_ms = exposure.done ? record.exposed_wait_ms : record.tile_wait_ms;
        cost.fovea_path_ms =
            record.agent_readback_ms + record.agent_encode_ms + record.network_ms + record.decode_ms;
        cost.tile_bytes = record.tile_bytes;
        sizing->observe(cost);
    }
    return composited;
}

// ---------------------------------------------------------------------------- asynchronous presents

// VK_SUCCESS < VK_SUBOPTIMAL_KHR < other errors < out of date < surface lost < device lost: what the
// application must hear first when several presents answered before it asked again.
int severity(VkResult r) {
    switch (r) {
    case VK_SUCCESS:
        return 0;
    case VK_SUBOPTIMAL_KHR:
        return 1;
    case VK_ERROR_OUT_OF_DATE_KHR:
        return 3;
    case VK_ERROR_SURFACE_LOST_KHR:
        return 4;
    case VK_ERROR_DEVICE_LOST:
        return 5;
    default:
        return r < 0 ? 2 : 0;
    }
}

VkResult worse(VkResult a, VkResult b) {
    return severity(b) > severity(a) ? b : a;
}

// What the asynchronous present knows of a swapchain, under the table's async_mutex.
struct SwapchainPresents {
    std::vector<uint32_t> held;     // image indices acquired by the application, not presented by it yet
    std::vector<uint32_t> queued;   // presented by the application, not by the present thread yet
    VkResult deferred = VK_SUCCESS; // the worst result of the thread's presents the app has not had
    // The application drew into an image it did not hold (see the top of this file, "Order"):
    // from then on its acquires reach the driver only after the thread's presents.
    bool in_order = false;
    std::optional<uint32_t> stray; // the image it drew into, until its next present
};

void erase_one(std::vector<uint32_t> &v, uint32_t value) {
    if (const auto it = std::find(v.begin(), v.end(), value); it != v.end()) v.erase(it);
}

bool contains(const std::vector<uint32_t> &v, uint32_t value) {
    return std::find(v.begin(), v.end(), value) != v.end();
}

struct PresentThread {
    std::thread thread;
    std::deque<SplitPresent> frames;
    uint32_t in_layer = 0; // frames reserved, queued or being presented
    bool stopping = false;
};

// A copy of one swapchain image into another of the same swapchain ("Order"): its command buffer,
// its fence, and the semaphore the present waits on. Its lock is held while it is recorded and
// submitted (after a wait for its previous copy), which concerns that swapchain's presents only.
struct Redirect {
    std::mutex mutex; // what follows
    VkCommandPool pool = VK_NULL_HANDLE;
    VkCommandBuffer command_buffer = VK_NULL_HANDLE;
    VkFence fence = VK_NULL_HANDLE;
    VkSemaphore semaphore = VK_NULL_HANDLE;
    bool in_flight = false;
};

} // namespace

struct PresentTable {
    std::mutex async_mutex; // `thread`'s queue and counts, and `swapchains`
    std::condition_variable async_changed;
    std::unique_ptr<PresentThread> thread; // made at the first asynchronous present
    std::unordered_map<VkSwapchainKHR, SwapchainPresents> swapchains;
    // The map only: held for a lookup, never while a copy is recorded or waited for.
    std::mutex redirects_mutex;
    std::map<VkSwapchainKHR, std::shared_ptr<Redirect>> redirects;
};

std::shared_ptr<PresentTable> make_present_table() {
    return std::make_shared<PresentTable>();
}

namespace {

// The present thread's half of a frame: its tiles, the composite and the real present.
VkResult present_split_frame(DeviceState &dev, SplitPresent &p) {
    const VkSemaphore taken = p.taken;
    FrameRecord record;
    VkSemaphore wait = composite_split_frame(dev, p, {&taken, 1}, /*lock=*/true, &record);
    if (!wait) wait = taken;
    VkPresentInfoKHR present{};
    present.sType = VK_STRUCTURE_TYPE_PRESENT_INFO_KHR;
    present.waitSemaphoreCount = 1;
    present.pWaitSemaphores = &wait;
    present.swapchainCount = 1;
    const VkSwapchainKHR swapchain = p.swapchain->handle;
    present.pSwapchains = &swapchain;
    present.pImageIndices = &p.image_index;
    VkResult result;
    {
        const auto lock = lock_queue(dev, p.queue);
        result = dev.dispatch.QueuePresentKHR(p.queue, &present);
    }
    record.frame_latency_ms = latency_ms(p.acquired, std::chrono::steady_clock::now());
    dev.session->stats().record(record);
    return result;
}

void run_present_thread(DeviceState &dev, PresentThread &t) {
    PresentTable &table = *dev.presents;
    std::unique_lock lock(table.async_mutex);
    for (;;) {
        table.async_changed.wait(lock, [&] { return t.stopping || !t.frames.empty(); });
        if (t.frames.empty()) return; // stopping, and every frame presented
        SplitPresent p = std::move(t.frames.front());
        t.frames.pop_front();
        lock.unlock();
        const VkResult result = present_split_frame(dev, p);
        if (result != VK_SUCCESS)
            SPLITVK_INFO(
                "present thread: frame %llu: vkQueuePresentKHR answered %s; the application hears it "
                "at its next present or acquire",
                static_cast<unsigned long long>(p.frame), vk_result_name(result));
        lock.lock();
        SwapchainPresents &sc = table.swapchains[p.swapchain->handle];
        erase_one(sc.queued, p.image_index);
        sc.deferred = worse(sc.deferred, result);
        --t.in_layer;
        table.async_changed.notify_all();
    }
}

// The application's half: takes the frame (its semaphores) and queues it for the present thread,
// after waiting for room. The result for the application: what the thread's earlier presents of
// this swapchain answered. std::nullopt: nothing was taken, present synchronously.
std::optional<VkResult> present_async(DeviceState &dev, SplitPresent &p, std::span<const VkSemaphore> waits) {
    Session &session = *dev.session;
    p.compositor = compositor_for(dev, *p.swapchain, queue_family_of(dev, p.queue),
                                  !session.settings().stats_path.empty());
    if (!p.compositor) return std::nullopt;
    PresentTable &table = *dev.presents;
    PresentThread *t = nullptr;
    {
        std::unique_lock lock(table.async_mutex);
        auto &slot = table.thread;
        if (!slot) {
            slot = std::make_unique<PresentThread>();
            slot->thread = std::thread([&dev, thread = slot.get()] { run_present_thread(dev, *thread); });
        }
        t = slot.get();
        const uint32_t depth = session.settings().present_depth;
        table.async_changed.wait(lock, [&] { return t->in_layer < depth; });
        ++t->in_layer;
    }
    VkResult taken;
    {
        const auto queue_lock = lock_queue(dev, p.queue);
        taken = p.compositor->take_waits(p.queue, p.image_index, waits, &p.taken, &p.done);
    }
    std::lock_guard lock(table.async_mutex);
    if (taken != VK_SUCCESS) {
        --t->in_layer;
        table.async_changed.notify_all();
        return std::nullopt;
    }
    SwapchainPresents &sc = table.swapchains[p.swapchain->handle];
    sc.queued.push_back(p.image_index);
    erase_one(sc.held, p.image_index);
    sc.stray.reset();
    const VkResult result = sc.deferred;
    sc.deferred = VK_SUCCESS;
    p.present_call_ms = ms_between(p.called, std::chrono::steady_clock::now());
    t->frames.push_back(std::move(p));
    table.async_changed.notify_all();
    return result;
}

// Before the driver's acquire: an error a present thread's present answered, returned instead of
// acquiring; else waits until one more acquired image stays within the surface's allowance, or,
// for a swapchain whose application depends on the order of its images, until the thread has
// presented every frame of it (so the driver picks the image it would have picked without the
// layer).
VkResult before_acquire(const DeviceState &dev, VkSwapchainKHR swapchain) {
    if (!dev.session) return VK_SUCCESS;
    const SwapchainState *state = find_swapchain(dev, swapchain);
    const uint32_t allowance = state ? state->acquire_allowance : 0;
    PresentTable &table = *dev.presents;
    std::unique_lock lock(table.async_mutex);
    const auto it = table.swapchains.find(swapchain);
    if (it == table.swapchains.end()) return VK_SUCCESS;
    SwapchainPresents &sc = it->second;
    if (sc.deferred < 0) return std::exchange(sc.deferred, VK_SUCCESS);
    table.async_changed.wait(lock, [&] {
        return sc.queued.empty() || (!sc.in_order && sc.held.size() + sc.queued.size() < allowance);
    });
    if (sc.deferred < 0) return std::exchange(sc.deferred, VK_SUCCESS);
    return VK_SUCCESS;
}

// After the driver's acquire: the image counts as the application's, and a suboptimal answer of
// the thread's reaches it here if its acquire succeeded.
VkResult after_acquire(const DeviceState &dev, VkSwapchainKHR swapchain, VkResult result, uint32_t index) {
    if (!dev.session || (result != VK_SUCCESS && result != VK_SUBOPTIMAL_KHR)) return result;
    std::lock_guard lock(dev.presents->async_mutex);
    SwapchainPresents &sc = dev.presents->swapchains[swapchain];
    sc.held.push_back(index);
    if (sc.deferred == VK_SUBOPTIMAL_KHR) {
        sc.deferred = VK_SUCCESS;
        return VK_SUBOPTIMAL_KHR;
    }
    return result;
}

// The application presented these images synchronously: they are no longer its own, and what the
// present thread's earlier presents of the same swapchains answered joins the driver's answers.
VkResult note_presented(const DeviceState &dev, const VkPresentInfoKHR &info, VkResult result) {
    PresentTable &table = *dev.presents;
    std::lock_guard lock(table.async_mutex);
    for (uint32_t i = 0; i < info.swapchainCount; ++i) {
        const auto it = table.swapchains.find(info.pSwapchains[i]);
        if (it == table.swapchains.end()) continue;
        erase_one(it->second.held, info.pImageIndices[i]);
        it->second.stray.reset();
        const VkResult deferred = std::exchange(it->second.deferred, VK_SUCCESS);
        if (info.pResults) info.pResults[i] = worse(info.pResults[i], deferred);
        result = worse(result, deferred);
    }
    return result;
}

// The image the application drew into while it did not hold it, when it now presents another
// one, `presented` (see the top of this file, "Order"); cleared either way.
std::optional<uint32_t> take_stray(const DeviceState &dev, VkSwapchainKHR swapchain, uint32_t presented) {
    PresentTable &table = *dev.presents;
    std::lock_guard lock(table.async_mutex);
    const auto it = table.swapchains.find(swapchain);
    if (it == table.swapchains.end()) return std::nullopt;
    const auto stray = std::exchange(it->second.stray, std::nullopt);
    return stray && *stray != presented ? stray : std::nullopt;
}

// Under r.mutex.
void destroy(DeviceState &dev, Redirect &r) {
    const VkDevice d = dev.handle;
    if (r.in_flight) dev.dispatch.WaitForFences(d, 1, &r.fence, VK_TRUE, kFenceWaitNs);
    if (r.semaphore) dev.dispatch.DestroySemaphore(d, r.semaphore, nullptr);
    if (r.fence) dev.dispatch.DestroyFence(d, r.fence, nullptr);
    if (r.pool) dev.dispatch.DestroyCommandPool(d, r.pool, nullptr);
    r.pool = VK_NULL_HANDLE;
    r.command_buffer = VK_NULL_HANDLE;
    r.fence = VK_NULL_HANDLE;
    r.semaphore = VK_NULL_HANDLE;
    r.in_flight = false;
}

bool create(DeviceState &dev, uint32_t family, Redirect &r) {
    if (create_command_pool(dev, family, VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT, &r.pool) !=
            VK_SUCCESS ||
        allocate_primary_command_buffer(dev, r.pool, &r.command_buffer) != VK_SUCCESS)
        return false;
    return create_fence(dev, &r.fence) == VK_SUCCESS && create_semaphore(dev, &r.semaphore) == VK_SUCCESS;
}

// Submits on `queue` (its lock held) a copy of the whole image `from` into image `to`, which the
// application acquired and presents but did not draw: after `waits` (consumed), leaving both in
// the present layout. Returns the semaphore the present waits on instead, or VK_NULL_HANDLE when
// nothing was submitted (`waits` untouched).
VkSemaphore copy_swapchain_image(DeviceState &dev, VkQueue queue, const SwapchainState &sc, uint32_t from,
                                 uint32_t to, std::span<const VkSemaphore> waits) {
    const uint32_t family = queue_family_of(dev, queue);
    if (family == UINT32_MAX || from >= sc.images.size() || to >= sc.images.size()) return VK_NULL_HANDLE;
    const auto &k = dev.dispatch;
    std::shared_ptr<Redirect> slot;
    {
        PresentTable &table = *dev.presents;
        std::lock_guard lock(table.redirects_mutex);
        std::shared_ptr<Redirect> &found = table.redirects[sc.handle];
        if (!found) found = std::make_shared<Redirect>();
        slot = found;
    }
    Redirect &r = *slot;
    std::lock_guard lock(r.mutex);
    if (!r.pool && !create(dev, family, r)) {
        destroy(dev, r);
        return VK_NULL_HANDLE;
    }
    if (r.in_flight) {
        if (k.WaitForFences(dev.handle, 1, &r.fence, VK_TRUE, kFenceWaitNs) != VK_SUCCESS)
            return VK_NULL_HANDLE;
        r.in_flight = false;
    }
    k.ResetFences(dev.handle, 1, &r.fence);
    k.ResetCommandBuffer(r.command_buffer, 0);
    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    k.BeginCommandBuffer(r.command_buffer, &begin);
    // The submit waits at the TRANSFER stage, the barriers' source stage: the transitions follow
    // the waits. `to` holds nothing the application drew: its old contents are not needed.
    const VkImageMemoryBarrier before[2] = {
        colour_image_barrier(sc.images[from], 0, VK_ACCESS_TRANSFER_READ_BIT, sc.present_layout,
                             VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL),
        colour_image_barrier(sc.images[to], 0, VK_ACCESS_TRANSFER_WRITE_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                             VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL),
    };
    k.CmdPipelineBarrier(r.command_buffer, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0,
                         0, nullptr, 0, nullptr, 2, before);
    VkImageCopy copy{};
    copy.srcSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    copy.dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    copy.extent = {sc.extent.width, sc.extent.height, 1};
    k.CmdCopyImage(r.command_buffer, sc.images[from], VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, sc.images[to],
                   VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &copy);
    // The present waits on the semaphore, whose signal makes the copy's writes visible to it.
    const VkImageMemoryBarrier after[2] = {
        colour_image_barrier(sc.images[from], 0, 0, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, sc.present_layout),
        colour_image_barrier(sc.images[to], VK_ACCESS_TRANSFER_WRITE_BIT, 0,
                             VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, sc.present_layout),
    };
    k.CmdPipelineBarrier(r.command_buffer, VK_PIPELINE_STAGE_TRANSFER_BIT,
                         VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, 0, 0, nullptr, 0, nullptr, 2, after);
    if (k.EndCommandBuffer(r.command_buffer) != VK_SUCCESS) return VK_NULL_HANDLE;
    const std::vector<VkPipelineStageFlags> stages(waits.size(), VK_PIPELINE_STAGE_TRANSFER_BIT);
    const VkSubmitInfo submit = submit_info(&r.command_buffer, waits, stages.data(), &r.semaphore);
    if (k.QueueSubmit(queue, 1, &submit, r.fence) != VK_SUCCESS) return VK_NULL_HANDLE;
    r.in_flight = true;
    return r.semaphore;
}

// This present answers VK_ERROR_OUT_OF_DATE_KHR, unless the driver's answer is worse, when the
// application must record its command buffers again, which one that records them once would never do
// by itself: the swapped split lost its agent (Session::take_forced_out_of_date: cutting() is false
// now, the frames are recorded whole), or SPLITVK_SPLIT=auto switched between splitting and passing
// through (Session::take_payoff_out_of_date: the targets are made again too, for the new mode). The
// image was presented; the application recreates its swapchain, and the switch takes effect then.
VkResult forced_out_of_date(Session &session, const VkPresentInfoKHR &info, VkResult result) {
    if (session.take_forced_out_of_date()) {
        SPLITVK_INFO(
            "present: the agent that rendered the periphery is gone: this present answers "
            "VK_ERROR_OUT_OF_DATE_KHR once, so that the application records its frames again, whole");
    } else if (!session.take_payoff_out_of_date()) {
        return result;
    }
    for (uint32_t i = 0; info.pResults && i < info.swapchainCount; ++i)
        info.pResults[i] = worse(info.pResults[i], VK_ERROR_OUT_OF_DATE_KHR);
    return worse(result, VK_ERROR_OUT_OF_DATE_KHR);
}

// A frame passed through (SPLITVK_SPLIT=auto): a row of the statistics with no fovea, and no tiles of
// its own or older kept waiting.
void note_passed_through(Session &session, uint64_t frame, double frame_ms,
                         std::optional<double> frame_latency_ms) {
    for (const auto &agent : session.agents())
        if (agent->tiles) agent->tiles->take(frame, std::chrono::steady_clock::now());
    FrameRecord record;
    record.frame = frame;
    record.frame_ms = frame_ms;
    record.passed_through = true;
    record.frame_latency_ms = frame_latency_ms;
    session.stats().record(record);
}

// Frames replayed with no split pass before the warning: an application may present a few copied
// frames (a splash screen) before it renders; most present none.
constexpr uint64_t kUnsplitFramesBeforeWarning = 100;

void warn_unsplit(Session &session) {
    if (session.split_frames.load() > 0 || session.unsplit_warned.exchange(true)) return;
    SPLITVK_WARN(
        "split: %llu frames forwarded to the agent, none split: nothing the layer can scale drew into a "
        "presented swapchain image (no render pass with inline contents or secondaries it could "
        "predict, no copy, blit or resolve; a compute shader writing the swapchain image is not "
        "scaled), so the agent replays every frame and the frames shown are the application's own",
        static_cast<unsigned long long>(session.unsplit_frames.load()));
}

// Counts the frame a live agent replays as split or not, and warns once when none ever is.
void note_split_or_not(Session &session, uint64_t frame, bool split) {
    if (!session.live() || frame < session.first_replayed_frame()) return;
    if (split) {
        session.split_frames.fetch_add(1);
    } else if (session.unsplit_frames.fetch_add(1) + 1 == kUnsplitFramesBeforeWarning) {
        warn_unsplit(session);
    }
}

// SPLITVK_STATS: the application has this image from now on (FrameRecord::frame_latency_ms).
void note_acquired(DeviceState &dev, VkSwapchainKHR swapchain, VkResult result, uint32_t index) {
    if (!dev.session || !dev.session->has_stats() || (result != VK_SUCCESS && result != VK_SUBOPTIMAL_KHR))
        return;
    dev.session->acquire_times().acquired(codec::handle_value(swapchain), index,
                                          std::chrono::steady_clock::now());
}

// The acquires the application's present ends, taken out for every swapchain it presents (the first
// one's is the frame's).
std::optional<std::chrono::steady_clock::time_point> take_acquired(Session &session,
                                                                   const VkPresentInfoKHR &info) {
    std::optional<std::chrono::steady_clock::time_point> first;
    if (!session.has_stats()) return first;
    for (uint32_t i = 0; i < info.swapchainCount; ++i) {
        const auto at =
            session.acquire_times().take(codec::handle_value(info.pSwapchains[i]), info.pImageIndices[i]);
        if (i == 0) first = at;
    }
    return first;
}

// Whether an OpenXR eye image's cut passes were all cut by the eyes of `eyes_version`, which its
// foveae are placed with (SplitPresent::keep_foveae); said once when not.
bool eyes_cut_by(uint64_t eyes_version, const SplitFrame &split, uint64_t frame) {
    if (split.cut_eyes >= 0 && static_cast<uint64_t>(split.cut_eyes) == eyes_version) return true;
    static std::once_flag logged;
    std::call_once(logged, [&] {
        SPLITVK_INFO("frame %llu: an OpenXR eye image's passes were cut by other views than its release "
                     "places its foveae by; such an image shows the agent's periphery alone",
                     static_cast<unsigned long long>(frame));
    });
    return false;
}

} // namespace

void begin_runtime_frame(DeviceState &dev, const SwapchainState &swapchain, uint32_t image_index) {
    if (!capturing(dev)) return;
    protocol::FrameBegin message{dev.session->current_frame(), codec::handle_value(swapchain.handle),
                                 image_index};
    dev.session->send_metadata(protocol::MessageType::FrameBegin, protocol::encode(message));
}

void end_runtime_frame(DeviceState &dev, VkQueue queue, const SwapchainState &swapchain, uint32_t image_index,
                       const std::vector<split::RuntimeEye> &eyes, const split::Gaze &gaze, uint64_t xr_frame,
                       int32_t xr_view, const deadline::FrameDisplay &display) {
    if (!dev.session || image_index >= swapchain.images.size()) return;
    const auto called = std::chrono::steady_clock::now();
    Session &session = *dev.session;
    const uint64_t frame = session.take_frame();
    // Everything happens on the application's thread, as presents with SPLITVK_PRESENT_DEPTH=0 do:
    // the runtime's release barrier follows at once on the same queue, and it must find the image
    // composited.
    drain_presents(dev);
    auto queue_lock = lock_queue(dev, queue);
    if (session.resync_pending()) session.resync(dev, queue, frame);
    if (frame == 1) log_live_state(dev, "at frame 1"); // SPLITVK_LOG_LEVEL=debug
    protocol::FramePresent message;
    const Session::FrameSizing sizing = session.size_frame(static_cast<int64_t>(xr_frame), 0);
    message.fovea_size = sizing.size;
    SplitFrame split;
    uint64_t cut_eyes_version = 0;
    if (session.splitting() && swapchain.composable) {
        split = take_split_frame(dev, swapchain.images[image_index], EyeMode::One, {}, message.fovea_size);
        // The eyes' foveae (one per layer before the application's views said where its eyes are),
        // each at its view direction or gaze point, wherever the passes drew. The swapped split keeps
        // the client's own where its passes were cut: by the eyes the swapchain's state holds
        // (core/swapchain.h), which the cut read at record time.
        const RuntimeEyes cut_by = split.cut ? runtime_eyes(swapchain) : RuntimeEyes{};
        cut_eyes_version = cut_by.version;
        if (!split.foveae.empty())
            split.foveae = split::runtime_eye_foveae(
                swapchain.extent, swapchain.array_layers, split.cut ? cut_by.eyes : eyes,
                split::frame_fovea_size(split_settings().fovea, message.fovea_size), gaze);
        // The swapped split renders a layered eye image whole by design (said once when its passes
        // were recorded, capture/render_pass.cpp): no news of the application's passes.
        if (session.client_renders() != ClientRenders::Fovea || swapchain.array_layers == 1)
            note_split_or_not(session, frame, split.split);
    }
    message.frame = frame;
    message.queue_id = codec::handle_value(queue);
    // The frame a resync brought an agent in at has no tiles of that agent's (send_frame_present).
    message.gaze = gaze;
    message.images.push_back({codec::handle_value(swapchain.handle), image_index});
    // A swapchain per eye: the image holds one eye, the view it was released for, whose number says
    // which agent sends its fovea (SPLITVK_AGENTS). An image of several eyes numbers them from 0.
    if (swapchain.array_layers == 1 && eyes.size() <= 1 && xr_view > 0)
        message.first_eye = std::min(static_cast<uint32_t>(xr_view), protocol::kMaxFirstEye - 1);
    // Verification: every layer of the image, as the runtime gets it. Nothing is composited into it
    // then: the paper's split is off, and the swapped split does not cut a runtime's images under
    // verification (cut_runtime_target).
    std::optional<PendingVerify> pending;
    if (session.verify()) pending = read_back_runtime_image(dev, queue, swapchain, image_index, frame);
    if (pending) message.flags |= protocol::kPresentVerify;
    session.send_frame_present(message);
    if (pending) {
        queue_lock = {};
        compare_verified_frame(dev, *pending);
    }
    if (!split.split) {
        // An eye image unsplit (verified, passed through, or without an agent): its row says when it
        // came and which frame it was of. A swapchain that is never split (a depth one) has none.
        if (session.has_stats() && swapchain.composable) {
            FrameRecord record;
            record.frame = frame;
            record.frame_ms = session.frame_interval_ms();
            record.xr_frame = static_cast<int64_t>(xr_frame);
            record.xr_view = xr_view;
            dev.session->stats().hold_eye_row(record);
        }
        return;
    }
    SplitPresent p;
    p.queue = queue;
    p.swapchain = &swapchain;
    p.image_index = image_index;
    p.split = std::move(split);
    p.frame = frame;
    p.sent = std::chrono::steady_clock::now();
    p.frame_ms = session.frame_interval_ms();
    p.called = called;
    p.sizing = sizing;
    p.xr_frame = static_cast<int64_t>(xr_frame);
    p.xr_view = xr_view;
    p.first_eye = message.first_eye;
    p.cut = frame_cut(p.swapchain, p.split);
    if (p.cut) p.keep_foveae = eyes_cut_by(cut_eyes_version, p.split, frame);
    if (session.settings().xr_deadline) p.display = display;
    FrameRecord record;
    composite_split_frame(dev, p, {}, /*lock=*/false, &record);
    dev.session->stats().hold_eye_row(record);
}

void finish_runtime_frame(DeviceState &dev, uint64_t xr_frame, std::optional<double> frame_latency_ms) {
    if (!dev.session || !dev.session->has_stats()) return;
    for (FrameRecord &row : dev.session->stats().take_eye_rows(xr_frame)) {
        // An earlier frame's rows are here only if that frame was never ended: no latency.
        if (static_cast<uint64_t>(row.xr_frame) == xr_frame) row.frame_latency_ms = frame_latency_ms;
        dev.session->stats().record(row);
    }
}

void send_runtime_view(DeviceState &dev, const SwapchainState &swapchain,
                       const protocol::SwapchainView &view) {
    if (!capturing(dev)) return;
    protocol::SwapchainView message = view;
    message.device_id = dev.session->device_id();
    message.swapchain_id = codec::handle_value(swapchain.handle);
    // Logged as the swapchain's, so that an agent joining later places the fovea as the client does. A
    // killer as well as a holder: a second entry of one holder would otherwise stand for a re-created
    // object and drop the first (SwapchainImages itself); this way each view only adds to it, the
    // latest replays last, and all go with the swapchain.
    const uint64_t id = message.swapchain_id;
    dev.session->send_metadata_logged(protocol::MessageType::SwapchainView, protocol::encode(message), id,
                                      std::span(&id, 1));
}

void drain_presents(DeviceState &device) {
    PresentTable &table = *device.presents;
    std::unique_lock lock(table.async_mutex);
    if (!table.thread) return;
    PresentThread &t = *table.thread;
    table.async_changed.wait(lock, [&] { return t.in_layer == 0; });
}

void stop_presents(DeviceState &device) {
    PresentTable &table = *device.presents;
    PresentThread *t = nullptr;
    {
        std::lock_guard lock(table.async_mutex);
        if (!table.thread) return;
        t = table.thread.get();
        t->stopping = true;
        table.async_changed.notify_all();
    }
    // It presents what it holds first: each frame bounded by SPLITVK_TILE_WAIT.
    t->thread.join();
    std::lock_guard lock(table.async_mutex);
    table.thread.reset();
    table.swapchains.clear();
}

void order_swapchain_writes(DeviceState &device, std::span<const uint64_t> images) {
    if (images.empty()) return;
    bool drain = false;
    {
        std::lock_guard lock(device.presents->async_mutex);
        for (auto &[handle, sc] : device.presents->swapchains) {
            const SwapchainState *state = find_swapchain(device, handle);
            // A shared present mode's image is acquired once and presented again and again.
            if (!state || state->present_layout == VK_IMAGE_LAYOUT_SHARED_PRESENT_KHR) continue;
            for (const uint64_t image : images) {
                const auto it = std::find_if(state->images.begin(), state->images.end(),
                                             [&](VkImage i) { return codec::handle_value(i) == image; });
                if (it == state->images.end()) continue;
                const auto index = static_cast<uint32_t>(it - state->images.begin());
                if (contains(sc.held, index)) continue;
                if (!sc.in_order)
                    SPLITVK_INFO(
                        "present: the application drew into swapchain image %u, which it had not acquired "
                        "(it uses its images in an order of its own, as gfxrecon-replay "
                        "--use-captured-swapchain-indices does); this swapchain's acquires now wait for "
                        "the present thread",
                        index);
                sc.in_order = true;
                sc.stray = index;
                drain = drain || contains(sc.queued, index);
            }
        }
    }
    // The present thread must be done with the image before the application's submit draws into it.
    if (drain) drain_presents(device);
}

void release_present_resources(DeviceState &device, VkSwapchainKHR swapchain) {
    if (device.session) device.session->acquire_times().forget(codec::handle_value(swapchain));
    PresentTable &table = *device.presents;
    {
        std::lock_guard lock(table.async_mutex);
        table.swapchains.erase(swapchain);
    }
    std::shared_ptr<Redirect> redirect;
    {
        std::lock_guard lock(table.redirects_mutex);
        if (const auto it = table.redirects.find(swapchain); it != table.redirects.end()) {
            redirect = std::move(it->second);
            table.redirects.erase(it);
        }
    }
    if (redirect) {
        std::lock_guard lock(redirect->mutex);
        destroy(device, *redirect);
    }
    release_verify_readbacks(device, swapchain);
}

void report_split_summary(DeviceState &device) {
    if (!device.session) return;
    // Eye images of a frame that was never ended keep their rows, without a latency.
    if (device.session->has_stats())
        for (const FrameRecord &row : device.session->stats().take_eye_rows(UINT64_MAX))
            device.session->stats().record(row);
    if (!device.session->splitting()) return;
    // A short session that never split ends before the warning's count: it says so now.
    if (device.session->unsplit_frames.load() > 0) warn_unsplit(*device.session);
    const std::string line = device.session->stats().summary();
    if (!line.empty()) splitvk::log_result("%s", line.c_str());
    if (const uint64_t invalid = device.session->invalid_frames.load())
        splitvk::log_result(
            "split: %llu frames the agent flagged invalid showed the periphery in their centre",
            static_cast<unsigned long long>(invalid));
}

namespace entry {

VKAPI_ATTR VkResult VKAPI_CALL AcquireNextImageKHR(VkDevice device, VkSwapchainKHR swapchain,
                                                   uint64_t timeout, VkSemaphore semaphore, VkFence fence,
                                                   uint32_t *pImageIndex) {
    DeviceState &dev = device_state(device);
    if (const VkResult deferred = before_acquire(dev, swapchain); deferred != VK_SUCCESS) return deferred;
    const VkResult acquired =
        dev.dispatch.AcquireNextImageKHR(device, swapchain, timeout, semaphore, fence, pImageIndex);
    const VkResult result = after_acquire(dev, swapchain, acquired, *pImageIndex);
    note_acquired(dev, swapchain, result, *pImageIndex);
    if ((result == VK_SUCCESS || result == VK_SUBOPTIMAL_KHR) && capturing(dev)) {
        protocol::FrameBegin message{dev.session->current_frame(), codec::handle_value(swapchain),
                                     *pImageIndex};
        dev.session->send_metadata(protocol::MessageType::FrameBegin, protocol::encode(message));
    }
    return result;
}

VKAPI_ATTR VkResult VKAPI_CALL AcquireNextImage2KHR(VkDevice device,
                                                    const VkAcquireNextImageInfoKHR *pAcquireInfo,
                                                    uint32_t *pImageIndex) {
    DeviceState &dev = device_state(device);
    if (const VkResult deferred = before_acquire(dev, pAcquireInfo->swapchain); deferred != VK_SUCCESS)
        return deferred;
    const VkResult acquired = dev.dispatch.AcquireNextImage2KHR(device, pAcquireInfo, pImageIndex);
    const VkResult result = after_acquire(dev, pAcquireInfo->swapchain, acquired, *pImageIndex);
    note_acquired(dev, pAcquireInfo->swapchain, result, *pImageIndex);
    if ((result == VK_SUCCESS || result == VK_SUBOPTIMAL_KHR) && capturing(dev)) {
        protocol::FrameBegin message{dev.session->current_frame(),
                                     codec::handle_value(pAcquireInfo->swapchain), *pImageIndex};
        dev.session->send_metadata(protocol::MessageType::FrameBegin, protocol::encode(message));
    }
    return result;
}

VKAPI_ATTR VkResult VKAPI_CALL QueuePresentKHR(VkQueue queue, const VkPresentInfoKHR *pPresentInfo) {
    DeviceState &dev = device_state(queue);
    if (!dev.session) return dev.dispatch.QueuePresentKHR(queue, pPresentInfo);

    const auto called = std::chrono::steady_clock::now();
    Session &session = *dev.session;
    const uint64_t frame = session.take_frame();
    const auto acquired = take_acquired(session, *pPresentInfo);
    // A new agent joins here, where this thread owns the queue (session.h); the present thread's
    // frames use the tile stream that the new agent replaces.
    if (session.resync_pending()) {
        drain_presents(dev);
        const auto queue_lock = lock_queue(dev, queue);
        session.resync(dev, queue, frame);
    }
    if (frame == 1) log_live_state(dev, "at frame 1"); // SPLITVK_LOG_LEVEL=debug
    protocol::FramePresent message;
    message.frame = frame;
    message.queue_id = codec::handle_value(queue);
    // Read here, once per frame: both sides place this frame's foveae with it.
    message.gaze = gaze::frame_gaze(session.settings());
    Session::FrameSizing sizing = session.size_frame(-1, 0);
    message.fovea_size = sizing.size;
    for (uint32_t i = 0; i < pPresentInfo->swapchainCount && i < protocol::kMaxPresentedImages; ++i)
        message.images.push_back(
            {codec::handle_value(pPresentInfo->pSwapchains[i]), pPresentInfo->pImageIndices[i]});

    // Verification reads back the first swapchain's image.
    std::optional<PendingVerify> pending;
    VkPresentInfoKHR present = *pPresentInfo;
    // Split mode composites the first swapchain's image (its split passes drew it scaled).
    const SwapchainState *split_swapchain = nullptr;
    SplitFrame split;
    // The image the application drew this frame into: the presented one, or ("Order") another.
    uint32_t drawn = pPresentInfo->swapchainCount > 0 ? pPresentInfo->pImageIndices[0] : 0;
    if (session.splitting() && pPresentInfo->swapchainCount > 0) {
        split_swapchain = find_swapchain(dev, pPresentInfo->pSwapchains[0]);
        const uint32_t index = pPresentInfo->pImageIndices[0];
        if (split_swapchain && index < split_swapchain->images.size())
            split = take_split_frame(dev, split_swapchain->images[index], split_settings().eyes, message.gaze,
                                     message.fovea_size);
        if (split_swapchain && !split.split)
            if (const auto stray = take_stray(dev, split_swapchain->handle, index);
                stray && *stray < split_swapchain->images.size()) {
                split = take_split_frame(dev, split_swapchain->images[*stray], split_settings().eyes,
                                         message.gaze, message.fovea_size);
                if (split.split) {
                    drawn = *stray;
                    // The agent's foveae are those of the image drawn.
                    if (!message.images.empty()) message.images[0].image_index = drawn;
                }
            }
        note_split_or_not(session, frame, split.split);
        if (split.split) message.fovea_size = split.fovea_size; // perhaps larger: a mask's (fovea_mask.h)
    }
    const bool redirect = split.split && drawn != pPresentInfo->pImageIndices[0];
    // SPLITVK_SPLIT=auto passing frames through: the agent replays them and sends no tiles (nor for
    // the frame a resync brought it in at: send_frame_present).
    const bool passing_through = session.splitting() && session.passing_through();
    if (passing_through) message.flags |= protocol::kPresentNoTiles;
    const double frame_ms =
        split.split || session.judges_payoff() || session.has_stats() ? session.frame_interval_ms() : 0;
    // May decide a switch, which this present's answer asks the application to follow.
    if (session.splitting()) session.observe_payoff(dev, frame_ms, message.fovea_size);
    const bool drawn_split = split.split;
    // The present thread's case (see the top of this file); everything else happens here, after
    // the thread's frames, with the queue this thread's for the rest of the call.
    const bool async = split.split && !redirect && session.settings().present_depth > 0 &&
                       !session.verify() && pPresentInfo->swapchainCount == 1 && !pPresentInfo->pNext;
    std::unique_lock<std::mutex> queue_lock;
    if (!async) {
        drain_presents(dev);
        queue_lock = lock_queue(dev, queue);
    }
    // A split frame under verification is the swapped split's (the paper's split is off then,
    // verification.h): it is read back after its composite, as it is shown. Any other frame before
    // anything of the layer's, as the application drew it.
    const bool verify_shown =
        session.verify() && split.split && presented_image_verifiable(dev, queue, present);
    if (session.verify() && !split.split) pending = read_back_presented_image(dev, queue, present, frame);
    if (pending || verify_shown) message.flags |= protocol::kPresentVerify;
    // A frame that waits for nothing of the agent's (passed through, unsplit) is shown first and
    // told after: the send flushes the frame's captured calls, which would otherwise lie between the
    // application's present and the display. Nothing of the application's comes between the two.
    const bool tell_after_present = !split.split;
    if (!tell_after_present) session.send_frame_present(message);

    VkSemaphore composited = VK_NULL_HANDLE;
    VkSemaphore redirected = VK_NULL_HANDLE;
    // verify_shown: what the comparison needs of the frame, and its stats row, held until then.
    bool cut = false;
    std::vector<VkRect2D> foveae;
    FrameRecord record;
    if (split.split) {
        SplitPresent p;
        p.queue = queue;
        p.swapchain = split_swapchain;
        p.image_index = drawn;
        p.cut = frame_cut(p.swapchain, split);
        p.passing_through = passing_through;
        p.split = std::move(split);
        p.frame = frame;
        p.sent = std::chrono::steady_clock::now();
        p.frame_ms = frame_ms;
        p.called = called;
        p.acquired = acquired;
        p.sizing = sizing;
        p.sizing.frame_ms = frame_ms;
        const std::span<const VkSemaphore> waits{present.pWaitSemaphores, present.waitSemaphoreCount};
        if (async) {
            if (const auto result = present_async(dev, p, waits)) {
                if (pPresentInfo->pResults) pPresentInfo->pResults[0] = *result;
                return forced_out_of_date(session, *pPresentInfo, *result);
            }
            drain_presents(dev); // nothing taken: this frame goes here, after the thread's
            queue_lock = lock_queue(dev, queue);
        }
        cut = p.cut;
        if (verify_shown) foveae = first_layer_foveae(p.split);
        composited = composite_split_frame(dev, p, waits, /*lock=*/false, &record);
        if (composited) {
            present.waitSemaphoreCount = 1;
            present.pWaitSemaphores = &composited;
        }
        // The presented image gets the frame: never an image the layer did not fill.
        if (redirect)
            if (const VkSemaphore copied =
                    copy_swapchain_image(dev, queue, *split_swapchain, drawn, pPresentInfo->pImageIndices[0],
                                         {present.pWaitSemaphores, present.waitSemaphoreCount})) {
                redirected = copied;
                present.waitSemaphoreCount = 1;
                present.pWaitSemaphores = &redirected;
            }
    }
    if (verify_shown) {
        pending = read_back_presented_image(dev, queue, present, frame);
        // A cut frame shows the agent's periphery around the client's foveae (Compositor::
        // composite_periphery keeps the same rects); one drawn whole must match whole.
        if (pending && cut) {
            pending->periphery = true;
            pending->foveae = std::move(foveae);
            // Its own periphery came, or it showed an earlier one (late, flagged invalid or mismatched).
            pending->late = record.periphery_bytes == 0;
        }
    }
    const VkResult presented =
        note_presented(dev, *pPresentInfo, dev.dispatch.QueuePresentKHR(queue, &present));
    const std::optional<double> latency = latency_ms(acquired, std::chrono::steady_clock::now());
    if (tell_after_present) session.send_frame_present(message);
    if (passing_through && !drawn_split) note_passed_through(session, frame, frame_ms, latency);
    const VkResult result = forced_out_of_date(session, *pPresentInfo, presented);
    queue_lock = {};
    std::optional<double> psnr;
    if (pending) psnr = compare_verified_frame(dev, *pending);
    if (drawn_split) {
        record.periphery_psnr_db = psnr;
        record.frame_latency_ms = latency;
        session.stats().record(record);
    } else if (!passing_through && session.has_stats()) {
        // A frame unsplit (verified, or without an agent: native through the layer): its row says
        // when it came and when it was shown, with no fovea and no tiles.
        record.frame = frame;
        record.frame_ms = frame_ms;
        record.frame_latency_ms = latency;
        session.stats().record(record);
    }
    return result;
}

} // namespace entry
} // namespace splitvk
