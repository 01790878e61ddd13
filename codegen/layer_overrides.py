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
}

# Global commands are answered by the loader from the manifest for interface version 2 layers;
# the layer neither intercepts nor dispatches them.
LOADER_ANSWERED = {
    "vkEnumerateInstanceExtensionProperties",
    "vkEnumerateInstanceLayerProperties",
    "vkEnumerateInstanceVersion",
}
