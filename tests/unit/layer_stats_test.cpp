// SPLITVK_STATS (layer/stats.h): the CSV's columns (new ones only ever at the end), the periphery's
// PSNR field, and the summary line's mode.

#include "stats.h"

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <utility>
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

// The header and the first row of a file written with `records`.
std::pair<std::string, std::string> header_and_row(const std::vector<FrameRecord> &records) {
    const std::string path = ::testing::TempDir() + "splitvk_stats_" + std::to_string(::getpid()) + ".csv";
    {
        FrameStats stats(path);
        for (const FrameRecord &record : records)
            stats.record(record);
    }
    std::ifstream in(path);
    std::string header, row;
    std::getline(in, header);
    std::getline(in, row);
    std::remove(path.c_str());
    return {header, row};
}

TEST(FrameStats, PeripheryColumnsComeLastAndCarryTheSwappedSplitsFigures) {
    FrameRecord record;
    record.frame = 7;
    record.present_to_composite_ms = 1.5;
    record.periphery_decode_ms = 2.25;
    record.periphery_bytes = 4096;
    record.periphery_psnr_db = 38.125;
    const auto [header, row] = header_and_row({record});
    const auto names = split_csv(header), values = split_csv(row);
    ASSERT_EQ(names.size(), values.size()) << header << "\n" << row;
    ASSERT_GE(names.size(), 4u);
    // The columns before them keep their order: present_to_composite_ms was the last.
    EXPECT_EQ(names[names.size() - 4], "present_to_composite_ms");
    EXPECT_EQ(names[names.size() - 3], "periphery_decode_ms");
    EXPECT_EQ(names[names.size() - 2], "periphery_bytes");
    EXPECT_EQ(names.back(), "periphery_psnr_db");
    EXPECT_EQ(values[0], "7");
    EXPECT_EQ(values[values.size() - 4], "1.500");
    EXPECT_EQ(values[values.size() - 3], "2.250");
    EXPECT_EQ(values[values.size() - 2], "4096");
    EXPECT_EQ(values.back(), "38.125");
}

// Outside verification in the swapped split there is no PSNR: the field is empty, not 0. Equal
// images give "inf", which strtod reads back.
TEST(FrameStats, PeripheryPsnrIsEmptyWhenNotMeasuredAndInfWhenEqual) {
    FrameRecord record;
    record.periphery_bytes = 4096;
    EXPECT_TRUE(header_and_row({record}).second.ends_with(",4096,")) << header_and_row({record}).second;
    record.periphery_psnr_db = std::numeric_limits<double>::infinity();
    const std::string row = header_and_row({record}).second;
    ASSERT_TRUE(row.ends_with(",4096,inf")) << row;
    EXPECT_EQ(std::strtod(row.c_str() + row.size() - 3, nullptr), std::numeric_limits<double>::infinity());
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

// A mirror window beside the eyes: its presents are counted as window presents, not eye images,
// so that the summary's counts agree with the application's.
TEST(FrameStats, SummaryCountsAMirrorWindowApartFromTheEyeImages) {
    FrameStats stats("");
    for (int64_t frame = 0; frame < 3; ++frame) {
        FrameRecord eye;
        eye.xr_frame = frame;
        stats.record(eye);
        eye.xr_view = 1;
        stats.record(eye);
        stats.record(FrameRecord{}); // the mirror window's present
    }
    EXPECT_EQ(stats.summary().rfind("split: 6 eye images in 3 OpenXR frames", 0), 0u) << stats.summary();
    EXPECT_TRUE(stats.summary().ends_with(", and 3 window presents")) << stats.summary();
}

} // namespace
} // namespace splitvk
