#pragma once

// The loader's chain information in the pNext of vkCreateInstance / vkCreateDevice.

#include <vulkan/vk_layer.h>

namespace splitvk {

// Finds the VK_LAYER_LINK_INFO entry: VkLayerInstanceCreateInfo under
// VK_STRUCTURE_TYPE_LOADER_INSTANCE_CREATE_INFO, or VkLayerDeviceCreateInfo under
// VK_STRUCTURE_TYPE_LOADER_DEVICE_CREATE_INFO. The chain is const in the create-info but owned by
// the loader, which expects each layer to advance it to the next layer; hence the const_cast.
template <typename LayerCreateInfo>
LayerCreateInfo *find_layer_link(const void *p_next, VkStructureType loader_s_type) {
    for (auto *next = static_cast<const VkBaseInStructure *>(p_next); next; next = next->pNext) {
        if (next->sType != loader_s_type) continue;
        auto *link = reinterpret_cast<LayerCreateInfo *>(const_cast<VkBaseInStructure *>(next));
        if (link->function == VK_LAYER_LINK_INFO) return link;
    }
    return nullptr;
}

} // namespace splitvk
