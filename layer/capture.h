#pragma once

// What the generated entry points (emit_layer.py) call to capture a forwarded command. With no
// session the whole cost is one pointer check.

#include "device.h"
#include "session.h"

namespace splitvk {

inline bool capturing(const DeviceState &device) {
    return device.session != nullptr && device.session->live();
}

// Device-level call into the global stream, with its effect on the live-state log.
template <class F>
inline void record_global(DeviceState &device, LiveChange change, uint64_t id, F &&encode) {
    device.session->record(change, id, std::forward<F>(encode));
}

// The stream a command buffer is being recorded into; nullptr when it is not captured
// (allocated before the session, or not between begin and end).
codec::Encoder *command_buffer_encoder(VkCommandBuffer command_buffer);

} // namespace splitvk
