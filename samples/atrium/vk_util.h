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

// Whether a colour target of this format takes linear colours: an sRGB format encodes them as it
// stores them, a 16-bit one keeps them as they are (HDR targets; OpenXR reads every format but an
// sRGB one as linear). An 8-bit UNORM target takes display colours: the shaders encode sRGB into it.
bool takes_linear(VkFormat format);

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
