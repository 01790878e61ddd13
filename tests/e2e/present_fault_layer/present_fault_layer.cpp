// VK_LAYER_SPLITVK_test_present_fault: a test-only layer that makes the driver's vkQueuePresentKHR
// answer VK_ERROR_OUT_OF_DATE_KHR or VK_SUBOPTIMAL_KHR once, as a real window system does when a
// window is resized. Lavapipe under Xvfb never does on its own, and splitvk presents from a thread
// of its own: what the driver answered that thread must still reach the application.
// The tests put this layer BELOW splitvk, next to the driver, so that it sees the presents splitvk
// makes, not the application's.
//
// TEST_PRESENT_FAULT=out_of_date:N or suboptimal:N: the Nth present that reaches this layer (from
// 0) answers that result. It prints "present fault: present N answered <result>" on stderr.
//  - suboptimal: the present goes to the driver as asked (the image is shown and released), and
//    VK_SUBOPTIMAL_KHR replaces the driver's VK_SUCCESS.
//  - out_of_date: what Mesa's WSI does for a surface that no longer matches its swapchain
//    (x11_queue_present returns the chain's error before it queues the image): the presentation
//    request is rejected, the image is not presented and stays acquired, but the present's
//    semaphore waits still execute ("if the presentation request is rejected by the presentation
//    engine with an error VK_ERROR_OUT_OF_DATE_KHR ... any semaphore wait operation specified in
//    VkPresentInfoKHR will execute when the corresponding queue operation is complete"). The layer
//    consumes them with an empty batch on the present queue, so that whoever signalled them may
//    signal them again; validation, which treats an image whose present answered an error as still
//    acquired, then agrees with the driver.
// Built into the build tree only and never installed.
#include "../present_layer/present_layer.h"

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

namespace splitvk::present_layer {
namespace {

std::atomic<unsigned long long> g_presents{0};

struct Fault {
    VkResult result = VK_SUCCESS;
    long long present = -1;
};

Fault fault() {
    Fault f;
    const char *value = std::getenv("TEST_PRESENT_FAULT");
    if (!value) return f;
    const std::string text(value);
    const auto colon = text.find(':');
    if (colon == std::string::npos) return f;
    const std::string kind = text.substr(0, colon);
    if (kind == "out_of_date")
        f.result = VK_ERROR_OUT_OF_DATE_KHR;
    else if (kind == "suboptimal")
        f.result = VK_SUBOPTIMAL_KHR;
    else
        return f;
    f.present = std::atoll(text.c_str() + colon + 1);
    return f;
}

const char *name_of(VkResult r) {
    return r == VK_ERROR_OUT_OF_DATE_KHR ? "VK_ERROR_OUT_OF_DATE_KHR" : "VK_SUBOPTIMAL_KHR";
}

} // namespace

VkResult present(const Next &next, VkQueue queue, const VkPresentInfoKHR *info) {
    const unsigned long long index = g_presents++;
    const Fault f = fault();
    if (static_cast<long long>(index) != f.present) return next.present(queue, info);

    VkResult result = VK_SUCCESS;
    if (f.result == VK_SUBOPTIMAL_KHR) {
        result = next.present(queue, info);
        if (result == VK_SUCCESS) result = VK_SUBOPTIMAL_KHR;
    } else {
        // Rejected: only the semaphore waits happen (the caller holds the queue, as for the present).
        const std::vector<VkPipelineStageFlags> stages(info->waitSemaphoreCount,
                                                       VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT);
        VkSubmitInfo submit{};
        submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
        submit.waitSemaphoreCount = info->waitSemaphoreCount;
        submit.pWaitSemaphores = info->pWaitSemaphores;
        submit.pWaitDstStageMask = stages.data();
        result = info->waitSemaphoreCount ? next.submit(queue, 1, &submit, VK_NULL_HANDLE) : VK_SUCCESS;
        if (result == VK_SUCCESS) {
            result = VK_ERROR_OUT_OF_DATE_KHR;
            if (info->pResults)
                for (uint32_t i = 0; i < info->swapchainCount; ++i)
                    info->pResults[i] = result;
        }
    }
    std::fprintf(stderr, "present fault: present %llu answered %s\n", index, name_of(result));
    std::fflush(stderr);
    return result;
}

} // namespace splitvk::present_layer
