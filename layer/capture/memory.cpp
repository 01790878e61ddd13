// VkDeviceMemory: allocations, maps and the shadow copies behind MemoryData (docs/architecture.md §3).
//
// Host writes through a mapped pointer are invisible to the layer. While an allocation is mapped
// with a session, the mapped range has a shadow copy: what the agent holds there. The mapped range
// is compared with the shadow at every submit, at vkFlushMappedMemoryRanges and at vkUnmapMemory;
// changed 256-byte blocks, merged into runs, are sent as MemoryData (offsets in the client's
// allocation) and the shadow updated. This covers coherent memory that is never flushed,
// persistent maps and maps with an offset, with no signal handlers. The application's pointer
// never crosses the wire.
//
// The shadow lives from the map to the unmap, and covers the mapped range only. A later map
// starts its shadow from the mapped bytes where an earlier map's changes were all sent (the agent
// holds them) and from zeros elsewhere (the agent zero-fills its allocations); see KnownRanges.
//
// Locks. The device's MemoryObjects lock guards which allocations exist and which are mapped, and
// is never held across a comparison or a send. Each allocation's own lock orders its comparisons
// and their sends, and is held across them, so that the agent receives one allocation's changes
// in the order they were found; a thread mapping, unmapping or allocating other memory waits for
// neither.

#include "capture/memory.h"

#include "capture/capture.h"
#include "capture/memory_diff.h"
#include "capture/session.h"
#include "layer_entry_points.h"
#include "log.h"
#include "wire.h"

#include <algorithm>
#include <chrono>
#include <cstring>
#include <mutex>
#include <unordered_map>
#include <unordered_set>

namespace splitvk {

namespace {

constexpr size_t kMaxMemoryDataBytes = size_t{8} << 20;

struct MemoryState {
    VkDeviceMemory handle = VK_NULL_HANDLE;
    VkDeviceSize size = 0;

    std::mutex mutex;                // the fields below; held across a comparison and its sends
    const uint8_t *mapped = nullptr; // the application's pointer (offset `map_offset`), or null
    VkDeviceSize map_offset = 0;
    VkDeviceSize map_size = 0;
    MappedShadow shadow; // of the mapped range; empty when unmapped, or when it could not be had
    KnownRanges known;   // what the agent holds as the client does, outside a map
    bool shadow_warned = false;
};

} // namespace

struct MemoryObjects {
    std::mutex mutex; // the two sets below, never held across a comparison or a send
    std::unordered_map<VkDeviceMemory, std::shared_ptr<MemoryState>> all;
    std::unordered_set<std::shared_ptr<MemoryState>> mapped;

    std::shared_ptr<MemoryState> find(VkDeviceMemory handle) {
        std::lock_guard lock(mutex);
        const auto it = all.find(handle);
        return it == all.end() ? nullptr : it->second;
    }
    std::vector<std::shared_ptr<MemoryState>> mapped_now() {
        std::lock_guard lock(mutex);
        return {mapped.begin(), mapped.end()};
    }
};

std::shared_ptr<MemoryObjects> make_memory_objects() {
    return std::make_shared<MemoryObjects>();
}

namespace {

void send_range(Session &session, const MemoryState &memory, VkDeviceSize offset, const uint8_t *begin,
                size_t size) {
    // Pieces well under the transport's payload cap (a staging buffer can be hundreds of MiB).
    for (size_t done = 0; done < size; done += kMaxMemoryDataBytes) {
        protocol::MemoryData data;
        data.device_id = session.device_id();
        data.memory_id = codec::handle_value(memory.handle);
        data.offset = offset + done;
        const uint8_t *piece = begin + done;
        data.bytes.assign(piece, piece + std::min(kMaxMemoryDataBytes, size - done));
        session.send_metadata(protocol::MessageType::MemoryData, protocol::encode(data));
    }
}

// Under memory.mutex: compares the mapped range and sends what changed.
void sync_locked(Session *session, MemoryState &memory, std::vector<DirtyRun> &runs) {
    if (!memory.mapped || memory.map_size == 0) return;
    if (!session || !session->live()) return;
    const auto size = static_cast<size_t>(memory.map_size);
    if (memory.shadow.empty()) {
        // No shadow to compare with: every sync sends all of it.
        send_range(*session, memory, memory.map_offset, memory.mapped, size);
        return;
    }
    runs.clear();
    memory.shadow.diff(memory.mapped, runs);
    for (const DirtyRun &run : runs)
        send_range(*session, memory, memory.map_offset + run.offset, memory.shadow.data(run.offset),
                   run.size);
}

// Under memory.mutex: the mapped range gets its shadow, or one line saying why not.
void begin_shadow(MemoryState &memory) {
    const auto size = static_cast<size_t>(memory.map_size);
    if (memory.shadow.begin(memory.mapped, static_cast<size_t>(memory.map_offset), size, memory.known))
        return;
    if (!memory.shadow_warned)
        SPLITVK_WARN(
            "memory: no host memory for the %zu-byte shadow of a mapped range; its contents are sent "
            "whole at every submit and flush while it is mapped",
            size);
    memory.shadow_warned = true;
}

} // namespace

void sync_mapped_memory(DeviceState &device) {
    const auto start = std::chrono::steady_clock::now();
    std::vector<DirtyRun> runs;
    for (const std::shared_ptr<MemoryState> &memory : device.memory->mapped_now()) {
        std::lock_guard lock(memory->mutex);
        sync_locked(device.session.get(), *memory, runs);
    }
    const auto ns =
        std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now() - start);
    device.session->memory_compare_ns.fetch_add(static_cast<uint64_t>(ns.count()), std::memory_order_relaxed);
}

void resync_mapped_shadows(DeviceState &device) {
    // A new agent gets every buffer's contents in the snapshot; from then on, diffs are against
    // what it has, which is what the memory holds now.
    std::vector<std::shared_ptr<MemoryState>> memories;
    {
        std::lock_guard lock(device.memory->mutex);
        for (const auto &[handle, memory] : device.memory->all)
            memories.push_back(memory);
    }
    for (const std::shared_ptr<MemoryState> &memory : memories) {
        std::lock_guard lock(memory->mutex);
        memory->known.clear();
        memory->known.add(0, static_cast<size_t>(memory->size));
        if (memory->mapped) memory->shadow.assign(memory->mapped);
    }
}

namespace entry {

VKAPI_ATTR VkResult VKAPI_CALL AllocateMemory(VkDevice device, const VkMemoryAllocateInfo *pAllocateInfo,
                                              const VkAllocationCallbacks *pAllocator,
                                              VkDeviceMemory *pMemory) {
    DeviceState &dev = device_state(device);
    const VkResult result = dev.dispatch.AllocateMemory(device, pAllocateInfo, pAllocator, pMemory);
    if (result != VK_SUCCESS || !capturing(dev)) return result;
    auto state = std::make_shared<MemoryState>();
    state->handle = *pMemory;
    state->size = pAllocateInfo->allocationSize;
    {
        std::lock_guard lock(dev.memory->mutex);
        dev.memory->all[*pMemory] = std::move(state);
    }
    record_global(dev, LiveChange::Created, codec::handle_value(*pMemory), [&](codec::Encoder &e) {
        encode_vkAllocateMemory(e, device, pAllocateInfo, pAllocator, pMemory);
    });
    return result;
}

VKAPI_ATTR void VKAPI_CALL FreeMemory(VkDevice device, VkDeviceMemory memory,
                                      const VkAllocationCallbacks *pAllocator) {
    DeviceState &dev = device_state(device);
    if (dev.session && memory != VK_NULL_HANDLE) {
        std::shared_ptr<MemoryState> state;
        {
            std::lock_guard lock(dev.memory->mutex);
            const auto it = dev.memory->all.find(memory);
            if (it != dev.memory->all.end()) {
                state = std::move(it->second);
                dev.memory->all.erase(it);
                dev.memory->mapped.erase(state);
            }
        }
        // A sync that found it mapped before the erase finishes reading it before the driver
        // frees it (freeing memory a submit is using is the application's error, not a crash).
        if (state) {
            std::lock_guard lock(state->mutex);
            state->mapped = nullptr;
            state->shadow.release();
        }
    }
    // Recorded before the driver may hand the value to memory another thread allocates.
    if (capturing(dev) && memory != VK_NULL_HANDLE)
        record_global(dev, LiveChange::Destroyed, codec::handle_value(memory),
                      [&](codec::Encoder &e) { encode_vkFreeMemory(e, device, memory, pAllocator); });
    dev.dispatch.FreeMemory(device, memory, pAllocator);
}

VKAPI_ATTR VkResult VKAPI_CALL MapMemory(VkDevice device, VkDeviceMemory memory, VkDeviceSize offset,
                                         VkDeviceSize size, VkMemoryMapFlags flags, void **ppData) {
    DeviceState &dev = device_state(device);
    const VkResult result = dev.dispatch.MapMemory(device, memory, offset, size, flags, ppData);
    if (result != VK_SUCCESS || !dev.session) return result;
    const std::shared_ptr<MemoryState> state = dev.memory->find(memory);
    if (!state || offset >= state->size) return result;
    {
        std::lock_guard lock(state->mutex);
        state->mapped = static_cast<const uint8_t *>(*ppData);
        state->map_offset = offset;
        state->map_size = size == VK_WHOLE_SIZE ? state->size - offset : std::min(size, state->size - offset);
        begin_shadow(*state);
    }
    std::lock_guard lock(dev.memory->mutex);
    if (dev.memory->all.count(memory)) dev.memory->mapped.insert(state);
    return result;
}

VKAPI_ATTR void VKAPI_CALL UnmapMemory(VkDevice device, VkDeviceMemory memory) {
    DeviceState &dev = device_state(device);
    if (dev.session) {
        if (const std::shared_ptr<MemoryState> state = dev.memory->find(memory)) {
            {
                std::lock_guard lock(dev.memory->mutex);
                dev.memory->mapped.erase(state);
            }
            std::lock_guard lock(state->mutex);
            std::vector<DirtyRun> runs;
            sync_locked(dev.session.get(), *state, runs); // before the pointer becomes invalid
            if (state->mapped) {
                const auto begin = static_cast<size_t>(state->map_offset);
                state->known.add(begin, begin + static_cast<size_t>(state->map_size));
            }
            state->mapped = nullptr;
            state->shadow.release();
        }
    }
    dev.dispatch.UnmapMemory(device, memory);
}

VKAPI_ATTR VkResult VKAPI_CALL FlushMappedMemoryRanges(VkDevice device, uint32_t memoryRangeCount,
                                                       const VkMappedMemoryRange *pMemoryRanges) {
    DeviceState &dev = device_state(device);
    if (capturing(dev)) {
        std::vector<DirtyRun> runs;
        std::unordered_set<VkDeviceMemory> done;
        for (uint32_t i = 0; i < memoryRangeCount; ++i) {
            if (!done.insert(pMemoryRanges[i].memory).second) continue;
            if (const std::shared_ptr<MemoryState> state = dev.memory->find(pMemoryRanges[i].memory)) {
                std::lock_guard lock(state->mutex);
                sync_locked(dev.session.get(), *state, runs);
            }
        }
    }
    return dev.dispatch.FlushMappedMemoryRanges(device, memoryRangeCount, pMemoryRanges);
}

} // namespace entry
} // namespace splitvk
