#pragma once

// A session's own Vulkan instance and GPU (docs/architecture.md §2-3): the agent never uses the client's
// instance, physical device or queue families. With --validate the instance enables
// VK_LAYER_KHRONOS_validation (synchronization validation on) and routes every message to the log.

#include "vk_result_name.h" // vk_result_name(), for the agent's log lines

#include <vulkan/vulkan.h>

#include <cstdint>
#include <string>
#include <vector>

namespace splitvk::agent {

// An image in device memory the agent draws into with transfers only (the swapped split's
// downsampled periphery): TRANSFER_SRC and TRANSFER_DST, optimal tiling, one layer, one mip.
struct TransferImage {
    VkImage image = VK_NULL_HANDLE;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    VkFormat format = VK_FORMAT_UNDEFINED;
    VkExtent2D extent{};
};

// A buffer in host-visible memory, mapped for its whole life: what the agent reads back.
struct HostBuffer {
    VkBuffer buffer = VK_NULL_HANDLE;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    uint8_t *mapped = nullptr;
    VkDeviceSize size = 0;
    bool coherent = true;
};

class VulkanContext {
public:
    VulkanContext() = default;
    ~VulkanContext();
    VulkanContext(const VulkanContext &) = delete;
    VulkanContext &operator=(const VulkanContext &) = delete;

    // Creates the instance and picks GPU `device_index`. False with one line in `error`.
    bool create_instance(uint32_t device_index, bool validate, uint64_t session_id, std::string *error);

    // Creates the device for the client's VkDeviceCreateInfo: its features and extensions that this
    // GPU supports (VK_KHR_swapchain kept when available so PRESENT_SRC_KHR layouts are legal), one
    // graphics queue.
    VkResult create_device(const VkDeviceCreateInfo &client_info, std::string *error);

    VkInstance instance = VK_NULL_HANDLE;
    VkPhysicalDevice physical_device = VK_NULL_HANDLE;
    VkDevice device = VK_NULL_HANDLE;
    VkQueue queue = VK_NULL_HANDLE;
    uint32_t queue_family = 0;
    uint32_t api_version = VK_API_VERSION_1_0;
    std::string gpu_name;
    bool swapchain_extension = false; // VK_KHR_swapchain enabled: PRESENT_SRC_KHR is a legal layout
    VkPhysicalDeviceMemoryProperties memory_properties{};

    // Validation messages seen, errors and warnings apart: only errors fail a session.
    uint64_t validation_errors() const { return validation_errors_; }
    uint64_t validation_warnings() const { return validation_warnings_; }

    // A host-visible TRANSFER_DST buffer of `size` bytes the host reads (cached memory preferred).
    // False with one line in `error`; `out` is then empty.
    bool create_readback_buffer(VkDeviceSize size, HostBuffer *out, std::string *error) const;
    // A host-visible TRANSFER_SRC buffer of `size` bytes the host writes (queued_writes.h).
    bool create_upload_buffer(VkDeviceSize size, HostBuffer *out, std::string *error) const;
    void destroy(HostBuffer &buffer) const;
    // False with one line in `error`; `out` is then empty.
    bool create_transfer_image(VkFormat format, VkExtent2D extent, TransferImage *out,
                               std::string *error) const;
    void destroy(TransferImage &image) const;
    // The filter a blit between two optimal images of `format` can use: linear where the format
    // supports it, else nearest; false when it cannot be blitted at all.
    bool blit_filter(VkFormat format, VkFilter *filter) const;
    // Makes the GPU's writes visible to the host (non-coherent memory only).
    void invalidate(const HostBuffer &buffer) const;

    // Records, into `cb` (begun and ended here), copies of `regions` of a presented image into
    // `dst`, leaving the image in `presented` (the layout the app left it in) and the bytes visible
    // to the host once the submit completes.
    static void record_present_readback(VkCommandBuffer cb, VkImage image, VkImageLayout presented,
                                        const HostBuffer &dst, const std::vector<VkBufferImageCopy> &regions);
    // The same for the swapped split's periphery: blits layer 0 of the presented image (`extent`)
    // onto the whole of `scaled` with `filter`, then copies `regions` of `scaled` into `dst`.
    static void record_present_downsample(VkCommandBuffer cb, VkImage image, VkImageLayout presented,
                                          VkExtent2D extent, const TransferImage &scaled, VkFilter filter,
                                          const HostBuffer &dst,
                                          const std::vector<VkBufferImageCopy> &regions);

    // A memory type among `type_bits` with all of `required`, preferring `preferred` too; -1 if none.
    int32_t find_memory_type(uint32_t type_bits, VkMemoryPropertyFlags required,
                             VkMemoryPropertyFlags preferred = 0) const;

private:
    bool create_host_buffer(VkDeviceSize size, VkBufferUsageFlags usage, VkMemoryPropertyFlags preferred,
                            HostBuffer *out, std::string *error) const;
    static VKAPI_ATTR VkBool32 VKAPI_CALL on_message(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                                     VkDebugUtilsMessageTypeFlagsEXT types,
                                                     const VkDebugUtilsMessengerCallbackDataEXT *data,
                                                     void *user);
    VkDebugUtilsMessengerEXT messenger_ = VK_NULL_HANDLE;
    uint64_t validation_errors_ = 0;
    uint64_t validation_warnings_ = 0;
    uint64_t session_id_ = 0;
    bool surface_extension_ = false;
};

} // namespace splitvk::agent
