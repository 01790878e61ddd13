#pragma once

// VkPipeline (pipeline.cpp): static viewport/scissor state the layer made dynamic (split.h).

#include "core/device.h"
#include "split_tracker.h"

#include <vulkan/vulkan.h>

#include <memory>

namespace splitvk {

// The static viewport/scissor state of a pipeline the layer made dynamic; null for every other
// pipeline.
std::shared_ptr<const split::StaticViewportState> pipeline_static_state(const DeviceState &device,
                                                                        VkPipeline pipeline);

} // namespace splitvk
