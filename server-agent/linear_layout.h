#pragma once

// Where the rows of one subresource of a linear image are, on the client and on the agent, and
// the copy of a byte range from one layout to the other (memory_rebind.h). Plain integers, no
// Vulkan calls, so that the arithmetic is tested on its own (tests/unit/linear_layout_test.cpp).

#include <algorithm>
#include <cstdint>
#include <cstring>

namespace splitvk::agent {

// `rows` rows of `row_bytes` (texel blocks) in each of `slices` depth slices.
struct RowShape {
    uint64_t row_bytes = 0;
    uint32_t rows = 0;
    uint32_t slices = 0;
};

// One side's placement of a subresource: from the image's first byte.
struct RowPlacement {
    uint64_t offset = 0;
    uint64_t row_pitch = 0;
    uint64_t depth_pitch = 0;
};

// The bytes from the subresource's offset to the end of its last row; false when its rows
// overlap (a pitch shorter than what it steps over). Callers bound pitches by 2^40 and counts by
// 2^16, so nothing here overflows.
inline bool row_span(const RowShape &shape, const RowPlacement &at, uint64_t *span) {
    if (shape.rows == 0 || shape.slices == 0 || at.row_pitch < shape.row_bytes) return false;
    const uint64_t slice = uint64_t{shape.rows - 1} * at.row_pitch + shape.row_bytes;
    if (shape.slices > 1 && at.depth_pitch < slice) return false;
    *span = uint64_t{shape.slices - 1} * at.depth_pitch + slice;
    return true;
}

struct Relayout {
    RowShape shape;
    RowPlacement client, agent;
};

// `n` bytes at `src`, which the client wrote at `at` bytes into its image, into `dst` (the agent's
// image) where the agent's layout puts them. Only the rows [at, at + n) touches are visited; bytes
// in the client's padding are dropped. `dst` must hold the agent's row_span past agent.offset.
inline void relay_rows(const Relayout &l, uint8_t *dst, uint64_t at, const uint8_t *src, uint64_t n) {
    const uint64_t end = at + n;
    for (uint32_t z = 0; z < l.shape.slices; ++z) {
        const uint64_t base = l.client.offset + z * l.client.depth_pitch;
        const uint64_t last = base + uint64_t{l.shape.rows - 1} * l.client.row_pitch + l.shape.row_bytes;
        if (end <= base || at >= last) continue;
        for (uint64_t y = at > base ? (at - base) / l.client.row_pitch : 0; y < l.shape.rows; ++y) {
            const uint64_t row = base + y * l.client.row_pitch;
            if (row >= end) break;
            const uint64_t from = std::max(at, row);
            const uint64_t to = std::min(end, row + l.shape.row_bytes);
            if (from >= to) continue; // [at, end) lies in this row's padding
            std::memcpy(dst + l.agent.offset + z * l.agent.depth_pitch + y * l.agent.row_pitch + (from - row),
                        src + (from - at), to - from);
        }
    }
}

} // namespace splitvk::agent
