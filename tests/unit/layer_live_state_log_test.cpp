// The object part of the live-state log (layer/capture/live_state_log.h), on its own: what a fresh agent
// would be given for the calls the layer logged. Each call's bytes here are one letter, so that a
// snapshot's Commands payload reads as the calls in replay order.
#include "capture/live_state_log.h"

#include <string>
#include <unordered_set>
#include <vector>

#include <gtest/gtest.h>

namespace splitvk {
namespace {

std::vector<uint8_t> call(const std::string &letters) {
    return {letters.begin(), letters.end()};
}

void created(LiveStateLog &log, uint64_t id, const std::string &letters) {
    log.note_change(LiveChange::Created, id, call(letters));
}

// The snapshot's Commands, one letter per call, with each other message as [its type].
std::string replayed(LiveStateLog &log, std::unordered_set<uint64_t> *live_ids = nullptr) {
    std::string out;
    for (const LiveMessage &message : log.messages(nullptr, live_ids)) {
        if (message.type == protocol::MessageType::Commands)
            out.append(message.payload.begin(), message.payload.end());
        else
            out.append(1, '[').append(std::to_string(static_cast<unsigned>(message.type))).append(1, ']');
    }
    return out;
}

TEST(LiveStateLog, ReplaysCreationsInCreationOrder) {
    LiveStateLog log;
    created(log, 30, "A");
    created(log, 10, "B");
    created(log, 20, "C");
    log.note_change(LiveChange::Unchanged, 0, call("x")); // a call that changes no object
    std::unordered_set<uint64_t> live;
    EXPECT_EQ(replayed(log, &live), "ABC");
    EXPECT_EQ(live, (std::unordered_set<uint64_t>{10, 20, 30}));
    EXPECT_EQ(log.size(), 3u);
}

TEST(LiveStateLog, KeepsAMessageOfItsOwnTypeInItsPlace) {
    LiveStateLog log;
    created(log, 1, "A");
    const uint64_t swapchain[] = {2};
    EXPECT_NE(log.add(call("W"), swapchain, {}, protocol::MessageType::SwapchainImages), 0u);
    created(log, 3, "B");
    const auto messages = log.messages(nullptr, nullptr);
    ASSERT_EQ(messages.size(), 3u);
    EXPECT_EQ(messages[0].type, protocol::MessageType::Commands);
    EXPECT_EQ(messages[1].type, protocol::MessageType::SwapchainImages);
    EXPECT_EQ(messages[1].payload, call("W"));
    EXPECT_EQ(messages[2].payload, call("B"));
}

TEST(LiveStateLog, DropsADestroyedObject) {
    LiveStateLog log;
    created(log, 10, "A");
    created(log, 20, "B");
    log.note_change(LiveChange::Destroyed, 10, call("a"));
    std::unordered_set<uint64_t> live;
    EXPECT_EQ(replayed(log, &live), "B");
    EXPECT_EQ(live, (std::unordered_set<uint64_t>{20}));
    EXPECT_EQ(log.size(), 1u);
}

TEST(LiveStateLog, DropsABatchWithItsLastObject) {
    LiveStateLog log;
    const uint64_t buffers[] = {1, 2};
    log.add(call("A"), buffers, {});
    log.forget(1);
    EXPECT_EQ(replayed(log), "A");
    log.forget(2);
    EXPECT_EQ(replayed(log), "");
}

TEST(LiveStateLog, DropsABindWithTheMemoryItBinds) {
    LiveStateLog log;
    created(log, 1, "M"); // the memory
    created(log, 2, "I"); // the image
    const uint64_t image[] = {2};
    const uint64_t memory[] = {1};
    log.add(call("b"), image, memory);
    EXPECT_EQ(replayed(log), "MIb");
    log.note_change(LiveChange::Destroyed, 1, call("m"));
    EXPECT_EQ(replayed(log), "I");
}

TEST(LiveStateLog, KeepsARetiredObjectWhileALaterOneNamesIt) {
    LiveStateLog log;
    created(log, 10, "S"); // a shader module
    created(log, 20, "P"); // a pipeline made from it
    log.note_change(LiveChange::Retired, 10, call("s"));
    std::unordered_set<uint64_t> live;
    // Its destroy replays after the live objects.
    EXPECT_EQ(replayed(log, &live), "SPs");
    EXPECT_EQ(live, (std::unordered_set<uint64_t>{20}));
    EXPECT_EQ(log.size(), 2u);
    // Nothing that can name it lives any more.
    log.note_change(LiveChange::Destroyed, 20, call("p"));
    EXPECT_EQ(replayed(log), "");
    EXPECT_EQ(log.size(), 0u);
}

TEST(LiveStateLog, DropsARetiredObjectNothingLaterNames) {
    LiveStateLog log;
    created(log, 5, "A");
    created(log, 10, "S");
    log.note_change(LiveChange::Retired, 10, call("s"));
    EXPECT_EQ(replayed(log), "A");
}

TEST(LiveStateLog, DestroysAReusedHandleValueJustBeforeItsNewObject) {
    LiveStateLog log;
    created(log, 10, "S");
    created(log, 20, "P"); // names the first object 10
    log.note_change(LiveChange::Retired, 10, call("s"));
    created(log, 10, "T"); // the driver hands the value out again
    created(log, 30, "Q"); // names the second object 10
    std::unordered_set<uint64_t> live;
    EXPECT_EQ(replayed(log, &live), "SPsTQ");
    EXPECT_EQ(live, (std::unordered_set<uint64_t>{10, 20, 30}));
    // With the pipeline gone nothing names the first object: it and its destroy go.
    log.forget(20);
    EXPECT_EQ(replayed(log), "TQ");
}

TEST(LiveStateLog, ACreationOfALiveValueNamesTheNewObject) {
    LiveStateLog log;
    created(log, 7, "Q"); // vkGetDeviceQueue
    created(log, 8, "A");
    created(log, 7, "R"); // the same queue again
    EXPECT_EQ(replayed(log), "AR");
    EXPECT_EQ(log.size(), 2u);
}

} // namespace
} // namespace splitvk
