"""What vk.xml cannot say about encoding, in small tables (GFXReconstruct's approach, docs/architecture.md §8).

The codec is driven by vk.xml (len, altlen, optional, noautovalidity, structextends). These tables
hold the rest: members the specification says are *ignored* in some states (so an application may
leave garbage there, and the encoder must not read them), the context an enclosing structure or
command gives its members, and the handle-table bookkeeping of pools.

Conditions are C++ boolean expressions evaluated by the ENCODER only, over `s` (the structure being
encoded, a const reference) and `e` (the codec::Encoder; `e.context()` holds what enclosing
structures set, see protocol/codec/codec.h). When a condition is false the member is encoded as
absent (a pointer: presence byte 0; a handle: id 0) and decodes as nullptr / VK_NULL_HANDLE, which
is what a driver that ignores the member sees anyway. The decoder never needs the condition, so it
never has to interpret state it cannot trust.

Every member of a codec structure that vk.xml marks `noautovalidity` and that is a pointer or a
handle must appear in CONDITIONS or in ALWAYS_VALID: the generator fails otherwise, so a new
structure forces a reading of its specification text.
"""

# (structure, member) -> (C++ condition, the specification's rule).
CONDITIONS = {
    # --- VkWriteDescriptorSet ------------------------------------------------------------------
    ("VkWriteDescriptorSet", "pImageInfo"): (
        "codec::descriptor_uses_image_info(s.descriptorType)",
        "Only one of pImageInfo, pBufferInfo, or pTexelBufferView members is used according to the "
        "descriptor type specified in the descriptorType member of the containing VkWriteDescriptorSet "
        "structure, or none of them in case descriptorType is VK_DESCRIPTOR_TYPE_INLINE_UNIFORM_BLOCK, in "
        "which case the source data for the descriptor writes is taken from the "
        "VkWriteDescriptorSetInlineUniformBlock structure included in the pNext chain."),
    ("VkWriteDescriptorSet", "pBufferInfo"): (
        "codec::descriptor_uses_buffer_info(s.descriptorType)",
        "(as pImageInfo)"),
    ("VkWriteDescriptorSet", "pTexelBufferView"): (
        "codec::descriptor_uses_texel_buffer_view(s.descriptorType)",
        "(as pImageInfo)"),
    ("VkWriteDescriptorSet", "dstSet"): (
        "!e.context().push_descriptor",
        "vkCmdPushDescriptorSetKHR: the dstSet member of each element of pDescriptorWrites is ignored."),
    # The element type depends on the write's descriptorType, which VkWriteDescriptorSet's prologue
    # puts in the context (see STRUCT_PROLOGUES).
    ("VkDescriptorImageInfo", "sampler"): (
        "codec::descriptor_uses_sampler(e.context().descriptor_type) && !e.context().immutable_samplers",
        "sampler is a sampler handle, and is used in descriptor updates for types VK_DESCRIPTOR_TYPE_SAMPLER "
        "and VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER if the binding being updated does not use immutable "
        "samplers."),
    ("VkDescriptorImageInfo", "imageView"): (
        "codec::descriptor_uses_image_view(e.context().descriptor_type)",
        "imageView is VK_NULL_HANDLE or an image view handle, and is used in descriptor updates for types "
        "VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, "
        "VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, and VK_DESCRIPTOR_TYPE_INPUT_ATTACHMENT."),

    # --- Descriptor set layouts and templates ----------------------------------------------------
    ("VkDescriptorSetLayoutBinding", "pImmutableSamplers"): (
        "codec::descriptor_uses_sampler(s.descriptorType)",
        "If descriptorType specifies a VK_DESCRIPTOR_TYPE_SAMPLER or VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER "
        "type descriptor, then pImmutableSamplers can be used to initialize a set of immutable samplers. [...] "
        "If descriptorType is not one of these descriptor types, then pImmutableSamplers is ignored."),
    ("VkDescriptorUpdateTemplateCreateInfo", "descriptorSetLayout"): (
        "s.templateType == VK_DESCRIPTOR_UPDATE_TEMPLATE_TYPE_DESCRIPTOR_SET",
        "descriptorSetLayout is the descriptor set layout used to build the descriptor update template. [...] "
        "This parameter is ignored if templateType is not VK_DESCRIPTOR_UPDATE_TEMPLATE_TYPE_DESCRIPTOR_SET."),
    ("VkDescriptorUpdateTemplateCreateInfo", "pipelineLayout"): (
        "s.templateType == VK_DESCRIPTOR_UPDATE_TEMPLATE_TYPE_PUSH_DESCRIPTORS_KHR",
        "pipelineLayout is a VkPipelineLayout object used to program the bindings. This parameter is ignored "
        "if templateType is not VK_DESCRIPTOR_UPDATE_TEMPLATE_TYPE_PUSH_DESCRIPTORS_KHR."),

    # --- Sharing modes -------------------------------------------------------------------------
    ("VkBufferCreateInfo", "pQueueFamilyIndices"): (
        "s.sharingMode == VK_SHARING_MODE_CONCURRENT",
        "pQueueFamilyIndices is a pointer to an array of queue families that will access this buffer. It is "
        "ignored if sharingMode is not VK_SHARING_MODE_CONCURRENT."),
    ("VkImageCreateInfo", "pQueueFamilyIndices"): (
        "s.sharingMode == VK_SHARING_MODE_CONCURRENT",
        "pQueueFamilyIndices is a pointer to an array of queue families that will access this image. It is "
        "ignored if sharingMode is not VK_SHARING_MODE_CONCURRENT."),
    ("VkSwapchainCreateInfoKHR", "pQueueFamilyIndices"): (
        "s.imageSharingMode == VK_SHARING_MODE_CONCURRENT",
        "pQueueFamilyIndices is a pointer to an array of queue family indices having access to the images(s) "
        "of the swapchain when imageSharingMode is VK_SHARING_MODE_CONCURRENT."),

    # --- Framebuffers --------------------------------------------------------------------------
    ("VkFramebufferCreateInfo", "pAttachments"): (
        "(s.flags & VK_FRAMEBUFFER_CREATE_IMAGELESS_BIT) == 0",
        "pAttachments is a pointer to an array of VkImageView handles [...]. If flags includes "
        "VK_FRAMEBUFFER_CREATE_IMAGELESS_BIT, this parameter is ignored."),

    # --- Command buffer begin / inheritance ------------------------------------------------------
    ("VkCommandBufferBeginInfo", "pInheritanceInfo"): (
        "e.context().secondary_command_buffer",
        "pInheritanceInfo is a pointer to a VkCommandBufferInheritanceInfo structure, used if commandBuffer is "
        "a secondary command buffer. If this is a primary command buffer, then this value is ignored."),
    ("VkCommandBufferInheritanceInfo", "renderPass"): (
        "e.context().render_pass_continue",
        "renderPass [...] defining which render passes the VkCommandBuffer will be compatible with and can be "
        "executed within. (VUs: only required when VK_COMMAND_BUFFER_USAGE_RENDER_PASS_CONTINUE_BIT is set.)"),
    ("VkCommandBufferInheritanceInfo", "framebuffer"): (
        "e.context().render_pass_continue",
        "framebuffer can refer to the VkFramebuffer object that the VkCommandBuffer will be rendering to if "
        "it is executed within a render pass instance. (Ignored outside a render pass.)"),
    ("VkCommandBufferInheritanceRenderingInfo", "pColorAttachmentFormats"): (
        "e.context().rendering_info_applies",
        "If VkCommandBufferInheritanceInfo::renderPass is not VK_NULL_HANDLE, or "
        "VK_COMMAND_BUFFER_USAGE_RENDER_PASS_CONTINUE_BIT is not specified in VkCommandBufferBeginInfo::flags, "
        "parameters of this structure are ignored."),
    ("VkAttachmentSampleCountInfoAMD", "pColorAttachmentSamples"): (
        "e.context().rendering_info_applies",
        "If VkGraphicsPipelineCreateInfo::renderPass [or VkCommandBufferInheritanceInfo::renderPass] is not "
        "VK_NULL_HANDLE, this structure is ignored."),

    # --- Graphics pipelines (GraphicsPipelineScope in protocol/codec/rules.cpp computes these) ---
    ("VkGraphicsPipelineCreateInfo", "pTessellationState"): (
        "e.context().pipeline_tessellation",
        "pTessellationState is a pointer to a VkPipelineTessellationStateCreateInfo structure, and is ignored "
        "if the pipeline does not include a tessellation control shader stage and tessellation evaluation "
        "shader stage."),
    ("VkGraphicsPipelineCreateInfo", "pViewportState"): (
        "e.context().pipeline_rasterization",
        "pViewportState is a pointer to a VkPipelineViewportStateCreateInfo structure, and is ignored if the "
        "pipeline has rasterization disabled."),
    ("VkGraphicsPipelineCreateInfo", "pMultisampleState"): (
        "e.context().pipeline_rasterization",
        "pMultisampleState is a pointer to a VkPipelineMultisampleStateCreateInfo structure, and is ignored "
        "if the pipeline has rasterization disabled."),
    ("VkGraphicsPipelineCreateInfo", "pDepthStencilState"): (
        "e.context().pipeline_rasterization && e.context().pipeline_depth_stencil",
        "pDepthStencilState is a pointer to a VkPipelineDepthStencilStateCreateInfo structure, and is ignored "
        "if the pipeline has rasterization disabled or if the subpass of the render pass the pipeline is "
        "created against does not use a depth/stencil attachment."),
    ("VkGraphicsPipelineCreateInfo", "pColorBlendState"): (
        "e.context().pipeline_rasterization && e.context().pipeline_color",
        "pColorBlendState is a pointer to a VkPipelineColorBlendStateCreateInfo structure, and is ignored if "
        "the pipeline has rasterization disabled or if the subpass of the render pass the pipeline is created "
        "against does not use any color attachments."),
    ("VkGraphicsPipelineCreateInfo", "basePipelineHandle"): (
        "(s.flags & VK_PIPELINE_CREATE_DERIVATIVE_BIT) != 0",
        "basePipelineHandle is a pipeline to derive from. (VUs: only used if flags contains "
        "VK_PIPELINE_CREATE_DERIVATIVE_BIT.)"),
    ("VkComputePipelineCreateInfo", "basePipelineHandle"): (
        "(s.flags & VK_PIPELINE_CREATE_DERIVATIVE_BIT) != 0",
        "basePipelineHandle is a pipeline to derive from. (VUs: only used if flags contains "
        "VK_PIPELINE_CREATE_DERIVATIVE_BIT.)"),
    ("VkPipelineViewportStateCreateInfo", "pViewports"): (
        "!e.context().dynamic_viewport",
        "pViewports is a pointer to an array of VkViewport structures, defining the viewport transforms. If "
        "the viewport state is dynamic, this member is ignored."),
    ("VkPipelineViewportStateCreateInfo", "pScissors"): (
        "!e.context().dynamic_scissor",
        "pScissors is a pointer to an array of VkRect2D structures defining the rectangular bounds of the "
        "scissor for the corresponding viewport. If the scissor state is dynamic, this member is ignored."),
    ("VkGraphicsPipelineCreateInfo", "pVertexInputState"): (
        "!e.context().dynamic_vertex_input",
        "pVertexInputState is a pointer to a VkPipelineVertexInputStateCreateInfo structure. It is ignored if "
        "the pipeline includes a mesh shader stage. It can be NULL if the pipeline is created with the "
        "VK_DYNAMIC_STATE_VERTEX_INPUT_EXT dynamic state set."),
    ("VkPipelineColorBlendStateCreateInfo", "pAttachments"): (
        "!e.context().dynamic_color_blend_attachments",
        "pAttachments [...] is ignored if the pipeline is created with VK_DYNAMIC_STATE_COLOR_BLEND_ENABLE_EXT, "
        "VK_DYNAMIC_STATE_COLOR_BLEND_EQUATION_EXT, and VK_DYNAMIC_STATE_COLOR_WRITE_MASK_EXT dynamic states "
        "set (and VK_DYNAMIC_STATE_COLOR_BLEND_ADVANCED_EXT, whose feature splitvk withholds)."),
    ("VkPipelineRenderingCreateInfo", "pColorAttachmentFormats"): (
        "e.context().rendering_info_applies",
        "If renderPass is not VK_NULL_HANDLE, the pipeline is being created with a render pass, and "
        "[VkPipelineRenderingCreateInfo] is ignored."),
}

# noautovalidity pointers and handles that are always valid to read (the reason is why).
ALWAYS_VALID = {
    ("VkGraphicsPipelineCreateInfo", "pStages"): "noautovalidity only for graphics pipeline libraries (not forwarded)",
    ("VkGraphicsPipelineCreateInfo", "pInputAssemblyState"): "ignored only with mesh shaders (not forwarded)",
    ("VkGraphicsPipelineCreateInfo", "pRasterizationState"): "NULL (never garbage) when EDS3 makes all of it dynamic",
    ("VkGraphicsPipelineCreateInfo", "layout"): "required without graphics pipeline libraries; nullable on decode",
    ("VkGraphicsPipelineCreateInfo", "renderPass"): "VK_NULL_HANDLE selects dynamic rendering; nullable on decode",
    ("VkBindImageMemoryInfo", "memory"): "VK_NULL_HANDLE with VkBindImageMemorySwapchainInfoKHR; nullable on decode",
    ("VkRenderPassBeginInfo", "pClearValues"): "must be valid when clearValueCount is not 0; only the cleared entries matter",
}
# Command parameters with noautovalidity that are read as usual.
ALWAYS_VALID_PARAMS = {
    ("vkCmdClearColorImage", "pColor"): "a union: noautovalidity because the active member is not knowable",
    ("vkFreeCommandBuffers", "pCommandBuffers"): "elements may be VK_NULL_HANDLE (ignored); nullable on decode",
    ("vkFreeDescriptorSets", "pDescriptorSets"): "elements may be VK_NULL_HANDLE (ignored); nullable on decode",
    ("vkCmdBindTransformFeedbackBuffersEXT", "pSizes"):
        "may be NULL (every binding to the end of its buffer); read as usual when not",
    ("vkCmdBeginTransformFeedbackEXT", "pCounterBuffers"):
        "may be NULL (capture from byte 0) and its elements VK_NULL_HANDLE; nullable on decode",
    ("vkCmdEndTransformFeedbackEXT", "pCounterBuffers"):
        "may be NULL (counters not written) and its elements VK_NULL_HANDLE; nullable on decode",
    ("vkUpdateDescriptorSetWithTemplate", "pData"): "hand-written (codec_policy.TEMPLATE_COMMANDS)",
    ("vkCmdPushDescriptorSetWithTemplateKHR", "pData"): "hand-written (codec_policy.TEMPLATE_COMMANDS)",
}

# Code run before a structure's members (and its pNext chain) are encoded: it sets the context the
# conditions above read, and restores it when the structure is done (RAII).
STRUCT_PROLOGUES = {
    "VkGraphicsPipelineCreateInfo": "const codec::GraphicsPipelineScope scope(e, s);",
    "VkWriteDescriptorSet": "const codec::DescriptorWriteScope scope(e, s);",
    "VkCommandBufferBeginInfo":
        "const codec::ContextScope scope(e);\n"
        "e.context().render_pass_continue = (s.flags & VK_COMMAND_BUFFER_USAGE_RENDER_PASS_CONTINUE_BIT) != 0;",
    "VkCommandBufferInheritanceInfo":
        "const codec::ContextScope scope(e);\n"
        "e.context().rendering_info_applies = e.context().render_pass_continue && s.renderPass == VK_NULL_HANDLE;",
}

# Code run after a structure is decoded (`d` the Decoder, `s` the decoded structure, mutable).
STRUCT_EPILOGUES = {
    # The agent creates its template with canonical offsets and strides, and the template update
    # decoder lays pData out the same way (protocol/codec/descriptor_template.h).
    "VkDescriptorUpdateTemplateCreateInfo": "codec::canonicalize_template_entries(s);",
}

# Commands whose encoder takes arguments beyond the Vulkan ones: [(C++ type, name)], and the
# prologue that uses them. The value is not sent; it decides what is.
COMMAND_EXTRA_ARGS = {
    # "If this is a primary command buffer, then [pInheritanceInfo] is ignored": only the layer knows
    # the level (from vkAllocateCommandBuffers), so the encoder is told.
    "vkBeginCommandBuffer": [("VkCommandBufferLevel", "level")],
}
COMMAND_PROLOGUES = {
    "vkBeginCommandBuffer":
        "const codec::ContextScope scope(e);\n"
        "e.context().secondary_command_buffer = level == VK_COMMAND_BUFFER_LEVEL_SECONDARY;",
    "vkCmdPushDescriptorSetKHR":
        "const codec::ContextScope scope(e);\ne.context().push_descriptor = true;",
}

# Extension structures the codec deliberately leaves out of pNext chains (skipped on encode
# without a report; an unknown sType on decode).
DROPPED_EXTENSIONS = {
    # Names a client handle in a raw uint64_t (objectHandle); debug names are local (codec_policy).
    "VkDebugUtilsObjectNameInfoEXT": "debug names stay on the client",
    # External memory, semaphores and fences (allowlist.CLIENT_ONLY_EXTENSIONS): shared with another
    # process of the client's (an OpenXR runtime), never with the agent, which allocates and creates
    # ordinary objects in their place. An imported fd would name nothing on the agent.
    "VkImportMemoryFdInfoKHR": "an fd of the client's process",
    "VkExportMemoryAllocateInfo": "the agent's memory is shared with no one",
    "VkExternalMemoryImageCreateInfo": "the agent's images are shared with no one",
    "VkExternalMemoryBufferCreateInfo": "the agent's buffers are shared with no one",
    "VkExportSemaphoreCreateInfo": "the agent drops submit semaphores (submit_rules.h)",
    "VkExportFenceCreateInfo": "the agent's fences are its own",
}

# Objects allocated from a pool die with it (vkDestroy*Pool, vkResetDescriptorPool): the handle
# table records the pool as their parent. command -> (structure, member) naming the pool.
POOL_PARENTS = {
    "vkAllocateCommandBuffers": ("VkCommandBufferAllocateInfo", "commandPool"),
    "vkAllocateDescriptorSets": ("VkDescriptorSetAllocateInfo", "descriptorPool"),
}
# Created handles whose parent is another parameter of the same command.
PARAM_PARENTS = {
    "vkGetSwapchainImagesKHR": "swapchain",  # the images die with the swapchain
}
# Commands that free every child of a pool without destroying the pool.
RESETS_CHILDREN = {
    "vkResetDescriptorPool": "descriptorPool",
}
