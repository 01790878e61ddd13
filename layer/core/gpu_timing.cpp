#include "core/gpu_timing.h"

#include "core/instance.h"

#include <mutex>
#include <unordered_map>
#include <vector>

namespace splitvk {
namespace {

constexpr uint32_t kPairs = 512; // command buffers timed at once; more go untimed

struct DeviceTiming {
    VkQueryPool pool = VK_NULL_HANDLE;
    bool unsupported = false;
    double period_ns = 1.0;
    uint32_t next_pair = 0;
    std::unordered_map<VkCommandBuffer, uint32_t> pairs; // command buffer -> its pair
    std::vector<bool> submitted = std::vector<bool>(kPairs);
    std::vector<bool> composite = std::vector<bool>(kPairs); // the pair times a composite (read apart)
    double latest_ms = 0;
    uint64_t calls = 0;
};

} // namespace

struct GpuTimingTable {
    std::mutex mutex; // `timing`, and every CommandTiming of the device while a function of this file uses it
    DeviceTiming timing;
};

std::shared_ptr<GpuTimingTable> make_gpu_timing_table() {
    return std::make_shared<GpuTimingTable>();
}

namespace {

// Under the table's lock: the device's pool, created on first use; nullptr when timestamps are
// unusable.
DeviceTiming *timing_locked(DeviceState &dev) {
    DeviceTiming &t = dev.gpu_timing->timing;
    if (t.pool || t.unsupported) return t.unsupported ? nullptr : &t;
    VkPhysicalDeviceProperties properties{};
    dev.instance->dispatch.GetPhysicalDeviceProperties(dev.physical_device, &properties);
    t.period_ns = properties.limits.timestampPeriod;
    VkQueryPoolCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO;
    info.queryType = VK_QUERY_TYPE_TIMESTAMP;
    info.queryCount = 2 * kPairs;
    // timestampComputeAndGraphics says every graphics queue has valid timestamps.
    if (!properties.limits.timestampComputeAndGraphics || t.period_ns <= 0 ||
        dev.dispatch.CreateQueryPool(dev.handle, &info, nullptr, &t.pool) != VK_SUCCESS) {
        t.unsupported = true;
        return nullptr;
    }
    return &t;
}

// Under the table's lock: `cb`'s pair, given on first use; nullptr when there is none.
const uint32_t *pair_locked(DeviceTiming &t, VkCommandBuffer cb) {
    auto found = t.pairs.find(cb);
    if (found == t.pairs.end()) {
        if (t.next_pair == kPairs) return nullptr;
        found = t.pairs.emplace(cb, t.next_pair++).first;
    }
    return &found->second;
}

} // namespace

void time_before_split_pass(DeviceState &dev, VkCommandBuffer cb, CommandTiming &timing) {
    std::lock_guard lock(dev.gpu_timing->mutex);
    if (timing.timed) return; // only the first split pass of a recording is timed
    DeviceTiming *t = timing_locked(dev);
    const uint32_t *pair = t ? pair_locked(*t, cb) : nullptr;
    if (!pair) return;
    t->composite[*pair] = false; // a handle a freed compositor's command buffer once had
    timing = CommandTiming{true, *pair, false, false};
    dev.dispatch.CmdResetQueryPool(cb, t->pool, 2 * *pair, 2);
}

void time_composite_begin(DeviceState &dev, VkCommandBuffer cb, CommandTiming &timing) {
    std::lock_guard lock(dev.gpu_timing->mutex);
    timing = {};
    DeviceTiming *t = timing_locked(dev);
    const uint32_t *pair = t ? pair_locked(*t, cb) : nullptr;
    if (!pair) return;
    t->composite[*pair] = true;
    timing = CommandTiming{true, *pair, true, false};
    dev.dispatch.CmdResetQueryPool(cb, t->pool, 2 * *pair, 2);
    dev.dispatch.CmdWriteTimestamp(cb, VK_PIPELINE_STAGE_TRANSFER_BIT, t->pool, 2 * *pair);
}

bool time_composite_end(DeviceState &dev, VkCommandBuffer cb, CommandTiming &timing, VkBuffer results) {
    std::lock_guard lock(dev.gpu_timing->mutex);
    if (!timing.timed || !timing.begun || timing.ended) return false;
    timing.ended = true;
    const VkQueryPool pool = dev.gpu_timing->timing.pool;
    const uint32_t first = 2 * timing.pair;
    dev.dispatch.CmdWriteTimestamp(cb, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, pool, first + 1);
    // WAIT_BIT: the copy waits on the queue for both timestamps, not the host.
    dev.dispatch.CmdCopyQueryPoolResults(cb, pool, first, 2, results, 0, sizeof(uint64_t),
                                         VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT);
    return true;
}

double timestamps_ms(DeviceState &dev, uint64_t begin, uint64_t end) {
    std::lock_guard lock(dev.gpu_timing->mutex);
    if (begin == 0 || end <= begin) return 0;
    return static_cast<double>(end - begin) * dev.gpu_timing->timing.period_ns / 1e6;
}

void time_split_pass_begun(DeviceState &dev, VkCommandBuffer cb, CommandTiming &timing) {
    std::lock_guard lock(dev.gpu_timing->mutex);
    if (!timing.timed || timing.begun) return;
    timing.begun = true;
    dev.dispatch.CmdWriteTimestamp(cb, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, dev.gpu_timing->timing.pool,
                                   2 * timing.pair);
}

void time_split_pass_ended(DeviceState &dev, VkCommandBuffer cb, CommandTiming &timing) {
    std::lock_guard lock(dev.gpu_timing->mutex);
    if (!timing.timed || !timing.begun || timing.ended) return;
    timing.ended = true;
    dev.dispatch.CmdWriteTimestamp(cb, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, dev.gpu_timing->timing.pool,
                                   2 * timing.pair + 1);
}

void note_timed_submit(DeviceState &dev, const CommandTiming &timing) {
    std::lock_guard lock(dev.gpu_timing->mutex);
    if (!timing.timed || !timing.ended) return;
    dev.gpu_timing->timing.submitted[timing.pair] = true;
}

double latest_periphery_ms(DeviceState &dev) {
    std::lock_guard lock(dev.gpu_timing->mutex);
    DeviceTiming &t = dev.gpu_timing->timing;
    if (!t.pool) return 0;
    if (t.calls++ % kPeripheryReadInterval != 0) return t.latest_ms;
    // Both timestamps of each submitted pair with their availability, without waiting: the most
    // recent completed measurement wins. Composites are read by the compositor itself.
    uint64_t latest_end = 0;
    for (uint32_t pair = 0; pair < t.next_pair; ++pair) {
        if (!t.submitted[pair] || t.composite[pair]) continue;
        uint64_t v[4] = {}; // begin, available, end, available
        dev.dispatch.GetQueryPoolResults(dev.handle, t.pool, 2 * pair, 2, sizeof(v), v, 2 * sizeof(uint64_t),
                                         VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WITH_AVAILABILITY_BIT);
        if (!v[1] || !v[3] || v[2] < v[0] || v[2] <= latest_end) continue;
        latest_end = v[2];
        t.latest_ms = static_cast<double>(v[2] - v[0]) * t.period_ns / 1e6;
    }
    return t.latest_ms;
}

void release_gpu_timing(DeviceState &dev) {
    std::lock_guard lock(dev.gpu_timing->mutex);
    DeviceTiming &t = dev.gpu_timing->timing;
    if (t.pool) dev.dispatch.DestroyQueryPool(dev.handle, t.pool, nullptr);
    t = DeviceTiming{};
}

} // namespace splitvk
