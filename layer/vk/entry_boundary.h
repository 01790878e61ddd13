#pragma once

// The exception boundary of every entry point the library hands out: the Vulkan layer's (each
// generated into namespace splitvk::boundary around its splitvk::entry function, emit_layer.py) and
// the OpenXR API layer's (xr_layer.cpp, a template around each function of its table). No exception
// leaves the library: one that reaches an entry point's boundary becomes one error line (once per
// entry point) naming the entry point and what was thrown, ends the split of the device the call
// was made on for good (its frames show the periphery alone from then on: whatever the layer was in
// the middle of, its capture stream and object state may have a hole the agent would replay), and
// the call returns VK_ERROR_OUT_OF_HOST_MEMORY (XR_ERROR_OUT_OF_MEMORY) for a std::bad_alloc,
// VK_ERROR_UNKNOWN (XR_ERROR_RUNTIME_FAILURE) for anything else, a zero value (nothing, for void)
// where the command returns no result.
//
// An exception thrown after the call went down and succeeded is answered with that error all the
// same: the application is told the call failed, although the driver (for OpenXR, the runtime) did
// it. What that made for it (a vkCreate*'s object) is then not destroyed, since the layer cannot
// tell how much of it its own state already holds; the application, told the call failed, will
// neither use nor destroy it, so it stays alive below splitvk until its parent is destroyed. The
// error line says so.

#include <vulkan/vulkan.h>

#include <atomic>
#include <new>

namespace splitvk {

struct DeviceState;

// What the command whose entry point threw returns, for the error line.
enum class EntryReturns { Nothing, VkResult, XrResult, Value };

// Called only inside a catch (...) of entry point `name` (by its API name): the error line if `said`
// is still false (it is the entry point's own flag), and the split of `device`, the device the call
// was made on, ends (nullptr: a call without a device). `creates`: the command makes an object, which
// the line then says the driver may still hold. True if what was thrown is a std::bad_alloc. Never
// throws.
bool entry_threw(const char *name, DeviceState *device, EntryReturns returns, bool creates,
                 std::atomic<bool> &said) noexcept;

inline VkResult vk_result_of_throw(bool bad_alloc) {
    return bad_alloc ? VK_ERROR_OUT_OF_HOST_MEMORY : VK_ERROR_UNKNOWN;
}

// TEST_SPLITVK_THROW=<entry point>[:<call>], for the tests only (so not a SPLITVK_ setting), read
// once: the boundary of that entry point throws std::bad_alloc right after each of its calls from
// number <call> on (from 0; default 0) went through the layer and down, as an allocation that fails
// in the layer after the driver call would. Every other call pays one relaxed load.
extern std::atomic<bool> g_test_throw_armed;
bool test_throw_due(const char *name) noexcept;
inline void test_throw_point(const char *name) {
    if (g_test_throw_armed.load(std::memory_order_relaxed)) [[unlikely]]
        if (test_throw_due(name)) throw std::bad_alloc();
}

} // namespace splitvk
