// VkDeviceMemory: allocations, maps and the shadow copies behind MemoryData (DESIGN §3).
//
// Host writes through a mapped pointer are invisible to the layer. Each allocation mapped while
// a session exists gets a shadow copy of the whole allocation, zero-initialised (the agent
// zero-fills its allocations, so the first comparison is against zeros). The mapped range is
// compared with the shadow at every submit, at vkFlushMappedMemoryRanges and at vkUnmapMemory;
// changed 256-byte blocks, merged into runs, are sent as MemoryData (offsets in the client's
// allocation) and the shadow updated. This covers coherent memory that is never flushed,
// persistent maps and maps with an offset, with no signal handlers. The application's pointer
// never crosses the wire.

#include "memory.h"

#include "capture.h"
#include "layer_entry_points.h"
#include "memory_diff.h"
#include "session.h"
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
    DeviceState *device = nullptr;
    VkDeviceMemory handle = VK_NULL_HANDLE;
    VkDeviceSize size = 0;
    bool host_visible = false;
    bool coherent = false;
    const uint8_t *mapped = nullptr; // the application's pointer (offset `map_offset`), or null
    VkDeviceSize map_offset = 0;
    VkDeviceSize map_size = 0;
    std::vector<uint8_t> shadow; // the whole allocation, as the agent last saw it
};

// One lock for the memory objects: map, unmap, free and the comparisons at submit are rare
// compared with command recording, and the comparison must not race an unmap.
std::mutex g_mutex;
std::unordered_map<VkDeviceMemory, std::unique_ptr<MemoryState>> g_memory;
std::unordered_map<DeviceState *, std::unordered_set<MemoryState *>> g_mapped;

// Under g_mutex: compares the mapped range and sends what changed.
void sync_locked(MemoryState &memory, std::vector<DirtyRun> &runs) {
    if (!memory.mapped || memory.map_size == 0) return;
    Session *session = memory.device->session.get();
    if (!session || !session->live()) return;
    if (memory.shadow.size() != memory.size) memory.shadow.assign(static_cast<size_t>(memory.size), 0);
    runs.clear();
    diff_and_update(memory.mapped, memory.shadow.data() + memory.map_offset,
                    static_cast<size_t>(memory.map_size), runs);
    for (const DirtyRun &run : runs) {
        // Pieces well under the transport's payload cap (a staging buffer can be hundreds of MiB).
        for (size_t done = 0; done < run.size; done += kMaxMemoryDataBytes) {
            protocol::MemoryData data;
            data.device_id = session->device_id();
            data.memory_id = codec::handle_value(memory.handle);
            data.offset = memory.map_offset + run.offset + done;
            const uint8_t *begin = memory.shadow.data() + data.offset;
            data.bytes.assign(begin, begin + std::min(kMaxMemoryDataBytes, run.size - done));
            session->send_metadata(protocol::MessageType::MemoryData, protocol::encode(data));
        }
    }
}

} // namespace

void sync_mapped_memory(DeviceState &device) {
    const auto start = std::chrono::steady_clock::now();
    {
        std::lock_guard lock(g_mutex);
        const auto it = g_mapped.find(&device);
        if (it == g_mapped.end()) return;
        std::vector<DirtyRun> runs;
        for (MemoryState *memory : it->second)
            sync_locked(*memory, runs);
    }
    const auto ns =
        std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now() - start);
    device.session->memory_compare_ns.fetch_add(static_cast<uint64_t>(ns.count()), std::memory_order_relaxed);
}

void resync_mapped_shadows(DeviceState &device) {
    // A new agent gets every buffer's contents in the snapshot; from then on, diffs are against
    // what it has, which is what the mapped memory holds now.
    std::lock_guard lock(g_mutex);
    const auto it = g_mapped.find(&device);
    if (it == g_mapped.end()) return;
    for (MemoryState *memory : it->second) {
        if (!memory->mapped) continue;
        if (memory->shadow.size() != memory->size)
            memory->shadow.assign(static_cast<size_t>(memory->size), 0);
        std::memcpy(memory->shadow.data() + memory->map_offset, memory->mapped,
                    static_cast<size_t>(memory->map_size));
    }
}

void forget_memory(DeviceState &device) {
    std::lock_guard lock(g_mutex);
    g_mapped.erase(&device);
    for (auto it = g_memory.begin(); it != g_memory.end();)
        it = it->second->device == &device ? g_memory.erase(it) : std::next(it);
}

namespace entry {

VKAPI_ATTR VkResult VKAPI_CALL AllocateMemory(VkDevice device, const VkMemoryAllocateInfo *pAllocateInfo,
                                              const VkAllocationCallbacks *pAllocator,
                                              VkDeviceMemory *pMemory) {
    DeviceState &dev = device_state(device);
    const VkResult result = dev.dispatch.AllocateMemory(device, pAllocateInfo, pAllocator, pMemory);
    if (result != VK_SUCCESS || !capturing(dev)) return result;
    auto state = std::make_unique<MemoryState>();
    state->device = &dev;
    state->handle = *pMemory;
    state->size = pAllocateInfo->allocationSize;
    if (pAllocateInfo->memoryTypeIndex < dev.memory_properties.memoryTypeCount) {
        const VkMemoryPropertyFlags flags =
            dev.memory_properties.memoryTypes[pAllocateInfo->memoryTypeIndex].propertyFlags;
        state->host_visible = flags & VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT;
        state->coherent = flags & VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
    }
    {
        std::lock_guard lock(g_mutex);
        g_memory[*pMemory] = std::move(state);
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
        std::lock_guard lock(g_mutex);
        const auto it = g_memory.find(memory);
        if (it != g_memory.end()) {
            const auto mapped = g_mapped.find(&dev);
            if (mapped != g_mapped.end()) mapped->second.erase(it->second.get());
            g_memory.erase(it);
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
    std::lock_guard lock(g_mutex);
    const auto it = g_memory.find(memory);
    if (it == g_memory.end()) return result;
    MemoryState &state = *it->second;
    if (offset >= state.size) return result;
    state.mapped = static_cast<const uint8_t *>(*ppData);
    state.map_offset = offset;
    state.map_size = size == VK_WHOLE_SIZE ? state.size - offset : std::min(size, state.size - offset);
    g_mapped[&dev].insert(&state);
    return result;
}

VKAPI_ATTR void VKAPI_CALL UnmapMemory(VkDevice device, VkDeviceMemory memory) {
    DeviceState &dev = device_state(device);
    if (dev.session) {
        std::lock_guard lock(g_mutex);
        const auto it = g_memory.find(memory);
        if (it != g_memory.end()) {
            std::vector<DirtyRun> runs;
            sync_locked(*it->second, runs); // before the pointer becomes invalid
            it->second->mapped = nullptr;
            const auto mapped = g_mapped.find(&dev);
            if (mapped != g_mapped.end()) mapped->second.erase(it->second.get());
        }
    }
    dev.dispatch.UnmapMemory(device, memory);
}

VKAPI_ATTR VkResult VKAPI_CALL FlushMappedMemoryRanges(VkDevice device, uint32_t memoryRangeCount,
                                                       const VkMappedMemoryRange *pMemoryRanges) {
    DeviceState &dev = device_state(device);
    if (capturing(dev)) {
        std::lock_guard lock(g_mutex);
        std::vector<DirtyRun> runs;
        std::unordered_set<VkDeviceMemory> done;
        for (uint32_t i = 0; i < memoryRangeCount; ++i) {
            const auto it = g_memory.find(pMemoryRanges[i].memory);
            if (it != g_memory.end() && done.insert(pMemoryRanges[i].memory).second)
                sync_locked(*it->second, runs);
        }
    }
    return dev.dispatch.FlushMappedMemoryRanges(device, memoryRangeCount, pMemoryRanges);
}

} // namespace entry
} // namespace splitvk
