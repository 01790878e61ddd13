"""Commands whose layer entry point is written by hand, in the layer file of their Vulkan concept.

Everything else gets a generated entry point. Keep this list to real semantics: object lifetime
of the dispatchable handles, the loader interface, and (later) what the split rewrite changes.
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
    # descriptor_template.cpp: the template layout pData is encoded with.
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
    "vkGetDeviceQueue",
    "vkGetDeviceQueue2",
    "vkQueueSubmit",
    "vkQueueSubmit2",
    "vkQueueSubmit2KHR",
    # swapchain.cpp / present.cpp: swapchain images and frame marks.
    "vkCreateSwapchainKHR",
    "vkDestroySwapchainKHR",
    "vkAcquireNextImageKHR",
    "vkAcquireNextImage2KHR",
    "vkQueuePresentKHR",
}

# Global commands are answered by the loader from the manifest for interface version 2 layers;
# the layer neither intercepts nor dispatches them.
LOADER_ANSWERED = {
    "vkEnumerateInstanceExtensionProperties",
    "vkEnumerateInstanceLayerProperties",
    "vkEnumerateInstanceVersion",
}
