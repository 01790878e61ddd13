#include "vk_context.h"

#include "engine_markers.h"
#include "xcb_window.h"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <string>

namespace atrium {

namespace {

template <typename T, typename F>
std::vector<T> enumerate(F &&query) {
    uint32_t count = 0;
    ATRIUM_VK_CHECK(query(&count, nullptr));
    std::vector<T> items(count);
    ATRIUM_VK_CHECK(query(&count, items.data()));
    items.resize(count);
    return items;
}

bool has_extension(const std::vector<VkExtensionProperties> &extensions, const char *name) {
    return std::any_of(extensions.begin(), extensions.end(), [&](const VkExtensionProperties &e) {
        return std::strcmp(e.extensionName, name) == 0;
    });
}

int device_type_rank(VkPhysicalDeviceType type) {
    switch (type) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU:
        return 0;
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU:
        return 1;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU:
        return 2;
    case VK_PHYSICAL_DEVICE_TYPE_CPU:
        return 3;
    default:
        return 4;
    }
}

} // namespace

VkContext::VkContext(const XcbWindow &window, bool dynamic_rendering, bool multiview, bool engine_extensions,
                     bool buffer_address) {
    uint32_t loader_version = VK_API_VERSION_1_0;
    if (vkEnumerateInstanceVersion(&loader_version) != VK_SUCCESS || loader_version < VK_API_VERSION_1_1)
        throw Error("the Vulkan loader does not support Vulkan 1.1");
    const auto instance_extensions =
        enumerate<VkExtensionProperties>([](uint32_t *n, VkExtensionProperties *p) {
            return vkEnumerateInstanceExtensionProperties(nullptr, n, p);
        });
    for (const char *name : {VK_KHR_SURFACE_EXTENSION_NAME, VK_KHR_XCB_SURFACE_EXTENSION_NAME})
        if (!has_extension(instance_extensions, name))
            throw Error(std::string("no Vulkan driver found that can present to X11 (") + name +
                        " is missing)");

    VkApplicationInfo app{};
    app.sType = VK_STRUCTURE_TYPE_APPLICATION_INFO;
    app.pApplicationName = "splitvk-atrium";
    app.applicationVersion = VK_MAKE_API_VERSION(0, 0, 1, 0);
    app.pEngineName = "splitvk-atrium";
    app.apiVersion = VK_API_VERSION_1_1;
    const char *extensions[] = {VK_KHR_SURFACE_EXTENSION_NAME, VK_KHR_XCB_SURFACE_EXTENSION_NAME};
    VkInstanceCreateInfo instance_info{};
    instance_info.sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO;
    instance_info.pApplicationInfo = &app;
    instance_info.enabledExtensionCount = 2;
    instance_info.ppEnabledExtensionNames = extensions;
    if (const VkResult r = vkCreateInstance(&instance_info, nullptr, &instance_); r != VK_SUCCESS)
        throw Error(std::string("no usable Vulkan driver (vkCreateInstance: ") + vk_result_name(r) + ")");

    VkXcbSurfaceCreateInfoKHR surface_info{};
    surface_info.sType = VK_STRUCTURE_TYPE_XCB_SURFACE_CREATE_INFO_KHR;
    surface_info.connection = window.connection();
    surface_info.window = window.window();
    ATRIUM_VK_CHECK(vkCreateXcbSurfaceKHR(instance_, &surface_info, nullptr, &surface_));

    // The first device by type (discrete, integrated, virtual, CPU) that does Vulkan 1.1 and can
    // present to the window from a graphics queue.
    const auto devices = enumerate<VkPhysicalDevice>(
        [&](uint32_t *n, VkPhysicalDevice *p) { return vkEnumeratePhysicalDevices(instance_, n, p); });
    if (devices.empty()) throw Error("no Vulkan device found");
    int best_rank = 1 << 30;
    for (VkPhysicalDevice device : devices) {
        VkPhysicalDeviceProperties props;
        vkGetPhysicalDeviceProperties(device, &props);
        const auto device_extensions =
            enumerate<VkExtensionProperties>([&](uint32_t *n, VkExtensionProperties *p) {
                return vkEnumerateDeviceExtensionProperties(device, nullptr, n, p);
            });
        if (props.apiVersion < VK_API_VERSION_1_1 ||
            !has_extension(device_extensions, VK_KHR_SWAPCHAIN_EXTENSION_NAME))
            continue;
        const auto families =
            enumerate<VkQueueFamilyProperties>([&](uint32_t *n, VkQueueFamilyProperties *p) {
                vkGetPhysicalDeviceQueueFamilyProperties(device, n, p);
                return VK_SUCCESS;
            });
        for (uint32_t f = 0; f < families.size(); ++f) {
            VkBool32 present = VK_FALSE;
            if (vkGetPhysicalDeviceSurfaceSupportKHR(device, f, surface_, &present) != VK_SUCCESS)
                present = VK_FALSE;
            if (!(families[f].queueFlags & VK_QUEUE_GRAPHICS_BIT) || !present) continue;
            if (device_type_rank(props.deviceType) < best_rank) {
                best_rank = device_type_rank(props.deviceType);
                physical_device_ = device;
                queue_family_ = f;
                properties_ = props;
            }
            break;
        }
    }
    if (physical_device_ == VK_NULL_HANDLE) throw Error("no Vulkan 1.1 device can present to the X window");
    create_device(dynamic_rendering, multiview, engine_extensions, true, buffer_address, nullptr);
}

VkContext::VkContext(const VkCreators &creators, bool dynamic_rendering, bool multiview,
                     const XcbWindow *window) {
    VkApplicationInfo app{};
    app.sType = VK_STRUCTURE_TYPE_APPLICATION_INFO;
    app.pApplicationName = "splitvk-atrium";
    app.applicationVersion = VK_MAKE_API_VERSION(0, 0, 1, 0);
    app.pEngineName = "splitvk-atrium";
    app.apiVersion = VK_API_VERSION_1_1;
    VkInstanceCreateInfo instance_info{};
    instance_info.sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO;
    instance_info.pApplicationInfo = &app;
    const char *surface_extensions[] = {VK_KHR_SURFACE_EXTENSION_NAME, VK_KHR_XCB_SURFACE_EXTENSION_NAME};
    if (window) {
        instance_info.enabledExtensionCount = 2;
        instance_info.ppEnabledExtensionNames = surface_extensions;
    }
    instance_ = creators.create_instance(instance_info);
    if (window) {
        VkXcbSurfaceCreateInfoKHR surface_info{};
        surface_info.sType = VK_STRUCTURE_TYPE_XCB_SURFACE_CREATE_INFO_KHR;
        surface_info.connection = window->connection();
        surface_info.window = window->window();
        ATRIUM_VK_CHECK(vkCreateXcbSurfaceKHR(instance_, &surface_info, nullptr, &surface_));
    }
    physical_device_ = creators.physical_device(instance_);
    vkGetPhysicalDeviceProperties(physical_device_, &properties_);
    if (properties_.apiVersion < VK_API_VERSION_1_1)
        throw Error(std::string(properties_.deviceName) + " does not support Vulkan 1.1");
    const auto families = enumerate<VkQueueFamilyProperties>([&](uint32_t *n, VkQueueFamilyProperties *p) {
        vkGetPhysicalDeviceQueueFamilyProperties(physical_device_, n, p);
        return VK_SUCCESS;
    });
    const auto graphics =
        std::find_if(families.begin(), families.end(), [](const VkQueueFamilyProperties &f) {
            return (f.queueFlags & VK_QUEUE_GRAPHICS_BIT) != 0;
        });
    if (graphics == families.end())
        throw Error(std::string(properties_.deviceName) + " has no graphics queue");
    queue_family_ = uint32_t(graphics - families.begin());
    if (window) {
        VkBool32 present = VK_FALSE;
        if (vkGetPhysicalDeviceSurfaceSupportKHR(physical_device_, queue_family_, surface_, &present) !=
                VK_SUCCESS ||
            !present)
            throw Error(std::string(properties_.deviceName) +
                        "'s graphics queue cannot present to the X window");
    }
    create_device(dynamic_rendering, multiview, false, window != nullptr, false, &creators.create_device);
}

void VkContext::create_device(
    bool dynamic_rendering, bool multiview, bool engine_extensions, bool swapchain, bool buffer_address,
    const std::function<VkDevice(VkPhysicalDevice, const VkDeviceCreateInfo &)> *create) {
    vkGetPhysicalDeviceMemoryProperties(physical_device_, &memory_properties_);

    VkFormatProperties depth;
    vkGetPhysicalDeviceFormatProperties(physical_device_, VK_FORMAT_D32_SFLOAT, &depth);
    if (!(depth.optimalTilingFeatures & VK_FORMAT_FEATURE_DEPTH_STENCIL_ATTACHMENT_BIT))
        throw Error(std::string(properties_.deviceName) + " cannot render to D32_SFLOAT depth");

    const float priority = 1.0f;
    VkDeviceQueueCreateInfo queue_info{};
    queue_info.sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO;
    queue_info.queueFamilyIndex = queue_family_;
    queue_info.queueCount = 1;
    queue_info.pQueuePriorities = &priority;
    std::vector<const char *> device_extensions;
    if (swapchain) device_extensions.push_back(VK_KHR_SWAPCHAIN_EXTENSION_NAME);
    if (dynamic_rendering)
        device_extensions.insert(device_extensions.end(), {VK_KHR_CREATE_RENDERPASS_2_EXTENSION_NAME,
                                                           VK_KHR_DEPTH_STENCIL_RESOLVE_EXTENSION_NAME,
                                                           VK_KHR_DYNAMIC_RENDERING_EXTENSION_NAME});
    VkPhysicalDeviceDynamicRenderingFeaturesKHR dynamic_rendering_features{};
    dynamic_rendering_features.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DYNAMIC_RENDERING_FEATURES_KHR;
    dynamic_rendering_features.dynamicRendering = VK_TRUE;
    VkPhysicalDeviceMultiviewFeatures multiview_features{};
    multiview_features.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MULTIVIEW_FEATURES;
    if (multiview) {
        VkPhysicalDeviceFeatures2 supported{};
        supported.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2;
        supported.pNext = &multiview_features;
        vkGetPhysicalDeviceFeatures2(physical_device_, &supported);
        if (!multiview_features.multiview)
            throw Error(std::string(properties_.deviceName) +
                        " does not support multiview (--path multiview)");
        multiview_features = {};
        multiview_features.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MULTIVIEW_FEATURES;
        multiview_features.multiview = VK_TRUE;
        multiview_features.pNext = dynamic_rendering ? &dynamic_rendering_features : nullptr;
    }
    VkDeviceCreateInfo device_info{};
    device_info.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
    device_info.pNext = multiview           ? static_cast<void *>(&multiview_features)
                        : dynamic_rendering ? &dynamic_rendering_features
                                            : nullptr;
    // --engine-extensions: in front of the chain above, only the features the markers use.
    VkPhysicalDeviceExtendedDynamicState3FeaturesEXT eds3_features{};
    eds3_features.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_EXTENDED_DYNAMIC_STATE_3_FEATURES_EXT;
    eds3_features.extendedDynamicState3PolygonMode = VK_TRUE;
    eds3_features.extendedDynamicState3SampleMask = VK_TRUE;
    eds3_features.extendedDynamicState3AlphaToCoverageEnable = VK_TRUE;
    eds3_features.extendedDynamicState3ColorWriteMask = VK_TRUE;
    VkPhysicalDeviceTransformFeedbackFeaturesEXT xfb_features{};
    xfb_features.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_TRANSFORM_FEEDBACK_FEATURES_EXT;
    xfb_features.transformFeedback = VK_TRUE;
    xfb_features.pNext = &eds3_features;
    VkPhysicalDeviceConditionalRenderingFeaturesEXT conditional_features{};
    conditional_features.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_CONDITIONAL_RENDERING_FEATURES_EXT;
    conditional_features.conditionalRendering = VK_TRUE;
    conditional_features.pNext = &xfb_features;
    if (engine_extensions) {
        EngineMarkers::check_support(physical_device_);
        eds3_features.pNext = const_cast<void *>(device_info.pNext);
        device_info.pNext = &conditional_features;
        device_extensions.insert(device_extensions.end(), {VK_EXT_CONDITIONAL_RENDERING_EXTENSION_NAME,
                                                           VK_EXT_TRANSFORM_FEEDBACK_EXTENSION_NAME,
                                                           VK_EXT_EXTENDED_DYNAMIC_STATE_3_EXTENSION_NAME});
    }
    // --buffer-address, on a Vulkan 1.1 instance: the extension's name, feature structure and entry point.
    VkPhysicalDeviceBufferDeviceAddressFeaturesKHR address_features{};
    address_features.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_BUFFER_DEVICE_ADDRESS_FEATURES_KHR;
    if (buffer_address) {
        VkPhysicalDeviceFeatures2 supported{};
        supported.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2;
        supported.pNext = &address_features;
        vkGetPhysicalDeviceFeatures2(physical_device_, &supported);
        if (!address_features.bufferDeviceAddress)
            throw Error(std::string(properties_.deviceName) +
                        " does not support bufferDeviceAddress (--buffer-address)");
        address_features = {};
        address_features.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_BUFFER_DEVICE_ADDRESS_FEATURES_KHR;
        address_features.bufferDeviceAddress = VK_TRUE;
        address_features.pNext = const_cast<void *>(device_info.pNext);
        device_info.pNext = &address_features;
        device_extensions.push_back(VK_KHR_BUFFER_DEVICE_ADDRESS_EXTENSION_NAME);
    }
    device_info.queueCreateInfoCount = 1;
    device_info.pQueueCreateInfos = &queue_info;
    device_info.enabledExtensionCount = uint32_t(device_extensions.size());
    device_info.ppEnabledExtensionNames = device_extensions.data();
    if (create)
        device_ = (*create)(physical_device_, device_info);
    else
        ATRIUM_VK_CHECK(vkCreateDevice(physical_device_, &device_info, nullptr, &device_));
    vkGetDeviceQueue(device_, queue_family_, 0, &queue_);
}

VkContext::~VkContext() {
    if (device_) vkDestroyDevice(device_, nullptr);
    if (surface_) vkDestroySurfaceKHR(instance_, surface_, nullptr);
    if (instance_) vkDestroyInstance(instance_, nullptr);
}

uint32_t VkContext::memory_type(uint32_t type_bits, VkMemoryPropertyFlags properties) const {
    for (uint32_t i = 0; i < memory_properties_.memoryTypeCount; ++i)
        if ((type_bits & (1u << i)) &&
            (memory_properties_.memoryTypes[i].propertyFlags & properties) == properties)
            return i;
    throw Error("no suitable Vulkan memory type");
}

Buffer VkContext::create_buffer(VkDeviceSize size, VkBufferUsageFlags usage,
                                VkMemoryPropertyFlags properties) {
    Buffer b;
    b.size = size;
    VkBufferCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
    info.size = size;
    info.usage = usage;
    info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
    ATRIUM_VK_CHECK(vkCreateBuffer(device_, &info, nullptr, &b.buffer));
    VkMemoryRequirements req;
    vkGetBufferMemoryRequirements(device_, b.buffer, &req);
    VkMemoryAllocateInfo alloc{};
    alloc.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
    alloc.allocationSize = req.size;
    alloc.memoryTypeIndex = memory_type(req.memoryTypeBits, properties);
    VkMemoryAllocateFlagsInfo flags{};
    flags.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_FLAGS_INFO;
    flags.flags = VK_MEMORY_ALLOCATE_DEVICE_ADDRESS_BIT;
    if (usage & VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT) alloc.pNext = &flags;
    ATRIUM_VK_CHECK(vkAllocateMemory(device_, &alloc, nullptr, &b.memory));
    ATRIUM_VK_CHECK(vkBindBufferMemory(device_, b.buffer, b.memory, 0));
    if (properties & VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT)
        ATRIUM_VK_CHECK(vkMapMemory(device_, b.memory, 0, VK_WHOLE_SIZE, 0, &b.mapped));
    return b;
}

void VkContext::destroy(Buffer &b) {
    if (b.buffer) vkDestroyBuffer(device_, b.buffer, nullptr);
    if (b.memory) vkFreeMemory(device_, b.memory, nullptr); // implicitly unmaps
    b = Buffer();
}

Image VkContext::create_image(const VkImageCreateInfo &info, VkImageAspectFlags aspect,
                              VkImageViewType view_type) {
    Image img;
    ATRIUM_VK_CHECK(vkCreateImage(device_, &info, nullptr, &img.image));
    VkMemoryRequirements req;
    vkGetImageMemoryRequirements(device_, img.image, &req);
    VkMemoryAllocateInfo alloc{};
    alloc.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
    alloc.allocationSize = req.size;
    alloc.memoryTypeIndex = memory_type(req.memoryTypeBits, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
    ATRIUM_VK_CHECK(vkAllocateMemory(device_, &alloc, nullptr, &img.memory));
    ATRIUM_VK_CHECK(vkBindImageMemory(device_, img.image, img.memory, 0));
    VkImageViewCreateInfo view{};
    view.sType = VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO;
    view.image = img.image;
    view.viewType = view_type;
    view.format = info.format;
    view.subresourceRange = {aspect, 0, info.mipLevels, 0, info.arrayLayers};
    ATRIUM_VK_CHECK(vkCreateImageView(device_, &view, nullptr, &img.view));
    return img;
}

void VkContext::destroy(Image &img) {
    if (img.view) vkDestroyImageView(device_, img.view, nullptr);
    if (img.image) vkDestroyImage(device_, img.image, nullptr);
    if (img.memory) vkFreeMemory(device_, img.memory, nullptr);
    img = Image();
}

const char *present_mode_name(VkPresentModeKHR mode) {
    switch (mode) {
    case VK_PRESENT_MODE_IMMEDIATE_KHR:
        return "immediate";
    case VK_PRESENT_MODE_MAILBOX_KHR:
        return "mailbox";
    case VK_PRESENT_MODE_FIFO_KHR:
        return "fifo";
    case VK_PRESENT_MODE_FIFO_RELAXED_KHR:
        return "fifo_relaxed";
    default:
        return "other";
    }
}

Swapchain::Swapchain(VkContext &context, const SwapchainRequest &request)
    : context_(context), request_(request) {
    VkPhysicalDevice gpu = context_.physical_device();
    const auto modes = enumerate<VkPresentModeKHR>([&](uint32_t *n, VkPresentModeKHR *p) {
        return vkGetPhysicalDeviceSurfacePresentModesKHR(gpu, context_.surface(), n, p);
    });
    present_mode_ = request_.present_mode;
    if (std::find(modes.begin(), modes.end(), present_mode_) == modes.end()) {
        std::fprintf(stderr, "splitvk-atrium: present mode %s is not supported, using fifo\n",
                     present_mode_name(present_mode_));
        present_mode_ = VK_PRESENT_MODE_FIFO_KHR; // the one mode every implementation supports
    }

    // Prefer the requested format; otherwise its RGBA twin with the same encoding.
    const auto formats = enumerate<VkSurfaceFormatKHR>([&](uint32_t *n, VkSurfaceFormatKHR *p) {
        return vkGetPhysicalDeviceSurfaceFormatsKHR(gpu, context_.surface(), n, p);
    });
    const VkFormat twin =
        request_.format == VK_FORMAT_B8G8R8A8_SRGB ? VK_FORMAT_R8G8B8A8_SRGB : VK_FORMAT_R8G8B8A8_UNORM;
    for (VkFormat wanted : {request_.format, twin}) {
        for (const VkSurfaceFormatKHR &f : formats)
            if (f.format == wanted && f.colorSpace == VK_COLOR_SPACE_SRGB_NONLINEAR_KHR) format_ = wanted;
        if (format_ != VK_FORMAT_UNDEFINED) break;
    }
    if (format_ == VK_FORMAT_UNDEFINED)
        throw Error("the window supports neither B8G8R8A8 nor R8G8B8A8 with the requested encoding");
    create(VK_NULL_HANDLE);
}

Swapchain::Swapchain(VkContext &context, VkFormat format, VkExtent2D extent,
                     const std::vector<VkImage> &images, uint32_t layers)
    : context_(context), format_(format), extent_(extent), images_(images),
      final_layout_(VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL) {
    for (VkImage image : images_) {
        VkImageViewCreateInfo view{};
        view.sType = VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO;
        view.image = image;
        view.viewType = layers > 1 ? VK_IMAGE_VIEW_TYPE_2D_ARRAY : VK_IMAGE_VIEW_TYPE_2D;
        view.format = format_;
        view.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, layers};
        views_.push_back(VK_NULL_HANDLE);
        ATRIUM_VK_CHECK(vkCreateImageView(context_.device(), &view, nullptr, &views_.back()));
    }
}

Swapchain::~Swapchain() {
    destroy_views();
    if (swapchain_) vkDestroySwapchainKHR(context_.device(), swapchain_, nullptr);
}

void Swapchain::recreate() {
    if (!swapchain_) throw Error("external swapchain images cannot be recreated");
    destroy_views();
    const VkSwapchainKHR old = swapchain_;
    swapchain_ = VK_NULL_HANDLE;
    create(old);
    vkDestroySwapchainKHR(context_.device(), old, nullptr);
}

void Swapchain::destroy_views() {
    for (VkImageView view : views_)
        vkDestroyImageView(context_.device(), view, nullptr);
    views_.clear();
    images_.clear();
}

void Swapchain::create(VkSwapchainKHR old) {
    VkDevice device = context_.device();
    VkSurfaceCapabilitiesKHR caps;
    ATRIUM_VK_CHECK(
        vkGetPhysicalDeviceSurfaceCapabilitiesKHR(context_.physical_device(), context_.surface(), &caps));
    extent_ = caps.currentExtent;
    if (extent_.width == UINT32_MAX || extent_.width == 0 || extent_.height == 0)
        throw Error("the window has no usable size");

    VkImageUsageFlags usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT;
    if (request_.transfer_src) usage |= VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
    if (request_.transfer_dst) usage |= VK_IMAGE_USAGE_TRANSFER_DST_BIT;
    if ((caps.supportedUsageFlags & usage) != usage)
        throw Error(request_.transfer_src && !(caps.supportedUsageFlags & VK_IMAGE_USAGE_TRANSFER_SRC_BIT)
                        ? "the swapchain cannot be read back (no TRANSFER_SRC usage) for --screenshot"
                        : "the swapchain cannot be blitted to (no TRANSFER_DST usage) for --path compute");

    uint32_t image_count = std::max(caps.minImageCount + 1, 3u);
    if (caps.maxImageCount != 0) image_count = std::min(image_count, caps.maxImageCount);

    VkSwapchainCreateInfoKHR info{};
    info.sType = VK_STRUCTURE_TYPE_SWAPCHAIN_CREATE_INFO_KHR;
    info.surface = context_.surface();
    info.minImageCount = image_count;
    info.imageFormat = format_;
    info.imageColorSpace = VK_COLOR_SPACE_SRGB_NONLINEAR_KHR;
    info.imageExtent = extent_;
    info.imageArrayLayers = 1;
    info.imageUsage = usage;
    info.imageSharingMode = VK_SHARING_MODE_EXCLUSIVE;
    info.preTransform = caps.currentTransform;
    info.compositeAlpha =
        (caps.supportedCompositeAlpha & VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR)
            ? VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR
            : VkCompositeAlphaFlagBitsKHR(caps.supportedCompositeAlpha &
                                          (~caps.supportedCompositeAlpha + 1)); // lowest bit
    info.presentMode = present_mode_;
    info.clipped = VK_TRUE;
    info.oldSwapchain = old;
    ATRIUM_VK_CHECK(vkCreateSwapchainKHR(device, &info, nullptr, &swapchain_));

    images_ = enumerate<VkImage>(
        [&](uint32_t *n, VkImage *p) { return vkGetSwapchainImagesKHR(device, swapchain_, n, p); });
    for (VkImage image : images_) {
        VkImageViewCreateInfo view{};
        view.sType = VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO;
        view.image = image;
        view.viewType = VK_IMAGE_VIEW_TYPE_2D;
        view.format = format_;
        view.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
        views_.push_back(VK_NULL_HANDLE);
        ATRIUM_VK_CHECK(vkCreateImageView(device, &view, nullptr, &views_.back()));
    }
}

} // namespace atrium
