#pragma once

// What the e2e tests' present layers (hold_layer/, present_fault_layer/) share: each intercepts
// vkQueuePresentKHR and nothing else, so all it writes is present() below; present_layer.cpp,
// compiled into each, answers vkQueuePresentKHR with it, over the loader plumbing of every test
// layer (test_layer/).

#include <vulkan/vk_layer.h>
#include <vulkan/vulkan.h>

namespace splitvk::present_layer {

// The next layer's (or the driver's) entry points of the device a queue belongs to.
struct Next {
    PFN_vkQueuePresentKHR present = nullptr;
    PFN_vkQueueSubmit submit = nullptr;
    PFN_vkQueueWaitIdle wait_idle = nullptr;
};

// Defined by each layer: its vkQueuePresentKHR. The caller holds the queue, as for any present.
VkResult present(const Next &next, VkQueue queue, const VkPresentInfoKHR *info);

} // namespace splitvk::present_layer
