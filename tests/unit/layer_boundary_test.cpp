// The OpenXR API layer's exception boundary on the built library: the layer opened with dlopen and
// negotiated as the OpenXR loader does, its xrDestroyInstance asked for and called with
// TEST_SPLITVK_THROW naming it (entry_boundary.h), so that its boundary throws std::bad_alloc after
// the call went through. The Vulkan layer's boundaries are exercised end to end (e2e Boundary suite).

#include "xr/xr_loader_interface.h"

#include <cstdint>
#include <cstdlib>
#include <string>

#include <dlfcn.h>
#include <gtest/gtest.h>
#include <openxr/openxr.h>

namespace {

TEST(LayerBoundary, ExceptionInAnOpenXrEntryPointBecomesOneLineAndOutOfMemory) {
    // Read when the library is loaded, so before dlopen; this binary opens it nowhere else.
    ASSERT_EQ(setenv("TEST_SPLITVK_THROW", "xrDestroyInstance:1", 1), 0);
    void *library = dlopen(SPLITVK_LAYER_LIBRARY, RTLD_NOW | RTLD_LOCAL);
    ASSERT_NE(library, nullptr) << dlerror();
    using Negotiate = XrResult (*)(const XrNegotiateLoaderInfo *, const char *, XrNegotiateApiLayerRequest *);
    auto negotiate = reinterpret_cast<Negotiate>(dlsym(library, "xrNegotiateLoaderApiLayerInterface"));
    ASSERT_NE(negotiate, nullptr);
    XrNegotiateLoaderInfo loader{};
    loader.structType = XR_LOADER_INTERFACE_STRUCT_LOADER_INFO;
    loader.structVersion = XR_LOADER_INFO_STRUCT_VERSION;
    loader.structSize = sizeof(loader);
    loader.minInterfaceVersion = XR_CURRENT_LOADER_API_LAYER_VERSION;
    loader.maxInterfaceVersion = XR_CURRENT_LOADER_API_LAYER_VERSION;
    loader.minApiVersion = XR_MAKE_VERSION(1, 0, 0);
    loader.maxApiVersion = XR_CURRENT_API_VERSION;
    XrNegotiateApiLayerRequest request{};
    request.structType = XR_LOADER_INTERFACE_STRUCT_API_LAYER_REQUEST;
    request.structVersion = XR_API_LAYER_INFO_STRUCT_VERSION;
    request.structSize = sizeof(request);
    ASSERT_EQ(negotiate(&loader, "XR_APILAYER_SPLITVK_split_render", &request), XR_SUCCESS);
    ASSERT_NE(request.getInstanceProcAddr, nullptr);
    PFN_xrVoidFunction function = nullptr;
    ASSERT_EQ(request.getInstanceProcAddr(XR_NULL_HANDLE, "xrDestroyInstance", &function), XR_SUCCESS);
    const auto destroy_instance = reinterpret_cast<PFN_xrDestroyInstance>(function);
    ASSERT_NE(destroy_instance, nullptr);
    const auto unknown = reinterpret_cast<XrInstance>(uintptr_t{0x1234});

    // Call 0 goes through untouched: an instance the layer never made is not its to destroy.
    testing::internal::CaptureStderr();
    EXPECT_EQ(destroy_instance(unknown), XR_ERROR_HANDLE_INVALID);
    EXPECT_EQ(testing::internal::GetCapturedStderr(), "");
    // Call 1 throws after it went through: no exception here, the call fails as out of memory, with
    // one line naming the entry point and what was thrown.
    testing::internal::CaptureStderr();
    EXPECT_EQ(destroy_instance(unknown), XR_ERROR_OUT_OF_MEMORY);
    EXPECT_EQ(
        testing::internal::GetCapturedStderr(),
        "[splitvk] error: xrDestroyInstance: std::bad_alloc (std::bad_alloc) thrown inside splitvk; the "
        "call returns XR_ERROR_OUT_OF_MEMORY\n");
    // Once per entry point: the next exception there fails its call alike and says nothing more.
    testing::internal::CaptureStderr();
    EXPECT_EQ(destroy_instance(unknown), XR_ERROR_OUT_OF_MEMORY);
    EXPECT_EQ(testing::internal::GetCapturedStderr(), "");
}

} // namespace
