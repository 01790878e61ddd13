#pragma once

// VkPhysicalDevice: what the application is told of its GPU. With an agent possible, that is the
// device envelope (protocol/device_envelope.h): the client's device narrowed by the agent
// baseline and by the agent's own GPU when one answered at vkCreateInstance, so that whatever the
// application sizes or aligns by these numbers replays correctly on the agent too.

#include "device_envelope.h"

#include <vulkan/vulkan.h>

#include <cstdint>
#include <optional>
#include <vector>

namespace splitvk {

struct PhysicalDeviceState {
    protocol::DeviceDescription client; // the client driver's own answers
    // What the application is told; unset when it is told the client's own (SPLITVK_ENVELOPE=
    // client, or settings that leave the layer unsplit for good).
    std::optional<protocol::DeviceDescription> envelope;
    bool agent_included = false;        // an agent's GPU is part of the envelope
    std::vector<uint8_t> envelope_wire; // the envelope as a Hello carries it; empty: unchecked
};

// The state of `physical_device`, made on first use (one line at info level says what the
// envelope changed). Never null for a physical device of an instance this layer created.
const PhysicalDeviceState *physical_device_state(VkPhysicalDevice physical_device);

} // namespace splitvk
