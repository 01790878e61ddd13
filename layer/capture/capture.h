#pragma once

// What the generated entry points (emit_layer.py) call to capture a forwarded command. With no
// session the whole cost is one pointer check.

#include "capture/command_buffer.h"
#include "capture/session.h"
#include "core/device.h"

#include <span>
#include <unordered_set>
#include <vector>

namespace splitvk {

// Whether calls go into the live-state log (and, with an agent connected, to the agent): every
// device with a session, connected or not, so that a later agent can be brought in.
inline bool capturing(const DeviceState &device) {
    return device.session != nullptr;
}

// Device-level call into the global stream, with its effect on the live-state log.
template <class F>
inline void record_global(DeviceState &device, LiveChange change, uint64_t id, F &&encode) {
    device.session->record(change, id, std::forward<F>(encode));
}

// The client ids of the handles a batch call created (vkAllocateCommandBuffers, pipelines, ...).
template <class Handle>
inline std::vector<uint64_t> handle_ids(const Handle *handles, uint32_t count) {
    std::vector<uint64_t> ids(count);
    for (uint32_t i = 0; i < count; ++i)
        ids[i] = codec::handle_value(handles[i]);
    return ids;
}

// A call that is one live-state log entry held by several ids (session.h: batches, binds).
template <class F>
inline void record_logged(DeviceState &device, std::span<const uint64_t> holders,
                          std::span<const uint64_t> killers, F &&encode) {
    device.session->record_logged(holders, killers, std::forward<F>(encode));
}

} // namespace splitvk
