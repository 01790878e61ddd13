// VK_LAYER_SPLITVK_test_hold: a test-only layer that freezes an application right after it has
// presented frame N, so that the X server can be grabbed showing exactly that frame. splitvk-atrium
// has --hold for this; vkcube and other unmodified apps do not, so the tests put this layer above
// splitvk (closest to the app) with TEST_HOLD_FRAME=N.
//
// After the present of frame N returns it prints "holding frame N" on stdout and blocks the
// presenting thread until the process is signalled. It is built into the build tree only and
// never installed.
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
    return result;
}

} // namespace splitvk::present_layer
