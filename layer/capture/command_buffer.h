#pragma once

// VkCommandBuffer (command_buffer.cpp): one CommandBufferState per command buffer allocated while
// the device has a session, created at vkAllocateCommandBuffers, begun afresh at
// vkBeginCommandBuffer / vkResetCommandBuffer / vkResetCommandPool, and dropped at
// vkFreeCommandBuffers / vkDestroyCommandPool (before the driver call) or with its device's table. It holds
// what the layer keeps of one recording: its capture stream (docs/architecture.md §3), its split tracker (the
// split's viewports and scissors, the split passes it drew, its bound compute sets: split.h), its
// image layout transitions (resource.h) and its split pass's timestamp pair (gpu_timing.h).
//
// The accessors below return the state's parts for the command buffer's recording thread, which
// Vulkan's external synchronisation makes the only user while it records; a submit reads them
// (queue.cpp) when no thread may record it.

#include "core/device.h"

#include <cstdint>
#include <unordered_set>
#include <vector>

namespace splitvk {

namespace codec {
class Encoder;
}
namespace split {
class CommandTracker;
}
struct CommandLayouts;
struct CommandTiming;
class LockedImages;

// The stream a command buffer is being recorded into; nullptr when it is not captured
// (allocated before the session, or not between begin and end).
codec::Encoder *command_buffer_encoder(VkCommandBuffer command_buffer);
// Its image layout transitions (resource.h), applied at every submit; nullptr without state.
CommandLayouts *command_buffer_layouts(VkCommandBuffer command_buffer);
// Its split tracker (split.h); nullptr without state.
split::CommandTracker *split_tracker(VkCommandBuffer command_buffer);
// Its split pass's timestamp pair, for the split-pass timing functions (gpu_timing.h); nullptr without
// state.
CommandTiming *command_buffer_timing(VkCommandBuffer command_buffer);

// vkQueueSubmit*, under the queue's lock just before the driver call, for each submitted command
// buffer in submission order: what it recorded reaches the images it names (layouts, resource.h;
// what its split passes drew, split.h). The caller holds `images` across the whole submit, so that
// its command buffers apply in order as one step. Returns its split pass's timing, which the
// caller marks submitted (gpu_timing.h: note_timed_submit) only once `images` is released: that
// lock can wait for the GPU (latest_periphery_ms), which the image table must never do.
const CommandTiming *note_submitted(DeviceState &device, LockedImages &images,
                                    VkCommandBuffer command_buffer);

// Snapshot part (session.h: build_live_snapshot): the last stream of each command buffer whose id
// is in `live`.
void snapshot_command_buffers(DeviceState &device, const std::unordered_set<uint64_t> &live,
                              std::vector<std::vector<uint8_t>> &streams);

} // namespace splitvk
