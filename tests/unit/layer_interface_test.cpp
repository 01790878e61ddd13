// The layer's loader interface, called the way layers above splitvk call it: the real library,
// opened with dlopen, negotiated like the loader does, then asked for commands with a null
// instance or device, as MangoHud and the Mesa overlay do while building their chains.

#include <vulkan/vk_layer.h>

#include <string>

#include <dlfcn.h>
#include <gtest/gtest.h>

namespace {

class LayerInterface : public ::testing::Test {
protected:
    void SetUp() override {
        // Opened once and never closed, as the loader keeps it while an instance lives: unloading
        // would leave what the library's globals own to LeakSanitizer as unreachable.
        static void *const library = dlopen(SPLITVK_LAYER_LIBRARY, RTLD_NOW | RTLD_LOCAL);
        library_ = library;
        ASSERT_NE(library_, nullptr) << dlerror();
        auto negotiate = reinterpret_cast<PFN_vkNegotiateLoaderLayerInterfaceVersion>(
            dlsym(library_, "vkNegotiateLoaderLayerInterfaceVersion"));
        ASSERT_NE(negotiate, nullptr);
        VkNegotiateLayerInterface version{};
        version.sType = LAYER_NEGOTIATE_INTERFACE_STRUCT;
        version.loaderLayerInterfaceVersion = CURRENT_LOADER_LAYER_INTERFACE_VERSION;
        ASSERT_EQ(negotiate(&version), VK_SUCCESS);
        EXPECT_EQ(version.loaderLayerInterfaceVersion, 2u);
        gipa_ = version.pfnGetInstanceProcAddr;
        gdpa_ = version.pfnGetDeviceProcAddr;
        ASSERT_NE(gipa_, nullptr);
        ASSERT_NE(gdpa_, nullptr);
    }
    // True if `function` is code of the layer's own library.
    bool in_layer(PFN_vkVoidFunction function) const {
        Dl_info info{};
        if (!function || !dladdr(reinterpret_cast<void *>(function), &info) || !info.dli_fname) return false;
        void *handle = dlopen(info.dli_fname, RTLD_NOW | RTLD_NOLOAD);
        const bool same = handle == library_;
        if (handle) dlclose(handle);
        return same;
    }

    void *library_ = nullptr;
    PFN_vkGetInstanceProcAddr gipa_ = nullptr;
    PFN_vkGetDeviceProcAddr gdpa_ = nullptr;
};

// Every level of command the layer intercepts: global, instance, physical device, device.
constexpr const char *kIntercepted[] = {
    "vkCreateInstance",
    "vkDestroyInstance",
    "vkEnumeratePhysicalDevices",
    "vkCreateDevice",
    "vkEnumerateDeviceExtensionProperties",
    "vkGetPhysicalDeviceFeatures",
    "vkDestroyDevice",
    "vkCreateSwapchainKHR",
    "vkQueuePresentKHR",
    "vkQueueSubmit",
    "vkCmdDraw",
    "vkGetDeviceQueue",
};

TEST_F(LayerInterface, NullInstanceAnswersEveryInterceptedCommand) {
    for (const char *name : kIntercepted) {
        const PFN_vkVoidFunction function = gipa_(VK_NULL_HANDLE, name);
        EXPECT_NE(function, nullptr) << name;
        EXPECT_TRUE(in_layer(function)) << name << " is not the layer's own entry point";
    }
    EXPECT_EQ(gipa_(VK_NULL_HANDLE, "vkGetInstanceProcAddr"), reinterpret_cast<PFN_vkVoidFunction>(gipa_));
    EXPECT_EQ(gipa_(VK_NULL_HANDLE, "vkGetDeviceProcAddr"), reinterpret_cast<PFN_vkVoidFunction>(gdpa_));
}

TEST_F(LayerInterface, NullDeviceAnswersInterceptedDeviceCommands) {
    for (const char *name : {"vkDestroyDevice", "vkQueuePresentKHR", "vkQueueSubmit", "vkCmdDraw"}) {
        EXPECT_EQ(gdpa_(VK_NULL_HANDLE, name), gipa_(VK_NULL_HANDLE, name)) << name;
        EXPECT_TRUE(in_layer(gdpa_(VK_NULL_HANDLE, name))) << name;
    }
    EXPECT_EQ(gdpa_(VK_NULL_HANDLE, "vkGetDeviceProcAddr"), reinterpret_cast<PFN_vkVoidFunction>(gdpa_));
    // Instance-level commands are not device commands.
    EXPECT_EQ(gdpa_(VK_NULL_HANDLE, "vkCreateDevice"), nullptr);
}

// Without an instance there is no next layer to ask, so what the layer does not intercept is NULL.
TEST_F(LayerInterface, NullHandlesGiveNullForWhatTheLayerDoesNotIntercept) {
    for (const char *name : {"vkNotACommand", "vkCmdDrawMeshTasksEXT", ""}) {
        EXPECT_EQ(gipa_(VK_NULL_HANDLE, name), nullptr) << name;
        EXPECT_EQ(gdpa_(VK_NULL_HANDLE, name), nullptr) << name;
    }
    EXPECT_EQ(gipa_(VK_NULL_HANDLE, nullptr), nullptr);
    EXPECT_EQ(gdpa_(VK_NULL_HANDLE, nullptr), nullptr);
}

} // namespace
