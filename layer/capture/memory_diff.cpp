#include "capture/memory_diff.h"

#include <algorithm>
#include <cstring>

namespace splitvk {

void diff_and_update(const uint8_t *current, uint8_t *shadow, size_t size, std::vector<DirtyRun> &runs,
                     size_t block) {
    if (block == 0) block = kMemoryBlockSize;
    for (size_t offset = 0; offset < size; offset += block) {
        const size_t n = std::min(block, size - offset);
        if (std::memcmp(current + offset, shadow + offset, n) == 0) continue;
        std::memcpy(shadow + offset, current + offset, n);
        if (!runs.empty() && runs.back().offset + runs.back().size == offset)
            runs.back().size += n;
        else
            runs.push_back({offset, n});
    }
}

void KnownRanges::add(size_t begin, size_t end) {
    if (begin >= end) return;
    // The first range that ends at or after `begin` (it may touch the new one) ...
    auto first = std::lower_bound(ranges_.begin(), ranges_.end(), begin,
                                  [](const Range &r, size_t value) { return r.end < value; });
    // ... and the first that starts after `end` (it neither overlaps nor touches).
    auto last = std::upper_bound(first, ranges_.end(), end,
                                 [](size_t value, const Range &r) { return value < r.begin; });
    if (first != last) {
        begin = std::min(begin, first->begin);
        end = std::max(end, std::prev(last)->end);
    }
    ranges_.insert(ranges_.erase(first, last), Range{begin, end});
}

bool MappedShadow::begin(const uint8_t *current, size_t offset, size_t size, const KnownRanges &known) {
    release();
    // malloc, not new: a failure is an answer here, not an exception.
    bytes_.reset(static_cast<uint8_t *>(std::malloc(std::max<size_t>(size, 1))));
    if (!bytes_) return false;
    size_ = size;
    const size_t end = offset + size;
    size_t at = offset; // bytes before `at` are filled
    for (const KnownRanges::Range &r : known.ranges()) {
        if (r.end <= at) continue;
        if (r.begin >= end) break;
        const size_t from = std::max(r.begin, at), to = std::min(r.end, end);
        std::memset(bytes_.get() + (at - offset), 0, from - at);
        std::memcpy(bytes_.get() + (from - offset), current + (from - offset), to - from);
        at = to;
    }
    std::memset(bytes_.get() + (at - offset), 0, end - at);
    return true;
}

void MappedShadow::assign(const uint8_t *current) {
    if (bytes_) std::memcpy(bytes_.get(), current, size_);
}

void MappedShadow::diff(const uint8_t *current, std::vector<DirtyRun> &runs) {
    if (bytes_) diff_and_update(current, bytes_.get(), size_, runs);
}

void MappedShadow::release() {
    bytes_.reset();
    size_ = 0;
}

} // namespace splitvk
