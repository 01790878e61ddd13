#pragma once

// The live-state log (docs/architecture.md §3, replayed at a resync): what is needed to rebuild the
// device's current state on a fresh agent, bounded by the live objects themselves.
//  - Objects: the encoded call that created each live object, one entry per call with a sequence
//    number (creation order). A single-handle vkCreate*, vkAllocateMemory and vkGetDeviceQueue*
//    are held by their one id; batches (vkAllocateCommandBuffers, vkAllocateDescriptorSets,
//    vkCreate*Pipelines) by each of their ids, and dropped when the last of them is destroyed or
//    freed (pool destroy/reset frees the pool's children). vkBind*Memory* entries are held by
//    their resources and die with the memory they bind. Objects that later creations may name
//    (shader modules, render passes, pipeline and set layouts, pipeline caches) are "retired" at
//    destroy: kept while anything created after them lives, their destroy replayed after the
//    live objects (or, when a new object reuses the handle value, just before its creation).
//    A live swapchain is its SwapchainImages message (held by the swapchain).
//  - Descriptor contents (descriptor_set.cpp): per set, the latest descriptor per (binding, array
//    element), from vkUpdateDescriptorSets writes, copies (resolved at copy time) and template
//    updates, re-encoded as one vkUpdateDescriptorSets per set in the snapshot; descriptors that
//    name a destroyed object are left out.
//  - Command buffers (command_buffer.cpp): the last recorded stream of each.
//  - Linear images (resource.cpp): the ImageLayouts message sent after the creation, held by the
//    image and dropped with it.
// build_live_snapshot() (session.h) turns it into messages in that order. Out of scope: memory contents.
// Host-visible memory is shadowed only while mapped (memory.cpp); device-local buffers and
// images are read back on the client when a resync sends a snapshot.
// Not covered: an object destroyed while a live one created later still names it, other than
// the retired kinds above (an image view under a live framebuffer), and command buffer streams
// naming objects destroyed since they were recorded (the app cannot submit those either).
//
// LiveStateLog holds the object part and knows nothing of the connection: Session (session.h)
// feeds it the calls it encodes and sends what it returns.

// For protocol::OutboundMessage, the type a snapshot is sent as; nothing of the connection is used.
#include "transport.h"

#include <cstddef>
#include <cstdint>
#include <map>
#include <span>
#include <unordered_map>
#include <unordered_set>
#include <vector>

namespace splitvk {

// Created: a new log entry held by `id`. Destroyed: `id` lets go of its entries. Retired: as
// Destroyed, but an entry created by `id` is kept while later entries live, with this call's
// bytes replayed as its destroy (see the top of this file).
enum class LiveChange { Unchanged, Created, Destroyed, Retired };

// One message of a snapshot: Commands, the SwapchainImages metadata of a live swapchain, or the
// ImageLayouts of a live linear image.
using LiveMessage = protocol::OutboundMessage;

// A snapshot of the live-state log: the messages to replay in order (objects in creation order,
// descriptor contents, then one Commands message per command buffer stream).
struct LiveSnapshot {
    std::vector<LiveMessage> messages;
    size_t objects = 0;         // log entries (creation calls, binds, retired objects)
    size_t descriptor_sets = 0; // sets with contents
    size_t command_buffers = 0; // recorded streams
    size_t bytes = 0;
};

// The object part of the live-state log. Not synchronised: its owner changes and reads it under
// one lock of its own (Session's mutex).
class LiveStateLog {
public:
    // The call whose encoded bytes are `call` changed object `id` as `change` says (Unchanged, or
    // an `id` of 0, leave the log as it is).
    void note_change(LiveChange change, uint64_t id, std::span<const uint8_t> call);
    // A call that makes one entry of `type`, held by every id in `holders` (dropped when the last of
    // them is forgotten) and dropped at once when any of `killers` is; with killers it only adds to
    // what its holders hold (a bind), else it names new objects. Returns the entry's sequence number,
    // 0 when no holder keeps it.
    uint64_t add(std::vector<uint8_t> &&bytes, std::span<const uint64_t> holders,
                 std::span<const uint64_t> killers,
                 protocol::MessageType type = protocol::MessageType::Commands);
    // An object gone without a call of its own (a freed command buffer or descriptor set, a pool's
    // children at its destroy or reset): it lets go of its entries.
    void forget(uint64_t id);

    // The log in replay order: entries in creation order (consecutive Commands joined into one
    // payload), each retired object's destroy just before the creation that reuses its handle
    // value, and the other retired objects' destroys after all. `entries`: the log's size; `live_ids`:
    // the ids that hold entries (what descriptor contents and streams may name).
    std::vector<LiveMessage> messages(size_t *entries, std::unordered_set<uint64_t> *live_ids);
    // Entries in the log (creation calls, binds, retired objects).
    size_t size() const { return log_.size(); }

private:
    struct Entry {
        protocol::MessageType type = protocol::MessageType::Commands;
        std::vector<uint8_t> bytes;
        std::vector<uint64_t> holders; // ids still holding it
        std::vector<uint64_t> killers;
        uint64_t retired_id = 0;      // non-zero: destroyed, kept for later entries
        std::vector<uint8_t> destroy; // retired: the encoded destroy
        uint64_t destroy_seq = 0;     // retired: where the destroy replays (0: after all entries)
    };
    void forget(uint64_t id, std::span<const uint8_t> retire_bytes, bool retire);
    void erase_entry(uint64_t seq);
    void prune_retired();

    // Entries by sequence number (creation order).
    std::map<uint64_t, Entry> log_;
    std::unordered_map<uint64_t, std::vector<uint64_t>> held_by_;          // id -> entries it holds
    std::unordered_map<uint64_t, std::unordered_set<uint64_t>> killed_by_; // id -> entries dying with it
    std::unordered_map<uint64_t, uint64_t> retired_;                       // retired id -> its entry
    uint64_t next_seq_ = 1;
};

} // namespace splitvk
