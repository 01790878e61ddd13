// SPLITVK_GAZE=fifo:PATH (layer/model/gaze.h): the line parser, and the reader on a real named pipe that
// a writer feeds, closes and reopens while the reader never blocks.
#include "model/gaze.h"

#include <chrono>
#include <filesystem>
#include <string>

#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

namespace splitvk::gaze {
namespace {

using split::kGazeOne;

split::Gaze parsed(const std::string &line) {
    std::string error;
    const auto gaze = parse_line(line, &error);
    EXPECT_TRUE(gaze.has_value()) << line << ": " << error;
    return gaze.value_or(split::Gaze{});
}

std::string refused(const std::string &line) {
    std::string error;
    EXPECT_FALSE(parse_line(line, &error).has_value()) << line;
    EXPECT_FALSE(error.empty()) << line;
    EXPECT_EQ(error.find('\n'), std::string::npos);
    return error;
}

TEST(LayerGaze, BothEyesOrEachEye) {
    split::Gaze g = parsed("0.25 0.75");
    EXPECT_FALSE(g.fixed);
    EXPECT_EQ(g.eyes[0].x, kGazeOne / 4);
    EXPECT_EQ(g.eyes[0].y, kGazeOne * 3 / 4);
    EXPECT_EQ(g.eyes[1].x, kGazeOne / 4) << "x y is both eyes";
    EXPECT_EQ(g.eyes[1].y, kGazeOne * 3 / 4);

    g = parsed("\t0.5  0.5 0.125 1\r");
    EXPECT_EQ(g.eyes[0].x, kGazeOne / 2);
    EXPECT_EQ(g.eyes[1].x, kGazeOne / 8);
    EXPECT_EQ(g.eyes[1].y, kGazeOne);
    g = parsed("1e-1 5E-1");
    EXPECT_EQ(g.eyes[0].x, 6554u); // round(0.1 * 65536)
}

// A fixation holds the fovea still; a saccade moves it at once, whole, with no lag; each eye alone.
TEST(LayerGaze, AFixationHoldsTheFoveaAndASaccadeMovesIt) {
    const split::Gaze shown = parsed("0.5 0.5");
    const uint32_t half = kGazeOne / 2;
    split::Gaze tremor = shown;
    tremor.eyes[0] = {half + kFixationRadius, half - kFixationRadius};
    tremor.eyes[1] = {half - 1, half + 1};
    split::Gaze held = hold_fixation(shown, tremor);
    EXPECT_EQ(held.eyes[0].x, half);
    EXPECT_EQ(held.eyes[0].y, half);
    EXPECT_EQ(held.eyes[1].x, half);

    split::Gaze saccade = tremor;
    saccade.eyes[0].x = half + kFixationRadius + 1; // the left eye moved; the right still fixates
    held = hold_fixation(shown, saccade);
    EXPECT_EQ(held.eyes[0].x, half + kFixationRadius + 1) << "the whole way, at once";
    EXPECT_EQ(held.eyes[0].y, half - kFixationRadius);
    EXPECT_EQ(held.eyes[1].x, half) << "the other eye holds";

    EXPECT_FALSE(hold_fixation(split::Gaze{}, tremor).fixed) << "the first point is taken as it is";
    EXPECT_EQ(hold_fixation(split::Gaze{}, tremor).eyes[0].x, half + kFixationRadius);
    EXPECT_TRUE(hold_fixation(shown, split::Gaze{}).fixed);
}

TEST(LayerGaze, PointsOffTheEyeAreClampedToItsEdges) {
    const split::Gaze g = parsed("-3 1.5 2 -0.0001");
    EXPECT_EQ(g.eyes[0].x, 0u);
    EXPECT_EQ(g.eyes[0].y, kGazeOne);
    EXPECT_EQ(g.eyes[1].x, kGazeOne);
    EXPECT_EQ(g.eyes[1].y, 0u);
}

TEST(LayerGaze, BadLinesAreRefusedWithAReason) {
    EXPECT_NE(refused("0.5").find("1 numbers"), std::string::npos);
    EXPECT_NE(refused("0.1 0.2 0.3").find("3 numbers"), std::string::npos);
    EXPECT_NE(refused("0.1 0.2 0.3 0.4 0.5").find("more than 4"), std::string::npos);
    EXPECT_NE(refused("left 0.5").find("'left'"), std::string::npos);
    refused("0.5,0.5");
    refused("0.5 0.5x");
    refused("nan 0.5");
    refused("0.5 inf");
    refused("0x1p-1 0.5");
    // Blank lines are no gaze and no complaint.
    std::string error = "unset";
    EXPECT_FALSE(parse_line("", &error).has_value());
    EXPECT_TRUE(error.empty());
    EXPECT_FALSE(parse_line("  \t\r", &error).has_value());
    EXPECT_TRUE(error.empty());
}

class GazeFifo : public ::testing::Test {
protected:
    void SetUp() override {
        dir_ = std::filesystem::temp_directory_path() /
               ("splitvk-gaze-" + std::to_string(::getpid()) + "-" +
                ::testing::UnitTest::GetInstance()->current_test_info()->name());
        std::filesystem::create_directories(dir_);
        path_ = (dir_ / "gaze").string();
        ASSERT_EQ(::mkfifo(path_.c_str(), 0600), 0);
    }
    void TearDown() override {
        if (writer_ >= 0) ::close(writer_);
        std::filesystem::remove_all(dir_);
    }
    void open_writer() {
        // The reader has the pipe open already, so this does not wait.
        writer_ = ::open(path_.c_str(), O_WRONLY | O_NONBLOCK | O_CLOEXEC);
        ASSERT_GE(writer_, 0);
    }
    void write_text(const std::string &text) {
        ASSERT_EQ(::write(writer_, text.data(), text.size()), static_cast<ssize_t>(text.size()));
    }

    std::filesystem::path dir_;
    std::string path_;
    int writer_ = -1;
};

TEST_F(GazeFifo, NewestGoodLineAppliesUntilTheNextOne) {
    FifoReader reader(path_);
    const auto start = std::chrono::steady_clock::now();
    EXPECT_TRUE(reader.poll().fixed) << "no writer yet: fixed, and no wait";
    EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(1));
    ASSERT_NO_FATAL_FAILURE(open_writer());
    EXPECT_TRUE(reader.poll().fixed) << "a writer with nothing written";
    ASSERT_NO_FATAL_FAILURE(write_text("0.1 0.1\n0.25 0.5\n"));
    split::Gaze g = reader.poll();
    EXPECT_FALSE(g.fixed);
    EXPECT_EQ(g.eyes[0].x, kGazeOne / 4) << "the newest line wins";
    // Half a line waits for its end; bad lines leave the gaze as it was.
    ASSERT_NO_FATAL_FAILURE(write_text("0.75 0."));
    EXPECT_EQ(reader.poll().eyes[0].x, kGazeOne / 4);
    ASSERT_NO_FATAL_FAILURE(write_text("75\ngarbage\n" + std::string(1000, '7') + "\n"));
    g = reader.poll();
    EXPECT_EQ(g.eyes[0].x, kGazeOne * 3 / 4);
    EXPECT_EQ(g.eyes[0].y, kGazeOne * 3 / 4);
    // The writer goes away and another comes: the reader goes on with the same pipe.
    ::close(writer_);
    writer_ = -1;
    EXPECT_EQ(reader.poll().eyes[0].x, kGazeOne * 3 / 4) << "the last point holds";
    ASSERT_NO_FATAL_FAILURE(open_writer());
    ASSERT_NO_FATAL_FAILURE(write_text("0 1 1 0\n"));
    g = reader.poll();
    EXPECT_EQ(g.eyes[0].x, 0u);
    EXPECT_EQ(g.eyes[1].x, kGazeOne);
}

TEST_F(GazeFifo, AMissingPipeKeepsTheFoveaFixed) {
    FifoReader reader((dir_ / "missing").string());
    EXPECT_TRUE(reader.poll().fixed);
    EXPECT_TRUE(reader.poll().fixed);
}

TEST_F(GazeFifo, APipeMadeAfterTheFirstPresentIsReadOnceItExists) {
    const std::string late = (dir_ / "late").string();
    FifoReader reader(late, std::chrono::milliseconds(0));
    EXPECT_TRUE(reader.poll().fixed) << "no pipe yet";
    ASSERT_EQ(::mkfifo(late.c_str(), 0600), 0);
    EXPECT_TRUE(reader.poll().fixed) << "the pipe, opened, with no writer";
    // The reader has it open now, so a non-blocking writer's open succeeds.
    writer_ = ::open(late.c_str(), O_WRONLY | O_NONBLOCK | O_CLOEXEC);
    ASSERT_GE(writer_, 0);
    ASSERT_NO_FATAL_FAILURE(write_text("0.25 0.75\n"));
    const split::Gaze g = reader.poll();
    EXPECT_FALSE(g.fixed);
    EXPECT_EQ(g.eyes[0].x, kGazeOne / 4);
    EXPECT_EQ(g.eyes[0].y, kGazeOne * 3 / 4);
}

TEST_F(GazeFifo, AMissingPipeIsTriedAgainAtMostOncePerInterval) {
    const std::string late = (dir_ / "late").string();
    FifoReader reader(late, std::chrono::hours(1));
    EXPECT_TRUE(reader.poll().fixed);
    ASSERT_EQ(::mkfifo(late.c_str(), 0600), 0);
    EXPECT_TRUE(reader.poll().fixed);
    // Not tried again within the hour: no reader has the pipe, so a non-blocking writer is refused.
    EXPECT_LT(::open(late.c_str(), O_WRONLY | O_NONBLOCK | O_CLOEXEC), 0);
    EXPECT_EQ(errno, ENXIO);
}

} // namespace
} // namespace splitvk::gaze
