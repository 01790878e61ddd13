// VkQueue: the queues a device was got, their families and locks (vk/queue.cpp fills them).

#include "core/queue.h"

namespace splitvk {

ObjectMap<VkQueue, QueueInfo> registry::g_queues;
using registry::g_queues;

uint32_t queue_family_of(VkQueue queue) {
    const QueueInfo *info = g_queues.find(queue);
    return info ? info->family : UINT32_MAX;
}

std::unique_lock<std::mutex> lock_queue(VkQueue queue) {
    QueueInfo *info = g_queues.find(queue);
    return info ? std::unique_lock(info->mutex) : std::unique_lock<std::mutex>();
}

} // namespace splitvk
