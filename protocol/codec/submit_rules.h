#pragma once

// Rules both ends of a session apply to submits and presented images, kept in one place.

#include <vulkan/vulkan.h>

#include <type_traits>
#include <vector>

namespace splitvk::codec {

// The agent executes every submit in order on one queue, and the client's semaphores are signalled
// by its own presentation engine, so a replayed submit keeps only its command buffers: semaphores
// and pNext (timeline values, device groups) are dropped. The layer applies this before sending,
// the agent again on receipt, since it does not trust the client.
template <typename SubmitInfo>
std::vector<SubmitInfo> without_synchronization(const SubmitInfo *submits, uint32_t count) {
    std::vector<SubmitInfo> out(submits, submits + count);
    for (SubmitInfo &s : out) {
        s.pNext = nullptr;
        if constexpr (std::is_same_v<SubmitInfo, VkSubmitInfo>) {
            s.waitSemaphoreCount = 0;
            s.pWaitSemaphores = nullptr;
            s.pWaitDstStageMask = nullptr;
            s.signalSemaphoreCount = 0;
            s.pSignalSemaphores = nullptr;
        } else {
            static_assert(std::is_same_v<SubmitInfo, VkSubmitInfo2>);
            s.waitSemaphoreInfoCount = 0;
            s.pWaitSemaphoreInfos = nullptr;
            s.signalSemaphoreInfoCount = 0;
            s.pSignalSemaphoreInfos = nullptr;
        }
    }
    return out;
}

// Formats whose presented images verification compares: 4 bytes per pixel, 8 bits per channel.
inline bool is_verifiable_format(VkFormat format) {
    switch (format) {
    case VK_FORMAT_B8G8R8A8_UNORM:
    case VK_FORMAT_B8G8R8A8_SRGB:
    case VK_FORMAT_R8G8B8A8_UNORM:
    case VK_FORMAT_R8G8B8A8_SRGB:
        return true;
    default:
        return false;
    }
}

} // namespace splitvk::codec
