// The shadow comparison behind MemoryData (layer/capture/memory_diff.h): changed blocks, merged runs,
// short last blocks, and the shadow kept in step so a second comparison finds nothing.
#include "capture/memory_diff.h"

#include <cstdlib>
#include <cstring>
#include <vector>

#include <gtest/gtest.h>
#include <sys/resource.h>

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

TEST(LayerKnownRanges, MergesOverlappingAndTouchingRanges) {
    KnownRanges known;
    known.add(100, 200);
    known.add(300, 400);
    known.add(0, 50);
    EXPECT_EQ(known.ranges(), (std::vector<KnownRanges::Range>{{0, 50}, {100, 200}, {300, 400}}));
    known.add(200, 300); // touches both neighbours
    EXPECT_EQ(known.ranges(), (std::vector<KnownRanges::Range>{{0, 50}, {100, 400}}));
    known.add(40, 120); // overlaps both
    EXPECT_EQ(known.ranges(), (std::vector<KnownRanges::Range>{{0, 400}}));
    known.add(10, 20); // inside
    known.add(5, 5);   // empty
    EXPECT_EQ(known.ranges(), (std::vector<KnownRanges::Range>{{0, 400}}));
}

TEST(LayerMappedShadow, CoversTheMappedRangeOnlyFromKnownBytesAndZeros) {
    // 4096 bytes mapped at offset 1000 of a larger allocation; an earlier map sent [1500, 2000),
    // so the agent holds those bytes, and zeros (its fill) elsewhere.
    std::vector<uint8_t> mapped(4096, 0xAB);
    KnownRanges known;
    known.add(1500, 2000);
    MappedShadow shadow;
    ASSERT_TRUE(shadow.begin(mapped.data(), 1000, mapped.size(), known));
    EXPECT_EQ(shadow.size(), mapped.size());
    std::vector<DirtyRun> runs;
    shadow.diff(mapped.data(), runs);
    // Everything but the known bytes differs from what the agent has; the blocks holding only
    // known bytes (map offsets 512..767, allocation 1512..1767) are not sent again.
    EXPECT_EQ(runs, (std::vector<DirtyRun>{{0, 512}, {768, 4096 - 768}}));
    EXPECT_EQ(std::memcmp(shadow.data(0), mapped.data(), mapped.size()), 0); // up to date now
    runs.clear();
    shadow.diff(mapped.data(), runs);
    EXPECT_TRUE(runs.empty());
    shadow.release();
    EXPECT_TRUE(shadow.empty());
    EXPECT_EQ(shadow.size(), 0u);
}

TEST(LayerMappedShadow, ARemapOfAnUnmappedRangeSendsOnlyNewWrites) {
    // Mapped, written, synced and unmapped: the unmap makes the range known. A second map of the
    // same range starts from its bytes, so only what is written after it is sent.
    std::vector<uint8_t> memory(2048, 0);
    KnownRanges known;
    MappedShadow shadow;
    ASSERT_TRUE(shadow.begin(memory.data(), 0, memory.size(), known));
    memory[5] = 1;
    std::vector<DirtyRun> runs;
    shadow.diff(memory.data(), runs);
    EXPECT_EQ(runs, (std::vector<DirtyRun>{{0, 256}}));
    shadow.release();
    known.add(0, memory.size());

    ASSERT_TRUE(shadow.begin(memory.data(), 0, memory.size(), known));
    runs.clear();
    shadow.diff(memory.data(), runs);
    EXPECT_TRUE(runs.empty());
    memory[1000] = 2;
    shadow.diff(memory.data(), runs);
    EXPECT_EQ(runs, (std::vector<DirtyRun>{{768, 256}}));
}

// Exit status 0 when a shadow of 1 GiB, under an address space cap of 256 MiB, is refused
// cleanly: no shadow, and nothing compared.
[[maybe_unused]] int shadow_without_memory() {
    rlimit cap{};
    cap.rlim_cur = cap.rlim_max = rlim_t{256} << 20;
    if (setrlimit(RLIMIT_AS, &cap) != 0) return 2;
    std::vector<uint8_t> page(4096, 1);
    KnownRanges known;
    MappedShadow shadow;
    // The mapped pointer is never read when there is no shadow to fill.
    const bool got = shadow.begin(page.data(), 0, size_t{1} << 30, known);
    std::vector<DirtyRun> runs;
    shadow.diff(page.data(), runs);
    return !got && shadow.empty() && runs.empty() ? 0 : 1;
}

TEST(LayerMappedShadow, NoHostMemoryIsAnAnswerNotAnException) {
#if defined(__SANITIZE_ADDRESS__)
    GTEST_SKIP() << "AddressSanitizer reports a failed allocation instead of returning null";
#else
    // In a child, with its address space capped below the shadow's size.
    EXPECT_EXIT(std::_Exit(shadow_without_memory()), ::testing::ExitedWithCode(0), "");
#endif
}

} // namespace
} // namespace splitvk
