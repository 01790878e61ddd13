// Descriptor update templates: pData is laid out by the client's template entries; on the wire it
// becomes structured writes, and the agent gets pData laid out for its canonical template.

#include "codec_test_util.h"
#include "vk_codec.h"

#include <cstddef>
#include <cstring>

#include <gtest/gtest.h>

namespace splitvk::codec {
namespace {

using test::garbage_handle;
using test::Session;

// The application's own layout of pData: interleaved, padded, one strided array.
struct Pair {
    VkDescriptorImageInfo info;
    uint64_t unrelated;
};
struct AppData {
    Pair pairs[2];                      // binding 0: combined image samplers, stride sizeof(Pair)
    uint32_t padding;                   //
    VkDescriptorBufferInfo ubo;         // binding 1
    VkBufferView texel;                 // binding 2
    uint8_t inline_block[16];           // binding 3: inline uniform block, 16 bytes
    VkDescriptorImageInfo sampled;      // binding 4: sampled image (sampler ignored)
    VkDescriptorImageInfo immutable[1]; // binding 5: combined, immutable samplers (sampler ignored)
};

struct TemplateFixture {
    Session s;
    VkDevice device = s.client<VkDevice>(VK_OBJECT_TYPE_DEVICE, 0x10);
    VkDescriptorSet set = s.client<VkDescriptorSet>(VK_OBJECT_TYPE_DESCRIPTOR_SET, 0x20);
    VkDescriptorSetLayout set_layout =
        s.client<VkDescriptorSetLayout>(VK_OBJECT_TYPE_DESCRIPTOR_SET_LAYOUT, 0x21);
    VkSampler sampler = s.client<VkSampler>(VK_OBJECT_TYPE_SAMPLER, 0x30);
    VkImageView views[2] = {s.client<VkImageView>(VK_OBJECT_TYPE_IMAGE_VIEW, 0x40),
                            s.client<VkImageView>(VK_OBJECT_TYPE_IMAGE_VIEW, 0x41)};
    VkBuffer buffer = s.client<VkBuffer>(VK_OBJECT_TYPE_BUFFER, 0x50);
    VkBufferView texel = s.client<VkBufferView>(VK_OBJECT_TYPE_BUFFER_VIEW, 0x60);
    VkDescriptorUpdateTemplate tmpl = to_handle<VkDescriptorUpdateTemplate>(0x70);

    VkDescriptorUpdateTemplateEntry entries[6] = {
        {0, 0, 2, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, offsetof(AppData, pairs), sizeof(Pair)},
        {1, 0, 1, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, offsetof(AppData, ubo), 0},
        {2, 0, 1, VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER, offsetof(AppData, texel), 0},
        {3, 0, 16, VK_DESCRIPTOR_TYPE_INLINE_UNIFORM_BLOCK, offsetof(AppData, inline_block), 0},
        {4, 1, 1, VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE, offsetof(AppData, sampled),
         sizeof(VkDescriptorImageInfo)},
        {5, 0, 1, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, offsetof(AppData, immutable),
         sizeof(VkDescriptorImageInfo)},
    };
    VkDescriptorUpdateTemplateCreateInfo info{};
    AppData data{};

    TemplateFixture() {
        info.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_UPDATE_TEMPLATE_CREATE_INFO;
        info.descriptorUpdateEntryCount = 6;
        info.pDescriptorUpdateEntries = entries;
        info.templateType = VK_DESCRIPTOR_UPDATE_TEMPLATE_TYPE_DESCRIPTOR_SET;
        info.descriptorSetLayout = set_layout;
        info.pipelineBindPoint = static_cast<VkPipelineBindPoint>(0x7777); // ignored
        info.pipelineLayout = garbage_handle<VkPipelineLayout>();          // ignored
        info.set = 99;

        data.pairs[0] = {{sampler, views[0], VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL}, 0x1111};
        data.pairs[1] = {{sampler, views[1], VK_IMAGE_LAYOUT_GENERAL}, 0x2222};
        data.padding = 0xFFFFFFFF;
        data.ubo = {buffer, 512, 256};
        data.texel = texel;
        for (int i = 0; i < 16; ++i)
            data.inline_block[i] = static_cast<uint8_t>(0xA0 + i);
        data.sampled = {garbage_handle<VkSampler>(), views[1], VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
        data.immutable[0] = {garbage_handle<VkSampler>(), views[0], VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
    }
};

struct ImmutableHooks : EncodeHooks {
    VkDescriptorSet asked_set = VK_NULL_HANDLE;
    bool has_immutable_samplers(VkDescriptorSet set, uint32_t binding) override {
        asked_set = set;
        return binding == 5;
    }
};

TEST(CodecTemplate, CreateAndUpdateWithTemplateRoundTrip) {
    TemplateFixture f;
    ImmutableHooks hooks;
    f.s.enc.set_hooks(&hooks);
    encode_vkCreateDescriptorUpdateTemplate(f.s.enc, f.device, &f.info, nullptr, &f.tmpl);
    // The layer keeps the layout from the create info.
    const DescriptorTemplateLayout layout = DescriptorTemplateLayout::from(f.info);
    encode_vkUpdateDescriptorSetWithTemplate(f.s.enc, f.device, f.set, f.tmpl, &f.data, layout);
    EXPECT_EQ(hooks.asked_set, f.set);

    Decoder d(f.s.bytes(), f.s.table, f.s.arena);
    Decoded_vkCreateDescriptorUpdateTemplate created;
    ASSERT_TRUE(decode_vkCreateDescriptorUpdateTemplate(d, created)) << d.error();
    const VkDescriptorUpdateTemplateCreateInfo &ci = *created.pCreateInfo;
    EXPECT_EQ(ci.descriptorSetLayout, Session::server(f.set_layout));
    EXPECT_EQ(ci.pipelineLayout, VK_NULL_HANDLE); // ignored for DESCRIPTOR_SET templates: not sent
    EXPECT_EQ(ci.set, 99u);
    ASSERT_EQ(ci.descriptorUpdateEntryCount, 6u);
    // Canonical offsets and strides: packed in order, 8-byte aligned.
    const size_t image = sizeof(VkDescriptorImageInfo);
    EXPECT_EQ(ci.pDescriptorUpdateEntries[0].offset, 0u);
    EXPECT_EQ(ci.pDescriptorUpdateEntries[0].stride, image);
    EXPECT_EQ(ci.pDescriptorUpdateEntries[1].offset, 2 * image);
    EXPECT_EQ(ci.pDescriptorUpdateEntries[1].stride, sizeof(VkDescriptorBufferInfo));
    EXPECT_EQ(ci.pDescriptorUpdateEntries[2].offset, 2 * image + sizeof(VkDescriptorBufferInfo));
    EXPECT_EQ(ci.pDescriptorUpdateEntries[3].offset, 2 * image + sizeof(VkDescriptorBufferInfo) + 8);
    EXPECT_EQ(ci.pDescriptorUpdateEntries[4].offset, 2 * image + sizeof(VkDescriptorBufferInfo) + 8 + 16);
    EXPECT_EQ(ci.pDescriptorUpdateEntries[4].dstArrayElement, 1u);
    created.pDescriptorUpdateTemplate[0] = to_handle<VkDescriptorUpdateTemplate>(0xF00);
    ASSERT_TRUE(apply_handle_changes(f.s.table, created));

    Decoded_vkUpdateDescriptorSetWithTemplate update;
    ASSERT_TRUE(decode_vkUpdateDescriptorSetWithTemplate(d, update)) << d.error();
    EXPECT_TRUE(d.at_end());
    EXPECT_EQ(update.descriptorSet, Session::server(f.set));
    EXPECT_EQ(update.descriptorUpdateTemplate, to_handle<VkDescriptorUpdateTemplate>(0xF00));
    ASSERT_EQ(update.templateData.entryCount, 6u);
    ASSERT_NE(update.pData, nullptr);
    EXPECT_EQ(update.pData, update.templateData.pData);

    // pData as the agent's (canonical) template reads it, with the agent's handles.
    const auto *bytes = static_cast<const uint8_t *>(update.pData);
    auto image_at = [&](size_t offset) {
        VkDescriptorImageInfo v;
        std::memcpy(&v, bytes + offset, sizeof(v));
        return v;
    };
    const VkDescriptorImageInfo i0 = image_at(ci.pDescriptorUpdateEntries[0].offset);
    const VkDescriptorImageInfo i1 = image_at(ci.pDescriptorUpdateEntries[0].offset + image);
    EXPECT_EQ(i0.sampler, Session::server(f.sampler));
    EXPECT_EQ(i0.imageView, Session::server(f.views[0]));
    EXPECT_EQ(i1.imageView, Session::server(f.views[1]));
    EXPECT_EQ(i1.imageLayout, VK_IMAGE_LAYOUT_GENERAL);
    VkDescriptorBufferInfo ubo;
    std::memcpy(&ubo, bytes + ci.pDescriptorUpdateEntries[1].offset, sizeof(ubo));
    EXPECT_EQ(ubo.buffer, Session::server(f.buffer));
    EXPECT_EQ(ubo.offset, 512u);
    EXPECT_EQ(ubo.range, 256u);
    VkBufferView view;
    std::memcpy(&view, bytes + ci.pDescriptorUpdateEntries[2].offset, sizeof(view));
    EXPECT_EQ(view, Session::server(f.texel));
    EXPECT_EQ(std::memcmp(bytes + ci.pDescriptorUpdateEntries[3].offset, f.data.inline_block, 16), 0);
    const VkDescriptorImageInfo sampled = image_at(ci.pDescriptorUpdateEntries[4].offset);
    EXPECT_EQ(sampled.sampler, VK_NULL_HANDLE); // ignored for sampled images: not sent
    EXPECT_EQ(sampled.imageView, Session::server(f.views[1]));
    const VkDescriptorImageInfo immutable = image_at(ci.pDescriptorUpdateEntries[5].offset);
    EXPECT_EQ(immutable.sampler, VK_NULL_HANDLE); // immutable samplers (the hooks said so)
    EXPECT_EQ(immutable.imageView, Session::server(f.views[0]));

    // The structured form, too.
    const DecodedTemplateEntry &e0 = update.templateData.pEntries[0];
    EXPECT_EQ(e0.descriptorType, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER);
    ASSERT_NE(e0.pImageInfo, nullptr);
    EXPECT_EQ(e0.pImageInfo[1].imageView, Session::server(f.views[1]));
    ASSERT_NE(update.templateData.pEntries[3].pInlineData, nullptr);

    // An agent that keeps the client's layout can lay the same data out for it.
    const void *client_layout = nullptr;
    std::string error;
    ASSERT_TRUE(layout_template_data(update.templateData, f.entries, f.s.arena, client_layout, &error))
        << error;
    AppData agent{};
    std::memcpy(&agent, client_layout, sizeof(agent));
    EXPECT_EQ(agent.pairs[1].info.imageView, Session::server(f.views[1]));
    EXPECT_EQ(agent.ubo.buffer, Session::server(f.buffer));
    EXPECT_EQ(agent.texel, Session::server(f.texel));
    EXPECT_EQ(agent.inline_block[15], 0xAF);
    // Entries that do not match are refused.
    VkDescriptorUpdateTemplateEntry other[6];
    std::memcpy(other, f.entries, sizeof(other));
    other[2].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_TEXEL_BUFFER;
    EXPECT_FALSE(layout_template_data(update.templateData, other, f.s.arena, client_layout, &error));
    EXPECT_NE(error.find("does not match"), std::string::npos) << error;
}

TEST(CodecTemplate, PushDescriptorSetWithTemplate) {
    TemplateFixture f;
    ImmutableHooks hooks;
    f.s.enc.set_hooks(&hooks);
    const VkCommandBuffer cb = f.s.client<VkCommandBuffer>(VK_OBJECT_TYPE_COMMAND_BUFFER, 0x80);
    const VkPipelineLayout pipeline_layout =
        f.s.client<VkPipelineLayout>(VK_OBJECT_TYPE_PIPELINE_LAYOUT, 0x90);
    const VkDescriptorUpdateTemplate tmpl =
        f.s.client<VkDescriptorUpdateTemplate>(VK_OBJECT_TYPE_DESCRIPTOR_UPDATE_TEMPLATE, 0xA0);
    // Only the buffer entry.
    DescriptorTemplateLayout layout;
    layout.entries.push_back(f.entries[1]);
    encode_vkCmdPushDescriptorSetWithTemplateKHR(f.s.enc, cb, tmpl, pipeline_layout, 3, &f.data, layout);
    EXPECT_EQ(hooks.asked_set, VK_NULL_HANDLE); // push descriptors have no set to ask about

    Decoder d(f.s.bytes(), f.s.table, f.s.arena);
    Decoded_vkCmdPushDescriptorSetWithTemplateKHR out;
    ASSERT_TRUE(decode_vkCmdPushDescriptorSetWithTemplateKHR(d, out)) << d.error();
    EXPECT_EQ(out.layout, Session::server(pipeline_layout));
    EXPECT_EQ(out.set, 3u);
    VkDescriptorBufferInfo ubo;
    std::memcpy(&ubo, out.pData, sizeof(ubo));
    EXPECT_EQ(ubo.buffer, Session::server(f.buffer));
    EXPECT_EQ(ubo.range, 256u);
}

TEST(CodecTemplate, TruncatedTemplateUpdatesFailCleanly) {
    TemplateFixture f;
    ImmutableHooks hooks;
    f.s.enc.set_hooks(&hooks);
    const DescriptorTemplateLayout layout = DescriptorTemplateLayout::from(f.info);
    encode_vkUpdateDescriptorSetWithTemplate(f.s.enc, f.device, f.set, f.tmpl, &f.data, layout);
    f.s.table.insert(0x70, VK_OBJECT_TYPE_DESCRIPTOR_UPDATE_TEMPLATE, uint64_t{0xF00});
    const auto bytes = f.s.bytes();
    for (size_t n = 0; n < bytes.size(); ++n) {
        Arena arena;
        Decoder d(bytes.first(n), f.s.table, arena);
        Decoded_vkUpdateDescriptorSetWithTemplate out;
        EXPECT_FALSE(decode_vkUpdateDescriptorSetWithTemplate(d, out)) << "truncated at " << n;
        EXPECT_FALSE(d.error().empty());
    }
    Arena arena;
    Decoder d(bytes, f.s.table, arena);
    Decoded_vkUpdateDescriptorSetWithTemplate out;
    EXPECT_TRUE(decode_vkUpdateDescriptorSetWithTemplate(d, out)) << d.error();
}

} // namespace
} // namespace splitvk::codec
