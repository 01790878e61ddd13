#pragma once

// The Vulkan loader's interface (layer.cpp): version negotiation, which hands the loader the layer's
// vkGetInstanceProcAddr and vkGetDeviceProcAddr (entry::, looked up in the generated table).

#include <vulkan/vk_layer.h>

// The library's only exported Vulkan symbol (layer.map); vk_layer.h declares it too, hidden by the
// library's default visibility.
extern "C" [[gnu::visibility("default")]] VKAPI_ATTR VkResult VKAPI_CALL
vkNegotiateLoaderLayerInterfaceVersion(VkNegotiateLayerInterface *pVersionStruct);
