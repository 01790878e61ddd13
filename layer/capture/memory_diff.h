#pragma once

// The shadow-copy comparison behind MemoryData (docs/architecture.md §3): which blocks of a mapped range the
// host changed since the last comparison, and what the shadow of a range starts from. Plain
// functions and values, unit-tested on their own.

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <memory>
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

// The byte ranges of an allocation that the agent holds as the client does while the memory is
// not mapped: a range was mapped and its last changes sent at the unmap, or a new agent was given
// every byte. The rest the agent has as it zero-filled it (or as its own GPU wrote it).
class KnownRanges {
public:
    struct Range {
        size_t begin = 0;
        size_t end = 0; // exclusive
        bool operator==(const Range &) const = default;
    };

    void add(size_t begin, size_t end);
    void clear() { ranges_.clear(); }
    // Sorted, disjoint and never adjacent (touching ranges are merged).
    const std::vector<Range> &ranges() const { return ranges_; }

private:
    std::vector<Range> ranges_;
};

// The shadow of one mapped range, [offset, offset + size) of its allocation: what the agent holds
// there, compared with the mapped bytes at each sync. Host memory for it is held from the map to
// the unmap only, and only for the mapped range.
class MappedShadow {
public:
    // Starts the shadow from `current` (the mapped bytes) where `known` says the agent has them and
    // from zeros elsewhere. False when the host memory cannot be had: the shadow stays empty and
    // the caller sends the whole range at each sync instead.
    bool begin(const uint8_t *current, size_t offset, size_t size, const KnownRanges &known);
    // The shadow becomes `current`: a new agent was given these bytes.
    void assign(const uint8_t *current);
    // diff_and_update() over the whole range; runs are relative to the mapped range.
    void diff(const uint8_t *current, std::vector<DirtyRun> &runs);
    // The shadow's bytes at `offset` into the mapped range.
    const uint8_t *data(size_t offset) const { return bytes_.get() + offset; }
    bool empty() const { return !bytes_; }
    size_t size() const { return size_; }
    void release();

private:
    struct Free {
        void operator()(uint8_t *p) const { std::free(p); }
    };
    std::unique_ptr<uint8_t[], Free> bytes_;
    size_t size_ = 0;
};

} // namespace splitvk
