#include "linear_upload.h"

#include <cstring>

namespace atrium {

LinearUpload::LinearUpload(const VkContext &context, const std::vector<Texture> &textures, VkFormat format)
    : device_(context.device()) {
    VkFormatProperties properties{};
    vkGetPhysicalDeviceFormatProperties(context.physical_device(), format, &properties);
    if (!(properties.linearTilingFeatures & VK_FORMAT_FEATURE_TRANSFER_SRC_BIT))
        throw Error("--linear-textures: the driver cannot copy from linear images of the texture format");

    VkDeviceSize total = 0;
    uint32_t type_bits = ~0u;
    std::vector<VkDeviceSize> offsets;
    for (size_t t = 0; t < textures.size(); ++t) {
        for (uint32_t level = 0; level < textures[t].levels; ++level) {
            Level l{t, level, textures[t].size >> level, VK_NULL_HANDLE};
            VkImageCreateInfo info{};
            info.sType = VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO;
            info.imageType = VK_IMAGE_TYPE_2D;
            info.format = format;
            info.extent = {l.size, l.size, 1};
            info.mipLevels = 1;
            info.arrayLayers = 1;
            info.samples = VK_SAMPLE_COUNT_1_BIT;
            info.tiling = VK_IMAGE_TILING_LINEAR;
            info.usage = VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
            info.initialLayout = VK_IMAGE_LAYOUT_PREINITIALIZED;
            ATRIUM_VK_CHECK(vkCreateImage(device_, &info, nullptr, &l.image));
            levels_.push_back(l);
            VkMemoryRequirements req{};
            vkGetImageMemoryRequirements(device_, l.image, &req);
            total = (total + req.alignment - 1) / req.alignment * req.alignment;
            offsets.push_back(total);
            total += req.size;
            type_bits &= req.memoryTypeBits;
        }
    }

    VkPhysicalDeviceMemoryProperties memory{};
    vkGetPhysicalDeviceMemoryProperties(context.physical_device(), &memory);
    const VkMemoryPropertyFlags wanted =
        VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
    uint32_t type = UINT32_MAX;
    for (uint32_t i = 0; i < memory.memoryTypeCount && type == UINT32_MAX; ++i)
        if ((type_bits & (1u << i)) && (memory.memoryTypes[i].propertyFlags & wanted) == wanted) type = i;
    if (type == UINT32_MAX) throw Error("--linear-textures: no host-visible memory type for linear images");
    VkMemoryAllocateInfo alloc{};
    alloc.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
    alloc.allocationSize = total;
    alloc.memoryTypeIndex = type;
    ATRIUM_VK_CHECK(vkAllocateMemory(device_, &alloc, nullptr, &memory_));
    void *mapped = nullptr;
    ATRIUM_VK_CHECK(vkMapMemory(device_, memory_, 0, VK_WHOLE_SIZE, 0, &mapped));
    for (size_t i = 0; i < levels_.size(); ++i) {
        const Level &l = levels_[i];
        ATRIUM_VK_CHECK(vkBindImageMemory(device_, l.image, memory_, offsets[i]));
        const VkImageSubresource sub{VK_IMAGE_ASPECT_COLOR_BIT, 0, 0};
        VkSubresourceLayout layout{};
        vkGetImageSubresourceLayout(device_, l.image, &sub, &layout);
        const Texture &t = textures[l.texture];
        const uint8_t *src = t.texels.data() + t.level_offset[l.level];
        auto *dst = static_cast<uint8_t *>(mapped) + offsets[i] + layout.offset;
        for (uint32_t y = 0; y < l.size; ++y)
            std::memcpy(dst + y * layout.rowPitch, src + size_t{y} * l.size * 4, size_t{l.size} * 4);
    }
    vkUnmapMemory(device_, memory_);
}

LinearUpload::~LinearUpload() {
    for (const Level &l : levels_)
        vkDestroyImage(device_, l.image, nullptr);
    if (memory_) vkFreeMemory(device_, memory_, nullptr);
}

void LinearUpload::record(VkCommandBuffer cmd, const std::vector<Image> &targets) const {
    std::vector<VkImageMemoryBarrier> barriers;
    for (const Level &l : levels_) {
        VkImageMemoryBarrier b{};
        b.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER;
        b.srcAccessMask = VK_ACCESS_HOST_WRITE_BIT;
        b.dstAccessMask = VK_ACCESS_TRANSFER_READ_BIT;
        b.oldLayout = VK_IMAGE_LAYOUT_PREINITIALIZED; // keeps what the host wrote
        b.newLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
        b.srcQueueFamilyIndex = b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
        b.image = l.image;
        b.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
        barriers.push_back(b);
    }
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_HOST_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0, nullptr, 0,
                         nullptr, uint32_t(barriers.size()), barriers.data());
    for (const Level &l : levels_) {
        VkImageCopy region{};
        region.srcSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
        region.dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, l.level, 0, 1};
        region.extent = {l.size, l.size, 1};
        vkCmdCopyImage(cmd, l.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, targets[l.texture].image,
                       VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
    }
}

} // namespace atrium
