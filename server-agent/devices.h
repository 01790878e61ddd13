#pragma once

#include "device_envelope.h"

#include <cstdint>
#include <string>
#include <vector>

namespace splitvk::agent {

struct GpuInfo {
    uint32_t index;
    std::string name;
    std::string type; // "discrete", "integrated", "cpu", ...
    uint32_t api_version;
    std::string driver;
    protocol::DeviceDescription description; // limits, features, formats (device_envelope.h)
    std::string uuid; // deviceUUID, 32 lowercase hex digits: the same GPU whatever the enumeration order
};

// The GPUs the Vulkan loader offers this process, in its enumeration order. On failure returns
// an empty list and sets `error` to one line.
std::vector<GpuInfo> enumerate_gpus(std::string *error);

} // namespace splitvk::agent
