// SPLITVK_VERIFY=full. At present the layer reads the presented image back with a copy of its own,
// submitted on the present queue: it waits on the application's wait semaphores (in the swapped
// split, on the composite's: what is read back is what is shown) and signals a semaphore of the
// layer's, which the present then waits on instead. Each swapchain image has its own command
// buffer, readback buffer, fence and semaphore (the Mesa overlay's scheme, minus its bug of reusing
// one slot per submit index, which lets a frame overwrite a copy still in flight). The layer then
// waits (bounded) for its copy and for the agent's VerifyFrame of the same frame, compares the two
// pixel by pixel (frame_difference.h), logs mismatching frames at info level, and vkDestroyDevice
// logs the summary once. A frame the agent does not return in time counts as all of its pixels
// mismatching.

#include "present/verification.h"

#include "capture/session.h"
#include "core/host_buffer.h"
#include "core/queue.h"
#include "core/swapchain.h"
#include "core/vk_util.h"
#include "log.h"
#include "model/frame_difference.h"
#include "tile_format.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace splitvk {

// One swapchain image's: the command buffer of the layer's copy, the buffer it copies into, and
// the fence and semaphore the copy signals. Its lock is held while its copy is made (after a wait
// for the previous one) and, for a window's present, until the copy is compared; that concerns
// this image's frames only.
struct VerifyReadback {
    std::mutex mutex; // what follows
    VkCommandPool pool = VK_NULL_HANDLE;
    VkCommandBuffer command_buffer = VK_NULL_HANDLE;
    HostBuffer staging; // the whole image, read back
    VkFence fence = VK_NULL_HANDLE;
    VkSemaphore semaphore = VK_NULL_HANDLE;
    bool in_flight = false;
};

namespace {

using namespace std::chrono_literals;
constexpr auto kVerifyWait = 5000ms;             // per frame
constexpr uint64_t kFenceWaitNs = 5'000'000'000; // the layer's own copy

} // namespace

struct VerifyTable {
    // The map only: held for a lookup, never while a copy is made, waited for or compared.
    std::mutex mutex;
    std::map<std::pair<VkSwapchainKHR, uint32_t>, std::shared_ptr<VerifyReadback>> readbacks;
};

std::shared_ptr<VerifyTable> make_verify_table() {
    return std::make_shared<VerifyTable>();
}

namespace {

void destroy(DeviceState &dev, VerifyReadback &r) {
    const VkDevice d = dev.handle;
    if (r.in_flight) dev.dispatch.WaitForFences(d, 1, &r.fence, VK_TRUE, kFenceWaitNs);
    if (r.semaphore) dev.dispatch.DestroySemaphore(d, r.semaphore, nullptr);
    if (r.fence) dev.dispatch.DestroyFence(d, r.fence, nullptr);
    destroy_host_buffer(dev, r.staging);
    if (r.pool) dev.dispatch.DestroyCommandPool(d, r.pool, nullptr);
    r.pool = VK_NULL_HANDLE;
    r.command_buffer = VK_NULL_HANDLE;
    r.staging = HostBuffer{};
    r.fence = VK_NULL_HANDLE;
    r.semaphore = VK_NULL_HANDLE;
    r.in_flight = false;
}

bool create(DeviceState &dev, const SwapchainState &sc, uint32_t family, VerifyReadback &r) {
    if (create_command_pool(dev, family, VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT, &r.pool) !=
            VK_SUCCESS ||
        allocate_primary_command_buffer(dev, r.pool, &r.command_buffer) != VK_SUCCESS)
        return false;

    std::string error;
    if (!create_host_buffer(dev,
                            VkDeviceSize{sc.extent.width} * sc.extent.height * tile_texel_bytes(sc.format) *
                                sc.array_layers,
                            VK_BUFFER_USAGE_TRANSFER_DST_BIT, HostAccess::Read, &r.staging, &error))
        return false;
    return create_fence(dev, &r.fence) == VK_SUCCESS && create_semaphore(dev, &r.semaphore) == VK_SUCCESS;
}

void record_copy(DeviceState &dev, const SwapchainState &sc, VkImage image, VerifyReadback &r) {
    const auto &k = dev.dispatch;
    k.ResetCommandBuffer(r.command_buffer, 0);
    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    k.BeginCommandBuffer(r.command_buffer, &begin);
    // A runtime's image comes with no semaphore, only after the application's rendering on the same
    // queue: the barrier itself must make those writes visible to the copy. Every layer, one after
    // the other in the buffer, as the agent reads them (VerifyFrame::layers).
    const VkImageMemoryBarrier to_src =
        colour_image_barrier(image, sc.runtime ? VK_ACCESS_MEMORY_WRITE_BIT : 0, VK_ACCESS_TRANSFER_READ_BIT,
                             sc.present_layout, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, 0, 0, sc.array_layers);
    k.CmdPipelineBarrier(r.command_buffer, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT,
                         0, 0, nullptr, 0, nullptr, 1, &to_src);
    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, sc.array_layers};
    region.imageExtent = {sc.extent.width, sc.extent.height, 1};
    k.CmdCopyImageToBuffer(r.command_buffer, image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, r.staging.buffer, 1,
                           &region);
    const VkImageMemoryBarrier back =
        colour_image_barrier(image, VK_ACCESS_TRANSFER_READ_BIT, 0, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                             sc.present_layout, 0, 0, sc.array_layers);
    k.CmdPipelineBarrier(r.command_buffer, VK_PIPELINE_STAGE_TRANSFER_BIT,
                         VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, 0, 0, nullptr, 0, nullptr, 1, &back);
    k.EndCommandBuffer(r.command_buffer);
}

// The agent's VerifyFrame for `frame`, waiting at most kVerifyWait.
std::optional<protocol::VerifyFrame> wait_verify_frame(Session &session, uint64_t frame) {
    const auto deadline = std::chrono::steady_clock::now() + kVerifyWait;
    while (session.live()) {
        const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
            deadline - std::chrono::steady_clock::now());
        if (left.count() <= 0) break;
        auto payload = session.receive_verify_frame(left);
        if (!payload) continue;
        auto decoded = protocol::decode_verify_frame(*payload, UINT32_MAX);
        if (!decoded) {
            SPLITVK_INFO("verify: bad VerifyFrame from the agent: %s", decoded.error().c_str());
            continue;
        }
        if (decoded->frame < frame) continue;
        if (decoded->frame == frame) return std::move(decoded.value());
        break;
    }
    return std::nullopt;
}

} // namespace

std::optional<double> compare_verified_frame(DeviceState &dev, const PendingVerify &p) {
    Session &session = *dev.session;
    VerifyReadback &r = *p.readback;
    const uint32_t layers = p.swapchain->array_layers;
    const uint32_t width = p.swapchain->extent.width;
    const uint32_t height = p.swapchain->extent.height;
    const uint64_t pixels = uint64_t{width} * height * layers;
    const uint32_t texel_bytes = tile_texel_bytes(p.swapchain->format);
    const bool copied =
        dev.dispatch.WaitForFences(dev.handle, 1, &r.fence, VK_TRUE, kFenceWaitNs) == VK_SUCCESS;
    r.in_flight = !copied;
    if (copied) invalidate_host_buffer(dev, r.staging);
    const auto theirs = wait_verify_frame(session, p.frame);
    uint64_t mismatches = pixels;
    std::optional<double> psnr;
    if (!copied) {
        SPLITVK_INFO("verify: frame %llu: the layer's readback did not finish", (unsigned long long)p.frame);
    } else if (!theirs) {
        SPLITVK_INFO("verify: frame %llu: no frame from the agent", (unsigned long long)p.frame);
    } else if (theirs->width != width || theirs->height != height || theirs->layers != layers ||
               theirs->pixels.size() != pixels * texel_bytes) {
        SPLITVK_INFO(
            "verify: frame %llu: the agent's frame is %ux%u in %u layer(s), the client's %ux%u in %u",
            (unsigned long long)p.frame, theirs->width, theirs->height, theirs->layers, width, height,
            layers);
    } else {
        // In the swapped split only the foveae must match; a frame without them must match whole.
        const std::span<const VkRect2D> exact =
            p.periphery ? std::span<const VkRect2D>(p.foveae) : std::span<const VkRect2D>();
        const FrameDifference d = compare_frames(r.staging.mapped, theirs->pixels.data(), width, height,
                                                 layers, exact, texel_bytes);
        mismatches = d.mismatches;
        // Another GPU rasterises differently: by how much is what tells a rounding
        // difference from a wrong picture.
        session.largest_difference.store(std::max(session.largest_difference.load(), d.largest));
        session.difference_sum.fetch_add(d.channel_sum);
        if (mismatches)
            SPLITVK_INFO("verify: frame %llu: %llu of %llu pixels differ%s", (unsigned long long)p.frame,
                         (unsigned long long)mismatches, (unsigned long long)pixels,
                         p.periphery ? " in its foveae" : "");
        if (p.periphery) {
            psnr = session.periphery_score.add(d, p.late);
            if (p.late)
                SPLITVK_INFO("verify: frame %llu showed an earlier periphery (late): PSNR %.1f dB",
                             (unsigned long long)p.frame, *psnr);
        }
    }
    session.verified_frames.fetch_add(1);
    if (!p.periphery) session.verified_whole_frames.fetch_add(1);
    session.mismatching_pixels.fetch_add(mismatches);
    session.compared_pixels.fetch_add(pixels);
    return psnr;
}

namespace {

// The readback of image `index` of `swapchain`, made empty on first use. It stays in the table
// until release_verify_readbacks, which takes its lock before destroying it.
VerifyReadback &readback_of(DeviceState &dev, VkSwapchainKHR swapchain, uint32_t index) {
    VerifyTable &t = *dev.readbacks;
    std::lock_guard lock(t.mutex);
    std::shared_ptr<VerifyReadback> &r = t.readbacks[{swapchain, index}];
    if (!r) r = std::make_shared<VerifyReadback>();
    return *r;
}

} // namespace

bool presented_image_verifiable(const DeviceState &dev, VkQueue queue, const VkPresentInfoKHR &present) {
    if (present.swapchainCount == 0) return false;
    const SwapchainState *sc = find_swapchain(dev, present.pSwapchains[0]);
    return sc && sc->transfer_src && tile_texel_bytes(sc->format) != 0 &&
           present.pImageIndices[0] < sc->images.size() && queue_family_of(dev, queue) != UINT32_MAX;
}

std::optional<PendingVerify> read_back_presented_image(DeviceState &dev, VkQueue queue,
                                                       VkPresentInfoKHR &present, uint64_t frame) {
    if (!presented_image_verifiable(dev, queue, present)) return std::nullopt;
    const SwapchainState *sc = find_swapchain(dev, present.pSwapchains[0]);
    const uint32_t index = present.pImageIndices[0];
    const uint32_t family = queue_family_of(dev, queue);
    VerifyReadback &r = readback_of(dev, sc->handle, index);
    std::unique_lock lock(r.mutex);
    bool ready = r.pool != VK_NULL_HANDLE;
    if (!ready) {
        ready = create(dev, *sc, family, r);
        if (!ready) destroy(dev, r);
    }
    if (ready && r.in_flight)
        ready = dev.dispatch.WaitForFences(dev.handle, 1, &r.fence, VK_TRUE, kFenceWaitNs) == VK_SUCCESS;
    if (!ready) return std::nullopt;
    dev.dispatch.ResetFences(dev.handle, 1, &r.fence);
    record_copy(dev, *sc, sc->images[index], r);
    std::vector<VkPipelineStageFlags> stages(present.waitSemaphoreCount, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT);
    const VkSubmitInfo submit =
        submit_info(&r.command_buffer, {present.pWaitSemaphores, present.waitSemaphoreCount}, stages.data(),
                    &r.semaphore);
    if (dev.dispatch.QueueSubmit(queue, 1, &submit, r.fence) != VK_SUCCESS) return std::nullopt;
    r.in_flight = true;
    // Kept in place by the lock the result holds (release_verify_readbacks waits for it).
    present.waitSemaphoreCount = 1;
    present.pWaitSemaphores = &r.semaphore;
    return PendingVerify{frame, sc, index, &r, std::move(lock), false, {}, false};
}

std::optional<PendingVerify> read_back_runtime_image(DeviceState &dev, VkQueue queue,
                                                     const SwapchainState &sc, uint32_t index,
                                                     uint64_t frame) {
    const uint32_t family = queue_family_of(dev, queue);
    if (!sc.transfer_src || tile_texel_bytes(sc.format) == 0 || index >= sc.images.size() ||
        family == UINT32_MAX)
        return std::nullopt;
    VerifyReadback &r = readback_of(dev, sc.handle, index);
    std::lock_guard lock(r.mutex);
    bool ready = r.pool != VK_NULL_HANDLE;
    if (!ready) {
        ready = create(dev, sc, family, r);
        if (!ready) destroy(dev, r);
    }
    if (ready && r.in_flight)
        ready = dev.dispatch.WaitForFences(dev.handle, 1, &r.fence, VK_TRUE, kFenceWaitNs) == VK_SUCCESS;
    if (!ready) return std::nullopt;
    dev.dispatch.ResetFences(dev.handle, 1, &r.fence);
    record_copy(dev, sc, sc.images[index], r);
    const VkSubmitInfo submit = submit_info(&r.command_buffer);
    if (dev.dispatch.QueueSubmit(queue, 1, &submit, r.fence) != VK_SUCCESS) return std::nullopt;
    r.in_flight = true;
    return PendingVerify{frame, &sc, index, &r, {}, false, {}, false};
}

void release_verify_readbacks(DeviceState &device, VkSwapchainKHR swapchain) {
    std::vector<std::shared_ptr<VerifyReadback>> doomed;
    {
        VerifyTable &t = *device.readbacks;
        std::lock_guard lock(t.mutex);
        for (auto it = t.readbacks.begin(); it != t.readbacks.end();) {
            if (it->first.first == swapchain) {
                doomed.push_back(std::move(it->second));
                it = t.readbacks.erase(it);
            } else {
                ++it;
            }
        }
    }
    for (const std::shared_ptr<VerifyReadback> &r : doomed) {
        std::lock_guard lock(r->mutex);
        destroy(device, *r);
    }
}

namespace {

std::string decibels(double db) {
    if (std::isinf(db)) return "inf dB (equal)";
    char text[32];
    std::snprintf(text, sizeof(text), "%.1f dB", db);
    return text;
}

} // namespace

void report_verify_summary(DeviceState &device) {
    if (!device.session || !device.session->verify()) return;
    const Session &s = *device.session;
    const uint64_t frames = s.verified_frames.load();
    const uint64_t mismatching = s.mismatching_pixels.load();
    if (s.splitting() && s.client_renders() == ClientRenders::Fovea) {
        const PeripheryScore::Totals periphery = s.periphery_score.totals();
        // Scripts and tests match this line whole; the details follow on lines of their own.
        splitvk::log_result(
            "verify: %llu frames, foveae %llu mismatching pixels, periphery PSNR %s",
            static_cast<unsigned long long>(frames), static_cast<unsigned long long>(mismatching),
            periphery.frames
                ? (decibels(periphery.psnr_db) + " (lowest " + decibels(periphery.lowest_db) + ")").c_str()
                : "none (no frame showed the agent's periphery)");
        splitvk::log_result(
            "verify: %llu frames showed the agent's periphery (PSNR over the whole image, mismatches in "
            "their foveae only), %llu of them late (an earlier frame's periphery, which lowers their "
            "PSNR); %llu drawn whole were compared whole",
            static_cast<unsigned long long>(periphery.frames),
            static_cast<unsigned long long>(periphery.late),
            static_cast<unsigned long long>(s.verified_whole_frames.load()));
    } else {
        // A line of its own: scripts and tests match it whole.
        splitvk::log_result("verify: %llu frames, %llu mismatching pixels",
                            static_cast<unsigned long long>(frames),
                            static_cast<unsigned long long>(mismatching));
    }
    splitvk::log_result("verify: %llu pixels compared (every array layer of each image)",
                        static_cast<unsigned long long>(s.compared_pixels.load()));
    if (mismatching)
        splitvk::log_result(
            "verify: largest channel difference %u of 255, mean %.3f over the differing pixels' channels",
            s.largest_difference.load(),
            static_cast<double>(s.difference_sum.load()) / (3.0 * static_cast<double>(mismatching)));
}

} // namespace splitvk
