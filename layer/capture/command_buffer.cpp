// VkCommandBuffer: one CommandBufferState each (command_buffer.h), and per-command-buffer streams
// (docs/architecture.md §3). A command buffer's commands are encoded into its own stream while it is recorded
// (vkBeginCommandBuffer resets it) and sent as one Commands message at vkEndCommandBuffer; a
// resubmit sends nothing again. The last recorded stream stays here as the command buffer's part of
// the live-state log.
//
// State exists only for command buffers allocated while the device has a session, so a device
// that runs unsplit never allocates any. Each command buffer is externally synchronised by the
// application (one recording thread at a time); the device's table has its own lock, held only for
// the lookup.

#include "capture/command_buffer.h"

#include "capture/capture.h"
#include "capture/resource.h"
#include "capture/split.h"
#include "core/gpu_timing.h"
#include "layer_entry_points.h"

#include <mutex>
#include <shared_mutex>
#include <unordered_map>
#include <unordered_set>

namespace splitvk {
namespace {

struct CommandBufferState {
    VkCommandPool pool = VK_NULL_HANDLE;
    VkCommandBufferLevel level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    bool recording = false;
    codec::Encoder encoder;
    std::vector<uint8_t> last_stream; // live-state log: the stream last sent for it
    // The split's viewport/scissor state and the split passes recorded (split.h); reset at begin,
    // read at submit (a resubmitted command buffer draws the same split passes again).
    split::CommandTracker split;
    CommandLayouts layouts; // the image layout transitions it records (resource.h); reset at begin
    CommandTiming timing;   // its split pass's timestamps (gpu_timing.h); reset at begin
};

} // namespace

struct CommandBufferTable {
    std::shared_mutex mutex; // the maps, not the states (see the top of this file)
    std::unordered_map<VkCommandBuffer, std::unique_ptr<CommandBufferState>> buffers;
    std::unordered_map<VkCommandPool, std::unordered_set<VkCommandBuffer>> pools;
};

std::shared_ptr<CommandBufferTable> make_command_buffer_table() {
    return std::make_shared<CommandBufferTable>();
}

namespace {

CommandBufferState *find_state(const DeviceState &device, VkCommandBuffer command_buffer) {
    CommandBufferTable &t = *device.command_buffers;
    std::shared_lock lock(t.mutex);
    const auto it = t.buffers.find(command_buffer);
    return it == t.buffers.end() ? nullptr : it->second.get();
}

// The command buffer's own device: the dispatch key finds it.
CommandBufferState *find_state(VkCommandBuffer command_buffer) {
    return find_state(device_state(command_buffer), command_buffer);
}

void discard_stream(CommandBufferState &state) {
    state.recording = false;
    (void)state.encoder.take();
}

// vkBeginCommandBuffer, vkResetCommandBuffer, vkResetCommandPool: what the previous recording
// left is gone (its stream, split passes, bound compute sets, layouts and timestamps), so that
// nothing of it applies to the next one (a stale compute set scaled a later dispatch).
void begin_afresh(CommandBufferState &state) {
    discard_stream(state);
    state.split.reset();
    state.layouts = {};
    state.timing = {};
}

// Under t.mutex (exclusive).
void erase_locked(CommandBufferTable &t, VkCommandBuffer command_buffer) {
    const auto it = t.buffers.find(command_buffer);
    if (it == t.buffers.end()) return;
    const auto pool = t.pools.find(it->second->pool);
    if (pool != t.pools.end()) {
        pool->second.erase(command_buffer);
        if (pool->second.empty()) t.pools.erase(pool);
    }
    t.buffers.erase(it);
}

} // namespace

codec::Encoder *command_buffer_encoder(VkCommandBuffer command_buffer) {
    CommandBufferState *state = find_state(command_buffer);
    return state && state->recording ? &state->encoder : nullptr;
}

CommandLayouts *command_buffer_layouts(VkCommandBuffer command_buffer) {
    CommandBufferState *state = find_state(command_buffer);
    return state ? &state->layouts : nullptr;
}

CommandTiming *command_buffer_timing(VkCommandBuffer command_buffer) {
    CommandBufferState *state = find_state(command_buffer);
    return state ? &state->timing : nullptr;
}

const CommandTiming *note_submitted(DeviceState &device, LockedImages &images,
                                    VkCommandBuffer command_buffer) {
    // The application may not free or re-record a command buffer while it is being submitted, so
    // its state stays put after the map's lock is released.
    const CommandBufferState *state = find_state(device, command_buffer);
    if (!state) return nullptr;
    if (split_enabled(device)) note_split_drawn(images, state->split);
    apply_layouts(images, state->layouts);
    return &state->timing;
}

split::CommandTracker *split_tracker(VkCommandBuffer command_buffer) {
    CommandBufferState *state = find_state(command_buffer);
    return state ? &state->split : nullptr;
}

void snapshot_command_buffers(DeviceState &device, const std::unordered_set<uint64_t> &live,
                              std::vector<std::vector<uint8_t>> &streams) {
    CommandBufferTable &t = *device.command_buffers;
    std::shared_lock lock(t.mutex);
    for (const auto &[cb, state] : t.buffers)
        if (!state->last_stream.empty() && live.count(codec::handle_value(cb)))
            streams.push_back(state->last_stream);
}

namespace entry {

VKAPI_ATTR VkResult VKAPI_CALL AllocateCommandBuffers(VkDevice device,
                                                      const VkCommandBufferAllocateInfo *pAllocateInfo,
                                                      VkCommandBuffer *pCommandBuffers) {
    DeviceState &dev = device_state(device);
    const VkResult result = dev.dispatch.AllocateCommandBuffers(device, pAllocateInfo, pCommandBuffers);
    if (result != VK_SUCCESS || !capturing(dev)) return result;
    {
        CommandBufferTable &t = *dev.command_buffers;
        std::unique_lock lock(t.mutex);
        for (uint32_t i = 0; i < pAllocateInfo->commandBufferCount; ++i) {
            auto state = std::make_unique<CommandBufferState>();
            state->pool = pAllocateInfo->commandPool;
            state->level = pAllocateInfo->level;
            state->encoder.set_hooks(dev.session->hooks());
            t.buffers[pCommandBuffers[i]] = std::move(state);
            t.pools[pAllocateInfo->commandPool].insert(pCommandBuffers[i]);
        }
    }
    record_logged(dev, handle_ids(pCommandBuffers, pAllocateInfo->commandBufferCount), {},
                  [&](codec::Encoder &e) {
                      encode_vkAllocateCommandBuffers(e, device, pAllocateInfo, pCommandBuffers);
                  });
    return result;
}

VKAPI_ATTR void VKAPI_CALL FreeCommandBuffers(VkDevice device, VkCommandPool commandPool,
                                              uint32_t commandBufferCount,
                                              const VkCommandBuffer *pCommandBuffers) {
    DeviceState &dev = device_state(device);
    // Forgotten and recorded before the driver may hand the values to command buffers another thread
    // allocates (as every destroy: codegen/emit_layer.py): they must keep their state, and the agent
    // must not free them.
    if (dev.session) {
        std::vector<uint64_t> ids;
        {
            std::unique_lock lock(dev.command_buffers->mutex);
            for (uint32_t i = 0; i < commandBufferCount; ++i)
                if (pCommandBuffers[i]) {
                    erase_locked(*dev.command_buffers, pCommandBuffers[i]);
                    ids.push_back(codec::handle_value(pCommandBuffers[i]));
                }
        }
        dev.session->forget(ids);
        if (capturing(dev))
            record_global(dev, LiveChange::Unchanged, 0, [&](codec::Encoder &e) {
                encode_vkFreeCommandBuffers(e, device, commandPool, commandBufferCount, pCommandBuffers);
            });
    }
    dev.dispatch.FreeCommandBuffers(device, commandPool, commandBufferCount, pCommandBuffers);
}

VKAPI_ATTR VkResult VKAPI_CALL BeginCommandBuffer(VkCommandBuffer commandBuffer,
                                                  const VkCommandBufferBeginInfo *pBeginInfo) {
    DeviceState &dev = device_state(commandBuffer);
    const VkResult result = dev.dispatch.BeginCommandBuffer(commandBuffer, pBeginInfo);
    if (!dev.session) return result;
    CommandBufferState *state = find_state(dev, commandBuffer);
    if (!state) return result;
    begin_afresh(*state);
    if (state->level == VK_COMMAND_BUFFER_LEVEL_SECONDARY && result == VK_SUCCESS && split_recording(dev))
        begin_secondary(dev, commandBuffer, *pBeginInfo);
    if (result == VK_SUCCESS && capturing(dev)) {
        encode_vkBeginCommandBuffer(state->encoder, commandBuffer, pBeginInfo, state->level);
        state->recording = true;
    }
    return result;
}

VKAPI_ATTR VkResult VKAPI_CALL EndCommandBuffer(VkCommandBuffer commandBuffer) {
    DeviceState &dev = device_state(commandBuffer);
    const VkResult result = dev.dispatch.EndCommandBuffer(commandBuffer);
    if (!dev.session) return result;
    CommandBufferState *state = find_state(dev, commandBuffer);
    if (!state || !state->recording) return result;
    state->recording = false;
    if (result != VK_SUCCESS || !capturing(dev)) {
        discard_stream(*state);
        return result;
    }
    encode_vkEndCommandBuffer(state->encoder, commandBuffer);
    state->last_stream = state->encoder.take();
    dev.session->send_commands(state->last_stream);
    return result;
}

VKAPI_ATTR VkResult VKAPI_CALL ResetCommandBuffer(VkCommandBuffer commandBuffer,
                                                  VkCommandBufferResetFlags flags) {
    DeviceState &dev = device_state(commandBuffer);
    const VkResult result = dev.dispatch.ResetCommandBuffer(commandBuffer, flags);
    if (!dev.session) return result;
    if (CommandBufferState *state = find_state(dev, commandBuffer)) {
        begin_afresh(*state);
        state->last_stream.clear();
    }
    // Not sent: the agent's vkBeginCommandBuffer resets implicitly, as the client's did.
    return result;
}

VKAPI_ATTR VkResult VKAPI_CALL ResetCommandPool(VkDevice device, VkCommandPool commandPool,
                                                VkCommandPoolResetFlags flags) {
    DeviceState &dev = device_state(device);
    const VkResult result = dev.dispatch.ResetCommandPool(device, commandPool, flags);
    if (!dev.session) return result;
    {
        CommandBufferTable &t = *dev.command_buffers;
        std::unique_lock lock(t.mutex);
        const auto pool = t.pools.find(commandPool);
        if (pool != t.pools.end())
            for (VkCommandBuffer cb : pool->second) {
                auto &state = *t.buffers.at(cb);
                begin_afresh(state);
                state.last_stream.clear();
            }
    }
    if (result == VK_SUCCESS && capturing(dev))
        record_global(dev, LiveChange::Unchanged, 0,
                      [&](codec::Encoder &e) { encode_vkResetCommandPool(e, device, commandPool, flags); });
    return result;
}

VKAPI_ATTR void VKAPI_CALL DestroyCommandPool(VkDevice device, VkCommandPool commandPool,
                                              const VkAllocationCallbacks *pAllocator) {
    DeviceState &dev = device_state(device);
    // Forgotten and recorded before the driver may hand the pool's value, or its command buffers',
    // to objects another thread creates (as every destroy: codegen/emit_layer.py).
    if (dev.session && commandPool != VK_NULL_HANDLE) {
        std::vector<uint64_t> ids;
        {
            CommandBufferTable &t = *dev.command_buffers;
            std::unique_lock lock(t.mutex);
            const auto pool = t.pools.find(commandPool);
            if (pool != t.pools.end()) {
                for (VkCommandBuffer cb : pool->second) {
                    t.buffers.erase(cb);
                    ids.push_back(codec::handle_value(cb));
                }
                t.pools.erase(pool);
            }
        }
        dev.session->forget(ids);
        if (capturing(dev))
            record_global(
                dev, LiveChange::Destroyed, codec::handle_value(commandPool),
                [&](codec::Encoder &e) { encode_vkDestroyCommandPool(e, device, commandPool, nullptr); });
    }
    dev.dispatch.DestroyCommandPool(device, commandPool, pAllocator);
}

} // namespace entry
} // namespace splitvk
