#include "periphery.h"

namespace splitvk::split {

std::vector<VkRect2D> periphery_parts(VkExtent2D periphery) {
    if (periphery.width < 2) return {VkRect2D{{0, 0}, periphery}};
    const uint32_t left = periphery.width / 2;
    return {VkRect2D{{0, 0}, {left, periphery.height}},
            VkRect2D{{static_cast<int32_t>(left), 0}, {periphery.width - left, periphery.height}}};
}

bool periphery_lossy_format(VkFormat format) {
    switch (format) {
    case VK_FORMAT_R8G8B8A8_UNORM:
    case VK_FORMAT_R8G8B8A8_SRGB:
    case VK_FORMAT_B8G8R8A8_UNORM:
    case VK_FORMAT_B8G8R8A8_SRGB:
        return true;
    default:
        return false;
    }
}

bool periphery_blue_first(VkFormat format) {
    return format == VK_FORMAT_B8G8R8A8_UNORM || format == VK_FORMAT_B8G8R8A8_SRGB;
}

TileCodec periphery_tile_codec(PeripheryCodec codec) {
    switch (codec) {
    case PeripheryCodec::H264:
        return TileCodec::H264Yuv420;
    case PeripheryCodec::Hevc:
        return TileCodec::HevcYuv420;
    case PeripheryCodec::Rgb:
        break;
    }
    return TileCodec::X264;
}

} // namespace splitvk::split
