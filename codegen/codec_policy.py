"""Which Vulkan commands cross the wire, decided one by one (docs/architecture.md §2-3).

Every command in the model (core 1.0-1.3 plus allowlist.py) must be classified here, or the
generator stops: adding an extension to the allow-list forces a decision for each of its commands.

  FORWARD  the layer encodes the call (after the client's driver returned, so created handles are
           known) and the agent replays it. Creates, destroys, binds, updates, every vkCmd*.
  LOCAL    answered by the client's own driver and never sent: queries, host waits and status,
           window-system queries. The application lives on the client (docs/architecture.md §2).
  MANUAL   hand-written semantics in the layer and the agent (memory, submit, present, swapchain,
           instance and device). Encoders and decoders are still generated for them, since their
           arguments are plain; the layer decides when (and whether) to call them.

Aliases (vkCmdDrawIndirectCountKHR -> vkCmdDrawIndirectCount) are not classified separately: an
alias follows the command it names, and the layer encodes it under that name (one command id).
"""

FORWARD = "forward"
LOCAL = "local"
MANUAL = "manual"

# Commands whose encoder and decoder are hand-written in protocol/codec/ (their data cannot be
# described from vk.xml alone): the generator emits their command id, decoded struct and dispatch
# entry, and calls the hand-written bodies. pData of a descriptor update template is laid out by the
# template's entries, which only the layer knows (GFXReconstruct: "descriptor update templates need
# the template layout to encode pData").
TEMPLATE_COMMANDS = {
    "vkUpdateDescriptorSetWithTemplate",
    "vkCmdPushDescriptorSetWithTemplateKHR",
}

POLICY = {
    # --- Instance and device: the agent creates its own, on its own GPU. -----------------------
    "vkCreateInstance": MANUAL,          # the agent owns its instance; the client's is informative
    "vkDestroyInstance": MANUAL,
    "vkCreateDevice": MANUAL,            # carries enabled features/extensions the agent mirrors
    "vkDestroyDevice": MANUAL,           # ends the replicated session
    "vkGetInstanceProcAddr": LOCAL,      # loader interface
    "vkGetDeviceProcAddr": LOCAL,
    "vkEnumerateInstanceExtensionProperties": LOCAL,
    "vkEnumerateInstanceLayerProperties": LOCAL,
    "vkEnumerateInstanceVersion": LOCAL,
    "vkEnumerateDeviceExtensionProperties": LOCAL,
    "vkEnumerateDeviceLayerProperties": LOCAL,
    "vkEnumeratePhysicalDevices": LOCAL,
    "vkEnumeratePhysicalDeviceGroups": LOCAL,
    "vkGetPhysicalDeviceExternalBufferProperties": LOCAL,
    "vkGetPhysicalDeviceExternalFenceProperties": LOCAL,
    "vkGetPhysicalDeviceExternalSemaphoreProperties": LOCAL,
    "vkGetPhysicalDeviceFeatures": LOCAL,
    "vkGetPhysicalDeviceFeatures2": LOCAL,
    "vkGetPhysicalDeviceFormatProperties": LOCAL,
    "vkGetPhysicalDeviceFormatProperties2": LOCAL,
    "vkGetPhysicalDeviceImageFormatProperties": LOCAL,
    "vkGetPhysicalDeviceImageFormatProperties2": LOCAL,
    "vkGetPhysicalDeviceMemoryProperties": LOCAL,
    "vkGetPhysicalDeviceMemoryProperties2": LOCAL,
    "vkGetPhysicalDeviceProperties": LOCAL,
    "vkGetPhysicalDeviceProperties2": LOCAL,
    "vkGetPhysicalDeviceQueueFamilyProperties": LOCAL,
    "vkGetPhysicalDeviceQueueFamilyProperties2": LOCAL,
    "vkGetPhysicalDeviceSparseImageFormatProperties": LOCAL,
    "vkGetPhysicalDeviceSparseImageFormatProperties2": LOCAL,
    "vkGetPhysicalDeviceToolProperties": LOCAL,

    # --- Queues: vkGetDeviceQueue* introduce queue handles the agent must name. ---------------
    "vkGetDeviceQueue": FORWARD,
    "vkGetDeviceQueue2": FORWARD,
    "vkQueueSubmit": MANUAL,             # streams + dirty memory first; fences/semaphores decided by the layer
    "vkQueueSubmit2": MANUAL,
    "vkQueueBindSparse": MANUAL,         # a queue operation like a submit (semaphores, fence)
    "vkQueueWaitIdle": LOCAL,            # host wait: the client's own queue
    "vkDeviceWaitIdle": LOCAL,

    # --- Memory: allocation is forwarded (the agent rebinds, docs/architecture.md §3); mapping is not. ------
    "vkAllocateMemory": FORWARD,         # the agent ignores type index/offsets and rebinds
    "vkFreeMemory": FORWARD,
    "vkMapMemory": MANUAL,               # shadow copies; the pointer never crosses the wire
    "vkUnmapMemory": MANUAL,             # compare the shadow, send changed blocks
    "vkFlushMappedMemoryRanges": MANUAL,
    "vkInvalidateMappedMemoryRanges": MANUAL,
    "vkGetDeviceMemoryCommitment": LOCAL,
    "vkGetDeviceMemoryOpaqueCaptureAddress": LOCAL,
    "vkGetDeviceGroupPeerMemoryFeatures": LOCAL,
    "vkBindBufferMemory": FORWARD,
    "vkBindBufferMemory2": FORWARD,
    "vkBindImageMemory": FORWARD,
    "vkBindImageMemory2": FORWARD,
    "vkGetBufferMemoryRequirements": LOCAL,
    "vkGetBufferMemoryRequirements2": LOCAL,
    "vkGetImageMemoryRequirements": LOCAL,
    "vkGetImageMemoryRequirements2": LOCAL,
    "vkGetImageSparseMemoryRequirements": LOCAL,
    "vkGetImageSparseMemoryRequirements2": LOCAL,
    "vkGetDeviceBufferMemoryRequirements": LOCAL,
    "vkGetDeviceImageMemoryRequirements": LOCAL,
    "vkGetDeviceImageSparseMemoryRequirements": LOCAL,
    # The client's address for a buffer: answered by the client's driver, and sent to the agent
    # (BufferAddress), which maps it to its own buffer's (server-agent/buffer_addresses.h).
    "vkGetBufferDeviceAddress": MANUAL,
    # Capture/replay addresses are only portable within one driver: the feature is hidden from
    # applications (layer/core/physical_device.cpp), and the answer stays the client's.
    "vkGetBufferOpaqueCaptureAddress": LOCAL,

    # --- Resources and views. ------------------------------------------------------------------
    "vkCreateBuffer": FORWARD,
    "vkDestroyBuffer": FORWARD,
    "vkCreateBufferView": FORWARD,
    "vkDestroyBufferView": FORWARD,
    "vkCreateImage": FORWARD,
    "vkDestroyImage": FORWARD,
    "vkCreateImageView": FORWARD,
    "vkDestroyImageView": FORWARD,
    "vkGetImageSubresourceLayout": LOCAL,
    "vkCreateSampler": FORWARD,
    "vkDestroySampler": FORWARD,
    "vkCreateSamplerYcbcrConversion": FORWARD,
    "vkDestroySamplerYcbcrConversion": FORWARD,

    # --- Descriptors. --------------------------------------------------------------------------
    "vkCreateDescriptorSetLayout": FORWARD,
    "vkDestroyDescriptorSetLayout": FORWARD,
    "vkGetDescriptorSetLayoutSupport": LOCAL,
    "vkCreateDescriptorPool": FORWARD,
    "vkDestroyDescriptorPool": FORWARD,  # frees its sets: the handle table drops them too
    "vkResetDescriptorPool": FORWARD,    # frees its sets: the handle table drops them too
    "vkAllocateDescriptorSets": FORWARD,
    "vkFreeDescriptorSets": FORWARD,
    "vkUpdateDescriptorSets": FORWARD,
    "vkCreateDescriptorUpdateTemplate": FORWARD,
    "vkDestroyDescriptorUpdateTemplate": FORWARD,
    "vkUpdateDescriptorSetWithTemplate": FORWARD,  # TEMPLATE_COMMANDS: hand-written body

    # --- Pipelines, shaders, render passes, framebuffers. --------------------------------------
    "vkCreateShaderModule": FORWARD,
    "vkDestroyShaderModule": FORWARD,
    "vkCreatePipelineCache": FORWARD,    # the client's initial data is rejected by a foreign driver (spec: it must cope)
    "vkDestroyPipelineCache": FORWARD,
    "vkMergePipelineCaches": FORWARD,
    "vkGetPipelineCacheData": LOCAL,
    "vkCreatePipelineLayout": FORWARD,
    "vkDestroyPipelineLayout": FORWARD,
    "vkCreateGraphicsPipelines": FORWARD,
    "vkCreateComputePipelines": FORWARD,
    "vkDestroyPipeline": FORWARD,
    "vkCreateRenderPass": FORWARD,
    "vkCreateRenderPass2": FORWARD,
    "vkDestroyRenderPass": FORWARD,
    "vkGetRenderAreaGranularity": LOCAL,
    "vkCreateFramebuffer": FORWARD,
    "vkDestroyFramebuffer": FORWARD,

    # --- Command pools and buffers. ------------------------------------------------------------
    "vkCreateCommandPool": FORWARD,
    "vkDestroyCommandPool": FORWARD,     # frees its command buffers: the handle table drops them too
    "vkResetCommandPool": FORWARD,
    "vkTrimCommandPool": FORWARD,        # a hint, but cheap and keeps the pools alike
    "vkAllocateCommandBuffers": FORWARD,
    "vkFreeCommandBuffers": FORWARD,
    "vkBeginCommandBuffer": FORWARD,     # needs the level: encoder takes it as an extra argument
    "vkEndCommandBuffer": FORWARD,
    "vkResetCommandBuffer": FORWARD,

    # --- Synchronisation objects: created and destroyed on both sides so submits can name them;
    # host waits and status are the client's own. ---------------------------------------------
    "vkCreateFence": FORWARD,
    "vkDestroyFence": FORWARD,
    # The client resets a fence after waiting on its own; the agent's copy may still be pending,
    # and resetting a fence in use is invalid. The agent manages its fences from submits.
    "vkResetFences": MANUAL,
    # External payloads (allowlist.CLIENT_ONLY_EXTENSIONS): fds of the client's process, exchanged
    # with another process of the client's (an OpenXR runtime). The agent's objects stay its own.
    "vkGetMemoryFdKHR": LOCAL,
    "vkGetMemoryFdPropertiesKHR": LOCAL,
    "vkGetSemaphoreFdKHR": LOCAL,
    "vkImportSemaphoreFdKHR": LOCAL,
    "vkGetFenceFdKHR": LOCAL,
    "vkImportFenceFdKHR": LOCAL,
    "vkGetFenceStatus": LOCAL,
    "vkWaitForFences": LOCAL,
    "vkCreateSemaphore": FORWARD,
    "vkDestroySemaphore": FORWARD,
    "vkGetSemaphoreCounterValue": LOCAL,
    "vkWaitSemaphores": LOCAL,
    # Host signal of a timeline semaphore: local as agreed. NB: a replayed submit that waits for a
    # host-signalled value would then wait forever on the agent; the layer must rewrite such waits.
    "vkSignalSemaphore": LOCAL,
    "vkCreateEvent": FORWARD,
    "vkDestroyEvent": FORWARD,
    "vkGetEventStatus": LOCAL,
    "vkSetEvent": FORWARD,               # replayed command buffers may vkCmdWaitEvents on a host-set event
    "vkResetEvent": FORWARD,
    "vkCreateQueryPool": FORWARD,
    "vkDestroyQueryPool": FORWARD,
    "vkResetQueryPool": FORWARD,         # host reset: the agent's queries must be reset before use too
    "vkGetQueryPoolResults": LOCAL,      # the client's own results

    # --- Private data: application-side storage the agent never needs. -------------------------
    "vkCreatePrivateDataSlot": LOCAL,
    "vkDestroyPrivateDataSlot": LOCAL,
    "vkSetPrivateData": LOCAL,
    "vkGetPrivateData": LOCAL,

    # --- Window system: the agent has no surface (swapchain images become offscreen images). ---
    "vkCreateXcbSurfaceKHR": LOCAL,
    "vkCreateXlibSurfaceKHR": LOCAL,
    "vkCreateWaylandSurfaceKHR": LOCAL,
    "vkDestroySurfaceKHR": LOCAL,
    "vkGetPhysicalDeviceSurfaceSupportKHR": LOCAL,
    "vkGetPhysicalDeviceSurfaceCapabilitiesKHR": LOCAL,
    "vkGetPhysicalDeviceSurfaceCapabilities2KHR": LOCAL,
    "vkGetPhysicalDeviceSurfaceFormatsKHR": LOCAL,
    "vkGetPhysicalDeviceSurfaceFormats2KHR": LOCAL,
    "vkGetPhysicalDeviceSurfacePresentModesKHR": LOCAL,
    "vkGetPhysicalDeviceXcbPresentationSupportKHR": LOCAL,
    "vkGetPhysicalDeviceXlibPresentationSupportKHR": LOCAL,
    "vkGetPhysicalDeviceWaylandPresentationSupportKHR": LOCAL,
    "vkGetPhysicalDevicePresentRectanglesKHR": LOCAL,
    "vkGetDeviceGroupPresentCapabilitiesKHR": LOCAL,
    "vkGetDeviceGroupSurfacePresentModesKHR": LOCAL,
    "vkCreateSwapchainKHR": MANUAL,      # becomes offscreen images on the agent
    "vkDestroySwapchainKHR": MANUAL,
    "vkGetSwapchainImagesKHR": MANUAL,   # the images' ids: created handles of the swapchain
    "vkAcquireNextImageKHR": MANUAL,     # a frame mark
    "vkAcquireNextImage2KHR": MANUAL,
    "vkQueuePresentKHR": MANUAL,         # a frame mark; the layer composites

    # --- Debugging. Decision: local. Names and labels change nothing the agent renders, the agent
    # does not enable VK_EXT_debug_utils (an instance extension) for replay, and messengers and
    # report callbacks carry client function pointers. The vkCmd*Label* commands are the only
    # vkCmd* that are not forwarded, for the same reason: replaying them would need the extension.
    "vkCreateDebugUtilsMessengerEXT": LOCAL,
    "vkDestroyDebugUtilsMessengerEXT": LOCAL,
    "vkSubmitDebugUtilsMessageEXT": LOCAL,
    "vkSetDebugUtilsObjectNameEXT": LOCAL,
    "vkSetDebugUtilsObjectTagEXT": LOCAL,
    "vkQueueBeginDebugUtilsLabelEXT": LOCAL,
    "vkQueueEndDebugUtilsLabelEXT": LOCAL,
    "vkQueueInsertDebugUtilsLabelEXT": LOCAL,
    "vkCmdBeginDebugUtilsLabelEXT": LOCAL,
    "vkCmdEndDebugUtilsLabelEXT": LOCAL,
    "vkCmdInsertDebugUtilsLabelEXT": LOCAL,
    "vkCreateDebugReportCallbackEXT": LOCAL,
    "vkDestroyDebugReportCallbackEXT": LOCAL,
    "vkDebugReportMessageEXT": LOCAL,
    # Pulled in by VK_KHR_synchronization2's interaction with VK_NV_device_diagnostic_checkpoints
    # (not allow-listed, so hidden from apps): a query in any case.
    "vkGetQueueCheckpointData2NV": LOCAL,

    # --- Command recording: every vkCmd* (except the debug labels above) is recorded into the
    # command buffer's stream and replayed into the agent's command buffer. ----------------------
    "vkCmdBeginQuery": FORWARD,
    "vkCmdBeginRenderPass": FORWARD,
    "vkCmdBeginRenderPass2": FORWARD,
    "vkCmdBeginRendering": FORWARD,
    "vkCmdBindDescriptorSets": FORWARD,
    "vkCmdBindIndexBuffer": FORWARD,
    "vkCmdBindPipeline": FORWARD,
    "vkCmdBindVertexBuffers": FORWARD,
    "vkCmdBindVertexBuffers2": FORWARD,
    "vkCmdBlitImage": FORWARD,
    "vkCmdBlitImage2": FORWARD,
    "vkCmdClearAttachments": FORWARD,
    "vkCmdClearColorImage": FORWARD,
    "vkCmdClearDepthStencilImage": FORWARD,
    "vkCmdCopyBuffer": FORWARD,
    "vkCmdCopyBuffer2": FORWARD,
    "vkCmdCopyBufferToImage": FORWARD,
    "vkCmdCopyBufferToImage2": FORWARD,
    "vkCmdCopyImage": FORWARD,
    "vkCmdCopyImage2": FORWARD,
    "vkCmdCopyImageToBuffer": FORWARD,
    "vkCmdCopyImageToBuffer2": FORWARD,
    "vkCmdCopyQueryPoolResults": FORWARD,
    "vkCmdDispatch": FORWARD,
    "vkCmdDispatchBase": FORWARD,
    "vkCmdDispatchIndirect": FORWARD,
    "vkCmdDraw": FORWARD,
    "vkCmdDrawIndexed": FORWARD,
    "vkCmdDrawIndexedIndirect": FORWARD,
    "vkCmdDrawIndexedIndirectCount": FORWARD,
    "vkCmdDrawIndirect": FORWARD,
    "vkCmdDrawIndirectCount": FORWARD,
    "vkCmdEndQuery": FORWARD,
    "vkCmdEndRenderPass": FORWARD,
    "vkCmdEndRenderPass2": FORWARD,
    "vkCmdEndRendering": FORWARD,
    "vkCmdExecuteCommands": FORWARD,
    "vkCmdFillBuffer": FORWARD,
    "vkCmdNextSubpass": FORWARD,
    "vkCmdNextSubpass2": FORWARD,
    "vkCmdPipelineBarrier": FORWARD,
    "vkCmdPipelineBarrier2": FORWARD,
    "vkCmdPushConstants": FORWARD,
    "vkCmdPushDescriptorSetKHR": FORWARD,
    "vkCmdPushDescriptorSetWithTemplateKHR": FORWARD,  # TEMPLATE_COMMANDS: hand-written body
    "vkCmdResetEvent": FORWARD,
    "vkCmdResetEvent2": FORWARD,
    "vkCmdResetQueryPool": FORWARD,
    "vkCmdResolveImage": FORWARD,
    "vkCmdResolveImage2": FORWARD,
    "vkCmdSetBlendConstants": FORWARD,
    "vkCmdSetCullMode": FORWARD,
    "vkCmdSetDepthBias": FORWARD,
    "vkCmdSetDepthBiasEnable": FORWARD,
    "vkCmdSetDepthBounds": FORWARD,
    "vkCmdSetDepthBoundsTestEnable": FORWARD,
    "vkCmdSetDepthCompareOp": FORWARD,
    "vkCmdSetDepthTestEnable": FORWARD,
    "vkCmdSetDepthWriteEnable": FORWARD,
    "vkCmdSetDeviceMask": FORWARD,
    "vkCmdSetEvent": FORWARD,
    "vkCmdSetEvent2": FORWARD,
    "vkCmdSetFrontFace": FORWARD,
    "vkCmdSetLineStippleEXT": FORWARD,
    "vkCmdSetLineWidth": FORWARD,
    "vkCmdSetLogicOpEXT": FORWARD,
    "vkCmdSetPatchControlPointsEXT": FORWARD,
    "vkCmdSetPrimitiveRestartEnable": FORWARD,
    "vkCmdSetPrimitiveTopology": FORWARD,
    "vkCmdSetRasterizerDiscardEnable": FORWARD,
    "vkCmdSetScissor": FORWARD,
    "vkCmdSetScissorWithCount": FORWARD,
    "vkCmdSetStencilCompareMask": FORWARD,
    "vkCmdSetStencilOp": FORWARD,
    "vkCmdSetStencilReference": FORWARD,
    "vkCmdSetStencilTestEnable": FORWARD,
    "vkCmdSetStencilWriteMask": FORWARD,
    "vkCmdSetViewport": FORWARD,
    "vkCmdSetViewportWithCount": FORWARD,
    "vkCmdUpdateBuffer": FORWARD,
    "vkCmdWaitEvents": FORWARD,
    "vkCmdWaitEvents2": FORWARD,
    # Pulled in by VK_KHR_synchronization2's interaction with VK_AMD_buffer_marker: apps cannot
    # reach it (the extension is hidden), but if one did it would be a recorded command like any other.
    "vkCmdWriteBufferMarker2AMD": FORWARD,
    "vkCmdWriteTimestamp": FORWARD,
    "vkCmdWriteTimestamp2": FORWARD,

    # --- Engines' extensions (allowlist.py): recorded like the core vkCmd*. -----------
    # The predicate buffer is the agent's own, written by the same replayed copies and memory data.
    "vkCmdBeginConditionalRenderingEXT": FORWARD,
    "vkCmdEndConditionalRenderingEXT": FORWARD,
    # Transform feedback captures vertices before the viewport transform, so the scaled viewports
    # of a split pass change nothing it writes; each side captures into its own buffers.
    "vkCmdBindTransformFeedbackBuffersEXT": FORWARD,
    "vkCmdBeginTransformFeedbackEXT": FORWARD,
    "vkCmdEndTransformFeedbackEXT": FORWARD,
    "vkCmdBeginQueryIndexedEXT": FORWARD,
    "vkCmdEndQueryIndexedEXT": FORWARD,
    "vkCmdDrawIndirectByteCountEXT": FORWARD,
    "vkCmdSetColorWriteEnableEXT": FORWARD,
    "vkCmdSetVertexInputEXT": FORWARD,
    # VK_EXT_extended_dynamic_state3. Every command is forwarded; the features of the ones whose
    # state belongs to withheld extensions are cleared (allowlist.WITHHELD_FEATURES), so an
    # application cannot reach those.
    "vkCmdSetTessellationDomainOriginEXT": FORWARD,
    "vkCmdSetDepthClampEnableEXT": FORWARD,
    "vkCmdSetPolygonModeEXT": FORWARD,
    "vkCmdSetRasterizationSamplesEXT": FORWARD,
    "vkCmdSetSampleMaskEXT": FORWARD,
    "vkCmdSetAlphaToCoverageEnableEXT": FORWARD,
    "vkCmdSetAlphaToOneEnableEXT": FORWARD,
    "vkCmdSetLogicOpEnableEXT": FORWARD,
    "vkCmdSetColorBlendEnableEXT": FORWARD,
    "vkCmdSetColorBlendEquationEXT": FORWARD,
    "vkCmdSetColorWriteMaskEXT": FORWARD,
    "vkCmdSetRasterizationStreamEXT": FORWARD,
    "vkCmdSetConservativeRasterizationModeEXT": FORWARD,
    "vkCmdSetExtraPrimitiveOverestimationSizeEXT": FORWARD,
    "vkCmdSetDepthClipEnableEXT": FORWARD,
    "vkCmdSetSampleLocationsEnableEXT": FORWARD,
    "vkCmdSetColorBlendAdvancedEXT": FORWARD,
    "vkCmdSetProvokingVertexModeEXT": FORWARD,
    "vkCmdSetLineRasterizationModeEXT": FORWARD,
    "vkCmdSetLineStippleEnableEXT": FORWARD,
    "vkCmdSetDepthClipNegativeOneToOneEXT": FORWARD,
    "vkCmdSetViewportWScalingEnableNV": FORWARD,
    "vkCmdSetViewportSwizzleNV": FORWARD,
    "vkCmdSetCoverageToColorEnableNV": FORWARD,
    "vkCmdSetCoverageToColorLocationNV": FORWARD,
    "vkCmdSetCoverageModulationModeNV": FORWARD,
    "vkCmdSetCoverageModulationTableEnableNV": FORWARD,
    "vkCmdSetCoverageModulationTableNV": FORWARD,
    "vkCmdSetShadingRateImageEnableNV": FORWARD,
    "vkCmdSetRepresentativeFragmentTestEnableNV": FORWARD,
    "vkCmdSetCoverageReductionModeNV": FORWARD,
    # Timestamps are the client's queries, calibrated against the client's clocks.
    "vkGetPhysicalDeviceCalibrateableTimeDomainsEXT": LOCAL,
    "vkGetCalibratedTimestampsEXT": LOCAL,
}

def classify(model) -> dict[str, str]:
    """{command name: FORWARD|LOCAL|MANUAL} for every non-alias command of the model.

    Fails (SystemExit) when a command is unclassified or the table names a command that is not
    in the model, so the table and the allow-list cannot drift apart silently.
    """
    result = {}
    unclassified = []
    names = set()
    for command in model.commands:
        if command.alias:
            continue
        names.add(command.name)
        if command.name in POLICY:
            result[command.name] = POLICY[command.name]
        else:
            unclassified.append(command.name)
    if unclassified:
        raise SystemExit("codec_policy.py: unclassified commands (decide forward/local/manual): " +
                         ", ".join(sorted(unclassified)))
    stale = set(POLICY) - names
    if stale:
        raise SystemExit("codec_policy.py: classified commands not in the model: " + ", ".join(sorted(stale)))
    bad_templates = {n for n in TEMPLATE_COMMANDS if result.get(n) not in (FORWARD, MANUAL)}
    if bad_templates:
        raise SystemExit("codec_policy.py: template commands must be forwarded: " + ", ".join(sorted(bad_templates)))
    return result
