// The agent's --validate: validation errors and warnings are counted apart, and
// only errors fail the session. Messages are injected with vkSubmitDebugUtilsMessageEXT into a real
// session instance with VK_LAYER_KHRONOS_validation, so they take the path the layer's own take.
#include "agent_session.h"
#include "vulkan_context.h"

#include <fstream>

#include <gtest/gtest.h>

namespace splitvk::agent {
namespace {

void submit(VkInstance instance, VkDebugUtilsMessageSeverityFlagBitsEXT severity,
            VkDebugUtilsMessageTypeFlagsEXT type, const char *id, const char *text) {
    auto fn = reinterpret_cast<PFN_vkSubmitDebugUtilsMessageEXT>(
        vkGetInstanceProcAddr(instance, "vkSubmitDebugUtilsMessageEXT"));
    ASSERT_NE(fn, nullptr);
    VkDebugUtilsMessengerCallbackDataEXT data{};
    data.sType = VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CALLBACK_DATA_EXT;
    data.pMessageIdName = id;
    data.pMessage = text;
    fn(instance, severity, type, &data);
}

class AgentValidation : public testing::Test {
protected:
    void SetUp() override {
        if (!std::ifstream("/usr/share/vulkan/explicit_layer.d/VkLayer_khronos_validation.json"))
            GTEST_SKIP() << "vulkan-validationlayers is not installed";
        std::string error;
        ASSERT_TRUE(context_.create_instance(0, true, 1, &error)) << error;
    }
    VulkanContext context_;
};

// What failed the paper's clean atrium (exit status 4): a performance warning is no error.
TEST_F(AgentValidation, PerformanceWarningIsCountedButDoesNotFailTheSession) {
    submit(context_.instance, VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT,
           VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT,
           "UNASSIGNED-CoreValidation-Shader-OutputNotConsumed",
           "fragment shader writes to output location 1 with no matching attachment");
    EXPECT_EQ(context_.validation_errors(), 0u);
    EXPECT_GE(context_.validation_warnings(), 1u);
    EXPECT_EQ(closed_session_status(context_.validation_errors()), kSessionClosed);
}

// The loader's own error about this machine (an ICD manifest of another architecture, as a multiarch
// host with mesa-vulkan-drivers:arm64 has) is of the general type alone: said, and no error.
TEST_F(AgentValidation, LoaderErrorAboutTheMachineIsNoValidationError) {
    submit(context_.instance, VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT,
           VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT, "Loader Message",
           "loader_icd_scan: Failed loading library associated with ICD JSON "
           "/usr/lib/aarch64-linux-gnu/libvulkan_lvp.so. Ignoring this JSON");
    EXPECT_EQ(context_.validation_errors(), 0u);
    EXPECT_EQ(closed_session_status(context_.validation_errors()), kSessionClosed);
}

TEST_F(AgentValidation, ValidationWarningDoesNotFailTheSession) {
    submit(context_.instance, VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT,
           VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT, "test-warning", "a warning");
    EXPECT_EQ(context_.validation_errors(), 0u);
    EXPECT_GE(context_.validation_warnings(), 1u);
    EXPECT_EQ(closed_session_status(context_.validation_errors()), kSessionClosed);
}

TEST_F(AgentValidation, ErrorFailsTheSessionAndIsNotAWarning) {
    submit(context_.instance, VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT,
           VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT, "VUID-test", "an error");
    EXPECT_GE(context_.validation_errors(), 1u);
    EXPECT_EQ(context_.validation_warnings(), 0u);
    EXPECT_EQ(closed_session_status(context_.validation_errors()), kSessionValidation);
    EXPECT_STREQ(session_exit_name(kSessionValidation), "closed, with validation errors");
}

TEST_F(AgentValidation, InfoIsNeitherErrorNorWarning) {
    submit(context_.instance, VK_DEBUG_UTILS_MESSAGE_SEVERITY_INFO_BIT_EXT,
           VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT, "test-info", "information");
    EXPECT_EQ(context_.validation_errors(), 0u);
    EXPECT_EQ(context_.validation_warnings(), 0u);
}

} // namespace
} // namespace splitvk::agent
