#include "vulkan_context.h"

#include "log.h"
#include "vk_codec.h"
#include "vk_envelope_tables.h"

#include <algorithm>
#include <cstring>
#include <memory>
#include <optional>
#include <string_view>
#include <vector>

namespace splitvk::agent {

namespace {

constexpr const char *kValidationLayer = "VK_LAYER_KHRONOS_validation";

bool has_extension(const std::vector<VkExtensionProperties> &list, std::string_view name) {
    return std::any_of(list.begin(), list.end(),
                       [&](const VkExtensionProperties &e) { return name == e.extensionName; });
}

std::vector<VkExtensionProperties> instance_extensions(const char *layer) {
    uint32_t count = 0;
    if (vkEnumerateInstanceExtensionProperties(layer, &count, nullptr) != VK_SUCCESS) return {};
    std::vector<VkExtensionProperties> list(count);
    if (vkEnumerateInstanceExtensionProperties(layer, &count, list.data()) < 0) return {};
    list.resize(count);
    return list;
}

// A feature structure of the client's vkCreateDevice chain that the agent mirrors member by member
// (what the client enabled and this GPU supports): VkPhysicalDeviceFeatures2, and every structure of
// VkBool32 members that vk.xml lets extend both it and VkDeviceCreateInfo (vk_envelope_tables.h),
// where this device has its core version or enables its extension.
struct FeatureStruct {
    VkStructureType stype;
    size_t size;
};

std::optional<FeatureStruct> mirrored_feature_struct(VkStructureType stype, uint32_t api_version,
                                                     const std::vector<const char *> &extensions) {
    if (stype == VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2)
        return api_version >= VK_API_VERSION_1_1
                   ? std::optional(FeatureStruct{stype, sizeof(VkPhysicalDeviceFeatures2)})
                   : std::nullopt;
    for (const auto &known : envelope::kDeviceFeatureStructs) {
        if (known.stype != stype) continue;
        // Any extension structure is queried through vkGetPhysicalDeviceFeatures2 (1.1).
        const bool available =
            known.extension
                ? api_version >= VK_API_VERSION_1_1 &&
                      std::any_of(extensions.begin(), extensions.end(),
                                  [&](const char *e) { return std::string_view(e) == known.extension; })
                : api_version >= known.core_version;
        if (available) return FeatureStruct{stype, known.size};
    }
    return std::nullopt;
}

constexpr size_t kBoolsOffset = sizeof(VkBaseOutStructure);

void and_bools(void *enabled, const void *supported, size_t size) {
    auto *e = static_cast<uint8_t *>(enabled) + kBoolsOffset;
    const auto *s = static_cast<const uint8_t *>(supported) + kBoolsOffset;
    for (size_t i = 0; i + sizeof(VkBool32) <= size - kBoolsOffset; i += sizeof(VkBool32)) {
        VkBool32 a, b;
        std::memcpy(&a, e + i, sizeof(a));
        std::memcpy(&b, s + i, sizeof(b));
        a = (a && b) ? VK_TRUE : VK_FALSE;
        std::memcpy(e + i, &a, sizeof(a));
    }
}

} // namespace

VulkanContext::~VulkanContext() {
    // The device is not destroyed here: a session ends by exiting its process, which frees
    // everything; destroying a device that still owns the client's objects would only make the
    // validation layer report them as leaks.
    if (device) vkDeviceWaitIdle(device);
}

VKAPI_ATTR VkBool32 VKAPI_CALL VulkanContext::on_message(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                                         VkDebugUtilsMessageTypeFlagsEXT types,
                                                         const VkDebugUtilsMessengerCallbackDataEXT *data,
                                                         void *user) {
    auto *self = static_cast<VulkanContext *>(user);
    const char *message = data && data->pMessage ? data->pMessage : "(no message)";
    const auto session = static_cast<unsigned long long>(self->session_id_);
    // A message of the general type alone is the loader's or a driver's about this machine, not about
    // what the session replays: a multiarch host's ICD manifests for another architecture make the
    // loader report an error for each library it cannot open. It is said, and fails nothing.
    if (!(types & (VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                   VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT))) {
        SPLITVK_INFO("session %llu: loader: %s", session, message);
        return VK_FALSE;
    }
    // Only errors fail the session: a warning (a performance one such as OutputNotConsumed, or a
    // best-practice note) describes a clean application too.
    if (severity >= VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT) {
        ++self->validation_errors_;
        SPLITVK_ERROR("session %llu: validation: %s", session, message);
    } else if (severity >= VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT) {
        ++self->validation_warnings_;
        SPLITVK_WARN("session %llu: validation: %s", session, message);
    }
    return VK_FALSE;
}

bool VulkanContext::create_instance(uint32_t device_index, bool validate, uint64_t session_id,
                                    std::string *error) {
    session_id_ = session_id;
    uint32_t loader_version = VK_API_VERSION_1_0;
    vkEnumerateInstanceVersion(&loader_version);
    api_version = std::min<uint32_t>(loader_version, VK_API_VERSION_1_3);

    const auto available = instance_extensions(nullptr);
    std::vector<const char *> extensions;
    std::vector<const char *> layers;
    if (has_extension(available, VK_KHR_SURFACE_EXTENSION_NAME)) {
        extensions.push_back(VK_KHR_SURFACE_EXTENSION_NAME); // VK_KHR_swapchain depends on it
        surface_extension_ = true;
    }
    VkValidationFeatureEnableEXT enables[] = {VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT};
    VkValidationFeaturesEXT features{};
    features.sType = VK_STRUCTURE_TYPE_VALIDATION_FEATURES_EXT;
    features.enabledValidationFeatureCount = 1;
    features.pEnabledValidationFeatures = enables;
    VkDebugUtilsMessengerCreateInfoEXT messenger_info{};
    messenger_info.sType = VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT;
    messenger_info.messageSeverity =
        VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
    messenger_info.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT |
                                 VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                                 VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
    messenger_info.pfnUserCallback = &VulkanContext::on_message;
    messenger_info.pUserData = this;
    const void *chain = nullptr;
    if (validate) {
        uint32_t count = 0;
        vkEnumerateInstanceLayerProperties(&count, nullptr);
        std::vector<VkLayerProperties> list(count);
        vkEnumerateInstanceLayerProperties(&count, list.data());
        const bool found = std::any_of(list.begin(), list.begin() + count, [](const VkLayerProperties &l) {
            return std::string_view(l.layerName) == kValidationLayer;
        });
        if (!found) {
            *error =
                "--validate: VK_LAYER_KHRONOS_validation is not installed (Debian: vulkan-validationlayers)";
            return false;
        }
        layers.push_back(kValidationLayer);
        const auto layer_extensions = instance_extensions(kValidationLayer);
        extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
        if (has_extension(layer_extensions, VK_EXT_VALIDATION_FEATURES_EXTENSION_NAME))
            extensions.push_back(VK_EXT_VALIDATION_FEATURES_EXTENSION_NAME);
        features.pNext = &messenger_info; // messages from vkCreateInstance itself too
        chain = &features;
    }

    VkApplicationInfo app{};

    app.sType = VK_STRUCTURE_TYPE_APPLICATION_INFO;
    app.pApplicationName = "splitvk-agent";
    app.pEngineName = "splitvk";
    app.apiVersion = api_version;
    VkInstanceCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO;
    info.pNext = chain;
    info.pApplicationInfo = &app;
    info.enabledLayerCount = static_cast<uint32_t>(layers.size());
    info.ppEnabledLayerNames = layers.data();
    info.enabledExtensionCount = static_cast<uint32_t>(extensions.size());
    info.ppEnabledExtensionNames = extensions.data();
    VkResult r = vkCreateInstance(&info, nullptr, &instance);
    if (r != VK_SUCCESS) {
        *error = std::string("vkCreateInstance failed: ") + vk_result_name(r);
        return false;
    }
    if (validate) {
        auto create = reinterpret_cast<PFN_vkCreateDebugUtilsMessengerEXT>(
            vkGetInstanceProcAddr(instance, "vkCreateDebugUtilsMessengerEXT"));
        if (create) create(instance, &messenger_info, nullptr, &messenger_);
    }

    uint32_t count = 0;
    vkEnumeratePhysicalDevices(instance, &count, nullptr);
    std::vector<VkPhysicalDevice> gpus(count);
    vkEnumeratePhysicalDevices(instance, &count, gpus.data());
    if (device_index >= count) {
        *error = "GPU " + std::to_string(device_index) + " is gone (" + std::to_string(count) + " GPUs)";
        return false;
    }
    physical_device = gpus[device_index];
    VkPhysicalDeviceProperties props{};
    vkGetPhysicalDeviceProperties(physical_device, &props);
    gpu_name = props.deviceName;
    api_version = std::min(api_version, props.apiVersion);
    vkGetPhysicalDeviceMemoryProperties(physical_device, &memory_properties);

    uint32_t families = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(physical_device, &families, nullptr);
    std::vector<VkQueueFamilyProperties> family_props(families);
    vkGetPhysicalDeviceQueueFamilyProperties(physical_device, &families, family_props.data());
    for (uint32_t i = 0; i < families; ++i) {
        if (family_props[i].queueFlags & VK_QUEUE_GRAPHICS_BIT) {
            queue_family = i;
            return true;
        }
    }
    *error = gpu_name + " has no graphics queue";
    return false;
}

VkResult VulkanContext::create_device(const VkDeviceCreateInfo &client_info, std::string *error) {
    // Extensions: the client's that this GPU has, plus VK_KHR_swapchain (PRESENT_SRC_KHR layouts).
    uint32_t count = 0;
    vkEnumerateDeviceExtensionProperties(physical_device, nullptr, &count, nullptr);
    std::vector<VkExtensionProperties> available(count);
    vkEnumerateDeviceExtensionProperties(physical_device, nullptr, &count, available.data());
    std::vector<const char *> extensions;
    std::vector<std::string> dropped;
    for (uint32_t i = 0; i < client_info.enabledExtensionCount; ++i) {
        const char *name =
            client_info.ppEnabledExtensionNames ? client_info.ppEnabledExtensionNames[i] : nullptr;
        if (!name) continue;
        const std::string_view n(name);
        // Shared with another process of the client's, never with the agent: its structures do not
        // cross the wire, so there is nothing to enable it for.
        if (codec::client_only_device_extension(n)) continue;
        const bool needs_surface = n == VK_KHR_SWAPCHAIN_EXTENSION_NAME;
        if (has_extension(available, n) && (!needs_surface || surface_extension_))
            extensions.push_back(name);
        else
            dropped.emplace_back(name);
    }
    const bool has_swapchain = std::any_of(extensions.begin(), extensions.end(), [](const char *e) {
        return std::string_view(e) == VK_KHR_SWAPCHAIN_EXTENSION_NAME;
    });
    if (!has_swapchain && surface_extension_ && has_extension(available, VK_KHR_SWAPCHAIN_EXTENSION_NAME))
        extensions.push_back(VK_KHR_SWAPCHAIN_EXTENSION_NAME);
    for (const auto &d : dropped)
        SPLITVK_INFO("session %llu: device extension %s is not available on %s; dropped",
                     static_cast<unsigned long long>(session_id_), d.c_str(), gpu_name.c_str());

    // Features: every known features structure of the client's chain, ANDed with what this GPU has.
    std::vector<std::unique_ptr<uint8_t[]>> storage;
    VkBaseOutStructure *head = nullptr;
    VkBaseOutStructure **tail = &head;
    bool features2 = false;
    for (auto *s = static_cast<const VkBaseInStructure *>(client_info.pNext); s; s = s->pNext) {
        const std::optional<FeatureStruct> known = mirrored_feature_struct(s->sType, api_version, extensions);
        if (!known) continue;
        auto enabled = std::make_unique<uint8_t[]>(known->size);
        auto supported = std::make_unique<uint8_t[]>(known->size);
        std::memcpy(enabled.get(), s, known->size);
        std::memset(supported.get(), 0, known->size);
        reinterpret_cast<VkBaseOutStructure *>(supported.get())->sType = s->sType;
        if (s->sType == VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2) {
            vkGetPhysicalDeviceFeatures(
                physical_device, &reinterpret_cast<VkPhysicalDeviceFeatures2 *>(supported.get())->features);
            features2 = true;
        } else {
            VkPhysicalDeviceFeatures2 query{};
            query.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2;
            query.pNext = supported.get();
            vkGetPhysicalDeviceFeatures2(physical_device, &query);
        }
        and_bools(enabled.get(), supported.get(), known->size);
        auto *node = reinterpret_cast<VkBaseOutStructure *>(enabled.get());
        node->pNext = nullptr;
        *tail = node;
        tail = &node->pNext;
        storage.push_back(std::move(enabled));
        storage.push_back(std::move(supported));
    }
    VkPhysicalDeviceFeatures features{};
    if (client_info.pEnabledFeatures && !features2) {
        VkPhysicalDeviceFeatures supported{};
        vkGetPhysicalDeviceFeatures(physical_device, &supported);
        features = *client_info.pEnabledFeatures;
        auto *e = reinterpret_cast<VkBool32 *>(&features);
        const auto *s = reinterpret_cast<const VkBool32 *>(&supported);
        for (size_t i = 0; i < sizeof(features) / sizeof(VkBool32); ++i)
            e[i] = (e[i] && s[i]) ? VK_TRUE : VK_FALSE;
    }

    const float priority = 1.0f;
    VkDeviceQueueCreateInfo queue_info{};
    queue_info.sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO;
    queue_info.queueFamilyIndex = queue_family;
    queue_info.queueCount = 1;
    queue_info.pQueuePriorities = &priority;
    VkDeviceCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
    info.pNext = head;
    info.queueCreateInfoCount = 1;
    info.pQueueCreateInfos = &queue_info;
    info.enabledExtensionCount = static_cast<uint32_t>(extensions.size());
    info.ppEnabledExtensionNames = extensions.data();
    info.pEnabledFeatures = (client_info.pEnabledFeatures && !features2) ? &features : nullptr;
    const VkResult r = vkCreateDevice(physical_device, &info, nullptr, &device);
    if (r != VK_SUCCESS) {
        *error = std::string("vkCreateDevice on ") + gpu_name + " failed: " + vk_result_name(r);
        device = VK_NULL_HANDLE;
        return r;
    }
    vkGetDeviceQueue(device, queue_family, 0, &queue);
    swapchain_extension = std::any_of(extensions.begin(), extensions.end(), [](const char *e) {
        return std::string_view(e) == VK_KHR_SWAPCHAIN_EXTENSION_NAME;
    });
    return VK_SUCCESS;
}

int32_t VulkanContext::find_memory_type(uint32_t type_bits, VkMemoryPropertyFlags required,
                                        VkMemoryPropertyFlags preferred) const {
    int32_t fallback = -1;
    for (uint32_t i = 0; i < memory_properties.memoryTypeCount; ++i) {
        if (!(type_bits & (1u << i))) continue;
        const auto flags = memory_properties.memoryTypes[i].propertyFlags;
        if ((flags & required) != required) continue;
        if ((flags & preferred) == preferred) return static_cast<int32_t>(i);
        if (fallback < 0) fallback = static_cast<int32_t>(i);
    }
    return fallback;
}

bool VulkanContext::create_readback_buffer(VkDeviceSize size, HostBuffer *out, std::string *error) const {
    // Cached: the host reads every byte (uncached reads are slow on a discrete GPU).
    return create_host_buffer(size, VK_BUFFER_USAGE_TRANSFER_DST_BIT, VK_MEMORY_PROPERTY_HOST_CACHED_BIT, out,
                              error);
}

bool VulkanContext::create_upload_buffer(VkDeviceSize size, HostBuffer *out, std::string *error) const {
    // Coherent: the host only writes, and a submit makes coherent writes visible to the GPU.
    return create_host_buffer(size, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, VK_MEMORY_PROPERTY_HOST_COHERENT_BIT,
                              out, error);
}

bool VulkanContext::create_host_buffer(VkDeviceSize size, VkBufferUsageFlags usage,
                                       VkMemoryPropertyFlags preferred, HostBuffer *out,
                                       std::string *error) const {
    HostBuffer b;
    VkBufferCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
    info.size = size;
    info.usage = usage;
    VkResult r = vkCreateBuffer(device, &info, nullptr, &b.buffer);
    if (r != VK_SUCCESS) {
        *error = std::string("host buffer: ") + vk_result_name(r);
        return false;
    }
    VkMemoryRequirements req{};
    vkGetBufferMemoryRequirements(device, b.buffer, &req);
    const int32_t type = find_memory_type(req.memoryTypeBits, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT, preferred);
    if (type < 0) {
        *error = "no host-visible memory for a host buffer";
        destroy(b);
        return false;
    }
    VkMemoryAllocateInfo alloc{};
    alloc.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
    alloc.allocationSize = req.size;
    alloc.memoryTypeIndex = static_cast<uint32_t>(type);
    void *mapped = nullptr;
    r = vkAllocateMemory(device, &alloc, nullptr, &b.memory);
    if (r == VK_SUCCESS) r = vkBindBufferMemory(device, b.buffer, b.memory, 0);
    if (r == VK_SUCCESS) r = vkMapMemory(device, b.memory, 0, VK_WHOLE_SIZE, 0, &mapped);
    if (r != VK_SUCCESS) {
        *error = std::string("host buffer memory: ") + vk_result_name(r);
        destroy(b);
        return false;
    }
    b.mapped = static_cast<uint8_t *>(mapped);
    b.size = size;
    b.coherent = memory_properties.memoryTypes[type].propertyFlags & VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
    *out = b;
    return true;
}

void VulkanContext::destroy(HostBuffer &b) const {
    if (b.buffer) vkDestroyBuffer(device, b.buffer, nullptr);
    if (b.memory) vkFreeMemory(device, b.memory, nullptr); // unmaps
    b = HostBuffer{};
}

bool VulkanContext::create_transfer_image(VkFormat format, VkExtent2D extent, TransferImage *out,
                                          std::string *error) const {
    TransferImage t;
    t.format = format;
    t.extent = extent;
    VkImageCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO;
    info.imageType = VK_IMAGE_TYPE_2D;
    info.format = format;
    info.extent = {extent.width, extent.height, 1};
    info.mipLevels = 1;
    info.arrayLayers = 1;
    info.samples = VK_SAMPLE_COUNT_1_BIT;
    info.tiling = VK_IMAGE_TILING_OPTIMAL;
    info.usage = VK_IMAGE_USAGE_TRANSFER_SRC_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
    info.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    VkResult r = vkCreateImage(device, &info, nullptr, &t.image);
    if (r != VK_SUCCESS) {
        *error = std::string("transfer image: ") + vk_result_name(r);
        return false;
    }
    VkMemoryRequirements req{};
    vkGetImageMemoryRequirements(device, t.image, &req);
    const int32_t type = find_memory_type(req.memoryTypeBits, 0, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
    if (type < 0) {
        *error = "no memory type for a transfer image";
        destroy(t);
        return false;
    }
    VkMemoryAllocateInfo alloc{};
    alloc.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
    alloc.allocationSize = req.size;
    alloc.memoryTypeIndex = static_cast<uint32_t>(type);
    r = vkAllocateMemory(device, &alloc, nullptr, &t.memory);
    if (r == VK_SUCCESS) r = vkBindImageMemory(device, t.image, t.memory, 0);
    if (r != VK_SUCCESS) {
        *error = std::string("transfer image memory: ") + vk_result_name(r);
        destroy(t);
        return false;
    }
    *out = t;
    return true;
}

void VulkanContext::destroy(TransferImage &t) const {
    if (t.image) vkDestroyImage(device, t.image, nullptr);
    if (t.memory) vkFreeMemory(device, t.memory, nullptr);
    t = TransferImage{};
}

bool VulkanContext::blit_filter(VkFormat format, VkFilter *filter) const {
    VkFormatProperties properties{};
    vkGetPhysicalDeviceFormatProperties(physical_device, format, &properties);
    const VkFormatFeatureFlags features = properties.optimalTilingFeatures;
    if (!(features & VK_FORMAT_FEATURE_BLIT_SRC_BIT) || !(features & VK_FORMAT_FEATURE_BLIT_DST_BIT))
        return false;
    *filter =
        (features & VK_FORMAT_FEATURE_SAMPLED_IMAGE_FILTER_LINEAR_BIT) ? VK_FILTER_LINEAR : VK_FILTER_NEAREST;
    return true;
}

void VulkanContext::invalidate(const HostBuffer &b) const {
    if (b.coherent || !b.memory) return;
    VkMappedMemoryRange range{};
    range.sType = VK_STRUCTURE_TYPE_MAPPED_MEMORY_RANGE;
    range.memory = b.memory;
    range.size = VK_WHOLE_SIZE;
    vkInvalidateMappedMemoryRanges(device, 1, &range);
}

void VulkanContext::record_present_readback(VkCommandBuffer cb, VkImage image, VkImageLayout presented,
                                            const HostBuffer &dst,
                                            const std::vector<VkBufferImageCopy> &regions) {
    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    vkBeginCommandBuffer(cb, &begin);
    // The app's submits left the image in `presented`; they precede this one on the queue,
    // so a full source scope makes their attachment writes visible to the copy.
    VkImageMemoryBarrier barrier{};
    barrier.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER;
    barrier.srcAccessMask = VK_ACCESS_MEMORY_WRITE_BIT;
    barrier.dstAccessMask = VK_ACCESS_TRANSFER_READ_BIT;
    barrier.oldLayout = presented;
    barrier.newLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    barrier.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    barrier.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    barrier.image = image;
    // Every layer: the foveae of a layered OpenXR eye image come from each of its layers.
    barrier.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, VK_REMAINING_ARRAY_LAYERS};
    vkCmdPipelineBarrier(cb, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0,
                         nullptr, 0, nullptr, 1, &barrier);
    vkCmdCopyImageToBuffer(cb, image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, dst.buffer,
                           static_cast<uint32_t>(regions.size()), regions.data());
    // Back to where the app left it: the next frame's commands expect `presented` (or UNDEFINED,
    // which accepts anything). An OpenXR runtime's image is next handed over by the runtime's own
    // barrier, whose source scope is its attachment stage: the transition must come before it.
    barrier.srcAccessMask = VK_ACCESS_TRANSFER_READ_BIT;
    barrier.dstAccessMask = 0;
    barrier.oldLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    barrier.newLayout = presented;
    const VkPipelineStageFlags after = presented == VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL
                                           ? VK_PIPELINE_STAGE_ALL_COMMANDS_BIT
                                           : VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT;
    VkBufferMemoryBarrier host{};
    host.sType = VK_STRUCTURE_TYPE_BUFFER_MEMORY_BARRIER;
    host.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    host.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
    host.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    host.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    host.buffer = dst.buffer;
    host.size = VK_WHOLE_SIZE;
    vkCmdPipelineBarrier(cb, VK_PIPELINE_STAGE_TRANSFER_BIT, after | VK_PIPELINE_STAGE_HOST_BIT, 0, 0,
                         nullptr, 1, &host, 1, &barrier);
    vkEndCommandBuffer(cb);
}

void VulkanContext::record_present_downsample(VkCommandBuffer cb, VkImage image, VkImageLayout presented,
                                              VkExtent2D extent, const TransferImage &scaled, VkFilter filter,
                                              const HostBuffer &dst,
                                              const std::vector<VkBufferImageCopy> &regions) {
    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    vkBeginCommandBuffer(cb, &begin);
    // As in record_present_readback: the app's submits precede this one on the queue. The scaled
    // image's old contents are not needed (UNDEFINED); the last thing to touch it was the copy out
    // of it of an earlier frame on this queue, a read, which the execution dependency of the
    // ALL_COMMANDS source scope orders before the blit's writes.
    VkImageMemoryBarrier before[2] = {};
    for (VkImageMemoryBarrier &b : before) {
        b.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER;
        b.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
        b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    }
    before[0].srcAccessMask = VK_ACCESS_MEMORY_WRITE_BIT;
    before[0].dstAccessMask = VK_ACCESS_TRANSFER_READ_BIT;
    before[0].oldLayout = presented;
    before[0].newLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    before[0].image = image;
    before[0].subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, VK_REMAINING_ARRAY_LAYERS};
    before[1].srcAccessMask = 0;
    before[1].dstAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    before[1].oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    before[1].newLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
    before[1].image = scaled.image;
    before[1].subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    vkCmdPipelineBarrier(cb, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0,
                         nullptr, 0, nullptr, 2, before);
    VkImageBlit blit{};
    blit.srcSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    blit.srcOffsets[1] = {static_cast<int32_t>(extent.width), static_cast<int32_t>(extent.height), 1};
    blit.dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    blit.dstOffsets[1] = {static_cast<int32_t>(scaled.extent.width),
                          static_cast<int32_t>(scaled.extent.height), 1};
    vkCmdBlitImage(cb, image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, scaled.image,
                   VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &blit, filter);
    // The blit's writes before the copy's reads; the presented image back to where the app left it,
    // as record_present_readback does.
    VkImageMemoryBarrier after[2] = {before[1], before[0]};
    after[0].srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    after[0].dstAccessMask = VK_ACCESS_TRANSFER_READ_BIT;
    after[0].oldLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
    after[0].newLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    after[1].srcAccessMask = VK_ACCESS_TRANSFER_READ_BIT;
    after[1].dstAccessMask = 0;
    after[1].oldLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    after[1].newLayout = presented;
    const VkPipelineStageFlags presented_stage = presented == VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL
                                                     ? VK_PIPELINE_STAGE_ALL_COMMANDS_BIT
                                                     : VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT;
    vkCmdPipelineBarrier(cb, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT | presented_stage,
                         0, 0, nullptr, 0, nullptr, 2, after);
    vkCmdCopyImageToBuffer(cb, scaled.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, dst.buffer,
                           static_cast<uint32_t>(regions.size()), regions.data());
    VkBufferMemoryBarrier host{};
    host.sType = VK_STRUCTURE_TYPE_BUFFER_MEMORY_BARRIER;
    host.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    host.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
    host.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    host.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    host.buffer = dst.buffer;
    host.size = VK_WHOLE_SIZE;
    vkCmdPipelineBarrier(cb, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_HOST_BIT, 0, 0, nullptr, 1,
                         &host, 0, nullptr);
    vkEndCommandBuffer(cb);
}

} // namespace splitvk::agent
