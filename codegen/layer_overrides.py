"""Which layer entry points call hand-written code, listed under the layer file of their Vulkan concept.

Everything not listed here gets a generated forwarded entry point (emit_layer.py). Three lists:
OBSERVED_COMMANDS (generated, and a hand-written observer of state the layer tracks),
REWRITTEN_COMMANDS (generated capture, and a hand-written hook that passes down the split's changed
call) and MANUAL_COMMANDS (whole entry points by hand). Keep the manual list to what the other two
cannot express: object lifetime of the dispatchable handles, the loader interface, memory, queues.
"""

MANUAL_COMMANDS = {
    # layer.cpp: the loader interface.
    "vkGetInstanceProcAddr",
    "vkGetDeviceProcAddr",
    # instance.cpp: the instance chain and our own layer's (empty) extension lists.
    "vkCreateInstance",
    "vkDestroyInstance",
    "vkEnumerateDeviceExtensionProperties",
    # physical_device.cpp: the device envelope the application is told.
    "vkGetPhysicalDeviceProperties",
    "vkGetPhysicalDeviceProperties2",
    "vkGetPhysicalDeviceProperties2KHR",
    "vkGetPhysicalDeviceFeatures",
    "vkGetPhysicalDeviceFeatures2",
    "vkGetPhysicalDeviceFeatures2KHR",
    "vkGetPhysicalDeviceFormatProperties",
    "vkGetPhysicalDeviceFormatProperties2",
    "vkGetPhysicalDeviceFormatProperties2KHR",
    # device.cpp: the device chain.
    "vkCreateDevice",
    "vkDestroyDevice",
    # command_buffer.cpp: per-command-buffer streams (begin resets, end sends) and their lifetime.
    "vkAllocateCommandBuffers",
    "vkFreeCommandBuffers",
    "vkBeginCommandBuffer",
    "vkEndCommandBuffer",
    "vkResetCommandBuffer",
    "vkResetCommandPool",
    "vkDestroyCommandPool",
    # descriptor_set.cpp (update templates): the template layout pData is encoded with.
    "vkCreateDescriptorUpdateTemplate",
    "vkCreateDescriptorUpdateTemplateKHR",
    "vkDestroyDescriptorUpdateTemplate",
    "vkDestroyDescriptorUpdateTemplateKHR",
    "vkUpdateDescriptorSetWithTemplate",
    "vkUpdateDescriptorSetWithTemplateKHR",
    "vkCmdPushDescriptorSetWithTemplateKHR",
    # descriptor_set.cpp: which bindings have immutable samplers (the encoder must skip those).
    "vkCreateDescriptorSetLayout",
    "vkDestroyDescriptorSetLayout",
    "vkAllocateDescriptorSets",
    "vkFreeDescriptorSets",
    "vkResetDescriptorPool",
    "vkDestroyDescriptorPool",
    # memory.cpp: allocations, maps and the shadow copies behind MemoryData.
    "vkAllocateMemory",
    "vkFreeMemory",
    "vkMapMemory",
    "vkUnmapMemory",
    "vkFlushMappedMemoryRanges",
    # queue.cpp: queues (their family, for the layer's own submits) and submits (dirty memory first, then the submit).
    # Every queue operation takes the queue's lock: the layer's present thread uses the app's queues too.
    "vkGetDeviceQueue",
    "vkGetDeviceQueue2",
    "vkQueueSubmit",
    "vkQueueSubmit2",
    "vkQueueSubmit2KHR",
    "vkQueueBindSparse",
    "vkQueueWaitIdle",
    "vkDeviceWaitIdle",
    "vkQueueBeginDebugUtilsLabelEXT",
    "vkQueueEndDebugUtilsLabelEXT",
    "vkQueueInsertDebugUtilsLabelEXT",
    # swapchain.cpp / present.cpp: swapchain images and frame marks.
    "vkCreateSwapchainKHR",
    "vkDestroySwapchainKHR",
    "vkAcquireNextImageKHR",
    "vkAcquireNextImage2KHR",
    "vkQueuePresentKHR",
    # resource.cpp: TRANSFER_SRC added down the chain, so that a snapshot can read contents back.
    "vkCreateBuffer",
    "vkCreateImage",
    # resource.cpp: the client's buffer address, sent to the agent (BufferAddress).
    "vkGetBufferDeviceAddress",
    "vkGetBufferDeviceAddressKHR",
}

# Commands whose generated entry point also tells a hand-written observer, after the call went down
# and was captured (a destroy's observer: before the call goes down, so that the driver cannot have
# reused the handle value for a new object whose state the observer would remove):
# observe::<Name>(DeviceState &, <the command's parameters>) in the namespace
# splitvk::observe, called only on a device with a session and, for VkResult commands, on success.
# For state the layer tracks but does not change (docs/architecture.md §3: the snapshot of a resync replays it).
OBSERVED_COMMANDS = {
    # resource.cpp: where buffers and images live, and the layout of every image subresource, so
    # that a snapshot can read their contents back.
    "vkDestroyBuffer",
    "vkDestroyImage",
    "vkBindBufferMemory",
    "vkBindBufferMemory2",
    "vkBindBufferMemory2KHR",
    "vkBindImageMemory",
    "vkBindImageMemory2",
    "vkBindImageMemory2KHR",
    "vkCmdPipelineBarrier",
    "vkCmdPipelineBarrier2",
    "vkCmdPipelineBarrier2KHR",
    "vkCmdWaitEvents",
    "vkCmdWaitEvents2",
    "vkCmdWaitEvents2KHR",
    "vkCreateRenderPass",
    "vkCreateRenderPass2",
    "vkCreateRenderPass2KHR",
    "vkDestroyRenderPass",
    # transfer.cpp: the compute descriptor sets bound, for dispatches over screen-space targets.
    "vkCmdBindDescriptorSets",
    # transfer.cpp: an indirect dispatch over a screen-space target, said once (not scaled).
    "vkCmdDispatchIndirect",
    # render_pass.cpp: the foveae of the viewports that executed secondaries drew with, and which
    # passes draw into swapchain images (their views and swapchain images; framebuffers: below).
    "vkCmdExecuteCommands",
    "vkGetSwapchainImagesKHR",
    "vkCreateImageView",
    "vkDestroyImageView",
    "vkDestroyFramebuffer",
    # pipeline.cpp: the static viewport/scissor state of pipelines the layer made dynamic.
    "vkDestroyPipeline",
}

# Commands the split rewrites (layer/capture/split.h), by canonical name: their aliases follow. The
# generated entry point captures the application's original call (a command buffer's stream, or
# the global stream with its live-state change: a destroy's before the call goes down, a create's
# after it, on success), then calls the hand-written hook
# rewrite::<Name>(DeviceState &, PFN_<name> down, <the command's parameters>) in the namespace
# splitvk::rewrite, which changes only what the split changes and makes the driver call through
# `down` (the called alias's own dispatch slot). Called only on a device with a session: without
# one the call goes down as made. For changes to what the driver is told; state the layer only
# tracks is observed (above).
REWRITTEN_COMMANDS = {
    # pipeline.cpp (dynamic state): the app's dynamic viewports/scissors, kept unscaled, passed down scaled in a split pass.
    "vkCmdSetViewport",
    "vkCmdSetViewportWithCount",
    "vkCmdSetScissor",
    "vkCmdSetScissorWithCount",
    # transfer.cpp: regions of screen-space targets scaled, copies and blits into swapchain images
    # drawn into the scaled top-left, dispatches over scaled storage images scaled.
    "vkCmdCopyImage",
    "vkCmdCopyImage2",
    "vkCmdResolveImage",
    "vkCmdResolveImage2",
    "vkCmdBlitImage",
    "vkCmdBlitImage2",
    "vkCmdCopyBufferToImage",
    "vkCmdCopyBufferToImage2",
    "vkCmdCopyImageToBuffer",
    "vkCmdCopyImageToBuffer2",
    "vkCmdDispatch",
    "vkCmdDispatchBase",
    # render_pass.cpp: passes into swapchain images and screen-space targets (split passes), their
    # scaled render area and clear rects, the viewport/scissor state re-emitted at their begin and
    # end, and framebuffers holding a screen-space target created at the scaled size.
    "vkCreateFramebuffer",
    "vkCmdBeginRenderPass",
    "vkCmdBeginRenderPass2",
    "vkCmdEndRenderPass",
    "vkCmdEndRenderPass2",
    "vkCmdBeginRendering",
    "vkCmdEndRendering",
    "vkCmdClearAttachments",
    # pipeline.cpp: static viewport/scissor state made dynamic down the chain, set at bind.
    "vkCreateGraphicsPipelines",
    "vkCmdBindPipeline",
}

# Global commands are answered by the loader from the manifest for interface version 2 layers;
# the layer neither intercepts nor dispatches them.
LOADER_ANSWERED = {
    "vkEnumerateInstanceExtensionProperties",
    "vkEnumerateInstanceLayerProperties",
    "vkEnumerateInstanceVersion",
}
