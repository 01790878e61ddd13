// The texel size of tiles (tile_format.h) over every VkFormat vk.xml lists, and the names log lines
// give formats.
#include "tile_format.h"
#include "vk_format_info.h"

#include <cstdint>
#include <set>
#include <string>

#include <gtest/gtest.h>

namespace splitvk {
namespace {

TEST(TileTexelBytes, EveryFormatIsZeroFourOrEight) {
    size_t four = 0, eight = 0;
    for (const VkFormat format : kFormats) {
        const uint32_t bytes = tile_texel_bytes(format);
        SCOPED_TRACE(format_name(format));
        ASSERT_TRUE(bytes == 0 || bytes == 4 || bytes == 8) << bytes;
        if (bytes == 0) continue;
        // What tiles carry is the image's texel as it is: one uncompressed colour block of 1x1.
        const FormatInfo info = format_info(format);
        EXPECT_EQ(info.block_bytes, bytes);
        EXPECT_EQ(info.block_width, 1u);
        EXPECT_EQ(info.block_height, 1u);
        EXPECT_FALSE(info.depth || info.stencil || info.compressed || info.ycbcr);
        (bytes == 4 ? four : eight) += 1;
    }
    // vk.xml grows; these are the formats of Vulkan 1.3's core alone.
    EXPECT_GE(four, 45u);
    EXPECT_GE(eight, 13u);
}

TEST(TileTexelBytes, FourByteColourFormats) {
    for (const VkFormat format :
         {VK_FORMAT_R8G8B8A8_UNORM, VK_FORMAT_R8G8B8A8_SRGB, VK_FORMAT_R8G8B8A8_SNORM,
          VK_FORMAT_R8G8B8A8_UINT, VK_FORMAT_B8G8R8A8_UNORM, VK_FORMAT_B8G8R8A8_SRGB,
          VK_FORMAT_A8B8G8R8_UNORM_PACK32, VK_FORMAT_A8B8G8R8_SRGB_PACK32, VK_FORMAT_A2R10G10B10_UNORM_PACK32,
          VK_FORMAT_A2B10G10R10_UNORM_PACK32, VK_FORMAT_A2B10G10R10_UINT_PACK32,
          VK_FORMAT_B10G11R11_UFLOAT_PACK32, VK_FORMAT_E5B9G9R9_UFLOAT_PACK32, VK_FORMAT_R16G16_SFLOAT,
          VK_FORMAT_R16G16_UNORM, VK_FORMAT_R32_SFLOAT, VK_FORMAT_R32_UINT})
        EXPECT_EQ(tile_texel_bytes(format), 4u) << format_name(format);
}

TEST(TileTexelBytes, EightByteColourFormats) {
    for (const VkFormat format :
         {VK_FORMAT_R16G16B16A16_UNORM, VK_FORMAT_R16G16B16A16_SNORM, VK_FORMAT_R16G16B16A16_USCALED,
          VK_FORMAT_R16G16B16A16_SSCALED, VK_FORMAT_R16G16B16A16_UINT, VK_FORMAT_R16G16B16A16_SINT,
          VK_FORMAT_R16G16B16A16_SFLOAT, VK_FORMAT_R32G32_SFLOAT, VK_FORMAT_R32G32_UINT, VK_FORMAT_R64_UINT})
        EXPECT_EQ(tile_texel_bytes(format), 8u) << format_name(format);
}

TEST(TileTexelBytes, FormatsTilesCannotCarry) {
    for (const VkFormat format :
         {VK_FORMAT_UNDEFINED,
          // 16 and 12 bytes, and 1, 2 and 3 bytes a texel.
          VK_FORMAT_R32G32B32A32_SFLOAT, VK_FORMAT_R32G32B32A32_UINT, VK_FORMAT_R32G32B32_SFLOAT,
          VK_FORMAT_R64G64_SFLOAT, VK_FORMAT_R8_UNORM, VK_FORMAT_R5G6B5_UNORM_PACK16,
          VK_FORMAT_R4G4B4A4_UNORM_PACK16, VK_FORMAT_R16_SFLOAT, VK_FORMAT_R8G8B8_UNORM,
          VK_FORMAT_B8G8R8_SRGB, VK_FORMAT_R16G16B16_UNORM,
          // Depth and stencil, 4 and 8 bytes among them.
          VK_FORMAT_D32_SFLOAT, VK_FORMAT_X8_D24_UNORM_PACK32, VK_FORMAT_D24_UNORM_S8_UINT,
          VK_FORMAT_D32_SFLOAT_S8_UINT, VK_FORMAT_D16_UNORM, VK_FORMAT_S8_UINT,
          // Compressed, 8-byte blocks among them.
          VK_FORMAT_BC1_RGB_UNORM_BLOCK, VK_FORMAT_BC4_UNORM_BLOCK, VK_FORMAT_BC7_SRGB_BLOCK,
          VK_FORMAT_ETC2_R8G8B8_UNORM_BLOCK, VK_FORMAT_EAC_R11_UNORM_BLOCK, VK_FORMAT_ASTC_4x4_UNORM_BLOCK,
          // Multi-planar, 2x1 blocks and single-plane Y'CbCr of 8 bytes.
          VK_FORMAT_G8_B8R8_2PLANE_420_UNORM, VK_FORMAT_G8_B8_R8_3PLANE_444_UNORM,
          VK_FORMAT_G16_B16R16_2PLANE_420_UNORM, VK_FORMAT_G8B8G8R8_422_UNORM,
          VK_FORMAT_B16G16R16G16_422_UNORM, VK_FORMAT_R10X6G10X6B10X6A10X6_UNORM_4PACK16,
          VK_FORMAT_R12X4G12X4B12X4A12X4_UNORM_4PACK16})
        EXPECT_EQ(tile_texel_bytes(format), 0u) << format_name(format);
    EXPECT_EQ(tile_texel_bytes(static_cast<VkFormat>(0x7ffffff0)), 0u) << "a value vk.xml does not list";
}

TEST(FormatName, IsTheEnumerantsName) {
    EXPECT_STREQ(format_name(VK_FORMAT_R16G16B16A16_UNORM), "VK_FORMAT_R16G16B16A16_UNORM");
    EXPECT_STREQ(format_name(VK_FORMAT_B8G8R8A8_SRGB), "VK_FORMAT_B8G8R8A8_SRGB");
    EXPECT_STREQ(format_name(VK_FORMAT_G8_B8R8_2PLANE_420_UNORM), "VK_FORMAT_G8_B8R8_2PLANE_420_UNORM");
    EXPECT_STREQ(format_name(VK_FORMAT_UNDEFINED), "VK_FORMAT_UNDEFINED");
    EXPECT_STREQ(format_name(static_cast<VkFormat>(0x7ffffff0)), "an unknown VkFormat");
    std::set<std::string> names;
    for (const VkFormat format : kFormats) {
        const std::string name = format_name(format);
        EXPECT_EQ(name.rfind("VK_FORMAT_", 0), 0u) << name;
        EXPECT_TRUE(names.insert(name).second) << name << " twice";
    }
}

} // namespace
} // namespace splitvk
