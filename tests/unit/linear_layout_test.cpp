// The agent's copy of a linear image's bytes from the client's layout to its own
// (server-agent/linear_layout.h), with the layouts and diff blocks of any shape.

#include "linear_layout.h"

#include <algorithm>
#include <random>
#include <vector>

#include <gtest/gtest.h>

namespace splitvk::agent {
namespace {

TEST(LinearLayout, RowSpanRefusesOverlappingRows) {
    const RowShape shape{16, 8, 1};
    uint64_t span = 0;
    ASSERT_TRUE(row_span(shape, {0, 16, 0}, &span));
    EXPECT_EQ(span, 128u);
    ASSERT_TRUE(row_span(shape, {100, 80, 0}, &span));
    EXPECT_EQ(span, 7 * 80 + 16u);
    EXPECT_FALSE(row_span(shape, {0, 15, 0}, &span)) << "a row pitch shorter than a row";
    const RowShape volume{16, 4, 3};
    ASSERT_TRUE(row_span(volume, {0, 32, 112}, &span));
    EXPECT_EQ(span, 2 * 112 + 3 * 32 + 16u);
    EXPECT_FALSE(row_span(volume, {0, 32, 111}, &span)) << "a depth pitch shorter than a slice";
    EXPECT_FALSE(row_span({16, 0, 1}, {0, 16, 0}, &span)) << "no rows";
}

uint8_t texel(uint32_t sub, uint32_t z, uint32_t y, uint64_t x) {
    return static_cast<uint8_t>(1 + sub * 59 + z * 37 + y * 13 + x * 3);
}

// Random layouts of one or two subresources (two mips of a volume, say), the client's image
// written in random diff blocks in random order: the agent's image holds every texel where its
// layout puts it, and nothing of the client's padding.
TEST(LinearLayout, RandomBlocksLandWhereTheAgentsLayoutPutsThem) {
    std::mt19937 rng(1234);
    const auto pick = [&](uint64_t lo, uint64_t hi) {
        return std::uniform_int_distribution<uint64_t>(lo, hi)(rng);
    };
    for (int round = 0; round < 300; ++round) {
        const uint32_t subresources = static_cast<uint32_t>(pick(1, 2));
        std::vector<Relayout> layouts;
        uint64_t client_end = 0, agent_end = 0;
        for (uint32_t s = 0; s < subresources; ++s) {
            Relayout l;
            l.shape = {pick(1, 12) * 4, static_cast<uint32_t>(pick(1, 9)), static_cast<uint32_t>(pick(1, 3))};
            const auto place = [&](uint64_t after) {
                RowPlacement p;
                p.row_pitch = l.shape.row_bytes + pick(0, 3) * 16;
                p.depth_pitch = (l.shape.rows - 1) * p.row_pitch + l.shape.row_bytes + pick(0, 40);
                p.offset = after + pick(0, 64);
                return p;
            };
            l.client = place(client_end);
            l.agent = place(agent_end);
            uint64_t span = 0;
            ASSERT_TRUE(row_span(l.shape, l.client, &span));
            client_end = l.client.offset + span;
            ASSERT_TRUE(row_span(l.shape, l.agent, &span));
            agent_end = l.agent.offset + span;
            layouts.push_back(l);
        }
        std::vector<uint8_t> client(client_end, 0xee), expected(agent_end, 0), agent(agent_end, 0);
        for (uint32_t s = 0; s < subresources; ++s) {
            const Relayout &l = layouts[s];
            for (uint32_t z = 0; z < l.shape.slices; ++z)
                for (uint32_t y = 0; y < l.shape.rows; ++y)
                    for (uint64_t x = 0; x < l.shape.row_bytes; ++x) {
                        client[l.client.offset + z * l.client.depth_pitch + y * l.client.row_pitch + x] =
                            texel(s, z, y, x);
                        expected[l.agent.offset + z * l.agent.depth_pitch + y * l.agent.row_pitch + x] =
                            texel(s, z, y, x);
                    }
        }
        // Blocks of 1 to 200 bytes cut anywhere (inside rows, across rows, in padding).
        std::vector<std::pair<uint64_t, uint64_t>> blocks;
        for (uint64_t at = 0; at < client_end;) {
            const uint64_t n = std::min(client_end - at, pick(1, 200));
            blocks.emplace_back(at, n);
            at += n;
        }
        std::shuffle(blocks.begin(), blocks.end(), rng);
        for (const auto &[at, n] : blocks)
            for (const Relayout &l : layouts)
                relay_rows(l, agent.data(), at, client.data() + at, n);
        ASSERT_EQ(agent, expected) << "round " << round;
    }
}

} // namespace
} // namespace splitvk::agent
