// Round trips of the generated Vulkan wire codec with real, fully populated arguments: encode on
// the "client", decode with handle replacement on the "agent", compare field by field, and check
// that the decoded arguments re-encode to the very same bytes. Members the specification ignores
// point at invalid addresses or hold unknown handles: reading or sending them fails the test.

#include "codec_test_util.h"
#include "vk_codec.h"

#include <array>
#include <cstring>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace splitvk::codec {
namespace {

using test::garbage_handle;
using test::invalid_pointer;
using test::Session;

// Decodes the session's bytes with the identity table and re-encodes them with `reencode`:
// empty when the bytes are equal.
template <class Decoded, class DecodeFn, class ReencodeFn>
std::string reencode_identity(Session &s, DecodeFn decode, ReencodeFn reencode) {
    Arena arena;
    Decoder d(s.bytes(), s.identity, arena);
    Decoded out;
    if (!decode(d, out)) return "identity decode: " + d.error();
    if (!d.at_end()) return "identity decode left bytes";
    Encoder again;
    reencode(again, out);
    return test::same_bytes(s.bytes(), again.data());
}

#define EXPECT_REENCODES(Cmd, ...)                                                                           \
    EXPECT_EQ((reencode_identity<Decoded_##Cmd>(                                                             \
                  s, [](Decoder &dd, Decoded_##Cmd &o) { return decode_##Cmd(dd, o); },                      \
                  [&](Encoder &ee, const Decoded_##Cmd &o) { __VA_ARGS__; })),                               \
              "")

// ---------------------------------------------------------------------------------------------

struct PipelineObjects {
    VkDevice device;
    VkPipelineCache cache;
    VkShaderModule vs, fs;
    VkPipelineLayout layout;
    VkRenderPass render_pass;

    explicit PipelineObjects(Session &s)
        : device(s.client<VkDevice>(VK_OBJECT_TYPE_DEVICE, 0x10)),
          cache(s.client<VkPipelineCache>(VK_OBJECT_TYPE_PIPELINE_CACHE, 0x20)),
          vs(s.client<VkShaderModule>(VK_OBJECT_TYPE_SHADER_MODULE, 0x30)),
          fs(s.client<VkShaderModule>(VK_OBJECT_TYPE_SHADER_MODULE, 0x31)),
          layout(s.client<VkPipelineLayout>(VK_OBJECT_TYPE_PIPELINE_LAYOUT, 0x40)),
          render_pass(s.client<VkRenderPass>(VK_OBJECT_TYPE_RENDER_PASS, 0x50)) {}
};

TEST(CodecRoundTrip, CreateGraphicsPipelinesWithFullState) {
    Session s;
    const PipelineObjects objs(s);

    const VkSpecializationMapEntry map[2] = {{7, 0, 4}, {9, 4, 8}};
    const uint8_t spec_data[12] = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12};
    const VkSpecializationInfo spec{2, map, sizeof(spec_data), spec_data};
    VkPipelineShaderStageCreateInfo stages[2]{};
    stages[0].sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
    stages[0].stage = VK_SHADER_STAGE_VERTEX_BIT;
    stages[0].module = objs.vs;
    stages[0].pName = "main";
    stages[0].pSpecializationInfo = &spec;
    stages[1].sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
    stages[1].stage = VK_SHADER_STAGE_FRAGMENT_BIT;
    stages[1].module = objs.fs;
    stages[1].pName = "fragment_main";

    const VkVertexInputBindingDescription bindings[2] = {{0, 32, VK_VERTEX_INPUT_RATE_VERTEX},
                                                         {1, 16, VK_VERTEX_INPUT_RATE_INSTANCE}};
    const VkVertexInputAttributeDescription attributes[3] = {{0, 0, VK_FORMAT_R32G32B32_SFLOAT, 0},
                                                             {1, 0, VK_FORMAT_R32G32_SFLOAT, 12},
                                                             {2, 1, VK_FORMAT_R8G8B8A8_UNORM, 4}};
    const VkPipelineVertexInputStateCreateInfo vertex_input{
        VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO, nullptr, 0, 2, bindings, 3, attributes};
    const VkPipelineInputAssemblyStateCreateInfo input_assembly{
        VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO, nullptr, 0,
        VK_PRIMITIVE_TOPOLOGY_TRIANGLE_STRIP, VK_TRUE};
    const VkViewport viewports[2] = {{0, 0, 1200, 1080, 0, 1}, {1200, 0, 1200, 1080, 0.25f, 0.75f}};
    const VkRect2D scissors[2] = {{{0, 0}, {1200, 1080}}, {{1200, 0}, {1200, 1080}}};
    const VkPipelineViewportStateCreateInfo viewport{
        VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO, nullptr, 0, 2, viewports, 2, scissors};
    VkPipelineRasterizationStateCreateInfo raster{};
    raster.sType = VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO;
    raster.polygonMode = VK_POLYGON_MODE_FILL;
    raster.cullMode = VK_CULL_MODE_BACK_BIT;
    raster.frontFace = VK_FRONT_FACE_COUNTER_CLOCKWISE;
    raster.depthBiasEnable = VK_TRUE;
    raster.depthBiasConstantFactor = 1.25f;
    raster.depthBiasSlopeFactor = -2.5f;
    raster.lineWidth = 1.5f;
    const VkSampleMask sample_mask[1] = {0xFFFF0000u};
    VkPipelineMultisampleStateCreateInfo multisample{};
    multisample.sType = VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO;
    multisample.rasterizationSamples = VK_SAMPLE_COUNT_4_BIT;
    multisample.sampleShadingEnable = VK_TRUE;
    multisample.minSampleShading = 0.25f;
    multisample.pSampleMask = sample_mask;
    multisample.alphaToCoverageEnable = VK_TRUE;
    VkPipelineDepthStencilStateCreateInfo depth{};
    depth.sType = VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO;
    depth.depthTestEnable = VK_TRUE;
    depth.depthWriteEnable = VK_TRUE;
    depth.depthCompareOp = VK_COMPARE_OP_GREATER_OR_EQUAL;
    depth.stencilTestEnable = VK_TRUE;
    depth.front = {VK_STENCIL_OP_KEEP,
                   VK_STENCIL_OP_REPLACE,
                   VK_STENCIL_OP_INCREMENT_AND_CLAMP,
                   VK_COMPARE_OP_ALWAYS,
                   0xFF,
                   0x0F,
                   3};
    depth.back = {VK_STENCIL_OP_ZERO,
                  VK_STENCIL_OP_INVERT,
                  VK_STENCIL_OP_DECREMENT_AND_WRAP,
                  VK_COMPARE_OP_EQUAL,
                  0xF0,
                  0xAA,
                  5};
    depth.minDepthBounds = 0.125f;
    depth.maxDepthBounds = 0.875f;
    VkPipelineColorBlendAttachmentState blend[2]{};
    blend[0] = {VK_TRUE,
                VK_BLEND_FACTOR_SRC_ALPHA,
                VK_BLEND_FACTOR_ONE_MINUS_SRC_ALPHA,
                VK_BLEND_OP_ADD,
                VK_BLEND_FACTOR_ONE,
                VK_BLEND_FACTOR_ZERO,
                VK_BLEND_OP_MAX,
                0xF};
    blend[1].colorWriteMask = VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_A_BIT;
    const VkPipelineColorBlendStateCreateInfo color_blend{
        VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO,
        nullptr,
        0,
        VK_TRUE,
        VK_LOGIC_OP_XOR,
        2,
        blend,
        {0.1f, 0.2f, 0.3f, 0.4f}};
    const VkDynamicState dynamic_states[2] = {VK_DYNAMIC_STATE_LINE_WIDTH, VK_DYNAMIC_STATE_BLEND_CONSTANTS};
    const VkPipelineDynamicStateCreateInfo dynamic{VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO,
                                                   nullptr, 0, 2, dynamic_states};

    VkGraphicsPipelineCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO;
    info.flags = VK_PIPELINE_CREATE_DISABLE_OPTIMIZATION_BIT;
    info.stageCount = 2;
    info.pStages = stages;
    info.pVertexInputState = &vertex_input;
    info.pInputAssemblyState = &input_assembly;
    info.pTessellationState =
        invalid_pointer<VkPipelineTessellationStateCreateInfo>(); // no tessellation stages
    info.pViewportState = &viewport;
    info.pRasterizationState = &raster;
    info.pMultisampleState = &multisample;
    info.pDepthStencilState = &depth;
    info.pColorBlendState = &color_blend;
    info.pDynamicState = &dynamic;
    info.layout = objs.layout;
    info.renderPass = objs.render_pass;
    info.subpass = 1;
    info.basePipelineHandle = garbage_handle<VkPipeline>(); // not a derivative: ignored
    info.basePipelineIndex = -1;

    VkPipeline created = to_handle<VkPipeline>(0x60);
    encode_vkCreateGraphicsPipelines(s.enc, objs.device, objs.cache, 1, &info, nullptr, &created);

    Decoder d(s.bytes(), s.table, s.arena);
    Decoded_vkCreateGraphicsPipelines out;
    ASSERT_TRUE(decode_vkCreateGraphicsPipelines(d, out)) << d.error();
    EXPECT_TRUE(d.at_end());
    EXPECT_EQ(out.device, Session::server(objs.device));
    EXPECT_EQ(out.device_id, 0x10u);
    EXPECT_EQ(out.pipelineCache, Session::server(objs.cache));
    EXPECT_EQ(out.pAllocator, nullptr);
    ASSERT_EQ(out.createInfoCount, 1u);
    const VkGraphicsPipelineCreateInfo &ci = out.pCreateInfos[0];
    EXPECT_EQ(ci.sType, VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO);
    EXPECT_EQ(ci.pNext, nullptr);
    EXPECT_EQ(ci.flags, info.flags);
    ASSERT_EQ(ci.stageCount, 2u);
    EXPECT_EQ(ci.pStages[0].stage, VK_SHADER_STAGE_VERTEX_BIT);
    EXPECT_EQ(ci.pStages[0].module, Session::server(objs.vs));
    EXPECT_STREQ(ci.pStages[0].pName, "main");
    ASSERT_NE(ci.pStages[0].pSpecializationInfo, nullptr);
    const VkSpecializationInfo &sp = *ci.pStages[0].pSpecializationInfo;
    ASSERT_EQ(sp.mapEntryCount, 2u);
    EXPECT_EQ(sp.pMapEntries[1].constantID, 9u);
    EXPECT_EQ(sp.pMapEntries[1].offset, 4u);
    EXPECT_EQ(sp.pMapEntries[1].size, 8u);
    ASSERT_EQ(sp.dataSize, sizeof(spec_data));
    EXPECT_EQ(std::memcmp(sp.pData, spec_data, sizeof(spec_data)), 0);
    EXPECT_EQ(ci.pStages[1].module, Session::server(objs.fs));
    EXPECT_STREQ(ci.pStages[1].pName, "fragment_main");
    EXPECT_EQ(ci.pStages[1].pSpecializationInfo, nullptr);

    ASSERT_NE(ci.pVertexInputState, nullptr);
    ASSERT_EQ(ci.pVertexInputState->vertexBindingDescriptionCount, 2u);
    EXPECT_EQ(ci.pVertexInputState->pVertexBindingDescriptions[1].inputRate, VK_VERTEX_INPUT_RATE_INSTANCE);
    EXPECT_EQ(ci.pVertexInputState->pVertexBindingDescriptions[0].stride, 32u);
    ASSERT_EQ(ci.pVertexInputState->vertexAttributeDescriptionCount, 3u);
    EXPECT_EQ(ci.pVertexInputState->pVertexAttributeDescriptions[2].format, VK_FORMAT_R8G8B8A8_UNORM);
    EXPECT_EQ(ci.pVertexInputState->pVertexAttributeDescriptions[1].offset, 12u);
    EXPECT_EQ(ci.pInputAssemblyState->topology, VK_PRIMITIVE_TOPOLOGY_TRIANGLE_STRIP);
    EXPECT_EQ(ci.pInputAssemblyState->primitiveRestartEnable, VK_TRUE);
    EXPECT_EQ(ci.pTessellationState, nullptr);
    ASSERT_NE(ci.pViewportState, nullptr);
    ASSERT_EQ(ci.pViewportState->viewportCount, 2u);
    EXPECT_EQ(ci.pViewportState->pViewports[1].x, 1200.0f);
    EXPECT_EQ(ci.pViewportState->pViewports[1].minDepth, 0.25f);
    EXPECT_EQ(ci.pViewportState->pScissors[1].offset.x, 1200);
    EXPECT_EQ(ci.pViewportState->pScissors[1].extent.height, 1080u);
    EXPECT_EQ(ci.pRasterizationState->cullMode, VK_CULL_MODE_BACK_BIT);
    EXPECT_EQ(ci.pRasterizationState->depthBiasSlopeFactor, -2.5f);
    EXPECT_EQ(ci.pRasterizationState->lineWidth, 1.5f);
    EXPECT_EQ(ci.pMultisampleState->rasterizationSamples, VK_SAMPLE_COUNT_4_BIT);
    EXPECT_EQ(ci.pMultisampleState->minSampleShading, 0.25f);
    ASSERT_NE(ci.pMultisampleState->pSampleMask, nullptr);
    EXPECT_EQ(ci.pMultisampleState->pSampleMask[0], 0xFFFF0000u);
    EXPECT_EQ(ci.pDepthStencilState->depthCompareOp, VK_COMPARE_OP_GREATER_OR_EQUAL);
    EXPECT_EQ(ci.pDepthStencilState->back.passOp, VK_STENCIL_OP_INVERT);
    EXPECT_EQ(ci.pDepthStencilState->back.reference, 5u);
    EXPECT_EQ(ci.pDepthStencilState->maxDepthBounds, 0.875f);
    EXPECT_EQ(ci.pColorBlendState->logicOp, VK_LOGIC_OP_XOR);
    ASSERT_EQ(ci.pColorBlendState->attachmentCount, 2u);
    EXPECT_EQ(ci.pColorBlendState->pAttachments[0].alphaBlendOp, VK_BLEND_OP_MAX);
    EXPECT_EQ(ci.pColorBlendState->pAttachments[1].colorWriteMask,
              VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_A_BIT);
    EXPECT_EQ(ci.pColorBlendState->blendConstants[3], 0.4f);
    ASSERT_EQ(ci.pDynamicState->dynamicStateCount, 2u);
    EXPECT_EQ(ci.pDynamicState->pDynamicStates[1], VK_DYNAMIC_STATE_BLEND_CONSTANTS);
    EXPECT_EQ(ci.layout, Session::server(objs.layout));
    EXPECT_EQ(ci.renderPass, Session::server(objs.render_pass));
    EXPECT_EQ(ci.subpass, 1u);
    EXPECT_EQ(ci.basePipelineHandle, VK_NULL_HANDLE);
    EXPECT_EQ(ci.basePipelineIndex, -1);

    // The created pipeline: its id, and room for the agent's handle.
    ASSERT_EQ(out.pPipelines_count, 1u);
    EXPECT_EQ(out.pPipelines_ids[0], 0x60u);
    ASSERT_NE(out.pPipelines, nullptr);
    out.pPipelines[0] = to_handle<VkPipeline>(0xABC0); // what the agent's driver returned
    std::string error;
    ASSERT_TRUE(apply_handle_changes(s.table, out, &error)) << error;
    ASSERT_NE(s.table.find(0x60), nullptr);
    EXPECT_EQ(s.table.find(0x60)->handle, 0xABC0u);
    EXPECT_EQ(s.table.find(0x60)->type, VK_OBJECT_TYPE_PIPELINE);

    EXPECT_REENCODES(vkCreateGraphicsPipelines,
                     for (uint32_t i = 0; i < o.pPipelines_count; ++i) o.pPipelines[i] =
                         to_handle<VkPipeline>(o.pPipelines_ids[i]);
                     encode_vkCreateGraphicsPipelines(ee, o.device, o.pipelineCache, o.createInfoCount,
                                                      o.pCreateInfos, o.pAllocator, o.pPipelines));
}

// The pointers the specification ignores in a pipeline's state are never read: dynamic viewport
// and scissor, rasterizer discard, and dynamic rendering without color or depth attachments.
TEST(CodecRoundTrip, GraphicsPipelineIgnoredStateIsNotRead) {
    Session s;
    const PipelineObjects objs(s);
    VkPipelineShaderStageCreateInfo stage{};
    stage.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
    stage.stage = VK_SHADER_STAGE_VERTEX_BIT;
    stage.module = objs.vs;
    stage.pName = "main";

    // 0: dynamic viewport (with count) and scissor: pViewports and pScissors are ignored.
    const VkDynamicState dyn0[2] = {VK_DYNAMIC_STATE_VIEWPORT_WITH_COUNT, VK_DYNAMIC_STATE_SCISSOR};
    const VkPipelineDynamicStateCreateInfo dynamic0{VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO,
                                                    nullptr, 0, 2, dyn0};
    const VkPipelineViewportStateCreateInfo viewport0{VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO,
                                                      nullptr,
                                                      0,
                                                      1,
                                                      invalid_pointer<VkViewport>(),
                                                      1,
                                                      invalid_pointer<VkRect2D>()};
    VkPipelineRasterizationStateCreateInfo raster{};
    raster.sType = VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO;
    raster.lineWidth = 1.0f;
    VkPipelineMultisampleStateCreateInfo multisample{};
    multisample.sType = VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO;
    multisample.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;

    VkGraphicsPipelineCreateInfo infos[3]{};
    for (auto &info : infos) {
        info.sType = VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO;
        info.stageCount = 1;
        info.pStages = &stage;
        info.layout = objs.layout;
        info.basePipelineIndex = -1;
    }
    infos[0].pViewportState = &viewport0;
    infos[0].pRasterizationState = &raster;
    infos[0].pMultisampleState = &multisample;
    infos[0].pDynamicState = &dynamic0;
    infos[0].renderPass = objs.render_pass;
    // A derivative: basePipelineHandle is read (and must be a known pipeline or null).
    infos[0].flags = VK_PIPELINE_CREATE_DERIVATIVE_BIT;
    infos[0].basePipelineHandle = VK_NULL_HANDLE;
    infos[0].basePipelineIndex = 2;

    // 1: rasterizer discard: viewport, multisample, depth/stencil and color blend state are ignored.
    VkPipelineRasterizationStateCreateInfo discard = raster;
    discard.rasterizerDiscardEnable = VK_TRUE;
    infos[1].pRasterizationState = &discard;
    infos[1].pViewportState = invalid_pointer<VkPipelineViewportStateCreateInfo>();
    infos[1].pMultisampleState = invalid_pointer<VkPipelineMultisampleStateCreateInfo>();
    infos[1].pDepthStencilState = invalid_pointer<VkPipelineDepthStencilStateCreateInfo>();
    infos[1].pColorBlendState = invalid_pointer<VkPipelineColorBlendStateCreateInfo>();
    infos[1].renderPass = objs.render_pass;

    // 2: dynamic rendering with one color attachment and no depth: pDepthStencilState is ignored.
    const VkFormat formats[1] = {VK_FORMAT_B8G8R8A8_SRGB};
    const VkPipelineRenderingCreateInfo rendering{VK_STRUCTURE_TYPE_PIPELINE_RENDERING_CREATE_INFO,
                                                  nullptr,
                                                  0b11,
                                                  1,
                                                  formats,
                                                  VK_FORMAT_UNDEFINED,
                                                  VK_FORMAT_UNDEFINED};
    VkPipelineColorBlendAttachmentState attachment{};
    attachment.colorWriteMask = 0xF;
    const VkPipelineColorBlendStateCreateInfo color_blend{
        VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO,
        nullptr,
        0,
        VK_FALSE,
        VK_LOGIC_OP_CLEAR,
        1,
        &attachment,
        {}};
    infos[2].pNext = &rendering;
    infos[2].pRasterizationState = &raster;
    infos[2].pMultisampleState = &multisample;
    infos[2].pDepthStencilState = invalid_pointer<VkPipelineDepthStencilStateCreateInfo>();
    infos[2].pColorBlendState = &color_blend;
    infos[2].renderPass = VK_NULL_HANDLE;

    VkPipeline created[3] = {to_handle<VkPipeline>(0x61), VK_NULL_HANDLE, to_handle<VkPipeline>(0x63)};
    encode_vkCreateGraphicsPipelines(s.enc, objs.device, VK_NULL_HANDLE, 3, infos, nullptr, created);

    Decoder d(s.bytes(), s.table, s.arena);
    Decoded_vkCreateGraphicsPipelines out;
    ASSERT_TRUE(decode_vkCreateGraphicsPipelines(d, out)) << d.error();
    EXPECT_EQ(out.pipelineCache, VK_NULL_HANDLE);
    const VkGraphicsPipelineCreateInfo *ci = out.pCreateInfos;
    ASSERT_NE(ci[0].pViewportState, nullptr);
    EXPECT_EQ(ci[0].pViewportState->viewportCount, 1u);
    EXPECT_EQ(ci[0].pViewportState->pViewports, nullptr);
    EXPECT_EQ(ci[0].pViewportState->pScissors, nullptr);
    EXPECT_EQ(ci[0].basePipelineIndex, 2);
    EXPECT_NE(ci[1].pRasterizationState, nullptr);
    EXPECT_EQ(ci[1].pViewportState, nullptr);
    EXPECT_EQ(ci[1].pMultisampleState, nullptr);
    EXPECT_EQ(ci[1].pDepthStencilState, nullptr);
    EXPECT_EQ(ci[1].pColorBlendState, nullptr);
    EXPECT_EQ(ci[2].pDepthStencilState, nullptr);
    ASSERT_NE(ci[2].pColorBlendState, nullptr);
    EXPECT_EQ(ci[2].pColorBlendState->pAttachments[0].colorWriteMask, 0xFu);
    ASSERT_NE(ci[2].pNext, nullptr);
    const auto *decoded_rendering = static_cast<const VkPipelineRenderingCreateInfo *>(ci[2].pNext);
    EXPECT_EQ(decoded_rendering->sType, VK_STRUCTURE_TYPE_PIPELINE_RENDERING_CREATE_INFO);
    EXPECT_EQ(decoded_rendering->viewMask, 0b11u);
    ASSERT_EQ(decoded_rendering->colorAttachmentCount, 1u);
    EXPECT_EQ(decoded_rendering->pColorAttachmentFormats[0], VK_FORMAT_B8G8R8A8_SRGB);
    EXPECT_EQ(ci[2].renderPass, VK_NULL_HANDLE);
    // A failed element of the batch (VK_NULL_HANDLE) has id 0 and is not registered.
    ASSERT_EQ(out.pPipelines_count, 3u);
    EXPECT_EQ(out.pPipelines_ids[1], 0u);
    for (uint32_t i = 0; i < 3; ++i)
        out.pPipelines[i] = out.pPipelines_ids[i] ? to_handle<VkPipeline>(0xB000 + i) : VK_NULL_HANDLE;
    ASSERT_TRUE(apply_handle_changes(s.table, out));
    EXPECT_NE(s.table.find(0x61), nullptr);
    EXPECT_NE(s.table.find(0x63), nullptr);
}

// The layer can tell the encoder which attachments a subpass uses; then the state the subpass
// does not use is not read either. VkPipelineRenderingCreateInfo is ignored with a render pass.
TEST(CodecRoundTrip, GraphicsPipelineSubpassUseFromHooks) {
    struct Hooks : EncodeHooks {
        SubpassUse subpass_use(VkRenderPass, uint32_t subpass) override { return {subpass == 0, false}; }
    } hooks;
    Session s;
    s.enc.set_hooks(&hooks);
    const PipelineObjects objs(s);
    VkPipelineRasterizationStateCreateInfo raster{};
    raster.sType = VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO;
    const VkPipelineRenderingCreateInfo rendering{VK_STRUCTURE_TYPE_PIPELINE_RENDERING_CREATE_INFO,
                                                  nullptr,
                                                  0,
                                                  4,
                                                  invalid_pointer<VkFormat>(),
                                                  VK_FORMAT_D32_SFLOAT,
                                                  VK_FORMAT_UNDEFINED};
    VkGraphicsPipelineCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO;
    info.pNext = &rendering;
    info.pRasterizationState = &raster;
    info.pDepthStencilState = invalid_pointer<VkPipelineDepthStencilStateCreateInfo>();
    info.pColorBlendState = invalid_pointer<VkPipelineColorBlendStateCreateInfo>();
    info.layout = objs.layout;
    info.renderPass = objs.render_pass;
    info.subpass = 1; // the hooks say: no color, no depth
    VkPipeline created = to_handle<VkPipeline>(0x70);
    encode_vkCreateGraphicsPipelines(s.enc, objs.device, VK_NULL_HANDLE, 1, &info, nullptr, &created);

    Decoder d(s.bytes(), s.table, s.arena);
    Decoded_vkCreateGraphicsPipelines out;
    ASSERT_TRUE(decode_vkCreateGraphicsPipelines(d, out)) << d.error();
    EXPECT_EQ(out.pCreateInfos[0].pDepthStencilState, nullptr);
    EXPECT_EQ(out.pCreateInfos[0].pColorBlendState, nullptr);
    const auto *r = static_cast<const VkPipelineRenderingCreateInfo *>(out.pCreateInfos[0].pNext);
    ASSERT_NE(r, nullptr);
    EXPECT_EQ(r->colorAttachmentCount, 4u);
    EXPECT_EQ(r->pColorAttachmentFormats, nullptr);
    EXPECT_EQ(r->depthAttachmentFormat, VK_FORMAT_D32_SFLOAT);
}

// ---------------------------------------------------------------------------------------------

TEST(CodecRoundTrip, CreateRenderPassWithMultiview) {
    Session s;
    const VkDevice device = s.client<VkDevice>(VK_OBJECT_TYPE_DEVICE, 0x10);
    VkAttachmentDescription attachments[3]{};
    attachments[0] = {0,
                      VK_FORMAT_B8G8R8A8_SRGB,
                      VK_SAMPLE_COUNT_4_BIT,
                      VK_ATTACHMENT_LOAD_OP_CLEAR,
                      VK_ATTACHMENT_STORE_OP_DONT_CARE,
                      VK_ATTACHMENT_LOAD_OP_DONT_CARE,
                      VK_ATTACHMENT_STORE_OP_DONT_CARE,
                      VK_IMAGE_LAYOUT_UNDEFINED,
                      VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
    attachments[1] = attachments[0];
    attachments[1].samples = VK_SAMPLE_COUNT_1_BIT;
    attachments[1].storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    attachments[1].finalLayout = VK_IMAGE_LAYOUT_PRESENT_SRC_KHR;
    attachments[2] = attachments[0];
    attachments[2].format = VK_FORMAT_D24_UNORM_S8_UINT;
    attachments[2].stencilLoadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
    attachments[2].finalLayout = VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL;
    const VkAttachmentReference color{0, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
    const VkAttachmentReference resolve{1, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
    const VkAttachmentReference depth{2, VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL};
    const VkAttachmentReference input{1, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
    const uint32_t preserve[1] = {2};
    VkSubpassDescription subpasses[2]{};
    subpasses[0].pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
    subpasses[0].colorAttachmentCount = 1;
    subpasses[0].pColorAttachments = &color;
    subpasses[0].pResolveAttachments = &resolve;
    subpasses[0].pDepthStencilAttachment = &depth;
    subpasses[1].pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
    subpasses[1].inputAttachmentCount = 1;
    subpasses[1].pInputAttachments = &input;
    subpasses[1].colorAttachmentCount = 1;
    subpasses[1].pColorAttachments = &color;
    subpasses[1].preserveAttachmentCount = 1;
    subpasses[1].pPreserveAttachments = preserve;
    const VkSubpassDependency dependency{0,
                                         1,
                                         VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT,
                                         VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT,
                                         VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT,
                                         VK_ACCESS_INPUT_ATTACHMENT_READ_BIT,
                                         VK_DEPENDENCY_BY_REGION_BIT | VK_DEPENDENCY_VIEW_LOCAL_BIT};
    const uint32_t view_masks[2] = {0b11, 0b11};
    const int32_t view_offsets[1] = {-1};
    const uint32_t correlation[1] = {0b11};
    const VkRenderPassMultiviewCreateInfo multiview{VK_STRUCTURE_TYPE_RENDER_PASS_MULTIVIEW_CREATE_INFO,
                                                    nullptr,
                                                    2,
                                                    view_masks,
                                                    1,
                                                    view_offsets,
                                                    1,
                                                    correlation};
    const VkRenderPassCreateInfo info{VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO,
                                      &multiview,
                                      0,
                                      3,
                                      attachments,
                                      2,
                                      subpasses,
                                      1,
                                      &dependency};
    VkRenderPass created = to_handle<VkRenderPass>(0x80);
    encode_vkCreateRenderPass(s.enc, device, &info, nullptr, &created);

    Decoder d(s.bytes(), s.table, s.arena);
    Decoded_vkCreateRenderPass out;
    ASSERT_TRUE(decode_vkCreateRenderPass(d, out)) << d.error();
    EXPECT_TRUE(d.at_end());
    const VkRenderPassCreateInfo &rp = *out.pCreateInfo;
    ASSERT_EQ(rp.attachmentCount, 3u);
    EXPECT_EQ(rp.pAttachments[2].format, VK_FORMAT_D24_UNORM_S8_UINT);
    EXPECT_EQ(rp.pAttachments[1].finalLayout, VK_IMAGE_LAYOUT_PRESENT_SRC_KHR);
    ASSERT_EQ(rp.subpassCount, 2u);
    ASSERT_NE(rp.pSubpasses[0].pResolveAttachments, nullptr);
    EXPECT_EQ(rp.pSubpasses[0].pResolveAttachments[0].attachment, 1u);
    ASSERT_NE(rp.pSubpasses[0].pDepthStencilAttachment, nullptr);
    EXPECT_EQ(rp.pSubpasses[0].pDepthStencilAttachment->layout,
              VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL);
    EXPECT_EQ(rp.pSubpasses[1].pResolveAttachments, nullptr);
    EXPECT_EQ(rp.pSubpasses[1].pDepthStencilAttachment, nullptr);
    ASSERT_EQ(rp.pSubpasses[1].inputAttachmentCount, 1u);
    EXPECT_EQ(rp.pSubpasses[1].pInputAttachments[0].layout, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
    ASSERT_EQ(rp.pSubpasses[1].preserveAttachmentCount, 1u);
    EXPECT_EQ(rp.pSubpasses[1].pPreserveAttachments[0], 2u);
    ASSERT_EQ(rp.dependencyCount, 1u);
    EXPECT_EQ(rp.pDependencies[0].dependencyFlags,
              VK_DEPENDENCY_BY_REGION_BIT | VK_DEPENDENCY_VIEW_LOCAL_BIT);
    ASSERT_NE(rp.pNext, nullptr);
    const auto &mv = *static_cast<const VkRenderPassMultiviewCreateInfo *>(rp.pNext);
    EXPECT_EQ(mv.sType, VK_STRUCTURE_TYPE_RENDER_PASS_MULTIVIEW_CREATE_INFO);
    EXPECT_EQ(mv.pNext, nullptr);
    ASSERT_EQ(mv.subpassCount, 2u);
    EXPECT_EQ(mv.pViewMasks[1], 0b11u);
    ASSERT_EQ(mv.dependencyCount, 1u);
    EXPECT_EQ(mv.pViewOffsets[0], -1);
    ASSERT_EQ(mv.correlationMaskCount, 1u);
    EXPECT_EQ(mv.pCorrelationMasks[0], 0b11u);
    EXPECT_EQ(out.pRenderPass_ids[0], 0x80u);

    EXPECT_REENCODES(vkCreateRenderPass, o.pRenderPass[0] = to_handle<VkRenderPass>(o.pRenderPass_ids[0]);
                     encode_vkCreateRenderPass(ee, o.device, o.pCreateInfo, o.pAllocator, o.pRenderPass));
}

TEST(CodecRoundTrip, CreateRenderPass2WithMultiviewAndResolve) {
    struct Hooks : EncodeHooks {
        std::vector<std::pair<VkStructureType, std::string>> skipped;
        void skipped_structure(VkStructureType type, const char *parent) override {
            skipped.emplace_back(type, parent);
        }
    } hooks;
    Session s;
    s.enc.set_hooks(&hooks);
    const VkDevice device = s.client<VkDevice>(VK_OBJECT_TYPE_DEVICE, 0x10);

    const VkAttachmentDescriptionStencilLayout stencil_layout{
        VK_STRUCTURE_TYPE_ATTACHMENT_DESCRIPTION_STENCIL_LAYOUT, nullptr,
        VK_IMAGE_LAYOUT_STENCIL_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_STENCIL_READ_ONLY_OPTIMAL};
    VkAttachmentDescription2 attachments[2]{};
    attachments[0].sType = VK_STRUCTURE_TYPE_ATTACHMENT_DESCRIPTION_2;
    attachments[0].format = VK_FORMAT_D32_SFLOAT_S8_UINT;
    attachments[0].samples = VK_SAMPLE_COUNT_4_BIT;
    attachments[0].pNext = &stencil_layout;
    attachments[1].sType = VK_STRUCTURE_TYPE_ATTACHMENT_DESCRIPTION_2;
    attachments[1].format = VK_FORMAT_D32_SFLOAT_S8_UINT;
    attachments[1].samples = VK_SAMPLE_COUNT_1_BIT;
    const VkAttachmentReference2 depth{VK_STRUCTURE_TYPE_ATTACHMENT_REFERENCE_2, nullptr, 0,
                                       VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL,
                                       VK_IMAGE_ASPECT_DEPTH_BIT | VK_IMAGE_ASPECT_STENCIL_BIT};
    const VkAttachmentReference2 depth_resolve{VK_STRUCTURE_TYPE_ATTACHMENT_REFERENCE_2, nullptr, 1,
                                               VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL,
                                               VK_IMAGE_ASPECT_DEPTH_BIT};
    const VkSubpassDescriptionDepthStencilResolve resolve{
        VK_STRUCTURE_TYPE_SUBPASS_DESCRIPTION_DEPTH_STENCIL_RESOLVE, nullptr, VK_RESOLVE_MODE_SAMPLE_ZERO_BIT,
        VK_RESOLVE_MODE_NONE, &depth_resolve};
    VkSubpassDescription2 subpass{};
    subpass.sType = VK_STRUCTURE_TYPE_SUBPASS_DESCRIPTION_2;
    subpass.pNext = &resolve;
    subpass.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
    subpass.viewMask = 0b11;
    subpass.pDepthStencilAttachment = &depth;
    const VkMemoryBarrier2 barrier{VK_STRUCTURE_TYPE_MEMORY_BARRIER_2,
                                   nullptr,
                                   VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
                                   VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT,
                                   VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT | (VkPipelineStageFlags2{1} << 40),
                                   VK_ACCESS_2_SHADER_SAMPLED_READ_BIT};
    VkSubpassDependency2 dependency{};
    dependency.sType = VK_STRUCTURE_TYPE_SUBPASS_DEPENDENCY_2;
    dependency.pNext = &barrier;
    dependency.srcSubpass = 0;
    dependency.dstSubpass = VK_SUBPASS_EXTERNAL;
    dependency.viewOffset = 1;
    // Not an extension of VkRenderPassCreateInfo2: skipped and reported, not sent.
    const uint32_t view_masks[1] = {0b11};
    const VkRenderPassMultiviewCreateInfo misplaced{
        VK_STRUCTURE_TYPE_RENDER_PASS_MULTIVIEW_CREATE_INFO, nullptr, 1, view_masks, 0, nullptr, 0, nullptr};
    const uint32_t correlated[2] = {0b01, 0b10};
    VkRenderPassCreateInfo2 info{};
    info.sType = VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO_2;
    info.pNext = &misplaced;
    info.attachmentCount = 2;
    info.pAttachments = attachments;
    info.subpassCount = 1;
    info.pSubpasses = &subpass;
    info.dependencyCount = 1;
    info.pDependencies = &dependency;
    info.correlatedViewMaskCount = 2;
    info.pCorrelatedViewMasks = correlated;
    VkRenderPass created = to_handle<VkRenderPass>(0x81);
    encode_vkCreateRenderPass2(s.enc, device, &info, nullptr, &created);
    ASSERT_EQ(hooks.skipped.size(), 1u);
    EXPECT_EQ(hooks.skipped[0].first, VK_STRUCTURE_TYPE_RENDER_PASS_MULTIVIEW_CREATE_INFO);
    EXPECT_EQ(hooks.skipped[0].second, "VkRenderPassCreateInfo2");
    EXPECT_EQ(s.enc.skipped_structures(), 1u);

    Decoder d(s.bytes(), s.table, s.arena);
    Decoded_vkCreateRenderPass2 out;
    ASSERT_TRUE(decode_vkCreateRenderPass2(d, out)) << d.error();
    const VkRenderPassCreateInfo2 &rp = *out.pCreateInfo;
    EXPECT_EQ(rp.pNext, nullptr);
    const auto *sl = static_cast<const VkAttachmentDescriptionStencilLayout *>(rp.pAttachments[0].pNext);
    ASSERT_NE(sl, nullptr);
    EXPECT_EQ(sl->stencilFinalLayout, VK_IMAGE_LAYOUT_STENCIL_READ_ONLY_OPTIMAL);
    EXPECT_EQ(rp.pAttachments[1].pNext, nullptr);
    EXPECT_EQ(rp.pSubpasses[0].viewMask, 0b11u);
    EXPECT_EQ(rp.pSubpasses[0].pDepthStencilAttachment->aspectMask,
              VkImageAspectFlags{VK_IMAGE_ASPECT_DEPTH_BIT | VK_IMAGE_ASPECT_STENCIL_BIT});
    const auto *r = static_cast<const VkSubpassDescriptionDepthStencilResolve *>(rp.pSubpasses[0].pNext);
    ASSERT_NE(r, nullptr);
    EXPECT_EQ(r->depthResolveMode, VK_RESOLVE_MODE_SAMPLE_ZERO_BIT);
    ASSERT_NE(r->pDepthStencilResolveAttachment, nullptr);
    EXPECT_EQ(r->pDepthStencilResolveAttachment->attachment, 1u);
    const auto *b = static_cast<const VkMemoryBarrier2 *>(rp.pDependencies[0].pNext);
    ASSERT_NE(b, nullptr);
    EXPECT_EQ(b->dstStageMask, barrier.dstStageMask); // 64-bit flags survive
    EXPECT_EQ(rp.pDependencies[0].dstSubpass, VK_SUBPASS_EXTERNAL);
    EXPECT_EQ(rp.pDependencies[0].viewOffset, 1);
    ASSERT_EQ(rp.correlatedViewMaskCount, 2u);
    EXPECT_EQ(rp.pCorrelatedViewMasks[1], 0b10u);

    EXPECT_REENCODES(vkCreateRenderPass2, o.pRenderPass[0] = to_handle<VkRenderPass>(o.pRenderPass_ids[0]);
                     encode_vkCreateRenderPass2(ee, o.device, o.pCreateInfo, o.pAllocator, o.pRenderPass));
}

TEST(CodecRoundTrip, CreateShaderModule) {
    Session s;
    const VkDevice device = s.client<VkDevice>(VK_OBJECT_TYPE_DEVICE, 0x10);
    std::vector<uint32_t> code(1001);
    for (size_t i = 0; i < code.size(); ++i)
        code[i] = static_cast<uint32_t>(0x07230203u * (i + 1));
    const VkShaderModuleCreateInfo info{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO, nullptr, 0,
                                        code.size() * 4, code.data()};
    VkShaderModule created = to_handle<VkShaderModule>(0x90);
    encode_vkCreateShaderModule(s.enc, device, &info, nullptr, &created);

    Decoder d(s.bytes(), s.table, s.arena);
    Decoded_vkCreateShaderModule out;
    ASSERT_TRUE(decode_vkCreateShaderModule(d, out)) << d.error();
    ASSERT_EQ(out.pCreateInfo->codeSize, code.size() * 4);
    EXPECT_EQ(std::memcmp(out.pCreateInfo->pCode, code.data(), code.size() * 4), 0);
    EXPECT_EQ(reinterpret_cast<uintptr_t>(out.pCreateInfo->pCode) % alignof(uint32_t), 0u);
    EXPECT_EQ(out.pShaderModule_ids[0], 0x90u);
    EXPECT_REENCODES(vkCreateShaderModule,
                     o.pShaderModule[0] = to_handle<VkShaderModule>(o.pShaderModule_ids[0]);
                     encode_vkCreateShaderModule(ee, o.device, o.pCreateInfo, o.pAllocator, o.pShaderModule));
}

// ---------------------------------------------------------------------------------------------

TEST(CodecRoundTrip, UpdateDescriptorSetsReadsOnlyWhatTheTypeUses) {
    Session s;
    const VkDevice device = s.client<VkDevice>(VK_OBJECT_TYPE_DEVICE, 0x10);
    const VkDescriptorSet set = s.client<VkDescriptorSet>(VK_OBJECT_TYPE_DESCRIPTOR_SET, 0x20);
    const VkDescriptorSet set2 = s.client<VkDescriptorSet>(VK_OBJECT_TYPE_DESCRIPTOR_SET, 0x21);
    const VkSampler sampler = s.client<VkSampler>(VK_OBJECT_TYPE_SAMPLER, 0x30);
    const VkImageView view0 = s.client<VkImageView>(VK_OBJECT_TYPE_IMAGE_VIEW, 0x40);
    const VkImageView view1 = s.client<VkImageView>(VK_OBJECT_TYPE_IMAGE_VIEW, 0x41);
    const VkBuffer buffer = s.client<VkBuffer>(VK_OBJECT_TYPE_BUFFER, 0x50);
    const VkBufferView texel = s.client<VkBufferView>(VK_OBJECT_TYPE_BUFFER_VIEW, 0x60);

    const VkDescriptorImageInfo combined[2] = {{sampler, view0, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL},
                                               {sampler, view1, VK_IMAGE_LAYOUT_GENERAL}};
    // A sampled image: the sampler member is ignored (garbage here).
    const VkDescriptorImageInfo sampled{garbage_handle<VkSampler>(), view1,
                                        VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
    // A sampler: the image view is ignored.
    const VkDescriptorImageInfo only_sampler{sampler, garbage_handle<VkImageView>(),
                                             VK_IMAGE_LAYOUT_UNDEFINED};
    const VkDescriptorBufferInfo buffers[2] = {{buffer, 256, 64}, {VK_NULL_HANDLE, 0, VK_WHOLE_SIZE}};
    const uint8_t inline_data[16] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15};
    const VkWriteDescriptorSetInlineUniformBlock inline_block{
        VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET_INLINE_UNIFORM_BLOCK, nullptr, sizeof(inline_data),
        inline_data};

    VkWriteDescriptorSet writes[6]{};
    for (auto &w : writes) {
        w.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
        w.dstSet = set;
        // Whatever the type does not use points at an invalid address.
        w.pImageInfo = invalid_pointer<VkDescriptorImageInfo>();
        w.pBufferInfo = invalid_pointer<VkDescriptorBufferInfo>();
        w.pTexelBufferView = invalid_pointer<VkBufferView>();
    }
    writes[0].dstBinding = 0;
    writes[0].descriptorCount = 2;
    writes[0].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
    writes[0].pImageInfo = combined;
    writes[1].dstBinding = 1;
    writes[1].dstArrayElement = 3;
    writes[1].descriptorCount = 2;
    writes[1].descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
    writes[1].pBufferInfo = buffers;
    writes[2].dstBinding = 2;
    writes[2].descriptorCount = 1;
    writes[2].descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER;
    writes[2].pTexelBufferView = &texel;
    writes[3].dstBinding = 3;
    writes[3].descriptorCount = 1;
    writes[3].descriptorType = VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE;
    writes[3].pImageInfo = &sampled;
    writes[4].dstBinding = 4;
    writes[4].descriptorCount = 1;
    writes[4].descriptorType = VK_DESCRIPTOR_TYPE_SAMPLER;
    writes[4].pImageInfo = &only_sampler;
    writes[5].dstSet = set2;
    writes[5].pNext = &inline_block;
    writes[5].dstBinding = 5;
    writes[5].descriptorCount = sizeof(inline_data);
    writes[5].descriptorType = VK_DESCRIPTOR_TYPE_INLINE_UNIFORM_BLOCK;
    const VkCopyDescriptorSet copy{VK_STRUCTURE_TYPE_COPY_DESCRIPTOR_SET, nullptr, set, 0, 1, set2, 0, 0, 2};

    encode_vkUpdateDescriptorSets(s.enc, device, 6, writes, 1, &copy);

    Decoder d(s.bytes(), s.table, s.arena);
    Decoded_vkUpdateDescriptorSets out;
    ASSERT_TRUE(decode_vkUpdateDescriptorSets(d, out)) << d.error();
    EXPECT_TRUE(d.at_end());
    ASSERT_EQ(out.descriptorWriteCount, 6u);
    const VkWriteDescriptorSet *w = out.pDescriptorWrites;
    EXPECT_EQ(w[0].dstSet, Session::server(set));
    ASSERT_NE(w[0].pImageInfo, nullptr);
    EXPECT_EQ(w[0].pBufferInfo, nullptr);
    EXPECT_EQ(w[0].pTexelBufferView, nullptr);
    EXPECT_EQ(w[0].pImageInfo[0].sampler, Session::server(sampler));
    EXPECT_EQ(w[0].pImageInfo[1].imageView, Session::server(view1));
    EXPECT_EQ(w[0].pImageInfo[1].imageLayout, VK_IMAGE_LAYOUT_GENERAL);
    EXPECT_EQ(w[1].dstArrayElement, 3u);
    EXPECT_EQ(w[1].pImageInfo, nullptr);
    ASSERT_NE(w[1].pBufferInfo, nullptr);
    EXPECT_EQ(w[1].pBufferInfo[0].buffer, Session::server(buffer));
    EXPECT_EQ(w[1].pBufferInfo[0].offset, 256u);
    EXPECT_EQ(w[1].pBufferInfo[0].range, 64u);
    EXPECT_EQ(w[1].pBufferInfo[1].buffer, VK_NULL_HANDLE); // a null descriptor (robustness2)
    EXPECT_EQ(w[1].pBufferInfo[1].range, VK_WHOLE_SIZE);
    ASSERT_NE(w[2].pTexelBufferView, nullptr);
    EXPECT_EQ(w[2].pTexelBufferView[0], Session::server(texel));
    EXPECT_EQ(w[2].pImageInfo, nullptr);
    EXPECT_EQ(w[3].pImageInfo[0].sampler, VK_NULL_HANDLE);
    EXPECT_EQ(w[3].pImageInfo[0].imageView, Session::server(view1));
    EXPECT_EQ(w[4].pImageInfo[0].sampler, Session::server(sampler));
    EXPECT_EQ(w[4].pImageInfo[0].imageView, VK_NULL_HANDLE);
    EXPECT_EQ(w[5].pImageInfo, nullptr);
    EXPECT_EQ(w[5].pBufferInfo, nullptr);
    EXPECT_EQ(w[5].pTexelBufferView, nullptr);
    ASSERT_NE(w[5].pNext, nullptr);
    const auto &ib = *static_cast<const VkWriteDescriptorSetInlineUniformBlock *>(w[5].pNext);
    ASSERT_EQ(ib.dataSize, sizeof(inline_data));
    EXPECT_EQ(std::memcmp(ib.pData, inline_data, sizeof(inline_data)), 0);
    ASSERT_EQ(out.descriptorCopyCount, 1u);
    EXPECT_EQ(out.pDescriptorCopies[0].srcSet, Session::server(set));
    EXPECT_EQ(out.pDescriptorCopies[0].dstSet, Session::server(set2));
    EXPECT_EQ(out.pDescriptorCopies[0].descriptorCount, 2u);

    EXPECT_REENCODES(vkUpdateDescriptorSets,
                     encode_vkUpdateDescriptorSets(ee, o.device, o.descriptorWriteCount, o.pDescriptorWrites,
                                                   o.descriptorCopyCount, o.pDescriptorCopies));
}

// With immutable samplers in the binding (the layer knows), the sampler member is ignored too.
TEST(CodecRoundTrip, ImmutableSamplersAreNotSent) {
    struct Hooks : EncodeHooks {
        bool has_immutable_samplers(VkDescriptorSet, uint32_t binding) override { return binding == 7; }
    } hooks;
    Session s;
    s.enc.set_hooks(&hooks);
    const VkDevice device = s.client<VkDevice>(VK_OBJECT_TYPE_DEVICE, 0x10);
    const VkDescriptorSet set = s.client<VkDescriptorSet>(VK_OBJECT_TYPE_DESCRIPTOR_SET, 0x20);
    const VkImageView view = s.client<VkImageView>(VK_OBJECT_TYPE_IMAGE_VIEW, 0x40);
    const VkDescriptorImageInfo info{garbage_handle<VkSampler>(), view,
                                     VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
    VkWriteDescriptorSet write{};
    write.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
    write.dstSet = set;
    write.dstBinding = 7;
    write.descriptorCount = 1;
    write.descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
    write.pImageInfo = &info;
    encode_vkUpdateDescriptorSets(s.enc, device, 1, &write, 0, invalid_pointer<VkCopyDescriptorSet>());
    Decoder d(s.bytes(), s.table, s.arena);
    Decoded_vkUpdateDescriptorSets out;
    ASSERT_TRUE(decode_vkUpdateDescriptorSets(d, out)) << d.error();
    EXPECT_EQ(out.pDescriptorWrites[0].pImageInfo[0].sampler, VK_NULL_HANDLE);
    EXPECT_EQ(out.pDescriptorWrites[0].pImageInfo[0].imageView, Session::server(view));
    EXPECT_EQ(out.pDescriptorCopies, nullptr);
}

TEST(CodecRoundTrip, PushDescriptorSetIgnoresDstSet) {
    Session s;
    const VkCommandBuffer cb = s.client<VkCommandBuffer>(VK_OBJECT_TYPE_COMMAND_BUFFER, 0x10);
    const VkPipelineLayout layout = s.client<VkPipelineLayout>(VK_OBJECT_TYPE_PIPELINE_LAYOUT, 0x20);
    const VkBuffer buffer = s.client<VkBuffer>(VK_OBJECT_TYPE_BUFFER, 0x30);
    const VkDescriptorBufferInfo info{buffer, 0, 128};
    VkWriteDescriptorSet write{};
    write.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
    write.dstSet = garbage_handle<VkDescriptorSet>();
    write.descriptorCount = 1;
    write.descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    write.pBufferInfo = &info;
    encode_vkCmdPushDescriptorSetKHR(s.enc, cb, VK_PIPELINE_BIND_POINT_COMPUTE, layout, 2, 1, &write);
    // The context does not leak into later commands: dstSet is sent again for updates.
    const VkDevice device = s.client<VkDevice>(VK_OBJECT_TYPE_DEVICE, 0x40);
    const VkDescriptorSet set = s.client<VkDescriptorSet>(VK_OBJECT_TYPE_DESCRIPTOR_SET, 0x50);
    write.dstSet = set;
    encode_vkUpdateDescriptorSets(s.enc, device, 1, &write, 0, nullptr);

    Decoder d(s.bytes(), s.table, s.arena);
    Decoded_vkCmdPushDescriptorSetKHR push;
    ASSERT_TRUE(decode_vkCmdPushDescriptorSetKHR(d, push)) << d.error();
    EXPECT_EQ(push.pipelineBindPoint, VK_PIPELINE_BIND_POINT_COMPUTE);
    EXPECT_EQ(push.set, 2u);
    EXPECT_EQ(push.pDescriptorWrites[0].dstSet, VK_NULL_HANDLE);
    EXPECT_EQ(push.pDescriptorWrites[0].pBufferInfo[0].buffer, Session::server(buffer));
    Decoded_vkUpdateDescriptorSets update;
    ASSERT_TRUE(decode_vkUpdateDescriptorSets(d, update)) << d.error();
    EXPECT_EQ(update.pDescriptorWrites[0].dstSet, Session::server(set));
    EXPECT_TRUE(d.at_end());
}

// ---------------------------------------------------------------------------------------------

TEST(CodecRoundTrip, CmdBeginRenderPassClearValuesAreBitExact) {
    Session s;
    const VkCommandBuffer cb = s.client<VkCommandBuffer>(VK_OBJECT_TYPE_COMMAND_BUFFER, 0x10);
    const VkRenderPass rp = s.client<VkRenderPass>(VK_OBJECT_TYPE_RENDER_PASS, 0x20);
    const VkFramebuffer fb = s.client<VkFramebuffer>(VK_OBJECT_TYPE_FRAMEBUFFER, 0x30);
    const VkImageView views[2] = {s.client<VkImageView>(VK_OBJECT_TYPE_IMAGE_VIEW, 0x40),
                                  s.client<VkImageView>(VK_OBJECT_TYPE_IMAGE_VIEW, 0x41)};
    VkClearValue clears[3]{};
    clears[0].color.float32[0] = 0.25f;
    clears[0].color.float32[1] = -0.0f;
    clears[0].color.float32[3] = 1.0f;
    clears[1].color.uint32[0] = 0xFFFFFFFFu;
    clears[1].color.uint32[1] = 0x7FC00001u; // a NaN pattern as a float: must survive bit for bit
    clears[1].color.int32[2] = -5;
    clears[2].depthStencil = {1.0f, 7};
    const VkRenderPassAttachmentBeginInfo attachments{VK_STRUCTURE_TYPE_RENDER_PASS_ATTACHMENT_BEGIN_INFO,
                                                      nullptr, 2, views};
    const VkRenderPassBeginInfo begin{
        VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO, &attachments, rp, fb, {{10, 20}, {640, 480}}, 3, clears};
    encode_vkCmdBeginRenderPass(s.enc, cb, &begin, VK_SUBPASS_CONTENTS_SECONDARY_COMMAND_BUFFERS);

    Decoder d(s.bytes(), s.table, s.arena);
    Decoded_vkCmdBeginRenderPass out;
    ASSERT_TRUE(decode_vkCmdBeginRenderPass(d, out)) << d.error();
    EXPECT_EQ(out.commandBuffer, Session::server(cb));
    EXPECT_EQ(out.commandBuffer_id, 0x10u);
    EXPECT_EQ(out.contents, VK_SUBPASS_CONTENTS_SECONDARY_COMMAND_BUFFERS);
    const VkRenderPassBeginInfo &b = *out.pRenderPassBegin;
    EXPECT_EQ(b.renderPass, Session::server(rp));
    EXPECT_EQ(b.framebuffer, Session::server(fb));
    EXPECT_EQ(b.renderArea.offset.y, 20);
    EXPECT_EQ(b.renderArea.extent.width, 640u);
    ASSERT_EQ(b.clearValueCount, 3u);
    EXPECT_EQ(std::memcmp(b.pClearValues, clears, sizeof(clears)), 0);
    const auto *a = static_cast<const VkRenderPassAttachmentBeginInfo *>(b.pNext);
    ASSERT_NE(a, nullptr);
    ASSERT_EQ(a->attachmentCount, 2u);
    EXPECT_EQ(a->pAttachments[1], Session::server(views[1]));
    EXPECT_REENCODES(vkCmdBeginRenderPass,
                     encode_vkCmdBeginRenderPass(ee, o.commandBuffer, o.pRenderPassBegin, o.contents));
}

TEST(CodecRoundTrip, CmdPushConstants) {
    Session s;
    const VkCommandBuffer cb = s.client<VkCommandBuffer>(VK_OBJECT_TYPE_COMMAND_BUFFER, 0x10);
    const VkPipelineLayout layout = s.client<VkPipelineLayout>(VK_OBJECT_TYPE_PIPELINE_LAYOUT, 0x20);
    std::array<uint8_t, 128> values{};
    for (size_t i = 0; i < values.size(); ++i)
        values[i] = static_cast<uint8_t>(i * 7 + 1);
    encode_vkCmdPushConstants(s.enc, cb, layout, VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT,
                              16, 112, values.data() + 16);
    Decoder d(s.bytes(), s.table, s.arena);
    Decoded_vkCmdPushConstants out;
    ASSERT_TRUE(decode_vkCmdPushConstants(d, out)) << d.error();
    EXPECT_TRUE(d.at_end());
    EXPECT_EQ(out.layout, Session::server(layout));
    EXPECT_EQ(out.stageFlags, VkShaderStageFlags{VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT});
    EXPECT_EQ(out.offset, 16u);
    ASSERT_EQ(out.size, 112u);
    EXPECT_EQ(std::memcmp(out.pValues, values.data() + 16, 112), 0);
    EXPECT_REENCODES(
        vkCmdPushConstants,
        encode_vkCmdPushConstants(ee, o.commandBuffer, o.layout, o.stageFlags, o.offset, o.size, o.pValues));
}

TEST(CodecRoundTrip, CmdPipelineBarrierWithAllThreeArrays) {
    Session s;
    const VkCommandBuffer cb = s.client<VkCommandBuffer>(VK_OBJECT_TYPE_COMMAND_BUFFER, 0x10);
    const VkBuffer buffer = s.client<VkBuffer>(VK_OBJECT_TYPE_BUFFER, 0x20);
    const VkImage images[2] = {s.client<VkImage>(VK_OBJECT_TYPE_IMAGE, 0x30),
                               s.client<VkImage>(VK_OBJECT_TYPE_IMAGE, 0x31)};
    const VkMemoryBarrier memory[2] = {
        {VK_STRUCTURE_TYPE_MEMORY_BARRIER, nullptr, VK_ACCESS_HOST_WRITE_BIT, VK_ACCESS_TRANSFER_READ_BIT},
        {VK_STRUCTURE_TYPE_MEMORY_BARRIER, nullptr, VK_ACCESS_SHADER_WRITE_BIT, VK_ACCESS_UNIFORM_READ_BIT}};
    const VkBufferMemoryBarrier buffer_barrier{VK_STRUCTURE_TYPE_BUFFER_MEMORY_BARRIER,
                                               nullptr,
                                               VK_ACCESS_TRANSFER_WRITE_BIT,
                                               VK_ACCESS_VERTEX_ATTRIBUTE_READ_BIT,
                                               VK_QUEUE_FAMILY_IGNORED,
                                               VK_QUEUE_FAMILY_IGNORED,
                                               buffer,
                                               4096,
                                               VK_WHOLE_SIZE};
    VkImageMemoryBarrier image_barriers[2]{};
    for (int i = 0; i < 2; ++i) {
        image_barriers[i].sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER;
        image_barriers[i].srcAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
        image_barriers[i].dstAccessMask = VK_ACCESS_SHADER_READ_BIT;
        image_barriers[i].oldLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
        image_barriers[i].newLayout = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL;
        image_barriers[i].srcQueueFamilyIndex = 0;
        image_barriers[i].dstQueueFamilyIndex = 1;
        image_barriers[i].image = images[i];
        image_barriers[i].subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 1, 3, 0, VK_REMAINING_ARRAY_LAYERS};
    }
    encode_vkCmdPipelineBarrier(s.enc, cb, VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT,
                                VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT, VK_DEPENDENCY_BY_REGION_BIT, 2, memory,
                                1, &buffer_barrier, 2, image_barriers);
    Decoder d(s.bytes(), s.table, s.arena);
    Decoded_vkCmdPipelineBarrier out;
    ASSERT_TRUE(decode_vkCmdPipelineBarrier(d, out)) << d.error();
    EXPECT_EQ(out.dependencyFlags, VkDependencyFlags{VK_DEPENDENCY_BY_REGION_BIT});
    ASSERT_EQ(out.memoryBarrierCount, 2u);
    EXPECT_EQ(out.pMemoryBarriers[1].dstAccessMask, VkAccessFlags{VK_ACCESS_UNIFORM_READ_BIT});
    ASSERT_EQ(out.bufferMemoryBarrierCount, 1u);
    EXPECT_EQ(out.pBufferMemoryBarriers[0].buffer, Session::server(buffer));
    EXPECT_EQ(out.pBufferMemoryBarriers[0].offset, 4096u);
    EXPECT_EQ(out.pBufferMemoryBarriers[0].size, VK_WHOLE_SIZE);
    EXPECT_EQ(out.pBufferMemoryBarriers[0].srcQueueFamilyIndex, VK_QUEUE_FAMILY_IGNORED);
    ASSERT_EQ(out.imageMemoryBarrierCount, 2u);
    EXPECT_EQ(out.pImageMemoryBarriers[1].image, Session::server(images[1]));
    EXPECT_EQ(out.pImageMemoryBarriers[1].newLayout, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
    EXPECT_EQ(out.pImageMemoryBarriers[0].subresourceRange.levelCount, 3u);
    EXPECT_EQ(out.pImageMemoryBarriers[0].subresourceRange.layerCount, VK_REMAINING_ARRAY_LAYERS);
    EXPECT_EQ(out.pImageMemoryBarriers[0].dstQueueFamilyIndex, 1u);
    EXPECT_REENCODES(vkCmdPipelineBarrier,
                     encode_vkCmdPipelineBarrier(ee, o.commandBuffer, o.srcStageMask, o.dstStageMask,
                                                 o.dependencyFlags, o.memoryBarrierCount, o.pMemoryBarriers,
                                                 o.bufferMemoryBarrierCount, o.pBufferMemoryBarriers,
                                                 o.imageMemoryBarrierCount, o.pImageMemoryBarriers));
}

TEST(CodecRoundTrip, CmdCopyBufferToImage) {
    Session s;
    const VkCommandBuffer cb = s.client<VkCommandBuffer>(VK_OBJECT_TYPE_COMMAND_BUFFER, 0x10);
    const VkBuffer buffer = s.client<VkBuffer>(VK_OBJECT_TYPE_BUFFER, 0x20);
    const VkImage image = s.client<VkImage>(VK_OBJECT_TYPE_IMAGE, 0x30);
    VkBufferImageCopy regions[3]{};
    for (uint32_t i = 0; i < 3; ++i) {
        regions[i].bufferOffset = 0x10000ull * i + (1ull << 33);
        regions[i].bufferRowLength = 256 >> i;
        regions[i].bufferImageHeight = 0;
        regions[i].imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, i, 0, 6};
        regions[i].imageOffset = {static_cast<int32_t>(i), -static_cast<int32_t>(i), 0};
        regions[i].imageExtent = {256u >> i, 256u >> i, 1};
    }
    encode_vkCmdCopyBufferToImage(s.enc, cb, buffer, image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 3, regions);
    Decoder d(s.bytes(), s.table, s.arena);
    Decoded_vkCmdCopyBufferToImage out;
    ASSERT_TRUE(decode_vkCmdCopyBufferToImage(d, out)) << d.error();
    EXPECT_EQ(out.srcBuffer, Session::server(buffer));
    EXPECT_EQ(out.dstImage, Session::server(image));
    EXPECT_EQ(out.dstImageLayout, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL);
    ASSERT_EQ(out.regionCount, 3u);
    EXPECT_EQ(out.pRegions[2].bufferOffset, 0x20000ull + (1ull << 33));
    EXPECT_EQ(out.pRegions[2].imageSubresource.mipLevel, 2u);
    EXPECT_EQ(out.pRegions[2].imageSubresource.layerCount, 6u);
    EXPECT_EQ(out.pRegions[2].imageOffset.y, -2);
    EXPECT_EQ(out.pRegions[1].imageExtent.width, 128u);
    EXPECT_REENCODES(vkCmdCopyBufferToImage,
                     encode_vkCmdCopyBufferToImage(ee, o.commandBuffer, o.srcBuffer, o.dstImage,
                                                   o.dstImageLayout, o.regionCount, o.pRegions));
}

// An OpenXR runtime's eye image (docs/architecture.md §9): its memory is imported from the runtime's process
// with an fd. The agent allocates ordinary memory in its place, so the import, the export and the external
// image info never cross the wire; the dedicated allocation does.
TEST(CodecRoundTrip, ExternalMemoryStructuresStayOnTheClient) {
    Session s;
    const VkDevice device = s.client<VkDevice>(VK_OBJECT_TYPE_DEVICE, 0x1);
    const VkImage image = s.client<VkImage>(VK_OBJECT_TYPE_IMAGE, 0x30);
    VkImportMemoryFdInfoKHR import{VK_STRUCTURE_TYPE_IMPORT_MEMORY_FD_INFO_KHR, nullptr,
                                   VK_EXTERNAL_MEMORY_HANDLE_TYPE_OPAQUE_FD_BIT, 42};
    VkMemoryDedicatedAllocateInfo dedicated{VK_STRUCTURE_TYPE_MEMORY_DEDICATED_ALLOCATE_INFO, &import, image,
                                            VK_NULL_HANDLE};
    VkExportMemoryAllocateInfo exported{VK_STRUCTURE_TYPE_EXPORT_MEMORY_ALLOCATE_INFO, &dedicated,
                                        VK_EXTERNAL_MEMORY_HANDLE_TYPE_OPAQUE_FD_BIT};
    VkMemoryAllocateInfo info{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO, &exported, 1 << 20, 0};
    VkDeviceMemory memory = to_handle<VkDeviceMemory>(0x40);
    encode_vkAllocateMemory(s.enc, device, &info, nullptr, &memory);
    Decoder d(s.bytes(), s.table, s.arena);
    Decoded_vkAllocateMemory out;
    ASSERT_TRUE(decode_vkAllocateMemory(d, out)) << d.error();
    const auto *chain = static_cast<const VkBaseInStructure *>(out.pAllocateInfo->pNext);
    ASSERT_NE(chain, nullptr);
    EXPECT_EQ(chain->sType, VK_STRUCTURE_TYPE_MEMORY_DEDICATED_ALLOCATE_INFO);
    EXPECT_EQ(reinterpret_cast<const VkMemoryDedicatedAllocateInfo *>(chain)->image, Session::server(image));
    EXPECT_EQ(chain->pNext, nullptr);

    VkExternalMemoryImageCreateInfo external{VK_STRUCTURE_TYPE_EXTERNAL_MEMORY_IMAGE_CREATE_INFO, nullptr,
                                             VK_EXTERNAL_MEMORY_HANDLE_TYPE_OPAQUE_FD_BIT};
    VkImageCreateInfo image_info{};
    image_info.sType = VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO;
    image_info.pNext = &external;
    image_info.imageType = VK_IMAGE_TYPE_2D;
    image_info.format = VK_FORMAT_R8G8B8A8_SRGB;
    image_info.extent = {320, 240, 1};
    image_info.mipLevels = 1;
    image_info.arrayLayers = 1;
    image_info.samples = VK_SAMPLE_COUNT_1_BIT;
    image_info.usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT;
    VkImage created = to_handle<VkImage>(0x50);
    Session images;
    const VkDevice image_device = images.client<VkDevice>(VK_OBJECT_TYPE_DEVICE, 0x1);
    encode_vkCreateImage(images.enc, image_device, &image_info, nullptr, &created);
    Decoder di(images.bytes(), images.table, images.arena);
    Decoded_vkCreateImage image_out;
    ASSERT_TRUE(decode_vkCreateImage(di, image_out)) << di.error();
    EXPECT_EQ(image_out.pCreateInfo->pNext, nullptr);
    EXPECT_EQ(image_out.pCreateInfo->extent.width, 320u);
}

// ---------------------------------------------------------------------------------------------

TEST(CodecRoundTrip, AllocateCommandBuffersRegistersIdsUnderTheirPool) {
    Session s;
    const VkDevice device = s.client<VkDevice>(VK_OBJECT_TYPE_DEVICE, 0x10);
    const VkCommandPool pool = s.client<VkCommandPool>(VK_OBJECT_TYPE_COMMAND_POOL, 0x20);
    const VkCommandBufferAllocateInfo info{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO, nullptr, pool,
                                           VK_COMMAND_BUFFER_LEVEL_SECONDARY, 3};
    VkCommandBuffer created[3] = {to_handle<VkCommandBuffer>(0x1000), to_handle<VkCommandBuffer>(0x1008),
                                  to_handle<VkCommandBuffer>(0x1010)};
    encode_vkAllocateCommandBuffers(s.enc, device, &info, created);

    Decoder d(s.bytes(), s.table, s.arena);
    Decoded_vkAllocateCommandBuffers out;
    ASSERT_TRUE(decode_vkAllocateCommandBuffers(d, out)) << d.error();
    EXPECT_EQ(out.pAllocateInfo->commandPool, Session::server(pool));
    EXPECT_EQ(out.pAllocateInfo->level, VK_COMMAND_BUFFER_LEVEL_SECONDARY);
    ASSERT_EQ(out.pCommandBuffers_count, 3u);
    EXPECT_EQ(out.pCommandBuffers_ids[0], 0x1000u);
    EXPECT_EQ(out.pCommandBuffers_ids[2], 0x1010u);
    EXPECT_EQ(out.parent_id, 0x20u);
    // The agent's driver fills the storage; then the ids are registered under the pool.
    for (uint32_t i = 0; i < 3; ++i)
        out.pCommandBuffers[i] = to_handle<VkCommandBuffer>(0xC000 + 8 * i);
    std::string error;
    ASSERT_TRUE(apply_handle_changes(s.table, out, &error)) << error;
    ASSERT_NE(s.table.find(0x1008), nullptr);
    EXPECT_EQ(s.table.find(0x1008)->handle, 0xC008u);
    EXPECT_EQ(s.table.find(0x1008)->type, VK_OBJECT_TYPE_COMMAND_BUFFER);
    EXPECT_EQ(s.table.find(0x1008)->parent, 0x20u);
    // Registering the same ids again with other handles is refused.
    out.pCommandBuffers[0] = to_handle<VkCommandBuffer>(0xD000);
    EXPECT_FALSE(apply_handle_changes(s.table, out, &error));
    EXPECT_NE(error.find("still names a live VkCommandBuffer"), std::string::npos) << error;

    // Free one (and a VK_NULL_HANDLE, which is ignored), then destroy the pool: all are gone.
    const VkCommandBuffer to_free[2] = {created[1], VK_NULL_HANDLE};
    Encoder e2;
    encode_vkFreeCommandBuffers(e2, device, pool, 2, to_free);
    encode_vkDestroyCommandPool(e2, device, pool, nullptr);
    Arena arena;
    Decoder d2(e2.data(), s.table, arena);
    Decoded_vkFreeCommandBuffers freed;
    ASSERT_TRUE(decode_vkFreeCommandBuffers(d2, freed)) << d2.error();
    EXPECT_EQ(freed.pCommandBuffers[0], to_handle<VkCommandBuffer>(0xC008));
    EXPECT_EQ(freed.pCommandBuffers[1], VK_NULL_HANDLE);
    ASSERT_TRUE(apply_handle_changes(s.table, freed));
    EXPECT_EQ(s.table.find(0x1008), nullptr);
    EXPECT_NE(s.table.find(0x1000), nullptr);
    Decoded_vkDestroyCommandPool destroyed;
    ASSERT_TRUE(decode_vkDestroyCommandPool(d2, destroyed)) << d2.error();
    ASSERT_TRUE(apply_handle_changes(s.table, destroyed));
    EXPECT_EQ(s.table.find(0x20), nullptr);
    EXPECT_EQ(s.table.find(0x1000), nullptr);
    EXPECT_EQ(s.table.find(0x1010), nullptr);
    EXPECT_NE(s.table.find(0x10), nullptr); // the device stays
}

TEST(CodecRoundTrip, ResetDescriptorPoolForgetsItsSets) {
    Session s;
    const VkDevice device = s.client<VkDevice>(VK_OBJECT_TYPE_DEVICE, 0x10);
    const VkDescriptorPool pool = s.client<VkDescriptorPool>(VK_OBJECT_TYPE_DESCRIPTOR_POOL, 0x20);
    const VkDescriptorSetLayout layouts[2] = {
        s.client<VkDescriptorSetLayout>(VK_OBJECT_TYPE_DESCRIPTOR_SET_LAYOUT, 0x30),
        s.client<VkDescriptorSetLayout>(VK_OBJECT_TYPE_DESCRIPTOR_SET_LAYOUT, 0x31)};
    const VkDescriptorSetAllocateInfo info{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO, nullptr, pool, 2,
                                           layouts};
    VkDescriptorSet sets[2] = {to_handle<VkDescriptorSet>(0x100), to_handle<VkDescriptorSet>(0x101)};
    encode_vkAllocateDescriptorSets(s.enc, device, &info, sets);
    encode_vkResetDescriptorPool(s.enc, device, pool, 0);
    Decoder d(s.bytes(), s.table, s.arena);
    Decoded_vkAllocateDescriptorSets allocated;
    ASSERT_TRUE(decode_vkAllocateDescriptorSets(d, allocated)) << d.error();
    EXPECT_EQ(allocated.parent_id, 0x20u); // the pool, not the last layout
    EXPECT_EQ(allocated.pAllocateInfo->pSetLayouts[1], Session::server(layouts[1]));
    for (uint32_t i = 0; i < 2; ++i)
        allocated.pDescriptorSets[i] = to_handle<VkDescriptorSet>(0xE000 + i);
    ASSERT_TRUE(apply_handle_changes(s.table, allocated));
    EXPECT_NE(s.table.find(0x101), nullptr);
    Decoded_vkResetDescriptorPool reset;
    ASSERT_TRUE(decode_vkResetDescriptorPool(d, reset)) << d.error();
    ASSERT_TRUE(apply_handle_changes(s.table, reset));
    EXPECT_EQ(s.table.find(0x100), nullptr);
    EXPECT_EQ(s.table.find(0x101), nullptr);
    EXPECT_NE(s.table.find(0x20), nullptr); // the pool stays
}

TEST(CodecRoundTrip, BeginCommandBufferInheritanceOnlyForSecondaries) {
    Session s;
    const VkCommandBuffer primary = s.client<VkCommandBuffer>(VK_OBJECT_TYPE_COMMAND_BUFFER, 0x10);
    const VkCommandBuffer secondary = s.client<VkCommandBuffer>(VK_OBJECT_TYPE_COMMAND_BUFFER, 0x11);
    const VkRenderPass rp = s.client<VkRenderPass>(VK_OBJECT_TYPE_RENDER_PASS, 0x20);

    // A primary: pInheritanceInfo is ignored (an invalid pointer here).
    const VkCommandBufferBeginInfo primary_begin{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO, nullptr,
                                                 VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT,
                                                 invalid_pointer<VkCommandBufferInheritanceInfo>()};
    encode_vkBeginCommandBuffer(s.enc, primary, &primary_begin, VK_COMMAND_BUFFER_LEVEL_PRIMARY);
    // A secondary continuing a render pass.
    const VkCommandBufferInheritanceInfo inside{VK_STRUCTURE_TYPE_COMMAND_BUFFER_INHERITANCE_INFO,
                                                nullptr,
                                                rp,
                                                1,
                                                VK_NULL_HANDLE,
                                                VK_TRUE,
                                                VK_QUERY_CONTROL_PRECISE_BIT,
                                                0};
    const VkCommandBufferBeginInfo continue_begin{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO, nullptr,
                                                  VK_COMMAND_BUFFER_USAGE_RENDER_PASS_CONTINUE_BIT, &inside};
    encode_vkBeginCommandBuffer(s.enc, secondary, &continue_begin, VK_COMMAND_BUFFER_LEVEL_SECONDARY);
    // A secondary outside a render pass: renderPass/framebuffer and the rendering info are ignored.
    const VkCommandBufferInheritanceRenderingInfo rendering{
        VK_STRUCTURE_TYPE_COMMAND_BUFFER_INHERITANCE_RENDERING_INFO,
        nullptr,
        0,
        0,
        2,
        invalid_pointer<VkFormat>(),
        VK_FORMAT_UNDEFINED,
        VK_FORMAT_UNDEFINED,
        VK_SAMPLE_COUNT_1_BIT};
    const VkCommandBufferInheritanceInfo outside{VK_STRUCTURE_TYPE_COMMAND_BUFFER_INHERITANCE_INFO,
                                                 &rendering,
                                                 garbage_handle<VkRenderPass>(),
                                                 0,
                                                 garbage_handle<VkFramebuffer>(),
                                                 VK_FALSE,
                                                 0,
                                                 0};
    const VkCommandBufferBeginInfo outside_begin{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO, nullptr, 0,
                                                 &outside};
    encode_vkBeginCommandBuffer(s.enc, secondary, &outside_begin, VK_COMMAND_BUFFER_LEVEL_SECONDARY);

    Decoder d(s.bytes(), s.table, s.arena);
    Decoded_vkBeginCommandBuffer a, b, c;
    ASSERT_TRUE(decode_vkBeginCommandBuffer(d, a)) << d.error();
    ASSERT_TRUE(decode_vkBeginCommandBuffer(d, b)) << d.error();
    ASSERT_TRUE(decode_vkBeginCommandBuffer(d, c)) << d.error();
    EXPECT_TRUE(d.at_end());
    EXPECT_EQ(a.pBeginInfo->pInheritanceInfo, nullptr);
    EXPECT_EQ(a.pBeginInfo->flags, VkCommandBufferUsageFlags{VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT});
    ASSERT_NE(b.pBeginInfo->pInheritanceInfo, nullptr);
    EXPECT_EQ(b.pBeginInfo->pInheritanceInfo->renderPass, Session::server(rp));
    EXPECT_EQ(b.pBeginInfo->pInheritanceInfo->subpass, 1u);
    EXPECT_EQ(b.pBeginInfo->pInheritanceInfo->occlusionQueryEnable, VK_TRUE);
    ASSERT_NE(c.pBeginInfo->pInheritanceInfo, nullptr);
    EXPECT_EQ(c.pBeginInfo->pInheritanceInfo->renderPass, VK_NULL_HANDLE);
    EXPECT_EQ(c.pBeginInfo->pInheritanceInfo->framebuffer, VK_NULL_HANDLE);
    const auto *r =
        static_cast<const VkCommandBufferInheritanceRenderingInfo *>(c.pBeginInfo->pInheritanceInfo->pNext);
    ASSERT_NE(r, nullptr);
    EXPECT_EQ(r->colorAttachmentCount, 2u);
    EXPECT_EQ(r->pColorAttachmentFormats, nullptr);
}

// ---------------------------------------------------------------------------------------------

// Several commands in one stream (a command buffer's), decoded through the visitor.
TEST(CodecRoundTrip, DispatchDecodedCallsTheVisitor) {
    Session s;
    const VkCommandBuffer cb = s.client<VkCommandBuffer>(VK_OBJECT_TYPE_COMMAND_BUFFER, 0x10);
    const VkPipeline pipeline = s.client<VkPipeline>(VK_OBJECT_TYPE_PIPELINE, 0x20);
    const VkBuffer vb = s.client<VkBuffer>(VK_OBJECT_TYPE_BUFFER, 0x30);
    const VkBuffer buffers[2] = {vb, VK_NULL_HANDLE};
    const VkDeviceSize offsets[2] = {0, 64};
    const float constants[4] = {1, 2, 3, 4};
    encode_vkCmdBindPipeline(s.enc, cb, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline);
    encode_vkCmdBindVertexBuffers(s.enc, cb, 0, 2, buffers, offsets);
    encode_vkCmdSetBlendConstants(s.enc, cb, constants);
    encode_vkCmdDraw(s.enc, cb, 36, 2, 0, 1);
    encode_vkEndCommandBuffer(s.enc, cb);

    struct Recorder : CommandVisitor {
        std::vector<std::string> calls;
        bool vkCmdBindPipeline(const Decoded_vkCmdBindPipeline &c) override {
            calls.push_back("bind " + std::to_string(handle_value(c.pipeline)));
            return true;
        }
        bool vkCmdBindVertexBuffers(const Decoded_vkCmdBindVertexBuffers &c) override {
            calls.push_back("vb " + std::to_string(handle_value(c.pBuffers[0])) + " " +
                            std::to_string(handle_value(c.pBuffers[1])) + " " +
                            std::to_string(c.pOffsets[1]) + " " + std::to_string(c.pBuffers_ids[0]));
            return true;
        }
        bool vkCmdSetBlendConstants(const Decoded_vkCmdSetBlendConstants &c) override {
            calls.push_back("blend " + std::to_string(c.blendConstants[3]));
            return true;
        }
        bool vkCmdDraw(const Decoded_vkCmdDraw &c) override {
            calls.push_back("draw " + std::to_string(c.vertexCount) + " " + std::to_string(c.firstInstance));
            return true;
        }
    } recorder;
    Decoder d(s.bytes(), s.table, s.arena);
    for (int i = 0; i < 4; ++i)
        ASSERT_TRUE(dispatch_decoded(d, recorder)) << d.error();
    // vkEndCommandBuffer is not overridden: the default refuses it, and decoding stays ok.
    EXPECT_FALSE(dispatch_decoded(d, recorder));
    EXPECT_TRUE(d.ok());
    EXPECT_TRUE(d.at_end());
    ASSERT_EQ(recorder.calls.size(), 4u);
    EXPECT_EQ(recorder.calls[0], "bind " + std::to_string(Session::server_of(0x20)));
    EXPECT_EQ(recorder.calls[1], "vb " + std::to_string(Session::server_of(0x30)) + " 0 64 48");
    EXPECT_EQ(recorder.calls[2], "blend 4.000000");
    EXPECT_EQ(recorder.calls[3], "draw 36 1");
}

TEST(CodecRoundTrip, CommandIdsNamesAndFingerprint) {
    EXPECT_EQ(static_cast<uint16_t>(VkCommandId::vkAcquireNextImage2KHR), kFirstCommandId);
    EXPECT_EQ(kLastCommandId - kFirstCommandId + 1, static_cast<int>(kCommandCount));
    EXPECT_LE(kLastCommandId, 0x0FFF); // inside MessageType's Vulkan range
    EXPECT_STREQ(command_name(VkCommandId::vkCmdDraw), "vkCmdDraw");
    EXPECT_STREQ(command_name(static_cast<VkCommandId>(0x0FFF)), "unknown");
    EXPECT_TRUE(is_command_id(static_cast<uint16_t>(VkCommandId::vkCreateBuffer)));
    EXPECT_FALSE(is_command_id(kLastCommandId + 1));
    EXPECT_FALSE(is_command_id(0));
    EXPECT_EQ(command_policy(VkCommandId::vkCmdDraw), CommandPolicy::Forward);
    EXPECT_EQ(command_policy(VkCommandId::vkQueueSubmit), CommandPolicy::Manual);
    EXPECT_EQ(command_policy(VkCommandId::vkCreateSwapchainKHR), CommandPolicy::Manual);
    EXPECT_TRUE(changes_handles(VkCommandId::vkCreateBuffer));
    EXPECT_TRUE(changes_handles(VkCommandId::vkDestroyBuffer));
    EXPECT_FALSE(changes_handles(VkCommandId::vkCmdDraw));
    EXPECT_NE(kCodecFingerprint, 0u);
    EXPECT_STREQ(object_type_name(VK_OBJECT_TYPE_BUFFER), "VkBuffer");
    EXPECT_STREQ(object_type_name(VK_OBJECT_TYPE_COMMAND_BUFFER), "VkCommandBuffer");
}

// Manual commands still have generated codecs: a submit, with its semaphores and command buffers.
TEST(CodecRoundTrip, QueueSubmitCodecIsGenerated) {
    Session s;
    const VkQueue queue = s.client<VkQueue>(VK_OBJECT_TYPE_QUEUE, 0x10);
    const VkSemaphore sems[2] = {s.client<VkSemaphore>(VK_OBJECT_TYPE_SEMAPHORE, 0x20),
                                 s.client<VkSemaphore>(VK_OBJECT_TYPE_SEMAPHORE, 0x21)};
    const VkCommandBuffer cb = s.client<VkCommandBuffer>(VK_OBJECT_TYPE_COMMAND_BUFFER, 0x30);
    const VkFence fence = s.client<VkFence>(VK_OBJECT_TYPE_FENCE, 0x40);
    const VkPipelineStageFlags stages[1] = {VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT};
    const uint64_t values[1] = {0};
    const uint64_t signal_values[1] = {42};
    const VkTimelineSemaphoreSubmitInfo timeline{
        VK_STRUCTURE_TYPE_TIMELINE_SEMAPHORE_SUBMIT_INFO, nullptr, 1, values, 1, signal_values};
    const VkSubmitInfo submit{
        VK_STRUCTURE_TYPE_SUBMIT_INFO, &timeline, 1, &sems[0], stages, 1, &cb, 1, &sems[1]};
    encode_vkQueueSubmit(s.enc, queue, 1, &submit, fence);
    Decoder d(s.bytes(), s.table, s.arena);
    Decoded_vkQueueSubmit out;
    ASSERT_TRUE(decode_vkQueueSubmit(d, out)) << d.error();
    EXPECT_EQ(out.queue, Session::server(queue));
    EXPECT_EQ(out.fence, Session::server(fence));
    EXPECT_EQ(out.pSubmits[0].pWaitSemaphores[0], Session::server(sems[0]));
    EXPECT_EQ(out.pSubmits[0].pCommandBuffers[0], Session::server(cb));
    EXPECT_EQ(out.pSubmits[0].pWaitDstStageMask[0],
              VkPipelineStageFlags{VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT});
    const auto *t = static_cast<const VkTimelineSemaphoreSubmitInfo *>(out.pSubmits[0].pNext);
    ASSERT_NE(t, nullptr);
    EXPECT_EQ(t->pSignalSemaphoreValues[0], 42u);
}

// ---------------------------------------------------------------------------------------------
// The extensions engines enable: conditional rendering, transform feedback and
// VK_EXT_extended_dynamic_state3, with the pointers the specification lets an application leave
// NULL (or, for the counter buffers, hold VK_NULL_HANDLE elements).

TEST(CodecRoundTrip, ConditionalRenderingAndTransformFeedback) {
    Session s;
    const VkCommandBuffer cb = s.client<VkCommandBuffer>(VK_OBJECT_TYPE_COMMAND_BUFFER, 0x10);
    const VkBuffer predicate = s.client<VkBuffer>(VK_OBJECT_TYPE_BUFFER, 0x20);
    const VkBuffer captures[2] = {s.client<VkBuffer>(VK_OBJECT_TYPE_BUFFER, 0x21),
                                  s.client<VkBuffer>(VK_OBJECT_TYPE_BUFFER, 0x22)};
    const VkBuffer counter = s.client<VkBuffer>(VK_OBJECT_TYPE_BUFFER, 0x23);
    const VkQueryPool pool = s.client<VkQueryPool>(VK_OBJECT_TYPE_QUERY_POOL, 0x30);

    const VkConditionalRenderingBeginInfoEXT begin{VK_STRUCTURE_TYPE_CONDITIONAL_RENDERING_BEGIN_INFO_EXT,
                                                   nullptr, predicate, 256,
                                                   VK_CONDITIONAL_RENDERING_INVERTED_BIT_EXT};
    encode_vkCmdBeginConditionalRenderingEXT(s.enc, cb, &begin);
    const VkDeviceSize offsets[2] = {0, 4096};
    encode_vkCmdBindTransformFeedbackBuffersEXT(s.enc, cb, 1, 2, captures, offsets, nullptr);
    // The first binding starts at byte 0 (no counter buffer), the second resumes from `counter`.
    const VkBuffer begin_counters[2] = {VK_NULL_HANDLE, counter};
    const VkDeviceSize counter_offsets[2] = {0, 16};
    encode_vkCmdBeginTransformFeedbackEXT(s.enc, cb, 1, 2, begin_counters, counter_offsets);
    encode_vkCmdBeginQueryIndexedEXT(s.enc, cb, pool, 3, VK_QUERY_CONTROL_PRECISE_BIT, 1);
    encode_vkCmdEndQueryIndexedEXT(s.enc, cb, pool, 3, 1);
    encode_vkCmdEndTransformFeedbackEXT(s.enc, cb, 0, 2, nullptr, nullptr);
    encode_vkCmdDrawIndirectByteCountEXT(s.enc, cb, 2, 5, counter, 16, 0, 24);
    encode_vkCmdEndConditionalRenderingEXT(s.enc, cb);

    Decoder d(s.bytes(), s.table, s.arena);
    Decoded_vkCmdBeginConditionalRenderingEXT begin_out;
    ASSERT_TRUE(decode_vkCmdBeginConditionalRenderingEXT(d, begin_out)) << d.error();
    ASSERT_NE(begin_out.pConditionalRenderingBegin, nullptr);
    EXPECT_EQ(begin_out.pConditionalRenderingBegin->buffer, Session::server(predicate));
    EXPECT_EQ(begin_out.pConditionalRenderingBegin->offset, 256u);
    EXPECT_EQ(begin_out.pConditionalRenderingBegin->flags,
              VkConditionalRenderingFlagsEXT{VK_CONDITIONAL_RENDERING_INVERTED_BIT_EXT});
    Decoded_vkCmdBindTransformFeedbackBuffersEXT bind;
    ASSERT_TRUE(decode_vkCmdBindTransformFeedbackBuffersEXT(d, bind)) << d.error();
    EXPECT_EQ(bind.firstBinding, 1u);
    ASSERT_EQ(bind.bindingCount, 2u);
    EXPECT_EQ(bind.pBuffers[1], Session::server(captures[1]));
    EXPECT_EQ(bind.pOffsets[1], 4096u);
    EXPECT_EQ(bind.pSizes, nullptr);
    Decoded_vkCmdBeginTransformFeedbackEXT begin_xfb;
    ASSERT_TRUE(decode_vkCmdBeginTransformFeedbackEXT(d, begin_xfb)) << d.error();
    ASSERT_EQ(begin_xfb.counterBufferCount, 2u);
    EXPECT_EQ(begin_xfb.pCounterBuffers[0], VK_NULL_HANDLE);
    EXPECT_EQ(begin_xfb.pCounterBuffers[1], Session::server(counter));
    EXPECT_EQ(begin_xfb.pCounterBufferOffsets[1], 16u);
    Decoded_vkCmdBeginQueryIndexedEXT begin_query;
    ASSERT_TRUE(decode_vkCmdBeginQueryIndexedEXT(d, begin_query)) << d.error();
    EXPECT_EQ(begin_query.queryPool, Session::server(pool));
    EXPECT_EQ(begin_query.query, 3u);
    EXPECT_EQ(begin_query.index, 1u);
    Decoded_vkCmdEndQueryIndexedEXT end_query;
    ASSERT_TRUE(decode_vkCmdEndQueryIndexedEXT(d, end_query)) << d.error();
    EXPECT_EQ(end_query.index, 1u);
    Decoded_vkCmdEndTransformFeedbackEXT end_xfb;
    ASSERT_TRUE(decode_vkCmdEndTransformFeedbackEXT(d, end_xfb)) << d.error();
    EXPECT_EQ(end_xfb.counterBufferCount, 2u);
    EXPECT_EQ(end_xfb.pCounterBuffers, nullptr);
    EXPECT_EQ(end_xfb.pCounterBufferOffsets, nullptr);
    Decoded_vkCmdDrawIndirectByteCountEXT draw;
    ASSERT_TRUE(decode_vkCmdDrawIndirectByteCountEXT(d, draw)) << d.error();
    EXPECT_EQ(draw.instanceCount, 2u);
    EXPECT_EQ(draw.firstInstance, 5u);
    EXPECT_EQ(draw.counterBuffer, Session::server(counter));
    EXPECT_EQ(draw.counterBufferOffset, 16u);
    EXPECT_EQ(draw.vertexStride, 24u);
    Decoded_vkCmdEndConditionalRenderingEXT end_out;
    ASSERT_TRUE(decode_vkCmdEndConditionalRenderingEXT(d, end_out)) << d.error();
    EXPECT_TRUE(d.at_end());
}

TEST(CodecRoundTrip, ExtendedDynamicState3AndVertexInput) {
    Session s;
    const VkCommandBuffer cb = s.client<VkCommandBuffer>(VK_OBJECT_TYPE_COMMAND_BUFFER, 0x10);
    // 64 samples take two mask words: vk.xml's altlen, (samples + 31) / 32.
    const VkSampleMask mask[2] = {0xF0F0F0F0u, 0x0000FFFFu};
    encode_vkCmdSetSampleMaskEXT(s.enc, cb, VK_SAMPLE_COUNT_64_BIT, mask);
    encode_vkCmdSetPolygonModeEXT(s.enc, cb, VK_POLYGON_MODE_LINE);
    encode_vkCmdSetDepthClipNegativeOneToOneEXT(s.enc, cb, VK_TRUE);
    const VkColorBlendEquationEXT equations[2] = {
        {VK_BLEND_FACTOR_SRC_ALPHA, VK_BLEND_FACTOR_ONE_MINUS_SRC_ALPHA, VK_BLEND_OP_ADD, VK_BLEND_FACTOR_ONE,
         VK_BLEND_FACTOR_ZERO, VK_BLEND_OP_ADD},
        {VK_BLEND_FACTOR_ONE, VK_BLEND_FACTOR_ONE, VK_BLEND_OP_MAX, VK_BLEND_FACTOR_ONE, VK_BLEND_FACTOR_ONE,
         VK_BLEND_OP_MIN}};
    encode_vkCmdSetColorBlendEquationEXT(s.enc, cb, 1, 2, equations);
    const VkBool32 writes[3] = {VK_TRUE, VK_FALSE, VK_TRUE};
    encode_vkCmdSetColorWriteEnableEXT(s.enc, cb, 3, writes);
    const VkVertexInputBindingDescription2EXT binding{
        VK_STRUCTURE_TYPE_VERTEX_INPUT_BINDING_DESCRIPTION_2_EXT,
        nullptr,
        2,
        20,
        VK_VERTEX_INPUT_RATE_INSTANCE,
        3};
    const VkVertexInputAttributeDescription2EXT attributes[2] = {
        {VK_STRUCTURE_TYPE_VERTEX_INPUT_ATTRIBUTE_DESCRIPTION_2_EXT, nullptr, 0, 2,
         VK_FORMAT_R32G32B32_SFLOAT, 0},
        {VK_STRUCTURE_TYPE_VERTEX_INPUT_ATTRIBUTE_DESCRIPTION_2_EXT, nullptr, 1, 2, VK_FORMAT_R8G8B8A8_UNORM,
         12}};
    encode_vkCmdSetVertexInputEXT(s.enc, cb, 1, &binding, 2, attributes);

    Decoder d(s.bytes(), s.table, s.arena);
    Decoded_vkCmdSetSampleMaskEXT sample_mask;
    ASSERT_TRUE(decode_vkCmdSetSampleMaskEXT(d, sample_mask)) << d.error();
    EXPECT_EQ(sample_mask.samples, VK_SAMPLE_COUNT_64_BIT);
    ASSERT_NE(sample_mask.pSampleMask, nullptr);
    EXPECT_EQ(sample_mask.pSampleMask[0], mask[0]);
    EXPECT_EQ(sample_mask.pSampleMask[1], mask[1]);
    Decoded_vkCmdSetPolygonModeEXT polygon;
    ASSERT_TRUE(decode_vkCmdSetPolygonModeEXT(d, polygon)) << d.error();
    EXPECT_EQ(polygon.polygonMode, VK_POLYGON_MODE_LINE);
    Decoded_vkCmdSetDepthClipNegativeOneToOneEXT clip;
    ASSERT_TRUE(decode_vkCmdSetDepthClipNegativeOneToOneEXT(d, clip)) << d.error();
    EXPECT_EQ(clip.negativeOneToOne, VK_TRUE);
    Decoded_vkCmdSetColorBlendEquationEXT blend;
    ASSERT_TRUE(decode_vkCmdSetColorBlendEquationEXT(d, blend)) << d.error();
    EXPECT_EQ(blend.firstAttachment, 1u);
    ASSERT_EQ(blend.attachmentCount, 2u);
    EXPECT_EQ(blend.pColorBlendEquations[1].alphaBlendOp, VK_BLEND_OP_MIN);
    EXPECT_EQ(blend.pColorBlendEquations[0].dstColorBlendFactor, VK_BLEND_FACTOR_ONE_MINUS_SRC_ALPHA);
    Decoded_vkCmdSetColorWriteEnableEXT write_enable;
    ASSERT_TRUE(decode_vkCmdSetColorWriteEnableEXT(d, write_enable)) << d.error();
    ASSERT_EQ(write_enable.attachmentCount, 3u);
    EXPECT_EQ(write_enable.pColorWriteEnables[1], VK_FALSE);
    EXPECT_EQ(write_enable.pColorWriteEnables[2], VK_TRUE);
    Decoded_vkCmdSetVertexInputEXT vertex_input;
    ASSERT_TRUE(decode_vkCmdSetVertexInputEXT(d, vertex_input)) << d.error();
    ASSERT_EQ(vertex_input.vertexBindingDescriptionCount, 1u);
    EXPECT_EQ(vertex_input.pVertexBindingDescriptions[0].divisor, 3u);
    EXPECT_EQ(vertex_input.pVertexBindingDescriptions[0].stride, 20u);
    ASSERT_EQ(vertex_input.vertexAttributeDescriptionCount, 2u);
    EXPECT_EQ(vertex_input.pVertexAttributeDescriptions[1].format, VK_FORMAT_R8G8B8A8_UNORM);
    EXPECT_EQ(vertex_input.pVertexAttributeDescriptions[1].offset, 12u);
    EXPECT_TRUE(d.at_end());
}

// With the vertex input dynamic, pVertexInputState is ignored; with blend enable, equation and
// write mask all dynamic (EDS3), the colour blend state's pAttachments are: neither is read. The
// pipeline's extension structures (rasterization stream, provoking vertex, depth clip control,
// colour write enables) cross the wire.
TEST(CodecRoundTrip, GraphicsPipelineWithEngineExtensionState) {
    Session s;
    const PipelineObjects objs(s);
    VkPipelineShaderStageCreateInfo stage{};
    stage.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
    stage.stage = VK_SHADER_STAGE_VERTEX_BIT;
    stage.module = objs.vs;
    stage.pName = "main";
    const VkDynamicState dynamic_states[5] = {
        VK_DYNAMIC_STATE_VERTEX_INPUT_EXT, VK_DYNAMIC_STATE_COLOR_BLEND_ENABLE_EXT,
        VK_DYNAMIC_STATE_COLOR_BLEND_EQUATION_EXT, VK_DYNAMIC_STATE_COLOR_WRITE_MASK_EXT,
        VK_DYNAMIC_STATE_POLYGON_MODE_EXT};
    const VkPipelineDynamicStateCreateInfo dynamic{VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO,
                                                   nullptr, 0, 5, dynamic_states};
    VkPipelineRasterizationProvokingVertexStateCreateInfoEXT provoking{};
    provoking.sType = VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_PROVOKING_VERTEX_STATE_CREATE_INFO_EXT;
    provoking.provokingVertexMode = VK_PROVOKING_VERTEX_MODE_LAST_VERTEX_EXT;
    VkPipelineRasterizationStateStreamCreateInfoEXT stream{};
    stream.sType = VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_STREAM_CREATE_INFO_EXT;
    stream.pNext = &provoking;
    stream.rasterizationStream = 1;
    VkPipelineRasterizationStateCreateInfo raster{};
    raster.sType = VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO;
    raster.pNext = &stream;
    raster.lineWidth = 1.0f;
    VkPipelineViewportDepthClipControlCreateInfoEXT clip_control{};
    clip_control.sType = VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_DEPTH_CLIP_CONTROL_CREATE_INFO_EXT;
    clip_control.negativeOneToOne = VK_TRUE;
    const VkViewport viewport{0, 0, 64, 64, 0, 1};
    const VkRect2D scissor{{0, 0}, {64, 64}};
    const VkPipelineViewportStateCreateInfo viewport_state{
        VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO, &clip_control, 0, 1, &viewport, 1, &scissor};
    VkPipelineMultisampleStateCreateInfo multisample{};
    multisample.sType = VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO;
    multisample.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;
    const VkBool32 write_enables[2] = {VK_TRUE, VK_FALSE};
    const VkPipelineColorWriteCreateInfoEXT color_write{
        VK_STRUCTURE_TYPE_PIPELINE_COLOR_WRITE_CREATE_INFO_EXT, nullptr, 2, write_enables};
    const VkPipelineColorBlendStateCreateInfo color_blend{
        VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO,
        &color_write,
        0,
        VK_FALSE,
        VK_LOGIC_OP_CLEAR,
        2,
        invalid_pointer<VkPipelineColorBlendAttachmentState>(),
        {}};
    VkGraphicsPipelineCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO;
    info.stageCount = 1;
    info.pStages = &stage;
    info.pVertexInputState = invalid_pointer<VkPipelineVertexInputStateCreateInfo>();
    info.pViewportState = &viewport_state;
    info.pRasterizationState = &raster;
    info.pMultisampleState = &multisample;
    info.pColorBlendState = &color_blend;
    info.pDynamicState = &dynamic;
    info.layout = objs.layout;
    info.renderPass = objs.render_pass;
    info.basePipelineIndex = -1;
    VkPipeline created = to_handle<VkPipeline>(0x61);
    encode_vkCreateGraphicsPipelines(s.enc, objs.device, VK_NULL_HANDLE, 1, &info, nullptr, &created);

    Decoder d(s.bytes(), s.table, s.arena);
    Decoded_vkCreateGraphicsPipelines out;
    ASSERT_TRUE(decode_vkCreateGraphicsPipelines(d, out)) << d.error();
    const VkGraphicsPipelineCreateInfo &ci = out.pCreateInfos[0];
    EXPECT_EQ(ci.pVertexInputState, nullptr);
    ASSERT_NE(ci.pColorBlendState, nullptr);
    EXPECT_EQ(ci.pColorBlendState->attachmentCount, 2u);
    EXPECT_EQ(ci.pColorBlendState->pAttachments, nullptr);
    const auto *decoded_write =
        static_cast<const VkPipelineColorWriteCreateInfoEXT *>(ci.pColorBlendState->pNext);
    ASSERT_NE(decoded_write, nullptr);
    EXPECT_EQ(decoded_write->sType, VK_STRUCTURE_TYPE_PIPELINE_COLOR_WRITE_CREATE_INFO_EXT);
    ASSERT_EQ(decoded_write->attachmentCount, 2u);
    EXPECT_EQ(decoded_write->pColorWriteEnables[1], VK_FALSE);
    const auto *decoded_clip =
        static_cast<const VkPipelineViewportDepthClipControlCreateInfoEXT *>(ci.pViewportState->pNext);
    ASSERT_NE(decoded_clip, nullptr);
    EXPECT_EQ(decoded_clip->negativeOneToOne, VK_TRUE);
    const auto *decoded_stream =
        static_cast<const VkPipelineRasterizationStateStreamCreateInfoEXT *>(ci.pRasterizationState->pNext);
    ASSERT_NE(decoded_stream, nullptr);
    EXPECT_EQ(decoded_stream->sType, VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_STREAM_CREATE_INFO_EXT);
    EXPECT_EQ(decoded_stream->rasterizationStream, 1u);
    const auto *decoded_provoking =
        static_cast<const VkPipelineRasterizationProvokingVertexStateCreateInfoEXT *>(decoded_stream->pNext);
    ASSERT_NE(decoded_provoking, nullptr);
    EXPECT_EQ(decoded_provoking->provokingVertexMode, VK_PROVOKING_VERTEX_MODE_LAST_VERTEX_EXT);
}

// A secondary that inherits the primary's conditional rendering says so in its inheritance info.
TEST(CodecRoundTrip, InheritedConditionalRendering) {
    Session s;
    const VkCommandBuffer secondary = s.client<VkCommandBuffer>(VK_OBJECT_TYPE_COMMAND_BUFFER, 0x11);
    const VkCommandBufferInheritanceConditionalRenderingInfoEXT conditional{
        VK_STRUCTURE_TYPE_COMMAND_BUFFER_INHERITANCE_CONDITIONAL_RENDERING_INFO_EXT, nullptr, VK_TRUE};
    const VkCommandBufferInheritanceInfo inheritance{VK_STRUCTURE_TYPE_COMMAND_BUFFER_INHERITANCE_INFO,
                                                     &conditional,
                                                     VK_NULL_HANDLE,
                                                     0,
                                                     VK_NULL_HANDLE,
                                                     VK_FALSE,
                                                     0,
                                                     0};
    const VkCommandBufferBeginInfo begin{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO, nullptr, 0,
                                         &inheritance};
    encode_vkBeginCommandBuffer(s.enc, secondary, &begin, VK_COMMAND_BUFFER_LEVEL_SECONDARY);
    Decoder d(s.bytes(), s.table, s.arena);
    Decoded_vkBeginCommandBuffer out;
    ASSERT_TRUE(decode_vkBeginCommandBuffer(d, out)) << d.error();
    ASSERT_NE(out.pBeginInfo->pInheritanceInfo, nullptr);
    const auto *decoded = static_cast<const VkCommandBufferInheritanceConditionalRenderingInfoEXT *>(
        out.pBeginInfo->pInheritanceInfo->pNext);
    ASSERT_NE(decoded, nullptr);
    EXPECT_EQ(decoded->sType, VK_STRUCTURE_TYPE_COMMAND_BUFFER_INHERITANCE_CONDITIONAL_RENDERING_INFO_EXT);
    EXPECT_EQ(decoded->conditionalRenderingEnable, VK_TRUE);
}

} // namespace
} // namespace splitvk::codec
