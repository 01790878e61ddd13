// --xr: the atrium drawn through OpenXR (XR_KHR_vulkan_enable2) into the runtime's eye swapchains
// instead of a window, with a frame loop as a real OpenXR application has one. See
// samples/README.md for what it takes from the runtime and how it stays deterministic.
#pragma once

#include "options.h"

#include <csignal>

namespace atrium {

// Renders options.frames frames (or holds the last one until *stop is set, with --hold), ends the
// session and destroys everything. Returns the exit code; throws Error for a one-line failure (no
// runtime, no head-mounted display, no XR_KHR_vulkan_enable2...).
int run_xr(const Options &options, const volatile std::sig_atomic_t *stop);

} // namespace atrium
