// The agent's limit guard (server-agent/limit_guard.h) with handles that are only keys: what a GPU
// with 256-byte alignments cannot honour is rewritten to something valid and marks the frames
// that use it.
#include "limit_guard.h"
#include "vk_envelope_tables.h"

#include <iterator>

#include <gtest/gtest.h>

namespace splitvk::agent {
namespace {

template <class T>
T handle(uintptr_t v) {
    return reinterpret_cast<T>(v);
}

protocol::DeviceDescription strict_gpu() {
    protocol::DeviceDescription d;
    d.name = "strict";
    d.limits.minUniformBufferOffsetAlignment = 256;
    d.limits.minStorageBufferOffsetAlignment = 256;
    d.limits.maxUniformBufferRange = 65536;
    d.limits.maxStorageBufferRange = 1u << 27;
    d.limits.maxImageDimension1D = d.limits.maxImageDimension2D = d.limits.maxImageDimensionCube = 4096;
    d.limits.maxImageDimension3D = 256;
    d.limits.maxImageArrayLayers = 256;
    d.features.assign(std::size(envelope::kFeatureFields), 1);
    d.formats.assign(std::size(envelope::kEnvelopeFormats), VkFormatProperties{~0u, ~0u, ~0u});
    return d;
}

VkWriteDescriptorSet uniform_write(VkDescriptorSet set, const VkDescriptorBufferInfo *info) {
    VkWriteDescriptorSet w{};
    w.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
    w.dstSet = set;
    w.descriptorCount = 1;
    w.descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
    w.pBufferInfo = info;
    return w;
}

TEST(LimitGuard, MisalignedUniformOffsetIsAlignedDownAndFlagsTheFramesThatBindIt) {
    LimitGuard guard(1, strict_gpu());
    const auto slot0 = handle<VkDescriptorSet>(0x10), slot1 = handle<VkDescriptorSet>(0x20);
    const VkDescriptorBufferInfo infos[] = {{handle<VkBuffer>(1), 0, 0x110},
                                            {handle<VkBuffer>(1), 0x110, 0x110}};
    const VkWriteDescriptorSet writes[] = {uniform_write(slot0, &infos[0]), uniform_write(slot1, &infos[1])};
    std::vector<VkWriteDescriptorSet> rewritten;
    std::vector<VkDescriptorBufferInfo> storage;
    const VkWriteDescriptorSet *out = guard.descriptor_writes(2, writes, rewritten, storage);
    EXPECT_EQ(out[0].pBufferInfo->offset, 0u);
    EXPECT_EQ(out[1].pBufferInfo->offset, 0x100u) << "what every GPU can bind";

    const auto even = handle<VkCommandBuffer>(0x100), odd = handle<VkCommandBuffer>(0x200);
    guard.command_buffer_begun(even);
    guard.sets_bound(even, 1, &slot0, 0, nullptr);
    guard.command_buffer_begun(odd);
    guard.sets_bound(odd, 1, &slot1, 0, nullptr);
    guard.submitted(1, &even);
    EXPECT_FALSE(guard.take_frame_invalid());
    guard.submitted(1, &odd);
    EXPECT_TRUE(guard.take_frame_invalid());
    EXPECT_FALSE(guard.take_frame_invalid()) << "the flag is per frame";

    // A valid rewrite of the descriptor clears it.
    const VkDescriptorBufferInfo aligned{handle<VkBuffer>(1), 0x200, 0x110};
    const VkWriteDescriptorSet fix = uniform_write(slot1, &aligned);
    guard.descriptor_writes(1, &fix, rewritten, storage);
    guard.submitted(1, &odd);
    EXPECT_FALSE(guard.take_frame_invalid());
    EXPECT_EQ(guard.invalid_frames(), 1u);
}

TEST(LimitGuard, CopiesCarryTheTaintAndFreeingForgetsIt) {
    LimitGuard guard(1, strict_gpu());
    const auto bad_set = handle<VkDescriptorSet>(0x10), copy_set = handle<VkDescriptorSet>(0x20);
    const VkDescriptorBufferInfo info{handle<VkBuffer>(1), 16, 64};
    const VkWriteDescriptorSet write = uniform_write(bad_set, &info);
    std::vector<VkWriteDescriptorSet> rewritten;
    std::vector<VkDescriptorBufferInfo> storage;
    guard.descriptor_writes(1, &write, rewritten, storage);
    VkCopyDescriptorSet copy{};
    copy.sType = VK_STRUCTURE_TYPE_COPY_DESCRIPTOR_SET;
    copy.srcSet = bad_set;
    copy.dstSet = copy_set;
    copy.descriptorCount = 1;
    guard.descriptor_copies(1, &copy);
    guard.descriptor_sets_freed(1, &bad_set);
    const auto cb = handle<VkCommandBuffer>(0x100);
    guard.command_buffer_begun(cb);
    guard.sets_bound(cb, 1, &copy_set, 0, nullptr);
    guard.submitted(1, &cb);
    EXPECT_TRUE(guard.take_frame_invalid());
}

TEST(LimitGuard, RangesDynamicOffsetsAndImages) {
    LimitGuard guard(1, strict_gpu());
    const auto set = handle<VkDescriptorSet>(0x10);
    const VkDescriptorBufferInfo huge{handle<VkBuffer>(1), 0, 1u << 20};
    const VkWriteDescriptorSet write = uniform_write(set, &huge);
    std::vector<VkWriteDescriptorSet> rewritten;
    std::vector<VkDescriptorBufferInfo> storage;
    EXPECT_EQ(guard.descriptor_writes(1, &write, rewritten, storage)->pBufferInfo->range, 65536u);

    const auto cb = handle<VkCommandBuffer>(0x100);
    guard.command_buffer_begun(cb);
    const uint32_t dynamic = 0x40;
    guard.sets_bound(cb, 0, nullptr, 1, &dynamic);
    guard.submitted(1, &cb);
    EXPECT_TRUE(guard.take_frame_invalid());
    guard.command_buffer_begun(cb); // re-recorded: a new start
    guard.submitted(1, &cb);
    EXPECT_FALSE(guard.take_frame_invalid());

    VkImageCreateInfo image{};
    image.sType = VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO;
    image.imageType = VK_IMAGE_TYPE_2D;
    image.format = VK_FORMAT_R8G8B8A8_UNORM;
    image.extent = {4096, 4096, 1};
    image.arrayLayers = 1;
    image.usage = VK_IMAGE_USAGE_SAMPLED_BIT;
    guard.image_created(image);
    EXPECT_FALSE(guard.take_frame_invalid()) << "at the limit is within it";
    image.extent.width = 4097;
    guard.image_created(image);
    EXPECT_TRUE(guard.take_frame_invalid());
    EXPECT_TRUE(guard.take_frame_invalid()) << "an image this GPU cannot make spoils every frame";
}

} // namespace
} // namespace splitvk::agent
