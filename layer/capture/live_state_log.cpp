// The object part of the live-state log (live_state_log.h).

#include "capture/live_state_log.h"

#include <algorithm>
#include <utility>

namespace splitvk {

void LiveStateLog::note_change(LiveChange change, uint64_t id, std::span<const uint8_t> call) {
    if (id == 0 || change == LiveChange::Unchanged) return;
    if (change == LiveChange::Created) {
        const uint64_t ids[] = {id};
        add(std::vector<uint8_t>(call.begin(), call.end()), ids, {});
    } else {
        forget(id, call, change == LiveChange::Retired);
    }
}

uint64_t LiveStateLog::add(std::vector<uint8_t> &&bytes, std::span<const uint64_t> holders,
                           std::span<const uint64_t> killers, protocol::MessageType type) {
    // A creation naming a handle value seen before (vkGetDeviceQueue returns the same queue; a
    // driver reuses the value of a retired object) names the new object from now on. Binds (the
    // entries with killers) only add to what their resources hold.
    for (uint64_t id : holders) {
        if (id == 0 || !killers.empty()) continue;
        const auto held = held_by_.find(id);
        if (held != held_by_.end() && !held->second.empty()) forget(id, {}, false);
        // The retired object with this value is destroyed, on replay, just before this creation:
        // what was created in between still names it.
        const auto retired = retired_.find(id);
        if (retired != retired_.end()) {
            log_[retired->second].destroy_seq = next_seq_++;
            retired_.erase(retired);
        }
    }
    const uint64_t seq = next_seq_++;
    Entry &entry = log_[seq];
    entry.type = type;
    entry.bytes = std::move(bytes);
    for (uint64_t id : holders)
        if (id != 0) {
            entry.holders.push_back(id);
            held_by_[id].push_back(seq);
        }
    for (uint64_t id : killers)
        if (id != 0) {
            entry.killers.push_back(id);
            killed_by_[id].insert(seq);
        }
    if (entry.holders.empty()) {
        erase_entry(seq);
        return 0;
    }
    return seq;
}

void LiveStateLog::forget(uint64_t id) {
    if (id != 0) forget(id, {}, false);
}

void LiveStateLog::erase_entry(uint64_t seq) {
    const auto it = log_.find(seq);
    if (it == log_.end()) return;
    for (uint64_t id : it->second.holders)
        if (const auto found = held_by_.find(id); found != held_by_.end()) {
            std::erase(found->second, seq);
            if (found->second.empty()) held_by_.erase(found);
        }
    // A set: many resources may be bound to one allocation.
    for (uint64_t id : it->second.killers)
        if (const auto found = killed_by_.find(id); found != killed_by_.end()) {
            found->second.erase(seq);
            if (found->second.empty()) killed_by_.erase(found);
        }
    if (it->second.retired_id != 0) {
        const auto retired = retired_.find(it->second.retired_id);
        if (retired != retired_.end() && retired->second == seq) retired_.erase(retired);
    }
    log_.erase(it);
}

void LiveStateLog::forget(uint64_t id, std::span<const uint8_t> retire_bytes, bool retire) {
    if (const auto killed = killed_by_.find(id); killed != killed_by_.end()) {
        const std::vector<uint64_t> seqs(killed->second.begin(), killed->second.end());
        for (uint64_t seq : seqs)
            erase_entry(seq);
    }
    const auto held = held_by_.find(id);
    if (held == held_by_.end()) return;
    const std::vector<uint64_t> seqs = std::move(held->second);
    held_by_.erase(held);
    for (uint64_t seq : seqs) {
        const auto it = log_.find(seq);
        if (it == log_.end()) continue;
        std::erase(it->second.holders, id);
        if (!it->second.holders.empty()) continue;
        // Only a single-handle creation retires (the entry `id` alone held).
        if (retire && it->second.killers.empty() && seq == seqs.front()) {
            it->second.retired_id = id;
            it->second.destroy.assign(retire_bytes.begin(), retire_bytes.end());
            retired_[id] = seq;
        } else {
            erase_entry(seq);
        }
    }
    if (retire) prune_retired();
}

void LiveStateLog::prune_retired() {
    // A retired object can only be named by entries created after it (and, when its value was
    // reused, before its destroy): it goes once no live entry is in that range.
    std::vector<uint64_t> live;
    for (const auto &[seq, entry] : log_)
        if (entry.retired_id == 0) live.push_back(seq); // ascending
    std::vector<uint64_t> stale;
    for (const auto &[seq, entry] : log_) {
        if (entry.retired_id == 0) continue;
        const auto after = std::upper_bound(live.begin(), live.end(), seq);
        if (after == live.end() || (entry.destroy_seq != 0 && *after > entry.destroy_seq))
            stale.push_back(seq);
    }
    for (uint64_t seq : stale)
        erase_entry(seq);
}

std::vector<LiveMessage> LiveStateLog::messages(size_t *entries, std::unordered_set<uint64_t> *live_ids) {
    prune_retired();
    std::vector<LiveMessage> out;
    const auto append = [&out](protocol::MessageType type, const std::vector<uint8_t> &bytes) {
        if (bytes.empty()) return;
        if (type != protocol::MessageType::Commands || out.empty() ||
            out.back().type != protocol::MessageType::Commands)
            out.push_back({type, {}});
        out.back().payload.insert(out.back().payload.end(), bytes.begin(), bytes.end());
    };
    // Creations in order, with the destroys of retired objects whose value a later creation
    // reuses just before that creation; the other retired objects' destroys at the end.
    std::map<uint64_t, std::pair<protocol::MessageType, const std::vector<uint8_t> *>> order;
    for (const auto &[seq, entry] : log_) {
        order[seq] = {entry.type, &entry.bytes};
        if (entry.retired_id != 0 && entry.destroy_seq != 0)
            order[entry.destroy_seq] = {protocol::MessageType::Commands, &entry.destroy};
    }
    for (const auto &[seq, emit] : order)
        append(emit.first, *emit.second);
    for (const auto &[seq, entry] : log_)
        if (entry.retired_id != 0 && entry.destroy_seq == 0)
            append(protocol::MessageType::Commands, entry.destroy);
    if (entries) *entries = log_.size();
    if (live_ids)
        for (const auto &[id, seqs] : held_by_)
            live_ids->insert(id);
    return out;
}

} // namespace splitvk
