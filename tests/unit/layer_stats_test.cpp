// SPLITVK_STATS (layer/stats.h): the CSV's columns (new ones only ever at the end) and the summary
// line's mode.

#include "stats.h"

#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <unistd.h>

namespace splitvk {
namespace {

std::vector<std::string> split_csv(const std::string &line) {
    std::vector<std::string> fields;
    std::stringstream in(line);
    for (std::string field; std::getline(in, field, ',');)
        fields.push_back(field);
    return fields;
}

TEST(FrameStats, PeripheryColumnsComeLastAndCarryTheSwappedSplitsFigures) {
    const std::string path = ::testing::TempDir() + "splitvk_stats_" + std::to_string(::getpid()) + ".csv";
    {
        FrameStats stats(path);
        FrameRecord record;
        record.frame = 7;
        record.present_to_composite_ms = 1.5;
        record.periphery_decode_ms = 2.25;
        record.periphery_bytes = 4096;
        stats.record(record);
    }
    std::ifstream in(path);
    std::string header, row;
    ASSERT_TRUE(std::getline(in, header));
    ASSERT_TRUE(std::getline(in, row));
    std::remove(path.c_str());
    const auto names = split_csv(header), values = split_csv(row);
    ASSERT_EQ(names.size(), values.size()) << header << "\n" << row;
    ASSERT_GE(names.size(), 3u);
    // The columns before them keep their order: present_to_composite_ms was the last.
    EXPECT_EQ(names[names.size() - 3], "present_to_composite_ms");
    EXPECT_EQ(names[names.size() - 2], "periphery_decode_ms");
    EXPECT_EQ(names.back(), "periphery_bytes");
    EXPECT_EQ(values[0], "7");
    EXPECT_EQ(values[values.size() - 3], "1.500");
    EXPECT_EQ(values[values.size() - 2], "2.250");
    EXPECT_EQ(values.back(), "4096");
}

TEST(FrameStats, SummaryNamesTheMode) {
    FrameStats stats("");
    EXPECT_EQ(stats.summary(), "");
    FrameRecord record;
    record.periphery_bytes = 1000;
    stats.record(record);
    EXPECT_EQ(stats.summary().rfind("split: 1 frames", 0), 0u) << stats.summary();
    stats.set_client_renders_fovea(true);
    EXPECT_EQ(stats.summary().rfind("split (client renders fovea): 1 frames", 0), 0u) << stats.summary();
}

} // namespace
} // namespace splitvk
