#pragma once

// The shadow-copy comparison behind MemoryData (DESIGN §3): which blocks of a mapped range the
// host changed since the last comparison. Plain functions, unit-tested on their own.

#include <cstddef>
#include <cstdint>
#include <vector>

namespace splitvk {

inline constexpr size_t kMemoryBlockSize = 256;

struct DirtyRun {
    size_t offset = 0; // from the start of the compared range
    size_t size = 0;
    bool operator==(const DirtyRun &) const = default;
};

// Compares `size` bytes of `current` with `shadow` in blocks of `block` bytes (the last block may
// be shorter), copies every changed block into `shadow`, and appends the changed blocks to `runs`
// merged into maximal runs of adjacent blocks. Send the shadow's bytes, never `current` again: the
// host may be writing it concurrently.
void diff_and_update(const uint8_t *current, uint8_t *shadow, size_t size, std::vector<DirtyRun> &runs,
                     size_t block = kMemoryBlockSize);

} // namespace splitvk
