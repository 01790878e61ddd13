#include "vk_util.h"

#include <string>

namespace atrium {

const char *vk_result_name(VkResult result) {
    switch (result) {
#define NAME(r)                                                                                              \
    case r:                                                                                                  \
        return #r
        NAME(VK_SUCCESS);
        NAME(VK_NOT_READY);
        NAME(VK_TIMEOUT);
        NAME(VK_INCOMPLETE);
        NAME(VK_SUBOPTIMAL_KHR);
        NAME(VK_ERROR_OUT_OF_HOST_MEMORY);
        NAME(VK_ERROR_OUT_OF_DEVICE_MEMORY);
        NAME(VK_ERROR_INITIALIZATION_FAILED);
        NAME(VK_ERROR_DEVICE_LOST);
        NAME(VK_ERROR_MEMORY_MAP_FAILED);
        NAME(VK_ERROR_LAYER_NOT_PRESENT);
        NAME(VK_ERROR_EXTENSION_NOT_PRESENT);
        NAME(VK_ERROR_FEATURE_NOT_PRESENT);
        NAME(VK_ERROR_INCOMPATIBLE_DRIVER);
        NAME(VK_ERROR_TOO_MANY_OBJECTS);
        NAME(VK_ERROR_FORMAT_NOT_SUPPORTED);
        NAME(VK_ERROR_FRAGMENTED_POOL);
        NAME(VK_ERROR_OUT_OF_POOL_MEMORY);
        NAME(VK_ERROR_SURFACE_LOST_KHR);
        NAME(VK_ERROR_NATIVE_WINDOW_IN_USE_KHR);
        NAME(VK_ERROR_OUT_OF_DATE_KHR);
        NAME(VK_ERROR_VALIDATION_FAILED_EXT);
#undef NAME
    default:
        return "VkResult(?)";
    }
}

void vk_check(VkResult result, const char *call) {
    if (result == VK_SUCCESS) return;
    std::string name(call);
    name = name.substr(0, name.find('('));
    throw Error(name + " failed: " + vk_result_name(result) + " (" + std::to_string(int(result)) + ")");
}

bool is_srgb(VkFormat format) {
    return format == VK_FORMAT_B8G8R8A8_SRGB || format == VK_FORMAT_R8G8B8A8_SRGB;
}

bool takes_linear(VkFormat format) {
    return is_srgb(format) || format == VK_FORMAT_R16G16B16A16_UNORM ||
           format == VK_FORMAT_R16G16B16A16_SFLOAT;
}

VkShaderModule create_shader(VkDevice device, const uint32_t *code, size_t bytes) {
    VkShaderModuleCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO;
    info.codeSize = bytes;
    info.pCode = code;
    VkShaderModule module;
    ATRIUM_VK_CHECK(vkCreateShaderModule(device, &info, nullptr, &module));
    return module;
}

} // namespace atrium
