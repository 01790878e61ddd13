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
// which is what a median over a run needs. Secondary command buffers are not timed. The
// compositor's command buffer gets a pair the same way, around everything it records.

#include "device.h"

namespace splitvk {

// render_pass.cpp, around the first split pass a command buffer records.
void time_before_split_pass(DeviceState &device, VkCommandBuffer command_buffer);
void time_split_pass_begun(DeviceState &device, VkCommandBuffer command_buffer);
void time_split_pass_ended(DeviceState &device, VkCommandBuffer command_buffer);

// vkQueueSubmit: these command buffers' timestamps will be written (only submitted pairs are read:
// a query is uninitialised until its reset executes).
void note_timed_submit(DeviceState &device, uint32_t count, const VkCommandBuffer *command_buffers);

// vkBeginCommandBuffer: a new recording has no split pass timed yet.
void reset_split_pass_timing(VkCommandBuffer command_buffer);

// compositor.cpp: the first and the last command of a composite. The begin timestamp is written
// at the transfer stage, the stage the composite's semaphore waits block, so that it does not
// count the wait for the application's rendering.
void time_composite_begin(DeviceState &device, VkCommandBuffer command_buffer);
void time_composite_end(DeviceState &device, VkCommandBuffer command_buffer);

struct GpuTimes {
    double periphery_ms = 0; // the latest split pass the GPU has completed
    double composite_ms = 0; // the latest composite the GPU has completed
};

// The latest completed measurements, 0 where none has completed yet. Reads the query pool only
// every kGpuTimesReadInterval calls and returns the last values in between: some drivers make
// vkGetQueryPoolResults wait for the device to go idle even without WAIT_BIT (lavapipe does), and
// the present thread must not pay that every frame.
inline constexpr uint64_t kGpuTimesReadInterval = 16;
GpuTimes latest_gpu_times(DeviceState &device);

// vkDestroyDevice.
void release_gpu_timing(DeviceState &device);

} // namespace splitvk
