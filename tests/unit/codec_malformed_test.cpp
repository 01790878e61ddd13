// Malformed input: the agent's decoder must fail cleanly, with one line naming the problem, and
// never read past the message, allocate beyond what the bytes justify, or crash. Run under
// ASan+UBSan (SPLITVK_SANITIZE=ON) as well.

#include "codec_test_util.h"
#include "vk_codec.h"

#include <functional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace splitvk::codec {
namespace {

using test::Session;

// A few real messages covering structures, arrays, strings, unions, blobs and pNext chains.
struct Messages {
    Session s;
    std::vector<std::pair<std::string, std::vector<uint8_t>>> list;
    // One decoder per message, to run on any bytes.
    std::vector<std::function<bool(Decoder &)>> decode;

    Messages() {
        const VkDevice device = s.client<VkDevice>(VK_OBJECT_TYPE_DEVICE, 0x10);
        const VkCommandBuffer cb = s.client<VkCommandBuffer>(VK_OBJECT_TYPE_COMMAND_BUFFER, 0x11);
        const VkDescriptorSet set = s.client<VkDescriptorSet>(VK_OBJECT_TYPE_DESCRIPTOR_SET, 0x20);
        const VkSampler sampler = s.client<VkSampler>(VK_OBJECT_TYPE_SAMPLER, 0x30);
        const VkImageView view = s.client<VkImageView>(VK_OBJECT_TYPE_IMAGE_VIEW, 0x40);
        const VkBuffer buffer = s.client<VkBuffer>(VK_OBJECT_TYPE_BUFFER, 0x50);
        const VkRenderPass rp = s.client<VkRenderPass>(VK_OBJECT_TYPE_RENDER_PASS, 0x60);
        const VkFramebuffer fb = s.client<VkFramebuffer>(VK_OBJECT_TYPE_FRAMEBUFFER, 0x70);
        const VkShaderModule module = s.client<VkShaderModule>(VK_OBJECT_TYPE_SHADER_MODULE, 0x80);
        const VkPipelineLayout layout = s.client<VkPipelineLayout>(VK_OBJECT_TYPE_PIPELINE_LAYOUT, 0x90);

        {
            const VkDescriptorImageInfo image{sampler, view, VK_IMAGE_LAYOUT_GENERAL};
            const VkDescriptorBufferInfo buffers[2] = {{buffer, 0, 64}, {buffer, 64, 64}};
            const uint8_t inline_data[8] = {1, 2, 3, 4, 5, 6, 7, 8};
            const VkWriteDescriptorSetInlineUniformBlock block{
                VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET_INLINE_UNIFORM_BLOCK, nullptr, 8, inline_data};
            VkWriteDescriptorSet writes[3]{};
            for (auto &w : writes) {
                w.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
                w.dstSet = set;
            }
            writes[0].descriptorCount = 1;
            writes[0].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
            writes[0].pImageInfo = &image;
            writes[1].descriptorCount = 2;
            writes[1].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
            writes[1].pBufferInfo = buffers;
            writes[2].pNext = &block;
            writes[2].descriptorCount = 8;
            writes[2].descriptorType = VK_DESCRIPTOR_TYPE_INLINE_UNIFORM_BLOCK;
            Encoder e;
            encode_vkUpdateDescriptorSets(e, device, 3, writes, 0, nullptr);
            add("vkUpdateDescriptorSets", e, [](Decoder &d) {
                Decoded_vkUpdateDescriptorSets out;
                return decode_vkUpdateDescriptorSets(d, out);
            });
        }
        {
            VkClearValue clears[2]{};
            clears[0].color.float32[0] = 0.5f;
            clears[1].depthStencil = {1.0f, 3};
            const VkRenderPassBeginInfo begin{
                VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO, nullptr, rp, fb, {{0, 0}, {64, 64}}, 2, clears};
            Encoder e;
            encode_vkCmdBeginRenderPass(e, cb, &begin, VK_SUBPASS_CONTENTS_INLINE);
            add("vkCmdBeginRenderPass", e, [](Decoder &d) {
                Decoded_vkCmdBeginRenderPass out;
                return decode_vkCmdBeginRenderPass(d, out);
            });
        }
        {
            const VkSpecializationMapEntry entry{0, 0, 4};
            const uint32_t value = 7;
            const VkSpecializationInfo spec{1, &entry, 4, &value};
            VkPipelineShaderStageCreateInfo stage{};
            stage.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
            stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
            stage.module = module;
            stage.pName = "main";
            stage.pSpecializationInfo = &spec;
            VkPipelineCreationFeedback feedback{};
            VkPipelineCreationFeedback stage_feedback[1]{};
            const VkPipelineCreationFeedbackCreateInfo feedback_info{
                VK_STRUCTURE_TYPE_PIPELINE_CREATION_FEEDBACK_CREATE_INFO, nullptr, &feedback, 1,
                stage_feedback};
            const VkComputePipelineCreateInfo info{VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO,
                                                   &feedback_info,
                                                   0,
                                                   stage,
                                                   layout,
                                                   VK_NULL_HANDLE,
                                                   -1};
            VkPipeline created = to_handle<VkPipeline>(0x100);
            Encoder e;
            encode_vkCreateComputePipelines(e, device, VK_NULL_HANDLE, 1, &info, nullptr, &created);
            add("vkCreateComputePipelines", e, [](Decoder &d) {
                Decoded_vkCreateComputePipelines out;
                return decode_vkCreateComputePipelines(d, out);
            });
        }
        {
            const uint32_t code[5] = {0x07230203, 0x00010000, 0, 1, 0};
            const VkShaderModuleCreateInfo info{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO, nullptr, 0,
                                                sizeof(code), code};
            VkShaderModule created = to_handle<VkShaderModule>(0x110);
            Encoder e;
            encode_vkCreateShaderModule(e, device, &info, nullptr, &created);
            add("vkCreateShaderModule", e, [](Decoder &d) {
                Decoded_vkCreateShaderModule out;
                return decode_vkCreateShaderModule(d, out);
            });
        }
        {
            const char *extensions[2] = {"VK_KHR_swapchain", "VK_KHR_multiview"};
            const float priority = 1.0f;
            const VkDeviceQueueCreateInfo queue{
                VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO, nullptr, 0, 0, 1, &priority};
            VkPhysicalDeviceMultiviewFeatures multiview{};
            multiview.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MULTIVIEW_FEATURES;
            multiview.multiview = VK_TRUE;
            VkDeviceCreateInfo info{};
            info.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
            info.pNext = &multiview;
            info.queueCreateInfoCount = 1;
            info.pQueueCreateInfos = &queue;
            info.enabledExtensionCount = 2;
            info.ppEnabledExtensionNames = extensions;
            const VkPhysicalDevice gpu = s.client<VkPhysicalDevice>(VK_OBJECT_TYPE_PHYSICAL_DEVICE, 0x120);
            VkDevice created = to_handle<VkDevice>(0x130);
            Encoder e;
            encode_vkCreateDevice(e, gpu, &info, nullptr, &created);
            add("vkCreateDevice", e, [](Decoder &d) {
                Decoded_vkCreateDevice out;
                return decode_vkCreateDevice(d, out);
            });
        }
    }

    void add(const char *name, Encoder &e, std::function<bool(Decoder &)> fn) {
        list.emplace_back(name, e.take());
        decode.push_back(std::move(fn));
    }
};

TEST(CodecMalformed, EveryTruncationFailsCleanly) {
    Messages m;
    for (size_t k = 0; k < m.list.size(); ++k) {
        const auto &[name, bytes] = m.list[k];
        {
            Arena arena;
            Decoder d(bytes, m.s.table, arena);
            ASSERT_TRUE(m.decode[k](d)) << name << ": " << d.error();
            EXPECT_TRUE(d.at_end()) << name;
        }
        for (size_t n = 0; n < bytes.size(); ++n) {
            Arena arena;
            Decoder d(std::span<const uint8_t>(bytes).first(n), m.s.table, arena);
            EXPECT_FALSE(m.decode[k](d))
                << name << " truncated to " << n << " of " << bytes.size() << " bytes";
            const std::string error = d.error();
            EXPECT_FALSE(error.empty()) << name << " at " << n;
            EXPECT_EQ(error.find('\n'), std::string::npos) << error;
            EXPECT_NE(error.find(name), std::string::npos) << "the line names the command: " << error;
            // Never more decoded data than a small multiple of the bytes present.
            EXPECT_LE(arena.used(), 8 * n + 256) << name << " at " << n;
        }
    }
}

TEST(CodecMalformed, UnknownIdWrongTypeAndNull) {
    Session s;
    const VkImage image = s.client<VkImage>(VK_OBJECT_TYPE_IMAGE, 0x42);
    const VkDevice device = s.client<VkDevice>(VK_OBJECT_TYPE_DEVICE, 0x10);
    {
        Encoder e;
        encode_vkCmdDraw(e, to_handle<VkCommandBuffer>(0x777), 3, 1, 0, 0);
        Decoder d(e.data(), s.table, s.arena);
        Decoded_vkCmdDraw out;
        EXPECT_FALSE(decode_vkCmdDraw(d, out));
        EXPECT_EQ(d.error(), "vkCmdDraw: unknown VkCommandBuffer id 0x777 in 'commandBuffer' at offset 10");
    }
    {
        Encoder e;
        encode_vkDestroyBuffer(e, device, to_handle<VkBuffer>(handle_value(image)), nullptr);
        Decoder d(e.data(), s.table, s.arena);
        Decoded_vkDestroyBuffer out;
        EXPECT_FALSE(decode_vkDestroyBuffer(d, out));
        EXPECT_EQ(d.error(),
                  "vkDestroyBuffer: id 0x42 is a VkImage, expected VkBuffer in 'buffer' at offset 18");
    }
    {
        Encoder e;
        encode_vkCmdDraw(e, VK_NULL_HANDLE, 3, 1, 0, 0);
        Decoder d(e.data(), s.table, s.arena);
        Decoded_vkCmdDraw out;
        EXPECT_FALSE(decode_vkCmdDraw(d, out));
        EXPECT_NE(d.error().find("null VkCommandBuffer for 'commandBuffer'"), std::string::npos) << d.error();
    }
    {
        // Optional handles may be null: vkDestroyBuffer(VK_NULL_HANDLE) is valid.
        Encoder e;
        encode_vkDestroyBuffer(e, device, VK_NULL_HANDLE, nullptr);
        Decoder d(e.data(), s.table, s.arena);
        Decoded_vkDestroyBuffer out;
        EXPECT_TRUE(decode_vkDestroyBuffer(d, out)) << d.error();
        EXPECT_EQ(out.buffer, VK_NULL_HANDLE);
    }
    {
        // Inside a structure too.
        const VkImageViewCreateInfo info{VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO,
                                         nullptr,
                                         0,
                                         to_handle<VkImage>(0x43),
                                         VK_IMAGE_VIEW_TYPE_2D,
                                         VK_FORMAT_R8G8B8A8_UNORM,
                                         {},
                                         {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1}};
        VkImageView created = to_handle<VkImageView>(0x44);
        Encoder e;
        encode_vkCreateImageView(e, device, &info, nullptr, &created);
        Decoder d(e.data(), s.table, s.arena);
        Decoded_vkCreateImageView out;
        EXPECT_FALSE(decode_vkCreateImageView(d, out));
        EXPECT_NE(d.error().find("unknown VkImage id 0x43 in 'image'"), std::string::npos) << d.error();
    }
}

// Offsets in a vkCmdSetViewport message: u16 id, u64 commandBuffer, u32 firstViewport,
// u32 viewportCount, u8 presence, then the viewports.
constexpr size_t kViewportCountOffset = 2 + 8 + 4;

TEST(CodecMalformed, CountLargerThanTheBytesPresent) {
    Session s;
    const VkCommandBuffer cb = s.client<VkCommandBuffer>(VK_OBJECT_TYPE_COMMAND_BUFFER, 0x10);
    const VkViewport viewports[2] = {{0, 0, 1, 1, 0, 1}, {0, 0, 2, 2, 0, 1}};
    encode_vkCmdSetViewport(s.enc, cb, 0, 2, viewports);
    std::vector<uint8_t> bytes = s.enc.take();
    protocol::store_le32(bytes.data() + kViewportCountOffset, 1'000'000);
    Decoder d(bytes, s.table, s.arena);
    Decoded_vkCmdSetViewport out;
    EXPECT_FALSE(decode_vkCmdSetViewport(d, out));
    EXPECT_NE(d.error().find("truncated: 'pViewports' of 1000000 elements"), std::string::npos) << d.error();
    EXPECT_EQ(s.arena.used(), 0u); // nothing allocated for the claimed elements

    // Over the configured limit, even if the bytes were there.
    protocol::store_le32(bytes.data() + kViewportCountOffset, 2);
    Arena arena;
    DecodeLimits limits;
    limits.max_array_count = 1;
    Decoder limited(bytes, s.table, arena, limits);
    EXPECT_FALSE(decode_vkCmdSetViewport(limited, out));
    EXPECT_NE(limited.error().find("'pViewports' count 2 exceeds the limit 1"), std::string::npos)
        << limited.error();
}

TEST(CodecMalformed, HugeStringLengthAndBadPresence) {
    Session s;
    const VkDevice device = s.client<VkDevice>(VK_OBJECT_TYPE_DEVICE, 0x10);
    const VkShaderModule module = s.client<VkShaderModule>(VK_OBJECT_TYPE_SHADER_MODULE, 0x20);
    const VkPipelineLayout layout = s.client<VkPipelineLayout>(VK_OBJECT_TYPE_PIPELINE_LAYOUT, 0x30);
    VkComputePipelineCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO;
    info.stage.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
    info.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
    info.stage.module = module;
    info.stage.pName = "abcdefgh";
    info.layout = layout;
    VkPipeline created = to_handle<VkPipeline>(0x40);
    encode_vkCreateComputePipelines(s.enc, device, VK_NULL_HANDLE, 1, &info, nullptr, &created);
    const std::vector<uint8_t> good = s.enc.take();
    // Find the string "abcdefgh": its u32 length precedes it.
    const std::string needle = "abcdefgh";
    const auto at = std::search(good.begin(), good.end(), needle.begin(), needle.end()) - good.begin();
    ASSERT_GT(at, 5);
    {
        std::vector<uint8_t> bad = good;
        protocol::store_le32(bad.data() + at - 4, 0xFFFFFFF0u);
        Decoder d(bad, s.table, s.arena);
        Decoded_vkCreateComputePipelines out;
        EXPECT_FALSE(decode_vkCreateComputePipelines(d, out));
        EXPECT_NE(d.error().find("exceeds the limit"), std::string::npos) << d.error();
    }
    {
        std::vector<uint8_t> bad = good;
        bad[static_cast<size_t>(at) - 5] = 2; // the string's presence byte
        Decoder d(bad, s.table, s.arena);
        Decoded_vkCreateComputePipelines out;
        EXPECT_FALSE(decode_vkCreateComputePipelines(d, out));
        EXPECT_NE(d.error().find("presence byte 2 of 'pName'"), std::string::npos) << d.error();
    }
    {
        std::vector<uint8_t> bad = good;
        bad[static_cast<size_t>(at) - 5] = 0; // pName is required
        Decoder d(bad, s.table, s.arena);
        Decoded_vkCreateComputePipelines out;
        EXPECT_FALSE(decode_vkCreateComputePipelines(d, out));
        EXPECT_NE(d.error().find("missing 'pName'"), std::string::npos) << d.error();
    }
}

TEST(CodecMalformed, InvalidEnumValue) {
    Session s;
    const VkCommandBuffer cb = s.client<VkCommandBuffer>(VK_OBJECT_TYPE_COMMAND_BUFFER, 0x10);
    const VkPipeline pipeline = s.client<VkPipeline>(VK_OBJECT_TYPE_PIPELINE, 0x20);
    encode_vkCmdBindPipeline(s.enc, cb, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline);
    std::vector<uint8_t> bytes = s.enc.take();
    protocol::store_le32(bytes.data() + 10, 0x80000000u); // pipelineBindPoint
    Decoder d(bytes, s.table, s.arena);
    Decoded_vkCmdBindPipeline out;
    EXPECT_FALSE(decode_vkCmdBindPipeline(d, out));
    EXPECT_NE(d.error().find("invalid enum value -2147483648 for 'pipelineBindPoint'"), std::string::npos)
        << d.error();
}

// A pNext chain as long as the client can make it (a loop is cut by the encoder), and a decoder
// that allows shorter chains. An sType that cannot extend the structure is an error.
TEST(CodecMalformed, PnextLoopChainLimitAndUnknownStype) {
    Session s;
    const VkDevice device = s.client<VkDevice>(VK_OBJECT_TYPE_DEVICE, 0x10);
    struct Hooks : EncodeHooks {
        int truncated = 0;
        void chain_truncated(const char *) override { ++truncated; }
    } hooks;
    s.enc.set_hooks(&hooks);
    // A loop: a -> a -> ... (VkBufferCreateInfo has one other extension the codec carries; external
    // memory's never crosses the wire).
    VkBufferOpaqueCaptureAddressCreateInfo a{VK_STRUCTURE_TYPE_BUFFER_OPAQUE_CAPTURE_ADDRESS_CREATE_INFO,
                                             nullptr, 0x1234};
    a.pNext = &a;
    VkBufferCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
    info.pNext = &a;
    info.size = 4096;
    info.usage = VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT;
    info.pQueueFamilyIndices = test::invalid_pointer<uint32_t>(); // exclusive sharing: ignored
    info.queueFamilyIndexCount = 3;
    VkBuffer created = to_handle<VkBuffer>(0x20);
    encode_vkCreateBuffer(s.enc, device, &info, nullptr, &created);
    EXPECT_EQ(hooks.truncated, 1);
    EXPECT_EQ(s.enc.truncated_chains(), 1u);
    const std::vector<uint8_t> bytes = s.enc.take();
    {
        Decoder d(bytes, s.table, s.arena);
        Decoded_vkCreateBuffer out;
        ASSERT_TRUE(decode_vkCreateBuffer(d, out)) << d.error();
        int length = 0;
        for (auto *p = static_cast<const VkBaseInStructure *>(out.pCreateInfo->pNext); p; p = p->pNext)
            ++length;
        EXPECT_EQ(length, static_cast<int>(Encoder::kMaxChainLength));
        EXPECT_EQ(out.pCreateInfo->size, 4096u);
        EXPECT_EQ(out.pCreateInfo->pQueueFamilyIndices, nullptr);
        EXPECT_EQ(out.pCreateInfo->queueFamilyIndexCount, 3u);
    }
    {
        Arena arena;
        DecodeLimits limits;
        limits.max_chain_length = 8;
        Decoder d(bytes, s.table, arena, limits);
        Decoded_vkCreateBuffer out;
        EXPECT_FALSE(decode_vkCreateBuffer(d, out));
        EXPECT_NE(d.error().find("pNext chain of VkBufferCreateInfo longer than 8"), std::string::npos)
            << d.error();
    }
    {
        // The first chain element's sType follows u16 id, u64 device and the presence byte.
        std::vector<uint8_t> bad = bytes;
        ASSERT_EQ(protocol::load_le32(bad.data() + 11),
                  VK_STRUCTURE_TYPE_BUFFER_OPAQUE_CAPTURE_ADDRESS_CREATE_INFO);
        protocol::store_le32(bad.data() + 11, VK_STRUCTURE_TYPE_RENDER_PASS_MULTIVIEW_CREATE_INFO);
        Arena arena;
        Decoder d(bad, s.table, arena);
        Decoded_vkCreateBuffer out;
        EXPECT_FALSE(decode_vkCreateBuffer(d, out));
        EXPECT_NE(d.error().find("VkStructureType " +
                                 std::to_string(VK_STRUCTURE_TYPE_RENDER_PASS_MULTIVIEW_CREATE_INFO) +
                                 " cannot extend VkBufferCreateInfo"),
                  std::string::npos)
            << d.error();
    }
}

TEST(CodecMalformed, NestingDepthLimit) {
    Messages m;
    const auto &[name, bytes] = m.list[2]; // vkCreateComputePipelines: create info -> stage -> chain
    ASSERT_EQ(name, "vkCreateComputePipelines");
    Arena arena;
    DecodeLimits limits;
    limits.max_depth = 1;
    Decoder d(bytes, m.s.table, arena, limits);
    EXPECT_FALSE(m.decode[2](d));
    EXPECT_NE(d.error().find("nested deeper than 1"), std::string::npos) << d.error();
}

TEST(CodecMalformed, ArenaLimit) {
    Messages m;
    const auto &bytes = m.list[0].second;
    Arena arena(64);
    Decoder d(bytes, m.s.table, arena);
    EXPECT_FALSE(m.decode[0](d));
    EXPECT_NE(d.error().find("exceeds the arena limit of 64 bytes"), std::string::npos) << d.error();
}

TEST(CodecMalformed, UnknownAndMismatchedCommandIds) {
    Session s;
    CommandVisitor visitor;
    for (const uint16_t id : {uint16_t{0}, uint16_t{0x00FF}, static_cast<uint16_t>(kLastCommandId + 1),
                              uint16_t{0x0FFF}, uint16_t{0xFFFF}}) {
        const uint8_t bytes[2] = {static_cast<uint8_t>(id), static_cast<uint8_t>(id >> 8)};
        Decoder d(bytes, s.table, s.arena);
        EXPECT_FALSE(dispatch_decoded(d, visitor));
        char expected[64];
        std::snprintf(expected, sizeof(expected), "unknown Vulkan command id 0x%04x", id);
        EXPECT_NE(d.error().find(expected), std::string::npos) << d.error();
    }
    const VkCommandBuffer cb = s.client<VkCommandBuffer>(VK_OBJECT_TYPE_COMMAND_BUFFER, 0x10);
    encode_vkCmdDispatch(s.enc, cb, 1, 1, 1);
    Decoder d(s.bytes(), s.table, s.arena);
    Decoded_vkCmdDraw out;
    EXPECT_FALSE(decode_vkCmdDraw(d, out));
    EXPECT_NE(d.error().find("where vkCmdDraw"), std::string::npos) << d.error();
    // An empty message.
    Decoder empty(std::span<const uint8_t>(), s.table, s.arena);
    EXPECT_FALSE(dispatch_decoded(empty, visitor));
    EXPECT_NE(empty.error().find("truncated"), std::string::npos);
}

TEST(CodecMalformed, ErrorsAreSticky) {
    Session s;
    const VkCommandBuffer cb = s.client<VkCommandBuffer>(VK_OBJECT_TYPE_COMMAND_BUFFER, 0x10);
    encode_vkCmdDraw(s.enc, to_handle<VkCommandBuffer>(0x99), 1, 1, 0, 0);
    encode_vkCmdDraw(s.enc, cb, 1, 1, 0, 0);
    Decoder d(s.bytes(), s.table, s.arena);
    Decoded_vkCmdDraw out;
    EXPECT_FALSE(decode_vkCmdDraw(d, out));
    const std::string first = d.error();
    EXPECT_FALSE(decode_vkCmdDraw(d, out)); // a valid command after the error still fails
    EXPECT_EQ(d.error(), first);
}

// ---------------------------------------------------------------------------------------------

TEST(CodecHandleTable, InsertFindRemove) {
    HandleTable t;
    std::string error;
    EXPECT_FALSE(t.insert(0, VK_OBJECT_TYPE_BUFFER, uint64_t{1}, 0, &error));
    EXPECT_EQ(error, "created VkBuffer has id 0");
    EXPECT_TRUE(t.insert(5, VK_OBJECT_TYPE_BUFFER, uint64_t{0x500}));
    EXPECT_TRUE(t.insert(5, VK_OBJECT_TYPE_BUFFER, uint64_t{0x500})); // the same again: accepted
    EXPECT_FALSE(t.insert(5, VK_OBJECT_TYPE_IMAGE, uint64_t{0x600}, 0, &error));
    EXPECT_EQ(error, "id 0x5 of a new VkImage still names a live VkBuffer");
    ASSERT_NE(t.find(5), nullptr);
    EXPECT_EQ(t.find(5)->handle, 0x500u);
    EXPECT_TRUE(t.remove(5));
    EXPECT_FALSE(t.remove(5));
    EXPECT_EQ(t.find(5), nullptr);
    // Reuse of the value after destroy (the stream is ordered).
    EXPECT_TRUE(t.insert(5, VK_OBJECT_TYPE_IMAGE, uint64_t{0x600}));
    EXPECT_EQ(t.size(), 1u);
}

TEST(CodecHandleTable, PoolChildren) {
    HandleTable t;
    ASSERT_TRUE(t.insert(1, VK_OBJECT_TYPE_DESCRIPTOR_POOL, uint64_t{0x100}));
    ASSERT_TRUE(t.insert(2, VK_OBJECT_TYPE_DESCRIPTOR_POOL, uint64_t{0x200}));
    for (uint64_t i = 10; i < 20; ++i)
        ASSERT_TRUE(t.insert(i, VK_OBJECT_TYPE_DESCRIPTOR_SET, i * 16, i < 15 ? 1 : 2));
    EXPECT_TRUE(t.remove(12)); // freed individually
    t.remove_children(1);      // reset pool 1
    for (uint64_t i = 10; i < 15; ++i)
        EXPECT_EQ(t.find(i), nullptr) << i;
    EXPECT_NE(t.find(1), nullptr);
    EXPECT_NE(t.find(17), nullptr);
    // A set id reused under pool 1, then pool 2 destroyed: only pool 2's sets go.
    ASSERT_TRUE(t.insert(12, VK_OBJECT_TYPE_DESCRIPTOR_SET, uint64_t{0xC0}, 1));
    EXPECT_TRUE(t.remove(2));
    for (uint64_t i = 15; i < 20; ++i)
        EXPECT_EQ(t.find(i), nullptr) << i;
    EXPECT_NE(t.find(12), nullptr);
    EXPECT_EQ(t.size(), 2u);
    t.clear();
    EXPECT_TRUE(t.empty());
}

TEST(CodecArena, AlignmentZeroFillCapAndReset) {
    Arena arena(1 << 20);
    auto *a = arena.allocate_array<uint8_t>(3);
    auto *b = arena.allocate_array<uint64_t>(4);
    ASSERT_NE(a, nullptr);
    ASSERT_NE(b, nullptr);
    EXPECT_EQ(reinterpret_cast<uintptr_t>(b) % alignof(uint64_t), 0u);
    for (int i = 0; i < 4; ++i)
        EXPECT_EQ(b[i], 0u);
    auto *big = arena.allocate_array<uint8_t>(200 << 10); // larger than a block
    ASSERT_NE(big, nullptr);
    EXPECT_EQ(arena.allocate_array<uint8_t>(1 << 20), nullptr); // past the cap
    EXPECT_EQ(arena.allocate_array<uint64_t>(SIZE_MAX / 4), nullptr);
    arena.reset();
    EXPECT_EQ(arena.used(), 0u);
    auto *again = arena.allocate_array<uint32_t>(16);
    ASSERT_NE(again, nullptr);
    EXPECT_EQ(again[15], 0u);
}

} // namespace
} // namespace splitvk::codec
