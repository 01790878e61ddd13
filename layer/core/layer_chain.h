#pragma once

// Where splitvk sits among the other layers of an instance's chain (layer_chain.cpp).

#include <vulkan/vk_layer.h>

namespace splitvk {

// Says once, at info level, when a layer known to draw at present (MangoHud, the Mesa overlay) is
// above splitvk in the instance chain: what it draws then becomes part of the periphery. `link` is
// this layer's own link, before the chain is advanced past it.
void report_layer_position(const VkLayerInstanceLink *link);

} // namespace splitvk
