// The layer's glue under what applications may legally do, through the real layer on lavapipe:
// queues got from several threads at once, an exit with the device still alive, and an exception
// inside the layer. Each must end the application normally: exit 0, no hang, no signal.
#include "agent.h"
#include "e2e_test.h"

#include <regex>
#include <string>
#include <thread>
#include <vector>

namespace splitvk::e2e {
namespace {

using namespace std::chrono_literals;

class Boundary : public XTest {
protected:
    void SetUp() override {
        XTest::SetUp();
        ASSERT_TRUE(built(explicit_layer_dir()));
    }
};

// vkGetDeviceQueue needs no external synchronisation: eight threads get the same queue at once, the
// first time on each of 500 fresh devices, and vkDeviceWaitIdle follows. The layer learns of a queue
// at its first vkGetDeviceQueue; were that a check and then an insert, two threads could each insert
// it, and vkDeviceWaitIdle, which locks every queue it knows once, would lock one twice and hang.
// The probe's time bound is the test's: 500 rounds take about 3 s on two busy cores.
TEST_F(Boundary, QueuesGotFromManyThreadsAtOnceThenDeviceWaitIdle) {
    Env e = env();
    use_explicit_layers(e, {kLayerName});
    // A session without an agent: the layer tracks queues whether or not one answers.
    e["SPLITVK_SERVER"] = "127.0.0.1:" + std::to_string(free_loopback_port());
    const auto r = run_app({probe_path().string(), "--concurrent-queues", "500"}, e, out_, "probe", 60s);
    ASSERT_FALSE(r.timed_out) << "hung (vkDeviceWaitIdle after concurrent vkGetDeviceQueue): " << r.describe()
                              << "\n"
                              << tail(r.err());
    ASSERT_TRUE(r.ok()) << r.describe() << "\n" << tail(r.err());
    EXPECT_FALSE(grep(r.out(), "concurrent queues: 500 rounds, 8 threads").empty()) << r.out();
    EXPECT_TRUE(grep(r.err(), "[splitvk] error").empty()) << tail(r.err());
}

} // namespace
} // namespace splitvk::e2e
