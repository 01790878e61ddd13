// VkQueue: the queues a device was got, their families and locks (vk/queue.cpp fills them).

#include "core/queue.h"

namespace splitvk {

std::shared_ptr<QueueTable> make_queue_table() {
    return std::make_shared<QueueTable>();
}

uint32_t queue_family_of(const DeviceState &device, VkQueue queue) {
    const QueueInfo *info = device.queues->queues.find(queue);
    return info ? info->family : UINT32_MAX;
}

std::unique_lock<std::mutex> lock_queue(const DeviceState &device, VkQueue queue) {
    QueueInfo *info = device.queues->queues.find(queue);
    return info ? std::unique_lock(info->mutex) : std::unique_lock<std::mutex>();
}

std::unique_lock<std::mutex> lock_queue(VkQueue queue) {
    return lock_queue(device_state(queue), queue);
}

} // namespace splitvk
