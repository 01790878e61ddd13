// Small Vulkan helpers: error checking and resources that own their memory.
#pragma once

#include "error.h"

#include <vulkan/vulkan.h>

namespace atrium {

const char *vk_result_name(VkResult result);

// Throws Error("<function> failed: VK_ERROR_...") unless result is VK_SUCCESS.
void vk_check(VkResult result, const char *call);

#define ATRIUM_VK_CHECK(call) ::atrium::vk_check((call), #call)

bool is_srgb(VkFormat format);

// Throws Error when the driver rejects the code.
VkShaderModule create_shader(VkDevice device, const uint32_t *code, size_t bytes);

struct Buffer {
    VkBuffer buffer = VK_NULL_HANDLE;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    VkDeviceSize size = 0;
    void *mapped = nullptr; // persistently mapped when host visible
};

struct Image {
    VkImage image = VK_NULL_HANDLE;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    VkImageView view = VK_NULL_HANDLE;
};

} // namespace atrium
