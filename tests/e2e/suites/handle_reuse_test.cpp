// A destroy is captured before the driver call. Once the driver has destroyed an object
// it may hand the same handle value to an object another thread creates before the destroying call
// returns; a destroy captured after that create ends the new object on the agent (and in the live
// state, and in the layer's own state of it).
//
// VK_LAYER_SPLITVK_test_reuse (tests/e2e/reuse_layer), below splitvk, stages that window
// deterministically: right after the driver destroyed a command pool, a descriptor pool or a
// descriptor set layout, or freed a descriptor set (vkFreeDescriptorSets, vkResetDescriptorPool),
// it creates one of the same kind, with the same handle value, through the top of the chain, and
// destroys it again. The probe destroys one of each with an agent connected.
// With the destroys captured after the driver call the agent sees the second create while the
// first object still lives under that id, and ends the session with an error.
#include "agent.h"
#include "e2e_test.h"

#include <thread>

namespace splitvk::e2e {
namespace {

using namespace std::chrono_literals;

class HandleReuse : public XTest {};

TEST_F(HandleReuse, DestroyIsCapturedBeforeTheDriverMayReuseTheValue) {
    const auto &out = out_;
    ASSERT_TRUE(built(probe_path()));
    ASSERT_TRUE(built(agent_path()));
    Env e = env();
    Agent agent;
    ASSERT_TRUE(agent.start(e, out)) << agent.error();

    use_explicit_layers(e, {kLayerName, "VK_LAYER_SPLITVK_test_reuse"});
    // One folder after the other, top first: this loader chains explicit layers in the order their
    // manifests are found.
    e.erase("VK_ADD_LAYER_PATH");
    e["VK_LAYER_PATH"] = explicit_layer_dir().string() + ":" + SPLITVK_E2E_REUSE_LAYER_DIR;
    enable_layer_info_log(e);
    e["SPLITVK_SERVER"] = agent.address();
    const auto r = run_app({probe_path().string()}, e, out, "probe", 60s);
    ASSERT_TRUE(r.ok()) << r.describe() << "\n" << tail(r.err());
    EXPECT_FALSE(grep(r.err(), "replicating to splitvk-agent").empty()) << "no session\n" << tail(r.err());
    // The staging worked: each destroyed value went at once to a new object.
    for (const char *destroy :
         {"vkDestroyCommandPool", "vkDestroyDescriptorPool", "vkDestroyDescriptorSetLayout",
          "vkFreeDescriptorSets", "vkResetDescriptorPool"})
        EXPECT_EQ(grep(r.err(), std::string("reuse: ") + destroy + ": the next ").size(), 1u)
            << destroy << " was not staged\n"
            << tail(r.err());
    const auto reused = grep(r.err(), "got the same handle value");
    ASSERT_EQ(reused.size(), 5u) << "the driver did not hand a destroyed value out again, so this run "
                                    "staged no race:\n"
                                 << tail(r.err());

    const auto deadline = std::chrono::steady_clock::now() + 20s;
    while (grep(agent.log(), ") ended: ").empty() && std::chrono::steady_clock::now() < deadline)
        std::this_thread::sleep_for(50ms);
    const std::string log = agent.log();
    EXPECT_EQ(grep(log, "ended: closed by the client (exit status 0)").size(), 1u) << tail(log, 20);
    EXPECT_TRUE(grep(log, "] error:").empty()) << tail(log, 20);
    EXPECT_TRUE(grep(r.err(), "[splitvk] error:").empty()) << tail(r.err());
}

} // namespace
} // namespace splitvk::e2e
