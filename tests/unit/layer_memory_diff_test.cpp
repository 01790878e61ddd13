// The shadow comparison behind MemoryData (layer/memory_diff.h): changed blocks, merged runs,
// short last blocks, and the shadow kept in step so a second comparison finds nothing.
#include "memory_diff.h"

#include <vector>

#include <gtest/gtest.h>

namespace splitvk {
namespace {

TEST(LayerMemoryDiff, ZeroShadowFindsEveryWrittenBlockOnce) {
    std::vector<uint8_t> mapped(4096, 0), shadow(4096, 0);
    mapped[10] = 1;   // block 0
    mapped[300] = 2;  // block 1 (adjacent: merged with block 0)
    mapped[2000] = 3; // block 7
    std::vector<DirtyRun> runs;
    diff_and_update(mapped.data(), shadow.data(), mapped.size(), runs);
    EXPECT_EQ(runs, (std::vector<DirtyRun>{{0, 512}, {1792, 256}}));
    EXPECT_EQ(shadow, mapped);
    runs.clear();
    diff_and_update(mapped.data(), shadow.data(), mapped.size(), runs);
    EXPECT_TRUE(runs.empty()); // nothing changed since: nothing is sent again
}

TEST(LayerMemoryDiff, ShortLastBlockAndOffsets) {
    // A map of 1000 bytes at offset 100 of a 2000-byte allocation: the caller compares against the
    // shadow at that offset; runs are relative to the map.
    std::vector<uint8_t> allocation_shadow(2000, 0);
    std::vector<uint8_t> mapped(1000, 0);
    mapped[999] = 7; // in the short last block (768..999)
    std::vector<DirtyRun> runs;
    diff_and_update(mapped.data(), allocation_shadow.data() + 100, mapped.size(), runs);
    ASSERT_EQ(runs.size(), 1u);
    EXPECT_EQ(runs[0], (DirtyRun{768, 232}));
    EXPECT_EQ(allocation_shadow[1099], 7);
    EXPECT_EQ(allocation_shadow[99], 0);
}

TEST(LayerMemoryDiff, PersistentMapSeesLaterWrites) {
    // A persistently mapped, coherent buffer written every frame (uniforms): each comparison sends
    // exactly what changed since the previous one.
    std::vector<uint8_t> mapped(1024, 0), shadow(1024, 0);
    std::vector<DirtyRun> runs;
    for (uint8_t frame = 1; frame <= 3; ++frame) {
        mapped[512 + frame] = frame;
        runs.clear();
        diff_and_update(mapped.data(), shadow.data(), mapped.size(), runs);
        EXPECT_EQ(runs, (std::vector<DirtyRun>{{512, 256}})) << int(frame);
    }
}

TEST(LayerMemoryDiff, WholeRangeChangedIsOneRun) {
    std::vector<uint8_t> mapped(100000, 0xAB), shadow(100000, 0);
    std::vector<DirtyRun> runs;
    diff_and_update(mapped.data(), shadow.data(), mapped.size(), runs, 4096);
    EXPECT_EQ(runs, (std::vector<DirtyRun>{{0, 100000}}));
}

} // namespace
} // namespace splitvk
