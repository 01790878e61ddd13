// SPLITVK_STATS (layer/model/stats.h): the CSV's columns (new ones only ever at the end), the periphery's
// PSNR field, the agent's name, the summary line's mode, and the frame latency's pairing of presents with
// acquires.

#include "model/stats.h"

#include <chrono>
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
    record.frame_latency_ms = 20.5;
    record.agent = "127.0.0.1:7447";
    const auto [header, row] = header_and_row({record});
    const auto names = split_csv(header), values = split_csv(row);
    ASSERT_EQ(names.size(), values.size()) << header << "\n" << row;
    ASSERT_GE(names.size(), 6u);
    // The columns before them keep their order: present_to_composite_ms was the last, and only
    // frame_latency_ms and agent came after them.
    EXPECT_EQ(names[names.size() - 6], "present_to_composite_ms");
    EXPECT_EQ(names[names.size() - 5], "periphery_decode_ms");
    EXPECT_EQ(names[names.size() - 4], "periphery_bytes");
    EXPECT_EQ(names[names.size() - 3], "periphery_psnr_db");
    EXPECT_EQ(names[names.size() - 2], "frame_latency_ms");
    EXPECT_EQ(names.back(), "agent");
    EXPECT_EQ(values[0], "7");
    EXPECT_EQ(values[values.size() - 6], "1.500");
    EXPECT_EQ(values[values.size() - 5], "2.250");
    EXPECT_EQ(values[values.size() - 4], "4096");
    EXPECT_EQ(values[values.size() - 3], "38.125");
    EXPECT_EQ(values[values.size() - 2], "20.500");
    EXPECT_EQ(values.back(), "127.0.0.1:7447");
}

// Outside verification in the swapped split there is no PSNR: the field is empty, not 0. Equal
// images give "inf", which strtod reads back.
TEST(FrameStats, PeripheryPsnrIsEmptyWhenNotMeasuredAndInfWhenEqual) {
    FrameRecord record;
    record.periphery_bytes = 4096;
    EXPECT_TRUE(header_and_row({record}).second.ends_with(",4096,,,")) << header_and_row({record}).second;
    record.periphery_psnr_db = std::numeric_limits<double>::infinity();
    const std::string row = header_and_row({record}).second;
    ASSERT_TRUE(row.ends_with(",4096,inf,,")) << row;
    EXPECT_EQ(std::strtod(row.c_str() + row.size() - 5, nullptr), std::numeric_limits<double>::infinity());
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

// A frame's latency is written with three decimals, and is an empty field when its start was not
// seen, never a 0 that would read as an instant frame.
TEST(FrameStats, FrameLatencyHasThreeDecimalsAndIsEmptyWhenUnknown) {
    FrameRecord record;
    EXPECT_TRUE(header_and_row({record}).second.ends_with(",,")) << header_and_row({record}).second;
    record.frame_latency_ms = 16.6667;
    const auto [header, row] = header_and_row({record});
    EXPECT_TRUE(header.ends_with(",frame_latency_ms,agent")) << header;
    EXPECT_TRUE(row.ends_with(",16.667,")) << row;
}

// The agent column names the agent whose tiles the frame shows, and is empty in a frame without.
TEST(FrameStats, AgentIsTheLastColumnAndEmptyWithoutOne) {
    FrameRecord record;
    record.frame_latency_ms = 16.6667;
    EXPECT_TRUE(header_and_row({record}).second.ends_with(",16.667,")) << header_and_row({record}).second;
    record.agent = "[::1]:7448";
    const auto [header, row] = header_and_row({record});
    EXPECT_TRUE(header.ends_with(",agent")) << header;
    EXPECT_TRUE(row.ends_with(",16.667,[::1]:7448")) << row;
    EXPECT_EQ(split_csv(header).size(), split_csv(row).size()) << header << "\n" << row;
}

using Clock = AcquireTimes::Clock;
constexpr uint64_t kSwapchain = 0x1000;

// Several images in flight, presented in another order than acquired: each present ends the
// acquire of its own image, and each acquire is taken once.
TEST(AcquireTimes, PairsEachPresentWithTheAcquireOfItsImage) {
    AcquireTimes times;
    const Clock::time_point t0 = Clock::now();
    times.acquired(kSwapchain, 0, t0);
    times.acquired(kSwapchain, 1, t0 + std::chrono::milliseconds(5));
    times.acquired(kSwapchain, 2, t0 + std::chrono::milliseconds(9));
    EXPECT_EQ(times.take(kSwapchain, 1), t0 + std::chrono::milliseconds(5));
    EXPECT_EQ(times.take(kSwapchain, 0), t0);
    EXPECT_EQ(times.take(kSwapchain, 0), std::nullopt) << "a second present of one acquire";
    EXPECT_EQ(times.take(kSwapchain, 2), t0 + std::chrono::milliseconds(9));
    EXPECT_EQ(times.size(), 0u);
}

// The same image index of two swapchains (a window and its mirror) are two images.
TEST(AcquireTimes, KeepsSwapchainsApart) {
    AcquireTimes times;
    const Clock::time_point t0 = Clock::now();
    times.acquired(kSwapchain, 0, t0);
    times.acquired(kSwapchain + 1, 0, t0 + std::chrono::milliseconds(3));
    EXPECT_EQ(times.take(kSwapchain + 1, 0), t0 + std::chrono::milliseconds(3));
    EXPECT_EQ(times.take(kSwapchain, 0), t0);
}

// An acquire that no present ends (the swapchain went out of date and was made again) leaves no
// stale start: the image's next acquire replaces it, and the swapchain's end drops it, so the
// latency of a later frame never runs from it.
TEST(AcquireTimes, AnAcquireWithoutAPresentIsReplacedOrForgotten) {
    AcquireTimes times;
    const Clock::time_point t0 = Clock::now();
    times.acquired(kSwapchain, 0, t0);
    times.acquired(kSwapchain, 0, t0 + std::chrono::milliseconds(40));
    EXPECT_EQ(times.take(kSwapchain, 0), t0 + std::chrono::milliseconds(40));
    times.acquired(kSwapchain, 1, t0);
    times.acquired(kSwapchain + 1, 1, t0);
    times.forget(kSwapchain);
    EXPECT_EQ(times.take(kSwapchain, 1), std::nullopt);
    EXPECT_EQ(times.take(kSwapchain + 1, 1), t0) << "another swapchain's acquire was dropped";
    EXPECT_EQ(times.take(kSwapchain, 7), std::nullopt) << "a present of an image never acquired";
}

TEST(FrameLatency, RunsFromTheStartAndIsUnsetWithoutOne) {
    const Clock::time_point t0 = Clock::now();
    EXPECT_EQ(latency_ms(std::nullopt, t0), std::nullopt);
    const auto ms = latency_ms(t0, t0 + std::chrono::microseconds(12500));
    ASSERT_TRUE(ms);
    EXPECT_DOUBLE_EQ(*ms, 12.5);
}

} // namespace
} // namespace splitvk
