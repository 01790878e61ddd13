"""Which layer entry points call hand-written code, listed under the layer file of their Vulkan concept.

Everything not listed here gets a generated forwarded entry point (emit_layer.py). Four lists:
OBSERVED_COMMANDS (generated, and a hand-written observer of state the layer tracks),
REWRITTEN_COMMANDS (generated capture, and a hand-written hook that passes down the split's changed
call), EDITED_COMMANDS (generated, and a hand-written hook that edits what the driver answered) and
MANUAL_COMMANDS (whole entry points by hand). Keep the manual list to what the other three cannot
express: object lifetime of the dispatchable handles, the loader interface, memory, queue submits.
LOCKED_HANDLES says which lock every call down on a handle takes.
"""

MANUAL_COMMANDS = {
    # layer.cpp: the loader interface.
    "vkGetInstanceProcAddr",
    "vkGetDeviceProcAddr",
    # instance.cpp: the instance chain and our own layer's (empty) extension lists.
    "vkCreateInstance",
    "vkDestroyInstance",
    "vkEnumerateDeviceExtensionProperties",
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
    # memory.cpp: allocations, maps and the shadow copies behind MemoryData.
    "vkAllocateMemory",
    "vkFreeMemory",
    "vkMapMemory",
    "vkUnmapMemory",
    "vkFlushMappedMemoryRanges",
    # queue.cpp: queues (their family, for the layer's own submits) and submits (dirty memory first,
    # then the submit), each under the queue's lock (LOCKED_HANDLES).
    "vkGetDeviceQueue",
    "vkGetDeviceQueue2",
    "vkQueueSubmit",
    "vkQueueSubmit2",
    "vkQueueSubmit2KHR",
    "vkQueueBindSparse",
    "vkQueueWaitIdle",
    "vkDeviceWaitIdle",
    # swapchain.cpp / present.cpp: swapchain images and frame marks.
    "vkCreateSwapchainKHR",
    "vkDestroySwapchainKHR",
    "vkAcquireNextImageKHR",
    "vkAcquireNextImage2KHR",
    "vkQueuePresentKHR",
    # resource.cpp: TRANSFER_SRC added down the chain, so that a snapshot can read contents back; a
    # linear image's layouts are sent after its capture (the buffer's create is rewritten: below).
    "vkCreateImage",
}

# Commands whose generated entry point also tells a hand-written observer, after the call went down
# and was captured (a destroy's observer: before the call goes down, so that the driver cannot have
# reused the handle value for a new object whose state the observer would remove):
# observe::<Name>(DeviceState &, <the command's parameters>) in the namespace
# splitvk::observe, called only on a device with a session and, for VkResult commands, on success.
# A command that returns another value (an address) passes it first:
# observe::<Name>(DeviceState &, <the value>, <the command's parameters>).
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
    # resource.cpp: the client's buffer address, sent to the agent (BufferAddress).
    "vkGetBufferDeviceAddress",
    "vkGetBufferDeviceAddressKHR",
    # descriptor_set.cpp: which bindings have immutable samplers (the encoder must skip those), and
    # the sets of each pool, which its reset and destroy free (frees and resets are observed and
    # captured before the call, as destroys: emit_layer.py).
    "vkCreateDescriptorSetLayout",
    "vkDestroyDescriptorSetLayout",
    "vkAllocateDescriptorSets",
    "vkFreeDescriptorSets",
    "vkResetDescriptorPool",
    "vkDestroyDescriptorPool",
    # descriptor_set.cpp (update templates): the template layout pData is encoded with (the updates' captures
    # look it up: emit_layer.py, codec_policy.TEMPLATE_COMMANDS).
    "vkCreateDescriptorUpdateTemplate",
    "vkCreateDescriptorUpdateTemplateKHR",
    "vkDestroyDescriptorUpdateTemplate",
    "vkDestroyDescriptorUpdateTemplateKHR",
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
    # resource.cpp: TRANSFER_SRC added down the chain, so that a snapshot can read the buffer back.
    "vkCreateBuffer",
}

# Commands whose answer the layer edits before the application sees it, by canonical name: their
# aliases follow. The generated entry point calls down through the called command's own dispatch
# slot, then the hand-written hook edit::<Name>(<the command's parameters>) in the namespace
# splitvk::edit, which changes the outputs in place. For queries the codec does not encode.
EDITED_COMMANDS = {
    # physical_device.cpp: the device envelope the application is told (limits, features, formats).
    "vkGetPhysicalDeviceProperties",
    "vkGetPhysicalDeviceProperties2",
    "vkGetPhysicalDeviceFeatures",
    "vkGetPhysicalDeviceFeatures2",
    "vkGetPhysicalDeviceFormatProperties",
    "vkGetPhysicalDeviceFormatProperties2",
}

# The lock every call down on a handle of the type takes, by the function that returns it held.
# Vulkan requires the operations of one queue to be externally synchronised, and the layer's present
# thread (present.cpp) uses the application's queues: every generated entry point called on a queue
# holds its lock around the call down, and the manual queue commands (queue.cpp, present.cpp) take
# the same lock by hand.
LOCKED_HANDLES = {
    "VkQueue": "lock_queue",
}

# Global commands are answered by the loader from the manifest for interface version 2 layers;
# the layer neither intercepts nor dispatches them.
LOADER_ANSWERED = {
    "vkEnumerateInstanceExtensionProperties",
    "vkEnumerateInstanceLayerProperties",
    "vkEnumerateInstanceVersion",
}
