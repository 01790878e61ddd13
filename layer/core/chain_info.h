#pragma once

// The loader's chain information in the pNext of vkCreateInstance / vkCreateDevice.

#include "core/vk_util.h"

#include <vulkan/vk_layer.h>

namespace splitvk {

// Finds the loader's entry for `function` (VK_LAYER_LINK_INFO, VK_LOADER_DATA_CALLBACK):
// VkLayerInstanceCreateInfo under VK_STRUCTURE_TYPE_LOADER_INSTANCE_CREATE_INFO, or
// VkLayerDeviceCreateInfo under VK_STRUCTURE_TYPE_LOADER_DEVICE_CREATE_INFO. Several entries share
// that type, one per function. The chain is const in the create-info but owned by the loader, which
// expects each layer to advance its link to the next layer; hence the const_cast.
template <typename LoaderCreateInfo>
LoaderCreateInfo *find_loader_info(const void *p_next, VkStructureType loader_s_type,
                                   VkLayerFunction function) {
    for (auto *info = find_in_chain<LoaderCreateInfo>(p_next, loader_s_type); info;
         info = find_in_chain<LoaderCreateInfo>(info->pNext, loader_s_type))
        if (info->function == function) return const_cast<LoaderCreateInfo *>(info);
    return nullptr;
}

} // namespace splitvk
