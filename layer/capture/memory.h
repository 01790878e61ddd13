#pragma once

// VkDeviceMemory (memory.cpp): the shadow copies of mapped memory behind MemoryData (docs/architecture.md
// §3). Their state is the device's (DeviceState::memory), under locks of its own, never one of the process.

#include "core/device.h"

namespace splitvk {

// Before a submit: compares every mapped range of the device with its shadow and sends what changed.
void sync_mapped_memory(DeviceState &device);

// A new agent was given the current contents of every buffer; the shadows of mapped memory become
// those contents, so that later diffs are against what it has.
void resync_mapped_shadows(DeviceState &device);

} // namespace splitvk
