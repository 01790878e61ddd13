#include "memory_diff.h"

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

} // namespace splitvk
