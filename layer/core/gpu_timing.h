#pragma once

// GPU time of the client's periphery render (SPLITVK_STATS' periphery_ms) and of the layer's
// composite (merge_gpu_ms): on the GPU, not the
// CPU, because the application records and submits long before the GPU runs the work, and a CPU
// clock around vkQueueSubmit would measure the driver, not the rendering.
//
// Each command buffer that records a split pass gets a pair of timestamp queries of the device's
// pool: reset just before its first split pass begins (outside the pass, so also valid when the
// command buffer is submitted again without being re-recorded), written at the top of the pipe
// after that pass began and at the bottom of the pipe after it ended. Results are read without
// waiting at present: a frame reports the latest completed measurement, one or two frames old,
// which is what a median over a run needs. A pass whose contents are secondary command buffers is
// timed from its primary: the first timestamp then goes just before the pass begins, since nothing
// but vkCmdExecuteCommands may be recorded inside it; the secondaries themselves get no queries. The
// compositor's command buffer gets a pair the same way, around everything it records.

#include "core/device.h"

namespace splitvk {

// The timestamp pair of a command buffer's current recording, if it times one. An application's
// command buffer keeps it in its CommandBufferState (command_buffer.h), which begins it afresh with
// every recording: a new recording has no split pass timed yet. The compositor keeps one per slot.
// Read and written by this file's functions under their lock; cleared without it only by its owner
// as a recording begins, when Vulkan's external synchronisation lets no other thread record or
// submit the command buffer.
struct CommandTiming {
    bool timed = false; // `pair` is this recording's
    uint32_t pair = 0;
    bool begun = false; // this recording wrote the begin timestamp
    bool ended = false;
};

// render_pass.cpp (and transfer.cpp, for a split pass that ends in a copy or blit), around the first
// split pass a command buffer records. `timing` is the command buffer's own, which the caller takes
// from its CommandBufferState (command_buffer.h: command_buffer_timing) on its recording thread.
void time_before_split_pass(DeviceState &device, VkCommandBuffer command_buffer, CommandTiming &timing);
void time_split_pass_begun(DeviceState &device, VkCommandBuffer command_buffer, CommandTiming &timing);
void time_split_pass_ended(DeviceState &device, VkCommandBuffer command_buffer, CommandTiming &timing);

// A command buffer's submit: its timestamps will be written (only submitted pairs are read: a
// query is uninitialised until its reset executes).
void note_timed_submit(DeviceState &device, const CommandTiming &timing);

// compositor.cpp: the first and the last command of a composite. The begin timestamp is written
// at the transfer stage, the stage the composite's semaphore waits block, so that it does not
// count the wait for the application's rendering. time_composite_end also records the copy of
// both timestamps (two uint64_t) into `results`, which the compositor reads once the composite's
// fence has signalled: it waits for that fence anyway before it reuses the image's slot, so
// reading costs no stall (vkGetQueryPoolResults would make lavapipe wait for idle). False when
// the composite is not timed.
void time_composite_begin(DeviceState &device, VkCommandBuffer command_buffer, CommandTiming &timing);
bool time_composite_end(DeviceState &device, VkCommandBuffer command_buffer, CommandTiming &timing,
                        VkBuffer results);
// Milliseconds between two timestamps of this device; 0 when they make no sense.
double timestamps_ms(DeviceState &device, uint64_t begin, uint64_t end);

// Milliseconds of the latest split pass the GPU has completed, 0 when none has yet. Reads the
// query pool only every kPeripheryReadInterval calls and returns the last value in between: some
// drivers make vkGetQueryPoolResults wait for the device to go idle even without WAIT_BIT
// (lavapipe does), and the present thread must not pay that every frame.
inline constexpr uint64_t kPeripheryReadInterval = 16;
double latest_periphery_ms(DeviceState &device);

// vkDestroyDevice.
void release_gpu_timing(DeviceState &device);

} // namespace splitvk
