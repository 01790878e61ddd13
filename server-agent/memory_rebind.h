#pragma once

// Memory rebind (docs/architecture.md §3, GFXReconstruct's "rebind"): the agent never trusts the client's
// memory type indices, offsets or alignments. vkAllocateMemory only records a client memory object; each
// bound buffer or image gets its own allocation on the agent's GPU, and MemoryData for a range of a
// client memory object is routed to every resource bound in that range. Bytes that arrive before a
// resource is bound are kept in a sparse, zero-initialised shadow and applied at bind time.
//
// Buffers get host-visible coherent memory and receive MemoryData directly. Optimal-tiling images
// get device-local memory and receive contents only through GPU copies, as applications do.
// Linear images get host-visible memory, and the bytes the host wrote into them are laid out by
// the client's driver, which need not place rows where the agent's does (lavapipe packs the rows
// of a small RGBA8 image tightly; GPUs align row pitch and subresource offsets). The client sends
// the VkSubresourceLayout of every subresource (ImageLayouts); MemoryData and the shadow applied at
// bind time are then copied row by row, each byte of a row (in texel blocks, vk_format_info.h)
// from the client's layout to the agent's own, and row padding is dropped. Without ImageLayouts
// (a format whose aspects the agent does not re-lay: multi-planar or combined depth/stencil), or
// when both layouts are the same, bytes are copied 1:1 at the same offsets.

#include "linear_layout.h"
#include "metadata.h"
#include "vulkan_context.h"

#include <vulkan/vulkan.h>

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

namespace splitvk::agent {

class QueuedWrites;

// Per-session caps (splitvk-agent --max-host-memory, --max-gpu-memory; docs/security.md). Going
// over one is an error like any other: the session ends with one line naming the cap.
struct MemoryLimits {
    // Client data kept in host memory: the shadow pages of every client memory object, which
    // hold whatever MemoryData wrote there (bound or not) until the memory is freed.
    uint64_t host_bytes = UINT64_MAX;
    // Device memory, counted twice over and capped on each count: the vkAllocateMemory sizes the
    // client asked for, and the agent's own allocations for the resources bound to them (which a
    // client could otherwise inflate by binding many large resources to one small allocation).
    uint64_t gpu_bytes = UINT64_MAX;
};

class MemoryRebind {
public:
    MemoryRebind(VulkanContext &context, const MemoryLimits &limits) : context_(context), limits_(limits) {}
    ~MemoryRebind();
    MemoryRebind(const MemoryRebind &) = delete;
    MemoryRebind &operator=(const MemoryRebind &) = delete;

    // A client memory object (nothing is allocated on the GPU).
    bool allocate(uint64_t memory_id, VkDeviceSize size, std::string *error);
    void free(uint64_t memory_id);
    bool has_memory(uint64_t memory_id) const { return memories_.count(memory_id) != 0; }

    // What the agent needs to know of resources before they are bound.
    void buffer_created(VkBuffer buffer, const VkBufferCreateInfo &info);
    void image_created(VkImage image, const VkImageCreateInfo &info);
    // Frees the resource's own allocation (after the resource itself was destroyed).
    void buffer_destroyed(VkBuffer buffer);
    void image_destroyed(VkImage image);

    // ImageLayouts for a linear image created through the stream (before or after its bind). An
    // error ends the session (a layout that does not describe the image); `warning` gets one line
    // when the image's bytes stay copied 1:1 (an aspect layout the agent does not re-lay).
    bool image_layouts(VkImage image, const protocol::ImageLayouts &layouts, std::string *error,
                       std::string *warning);

    // vkBind*Memory*: allocates the resource's own memory and binds it; applies the shadow.
    bool bind_buffer(VkBuffer buffer, uint64_t memory_id, VkDeviceSize offset, std::string *error);
    bool bind_image(VkImage image, uint64_t memory_id, VkDeviceSize offset, std::string *error);

    // MemoryData: into the shadow and into every host-visible resource bound in the range. With
    // `queued`, bytes for buffers are staged there (queued_writes.h) instead of written by the host.
    bool write(uint64_t memory_id, VkDeviceSize offset, std::span<const uint8_t> bytes, std::string *error,
               QueuedWrites *queued = nullptr);
    // What write() of `size` bytes at `offset` would do: bytes it would stage for buffers, and
    // whether a linear image (written by the host, row by row) lies in the range.
    struct WritePlan {
        VkDeviceSize buffer_bytes = 0;
        bool linear_images = false;
    };
    WritePlan plan_write(uint64_t memory_id, VkDeviceSize offset, VkDeviceSize size) const;

    size_t bound_resources() const { return resources_.size(); }
    // A buffer bound to its own allocation: its size (the client's, which is the agent's too).
    std::optional<VkDeviceSize> bound_buffer_size(VkBuffer buffer) const;

    void set_limits(const MemoryLimits &limits) { limits_ = limits; }
    uint64_t host_bytes() const { return host_bytes_; }             // shadow pages held
    uint64_t client_gpu_bytes() const { return client_gpu_bytes_; } // live client allocations
    uint64_t agent_gpu_bytes() const { return agent_gpu_bytes_; }   // the agent's own allocations

private:
    static constexpr VkDeviceSize kPageSize = 64 * 1024;
    struct ClientMemory {
        VkDeviceSize size = 0;
        std::map<VkDeviceSize, std::unique_ptr<uint8_t[]>> pages; // page index -> kPageSize bytes
        std::unordered_set<uint64_t> bound;                       // resources bound to it
    };
    struct Resource {
        bool is_image = false;
        VkDeviceSize client_size = 0; // bytes of client memory the resource covers (buffers)
        bool device_address = false;  // a buffer with VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT
        VkImageTiling tiling = VK_IMAGE_TILING_OPTIMAL;
        // Linear images: what ImageLayouts is checked against, and what it gave.
        VkImageType image_type = VK_IMAGE_TYPE_2D;
        VkFormat format = VK_FORMAT_UNDEFINED;
        VkExtent3D extent{};
        uint32_t mip_levels = 1;
        uint32_t array_layers = 1;
        bool has_layouts = false;
        VkDeviceSize client_image_bytes = 0; // the client's image: the end of its last subresource
        std::vector<Relayout> relayout;      // per subresource; empty: bytes are copied 1:1
        uint64_t memory_id = 0;              // 0 while unbound
        VkDeviceSize client_offset = 0;
        VkDeviceMemory memory = VK_NULL_HANDLE;
        uint8_t *mapped = nullptr; // host-visible buffers: written directly
        VkDeviceSize mapped_size = 0;
        VkDeviceSize allocated = 0; // bytes of `memory`, counted in agent_gpu_bytes_
    };

    bool bind(uint64_t handle, uint64_t memory_id, VkDeviceSize offset, const VkMemoryRequirements &req,
              std::string *error);
    void copy_shadow(const ClientMemory &memory, Resource &resource);
    // `n` bytes at `src` that the client wrote at `at` bytes into the resource's range, into the
    // agent's allocation: 1:1, or row by row through `relayout`.
    static void place(const Resource &resource, VkDeviceSize at, const uint8_t *src, VkDeviceSize n);
    void release(Resource &resource);

    VulkanContext &context_;
    std::unordered_map<uint64_t, ClientMemory> memories_;
    std::unordered_map<uint64_t, Resource> resources_; // by the agent's handle value
    MemoryLimits limits_;
    uint64_t host_bytes_ = 0;
    uint64_t client_gpu_bytes_ = 0;
    uint64_t agent_gpu_bytes_ = 0;
};

} // namespace splitvk::agent
