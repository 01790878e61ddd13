// The swapped split's shared periphery geometry (common/periphery.h).
#include "periphery.h"
#include "split_geometry.h"

#include <gtest/gtest.h>

namespace splitvk::split {
namespace {

bool same(const VkRect2D &a, const VkRect2D &b) {
    return a.offset.x == b.offset.x && a.offset.y == b.offset.y && a.extent.width == b.extent.width &&
           a.extent.height == b.extent.height;
}

TEST(PeripheryParts, TwoHalvesCoverTheImageOnce) {
    const auto parts = periphery_parts({1440, 648});
    ASSERT_EQ(parts.size(), 2u);
    EXPECT_TRUE(same(parts[0], VkRect2D{{0, 0}, {720, 648}}));
    EXPECT_TRUE(same(parts[1], VkRect2D{{720, 0}, {720, 648}}));

    const auto odd = periphery_parts({7, 3});
    ASSERT_EQ(odd.size(), 2u);
    EXPECT_TRUE(same(odd[0], VkRect2D{{0, 0}, {3, 3}}));
    EXPECT_TRUE(same(odd[1], VkRect2D{{3, 0}, {4, 3}}));

    const auto two = periphery_parts({2, 5});
    ASSERT_EQ(two.size(), 2u);
    EXPECT_TRUE(same(two[1], VkRect2D{{1, 0}, {1, 5}}));
}

TEST(PeripheryParts, NarrowImageIsOnePart) {
    const auto parts = periphery_parts({1, 9});
    ASSERT_EQ(parts.size(), 1u);
    EXPECT_TRUE(same(parts[0], VkRect2D{{0, 0}, {1, 9}}));
}

// What the client matches a frame's tiles against: the parts of the scaled window image.
TEST(PeripheryParts, OfTheScaledExtent) {
    const auto parts = periphery_parts(scaled_extent({2400, 1080}, 0.6));
    ASSERT_EQ(parts.size(), 2u);
    EXPECT_EQ(parts[0].extent.width + parts[1].extent.width, 1440u);
    EXPECT_EQ(parts[0].extent.height, 648u);
}

TEST(PeripheryParts, LossyFormatsAreThe8BitColourOnes) {
    EXPECT_TRUE(periphery_lossy_format(VK_FORMAT_B8G8R8A8_SRGB));
    EXPECT_TRUE(periphery_lossy_format(VK_FORMAT_B8G8R8A8_UNORM));
    EXPECT_TRUE(periphery_lossy_format(VK_FORMAT_R8G8B8A8_SRGB));
    EXPECT_TRUE(periphery_lossy_format(VK_FORMAT_R8G8B8A8_UNORM));
    EXPECT_FALSE(periphery_lossy_format(VK_FORMAT_A2B10G10R10_UNORM_PACK32));
    EXPECT_FALSE(periphery_lossy_format(VK_FORMAT_R8G8B8A8_SNORM));
}

} // namespace
} // namespace splitvk::split
