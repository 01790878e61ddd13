// --linear-textures: textures uploaded the way many ports and older engines do it. The host
// writes each mip level into a VK_IMAGE_TILING_LINEAR image, row by row at the driver's
// VkSubresourceLayout, and the GPU copies it into the optimal-tiling texture. The picture is the
// same as with the staging buffer; what differs is that the bytes the host wrote have a
// driver-specific layout.
#pragma once

#include "textures.h"
#include "vk_context.h"

#include <vector>

namespace atrium {

class LinearUpload {
public:
    // One linear image per mip level of every texture, all bound to one host-visible allocation,
    // written with the texels. Throws Error when the driver cannot sample-copy such images.
    LinearUpload(const VkContext &context, const std::vector<Texture> &textures, VkFormat format);
    ~LinearUpload();
    LinearUpload(const LinearUpload &) = delete;
    LinearUpload &operator=(const LinearUpload &) = delete;

    // Copies every level into `targets[i]` (in TRANSFER_DST_OPTIMAL), after a barrier that makes
    // the host writes visible to the copies.
    void record(VkCommandBuffer cmd, const std::vector<Image> &targets) const;

private:
    struct Level {
        size_t texture = 0;
        uint32_t level = 0;
        uint32_t size = 0;
        VkImage image = VK_NULL_HANDLE;
    };
    VkDevice device_;
    std::vector<Level> levels_;
    VkDeviceMemory memory_ = VK_NULL_HANDLE;
};

} // namespace atrium
