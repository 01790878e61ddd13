#include "buffer_addresses.h"

#include <cstring>

namespace splitvk::agent {

void BufferAddressMap::insert(uint64_t buffer, uint64_t client, uint64_t size, uint64_t agent) {
    erase(buffer);
    if (size == 0 || client + size < client) return; // no range, or one that wraps: names nothing
    if (const auto old = by_start_.find(client); old != by_start_.end()) start_.erase(old->second.buffer);
    by_start_[client] = Range{client + size, agent, buffer};
    start_[buffer] = client;
}

void BufferAddressMap::erase(uint64_t buffer) {
    const auto it = start_.find(buffer);
    if (it == start_.end()) return;
    by_start_.erase(it->second);
    start_.erase(it);
}

std::optional<uint64_t> BufferAddressMap::translate(uint64_t address) const {
    auto it = by_start_.upper_bound(address);
    if (it == by_start_.begin()) return std::nullopt;
    --it;
    if (address >= it->second.end) return std::nullopt;
    return it->second.agent + (address - it->first);
}

PushTranslation translate_push_constants(const BufferAddressMap &map,
                                         std::span<const uint32_t> pointer_offsets, uint32_t offset,
                                         std::span<uint8_t> bytes) {
    PushTranslation result;
    const uint64_t begin = offset;
    const uint64_t end = begin + bytes.size();
    for (const uint32_t at : pointer_offsets) {
        const uint64_t field_end = uint64_t{at} + sizeof(uint64_t);
        if (field_end <= begin || at >= end) continue; // not in this update
        if (at < begin || field_end > end) {
            ++result.partial;
            continue;
        }
        uint8_t *field = bytes.data() + (at - begin);
        uint64_t address;
        std::memcpy(&address, field, sizeof(address));
        if (address == 0) continue;
        const auto agent = map.translate(address);
        if (!agent) {
            ++result.unknown;
            continue;
        }
        std::memcpy(field, &*agent, sizeof(*agent));
        ++result.translated;
    }
    return result;
}

} // namespace splitvk::agent
