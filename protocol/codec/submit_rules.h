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

// A queue-family ownership transfer to or from another process (VK_QUEUE_FAMILY_EXTERNAL or
// _FOREIGN_EXT): an OpenXR runtime's client compositor hands each eye image to its service this way,
// and takes it back before the application draws again (docs/architecture.md §9). The agent has no such
// process and replays the image as an ordinary one, which such a transfer is invalid on; replayed as a
// barrier of its one queue (both families ignored), it keeps the layout transition and the access
// masks. Returns whether `barrier` was changed.
inline bool is_other_process_queue_family(uint32_t family) {
    return family == VK_QUEUE_FAMILY_EXTERNAL || family == VK_QUEUE_FAMILY_FOREIGN_EXT;
}
template <typename Barrier>
bool make_queue_families_local(Barrier &barrier) {
    if (!is_other_process_queue_family(barrier.srcQueueFamilyIndex) &&
        !is_other_process_queue_family(barrier.dstQueueFamilyIndex))
        return false;
    barrier.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    barrier.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    return true;
}
// The barriers of `barriers` with other processes' queue families made local; empty when none
// names one (the caller then passes the original array down).
template <typename Barrier>
std::vector<Barrier> with_local_queue_families(const Barrier *barriers, uint32_t count) {
    std::vector<Barrier> out;
    for (uint32_t i = 0; i < count; ++i) {
        if (!is_other_process_queue_family(barriers[i].srcQueueFamilyIndex) &&
            !is_other_process_queue_family(barriers[i].dstQueueFamilyIndex))
            continue;
        out.assign(barriers, barriers + count);
        for (Barrier &b : out)
            make_queue_families_local(b);
        break;
    }
    return out;
}

} // namespace splitvk::codec
