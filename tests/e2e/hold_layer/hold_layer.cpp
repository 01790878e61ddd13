// VK_LAYER_SPLITVK_test_hold: a test-only layer that freezes an application right after it has
// presented frame N, so that the X server can be grabbed showing exactly that frame. splitvk-atrium
// has --hold for this; vkcube and other unmodified apps do not, so the tests put this layer above
// splitvk (closest to the app) with TEST_HOLD_FRAME=N.
//
// After the present of frame N returns it prints "holding frame N" on stdout and blocks the
// presenting thread until the process is signalled. It is built into the build tree only and
// never installed.
//
// With TEST_HOLD_WHEN_FILE=<path> instead, it holds at the first present that returns after <path>
// exists, until <path> is removed: for a test that cannot know beforehand at which frame it will be
// done (it renders the native reference up to the frame printed afterwards). The file, not a
// signal, ends the hold because a process-directed signal may be handled on another thread (atrium
// ends on SIGTERM: sent before the file is removed, it ends the app's loop after this present).
#include "../present_layer/present_layer.h"

#include <atomic>
#include <cstdio>
#include <cstdlib>

#include <unistd.h>

namespace splitvk::present_layer {
namespace {

std::atomic<unsigned long long> g_presents{0};

long long hold_frame() {
    const char *value = std::getenv("TEST_HOLD_FRAME");
    return value ? std::atoll(value) : -1;
}

// TEST_HOLD_WHEN_FILE, or null.
const char *hold_file() {
    static const char *const path = std::getenv("TEST_HOLD_WHEN_FILE");
    return path;
}

} // namespace

VkResult present(const Next &next, VkQueue queue, const VkPresentInfoKHR *info) {
    const VkResult result = next.present(queue, info);
    const unsigned long long frame = g_presents++;
    if (static_cast<long long>(frame) == hold_frame()) {
        std::printf("holding frame %llu\n", frame);
        std::fflush(stdout);
        for (;;)
            ::pause(); // until a signal ends the process
    }
    if (const char *file = hold_file(); file && ::access(file, F_OK) == 0) {
        // A layer below may still hold this frame (splitvk's present thread composites it once its
        // tiles come): once the queue is idle it has reached the driver's present, so the X server.
        next.wait_idle(queue);
        std::printf("holding frame %llu\n", frame);
        std::fflush(stdout);
        while (::access(file, F_OK) == 0)
            ::usleep(10'000);
    }
    return result;
}

} // namespace splitvk::present_layer
