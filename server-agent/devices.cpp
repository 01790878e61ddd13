#include "devices.h"

#include <vulkan/vulkan.h>

namespace splitvk::agent {
namespace {

const char *device_type_name(VkPhysicalDeviceType type) {
    switch (type) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU:
        return "discrete";
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU:
        return "integrated";
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU:
        return "virtual";
    case VK_PHYSICAL_DEVICE_TYPE_CPU:
        return "cpu";
    default:
        return "other";
    }
}

std::string uuid_hex(const uint8_t (&uuid)[VK_UUID_SIZE]) {
    static constexpr char kDigits[] = "0123456789abcdef";
    std::string hex;
    for (const uint8_t byte : uuid) {
        hex += kDigits[byte >> 4];
        hex += kDigits[byte & 15];
    }
    return hex;
}

} // namespace

std::vector<GpuInfo> enumerate_gpus(std::string *error) {
    VkApplicationInfo app{};
    app.sType = VK_STRUCTURE_TYPE_APPLICATION_INFO;
    app.pApplicationName = "splitvk-agent";
    app.apiVersion = VK_API_VERSION_1_3;
    VkInstanceCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO;
    info.pApplicationInfo = &app;

    VkInstance instance = VK_NULL_HANDLE;
    if (const VkResult result = vkCreateInstance(&info, nullptr, &instance); result != VK_SUCCESS) {
        if (error)
            *error = "vkCreateInstance failed (VkResult " + std::to_string(result) +
                     "): is a Vulkan driver installed?";
        return {};
    }
    uint32_t count = 0;
    vkEnumeratePhysicalDevices(instance, &count, nullptr);
    std::vector<VkPhysicalDevice> devices(count);
    vkEnumeratePhysicalDevices(instance, &count, devices.data());

    std::vector<GpuInfo> gpus;
    for (uint32_t i = 0; i < count; ++i) {
        VkPhysicalDeviceIDProperties ids{};
        ids.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ID_PROPERTIES;
        VkPhysicalDeviceDriverProperties driver{};
        driver.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES;
        driver.pNext = &ids;
        VkPhysicalDeviceProperties2 props{};
        props.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2;
        props.pNext = &driver;
        vkGetPhysicalDeviceProperties2(devices[i], &props);
        protocol::DeviceQueries queries{vkGetPhysicalDeviceProperties, vkGetPhysicalDeviceFeatures,
                                        vkGetPhysicalDeviceFeatures2, vkGetPhysicalDeviceFormatProperties,
                                        vkEnumerateDeviceExtensionProperties};
        gpus.push_back(GpuInfo{i, props.properties.deviceName, device_type_name(props.properties.deviceType),
                               props.properties.apiVersion,
                               std::string(driver.driverName) + " " + driver.driverInfo,
                               protocol::describe(devices[i], queries), uuid_hex(ids.deviceUUID)});
    }
    vkDestroyInstance(instance, nullptr);
    if (gpus.empty() && error) *error = "no Vulkan physical devices found";
    return gpus;
}

} // namespace splitvk::agent
