#pragma once

// The snapshot of contents that brings a new agent in (session.h: after the object log, the agent
// gets the contents of every live buffer and image, read back on the client; resource.h keeps
// what the readback needs: TRANSFER_SRC on every resource that allows it, where buffers live, and
// the layout of every image subresource).

#include "capture/live_state_log.h"
#include "core/device.h"

#include <cstdint>
#include <string>
#include <vector>

namespace splitvk {

// The contents of every live buffer and image, read back with a copy submitted on `queue` (of
// family `family`), which must be idle; and the messages that give them to a fresh agent after the
// object log: MemoryData for buffers, and for images a staging buffer with the bytes plus a
// command buffer that copies them in and leaves each subresource in its tracked layout. Images the
// layer cannot read back (no TRANSFER_SRC, multisampled, depth/stencil, a format vk.xml does not
// describe as single-plane, or no known layout) are counted in `skipped_images`; screen-space
// targets (screen_space.h) in `screen_space_images`.
struct ContentSnapshot {
    std::vector<LiveMessage> messages;
    uint64_t buffers = 0;
    uint64_t images = 0;
    uint64_t skipped_images = 0;
    uint64_t screen_space_images = 0; // left out: scaled on the client, rewritten every frame
    uint64_t bytes = 0;
};
bool snapshot_contents(DeviceState &device, VkQueue queue, uint32_t family, ContentSnapshot *out,
                       std::string *error);

} // namespace splitvk
