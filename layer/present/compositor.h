#pragma once

// Composition before present (docs/architecture.md §4): the periphery the application rendered at the reduced
// scale into the top-left of a swapchain image is upsampled to the whole image, then the fovea
// tiles the agent rendered are written over it byte for byte, and the image is presented.
//
// One Compositor per swapchain, used from vkQueuePresentKHR (when capturing(dev)):
//
//   VkPresentInfoKHR present = *pPresentInfo;
//   const SwapchainState *sc = find_swapchain(dev, pPresentInfo->pSwapchains[0]);
//   Compositor *c = sc ? compositor_for(dev, *sc, queue_family_of(dev, queue)) : nullptr;
//   VkSemaphore signal = VK_NULL_HANDLE;
//   if (c && c->composite(queue, pPresentInfo->pImageIndices[0],
//                         {pPresentInfo->pWaitSemaphores, pPresentInfo->waitSemaphoreCount},
//                         periphery /* the scaled render area the split used */, tiles, &signal) ==
//                         VK_SUCCESS) {
//       present.waitSemaphoreCount = 1;   // the app's semaphores are consumed by the compositor
//       present.pWaitSemaphores = &signal;
//   }   // otherwise present as the application asked: its semaphores are untouched
//   dev.dispatch.QueuePresentKHR(queue, &present);
//
// - Anything else that must see the composited image before present (SPLITVK_VERIFY's readback)
//   waits on `signal` and the present then waits on its semaphore instead.
// - Several swapchains in one present: composite each; give the application's semaphores to
//   the first only (a binary semaphore is waited once; later submits on the queue are in the
//   second scope of that wait) and let the present wait on every `signal`.
// - nullptr from compositor_for: the swapchain is not composable (the split must not have
//   split it) or the compositor could not be made (logged once): present unchanged.
//
// composite() submits one command buffer on the present queue that waits on the application's
// present semaphores (and so consumes them, as the present would have), and signals a semaphore
// of the compositor's that the present must wait on instead. Every swapchain image has its own
// slot (command buffer, fence, semaphore, periphery copy, the tiles' buffers), so a frame never
// overwrites resources a previous frame's submit still reads (the Mesa overlay's bug of one slot
// per submit index). A slot's previous submit is waited for before reuse, for at most one
// second (kSlotWaitNs); if it has not finished by then, composite() gives up for this frame
// rather than hang the application.

#include "core/device.h"
#include "settings.h"

#include <cstdint>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <vector>

namespace splitvk {

struct SwapchainState;

// A fovea tile: rect.extent.width * height pixels, 4 bytes each, rows tightly packed, in the
// swapchain format's byte order (what vkCmdCopyImageToBuffer of that image gives), at `offset` in
// `buffer` (TRANSFER_SRC usage, written by the host and flushed before composite(): the decoder
// writes them there, UploadPool). The GPU copies the tile's rect straight from it; the compositor
// holds `keep` until that copy has finished, so the memory is not rewritten while the GPU reads
// it. A tile reaching past the image is clipped to it (only the clipped rect is copied).
struct FoveaTile {
    VkRect2D rect{};
    VkBuffer buffer = VK_NULL_HANDLE;
    VkDeviceSize offset = 0; // a multiple of the texel size
    std::shared_ptr<const void> keep;
    uint32_t layer =
        0; // the array layer it goes into (a layered OpenXR eye image); a tile past them is dropped
    // Its texels' size as decoded (tile_format.h); a tile whose size is not the image format's is
    // dropped, so that no texel is ever copied in at another stride.
    uint32_t texel_bytes = 4;
};

// The swapped split (SPLITVK_CLIENT_RENDERS=fovea): the periphery the agent rendered, downsampled
// to `extent` (split::scaled_extent of the image's), as decoded parts (split::periphery_parts) in
// its own coordinates: each part as a FoveaTile whose rect is in the periphery, not the image.
struct PeripheryImage {
    VkExtent2D extent{};
    std::vector<FoveaTile> parts;
};

// An image the compositor makes for itself (a slot's periphery and seam copies, the swapped
// split's latest periphery): device-local memory, and a view where a draw samples it; all null and
// `extent` {} when there is none.
struct CompositorImage {
    VkImage image = VK_NULL_HANDLE;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    VkImageView view = VK_NULL_HANDLE;
    VkExtent2D extent{};
};

// The periphery filter, a specialisation constant of shaders/upsample.frag.
// BilinearBlit is no shader's: the upsample is a vkCmdBlitImage with a linear filter (bilinear
// too), where the format allows it (else Bilinear).
enum class UpsampleFilter : int { Bilinear = 0, CatmullRom = 1, BilinearBlit = 2 };
// What compositor_for() uses: bilinear, by vkCmdBlitImage. On lavapipe (one thread, best of 12,
// tests/unit/compositor_test.cpp DISABLED_Cost) a composite with the stereo foveae costs 16.9 ms at
// 2400x1080 and 2.1-2.2 ms at 960x432 with the blit, 19.6 ms and 2.6-2.9 ms with the bilinear
// shader drawn only around the foveae; both give the same picture (whole-frame SSIM against native
// on splitvk-atrium at 2400x1080: 0.9682 stereo, 0.9736 mono, 0.9673 sRGB). Catmull-Rom measured
// better against native (0.9714, 0.9760, 0.9707) but its 9 bilinear taps per pixel cost the weak
// client far more than they give (55.8 ms at 2400x1080 in the same measurement; in `scripts/bench
// paper --quick`, split/native 1.197 against 0.789). A client with a real GPU can afford it: pass
// UpsampleFilter::CatmullRom to create(). Catmull-Rom through 5 taps (the 9 less the corners,
// renormalised; tried, not kept) scored as well as the 9 at 2400x1080 (0.9715 stereo, 0.9762 mono,
// 0.9708 sRGB) and hardly better than bilinear at 960x432 (0.9017 against 0.9012 stereo, 0.9116
// against 0.9116 mono, 0.8995 against 0.8992 sRGB), but cost 44-62 ms and 7.6-8.7 ms: 2.5 to 3.5
// times the blit.
inline constexpr UpsampleFilter kDefaultUpsampleFilter = UpsampleFilter::BilinearBlit;

// The filter SPLITVK_UPSAMPLE asks for: bilinear by blit (create() draws it where the format does
// not blit), or Catmull-Rom by the draw (a layered image: one pass per layer).
UpsampleFilter upsample_filter(UpsampleMode mode);

class Compositor {
public:
    // Whether a swapchain of `format` (and `layers` array layers) can be composited on this device,
    // with the usage kSwapchainUsage added (swapchain.cpp asks before it adds the usage). `why` says
    // why not. Layered images (an OpenXR swapchain drawn with multiview) are upsampled by blit by
    // default, one layer per region, so their format must blit with a linear filter (the draw, one
    // pass per layer, needs only what every format here has).
    static bool supports(DeviceState &device, VkFormat format, std::string *why, uint32_t layers = 1);
    // The swapchain image usage composition needs: TRANSFER_SRC (the periphery copy),
    // TRANSFER_DST (the tiles), COLOR_ATTACHMENT (the upsample draw).
    static constexpr VkImageUsageFlags kSwapchainUsage = VK_IMAGE_USAGE_TRANSFER_SRC_BIT |
                                                         VK_IMAGE_USAGE_TRANSFER_DST_BIT |
                                                         VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT;

    // Everything composition needs that does not depend on a frame; per-image slots are made
    // on first use. nullptr and *error when the device cannot (queue_family without graphics,
    // unsupported format, out of memory). `timed`: each composite's GPU time is measured
    // (gpu_timing.h; SPLITVK_STATS' merge_gpu_ms).
    static std::unique_ptr<Compositor> create(DeviceState &device, const SwapchainState &swapchain,
                                              uint32_t queue_family, std::string *error,
                                              UpsampleFilter filter = kDefaultUpsampleFilter,
                                              bool timed = false);
    ~Compositor(); // waits (bounded) for its submits, then frees everything
    Compositor(const Compositor &) = delete;
    Compositor &operator=(const Compositor &) = delete;

    // Submits to `queue` (of the family given at create()): waits on `waits` (the application's
    // present wait semaphores), upsamples the top-left `periphery` of image `image_index` to the
    // whole image (each of its layers) but where tiles go (skipped when `periphery` is empty or the whole
    // image), writes `tiles` into it bit-exactly, and leaves it in the layout the present expects
    // (PRESENT_SRC_KHR, or SHARED_PRESENT_KHR for shared present modes). On VK_SUCCESS, *signal is the
    // compositor's semaphore that the present must wait on instead of `waits` (it stays the compositor's: do
    // not destroy it). On any other result nothing was submitted, `waits` are untouched and *signal is
    // unchanged: present as the application asked. VK_NOT_READY: nothing to do (no upsample, no tile);
    // VK_TIMEOUT: this image's previous composition had not finished. A null `signal` signals nothing (an
    // OpenXR runtime's image: the runtime's release barrier follows on the same queue).
    VkResult composite(VkQueue queue, uint32_t image_index, std::span<const VkSemaphore> waits,
                       VkExtent2D periphery, std::span<const FoveaTile> tiles, VkSemaphore *signal);

    // The swapped split's composite (composite()'s reverse): the client rendered the foveae, `keep`
    // (image rects; clipped, overlapping ones dropped), the agent the periphery. Submits to `queue`,
    // after `waits`: copies `keep` out of image `image_index` into a slot-owned buffer, uploads
    // `periphery`'s parts into the compositor's latest periphery (one image for every slot: the
    // composites are ordered on one queue), upsamples that over the image with the filter given at
    // create() (around `keep` where the scale allows), copies `keep` back byte for byte, and leaves
    // the image in the present layout. A null `periphery` upsamples the latest one again (a late
    // frame: the previous periphery with this frame's foveae). Results and `signal` as composite();
    // VK_NOT_READY: no periphery was ever uploaded (present the image as it is);
    // VK_ERROR_FORMAT_NOT_SUPPORTED: `periphery` is empty or larger than the image;
    // VK_ERROR_FEATURE_NOT_PRESENT: a layered image (OpenXR; not cut in this slice).
    // `feather` (SPLITVK_SEAM=feather:N; 0: a hard seam): around each kept fovea, in its
    // split::seam_rect of `feather` pixels (which the client rendered too: its cut is grown alike),
    // the client's pixels are blended into the upsampled periphery, weighted from 0 at the band's
    // outer edge to 1 at the fovea's (shaders/feather.frag); the foveae themselves stay exact. Late
    // frames are feathered alike. A format the device cannot blend into gets the hard seam (logged once).
    // Cost on lavapipe (2 busy cores, best of 12, DISABLED_Cost) at 2400x1080 with the stereo
    // foveae, blit: 18.9 ms, 18.6 ms late (composite() with tiles: 18.7 ms); the two copies of the
    // foveae cost little beside the upsample. The feather (16 pixels, or 1: it hardly depends on the
    // band's width) adds 7-9 ms there (23-25 ms against 15-17 ms, best of 12 on a busy machine): about
    // 2 ms the copy of the bands, the rest the blending pass, most of it a cost of lavapipe's per
    // render pass rather than of the band's 58k fragments.
    VkResult composite_periphery(VkQueue queue, uint32_t image_index, std::span<const VkSemaphore> waits,
                                 const PeripheryImage *periphery, std::span<const VkRect2D> keep,
                                 VkSemaphore *signal, uint32_t feather = 0);

    // SPLITVK_STATS' exposed wait (and SPLITVK_FOVEA=auto's, which sizes the fovea from it), before the
    // tile wait: submits an empty batch to `queue` that
    // waits on `waits` and signals *taken and *done. A fence signal covers every command submitted
    // to the queue before it, so *done tells when the GPU has finished the application's frame.
    // On VK_SUCCESS `waits` are consumed: pass {*taken} to composite() instead, and present with
    // *taken if composite() then fails (both stay the compositor's). Otherwise nothing was
    // submitted. VK_TIMEOUT: this image's previous composition had not finished.
    VkResult take_waits(VkQueue queue, uint32_t image_index, std::span<const VkSemaphore> waits,
                        VkSemaphore *taken, VkFence *done);

    uint32_t queue_family() const { return queue_family_; }

    // Created `timed`: GPU milliseconds of the latest composite whose fence the compositor has
    // seen signalled (a few presents old), 0 before the first.
    double latest_gpu_ms();

private:
    struct Slot;
    Compositor(DeviceState &device, const SwapchainState &swapchain, uint32_t queue_family,
               UpsampleFilter filter, bool timed);
    bool init(std::string *error);
    bool init_slot(Slot &slot, uint32_t image_index, std::string *error);
    // feather_pipeline_ and what it needs, from init()'s upsample pipeline (left null where the format
    // cannot blend, or creation fails: the seam is then hard).
    void create_feather_pipeline(VkShaderModule vert, VkRenderPassCreateInfo render_pass_info,
                                 VkGraphicsPipelineCreateInfo pipeline_info);
    // Under mutex_: image `image_index`'s slot, made on first use, its previous submits finished
    // (bounded; take_waits()'s only when `wait_taken`); nullptr and *result when not.
    Slot *ready_slot(uint32_t image_index, bool wait_taken, VkResult *result);
    void read_timing(Slot &slot); // after the slot's fence: its composite's GPU time
    bool ensure_periphery_image(Slot &slot, VkExtent2D periphery, std::string *error);
    // The slot's command buffer begun afresh (the idle slot's: its fence waited for), with the
    // composite's first timestamp when timed; end_recording(): its last, and the buffer ended.
    void begin_recording(Slot &slot);
    void end_recording(Slot &slot);
    void record(Slot &slot, uint32_t image_index, VkExtent2D periphery); // periphery {} = no upsample
    // A barrier over every layer of `image` (the swapchain's or the slot's periphery copy): a layered
    // image is composited whole.
    VkImageMemoryBarrier layered_barrier(VkImage image, VkAccessFlags src, VkAccessFlags dst,
                                         VkImageLayout from, VkImageLayout to) const;
    // The upsample of `source` (`periphery` large) over the image, which is in TRANSFER_SRC_OPTIMAL
    // after transfer reads, around copy_regions_, then the image to where record_tile_copies()
    // wants it (or to the present layout when there is nothing to copy). `source_written`: it is in
    // TRANSFER_DST_OPTIMAL just written by a copy (the slot's periphery image, which the draw needs);
    // otherwise in TRANSFER_SRC_OPTIMAL, readable by transfers (the latest periphery, blit only).
    void record_upsample(Slot &slot, VkImage image, VkExtent2D periphery, VkImage source,
                         bool source_written);
    // copy_regions_ from copy_buffers_ into the image, then the present layout; nothing without any.
    void record_tile_copies(Slot &slot, VkImage image);
    VkResult submit(Slot &slot, VkQueue queue, std::span<const VkSemaphore> waits, VkSemaphore *signal);
    // composite_periphery(): copy_regions_ are the foveae kept, in the slot's saved buffer.
    void record_periphery(Slot &slot, uint32_t image_index, std::span<const VkBufferImageCopy> parts,
                          std::span<const VkBuffer> part_buffers);
    bool ensure_latest_periphery(VkExtent2D extent, std::string *error); // waits for every slot to resize
    bool ensure_saved_buffer(Slot &slot, VkDeviceSize size, std::string *error);
    // The slot's copy of the client's seam rectangles (seams_), side by side; idle slot only.
    bool ensure_seam_image(Slot &slot, VkExtent2D extent, std::string *error);
    // The feather draw over the upsampled image (TRANSFER_DST_OPTIMAL, left there for the fovea copies).
    void record_seams(Slot &slot, VkImage image);
    void destroy_latest_periphery();
    void destroy_slot(Slot &slot);

    DeviceState &device_;
    VkSwapchainKHR swapchain_ = VK_NULL_HANDLE;
    VkExtent2D extent_{};
    VkFormat format_ = VK_FORMAT_UNDEFINED;
    uint32_t texel_bytes_ = 4; // tile_texel_bytes(format_): the stride of every tile copied in
    uint32_t layers_ = 1;      // every image's array layers, each composited alike
    VkImageLayout present_layout_ = VK_IMAGE_LAYOUT_PRESENT_SRC_KHR;
    // What orders the application's rendering before the composite (the semaphores the submit waits
    // on at TRANSFER, or for a runtime's image the queue alone), and the composite before whatever
    // reads the image next (the present's semaphore, or the runtime's barrier on the queue).
    VkPipelineStageFlags ready_stages_ = VK_PIPELINE_STAGE_TRANSFER_BIT;
    VkAccessFlags ready_access_ = 0;
    VkPipelineStageFlags done_stages_ = VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT;
    VkAccessFlags done_access_ = 0;
    std::vector<VkImage> images_;
    uint32_t queue_family_ = 0;
    UpsampleFilter filter_ = kDefaultUpsampleFilter;
    bool blit_ = false; // the upsample is a vkCmdBlitImage, not a draw
    bool timed_ = false;
    double latest_gpu_ms_ = 0; // under mutex_

    VkCommandPool pool_ = VK_NULL_HANDLE;
    VkSampler sampler_ = VK_NULL_HANDLE;
    VkDescriptorSetLayout set_layout_ = VK_NULL_HANDLE;
    VkDescriptorPool descriptor_pool_ = VK_NULL_HANDLE;
    VkPipelineLayout pipeline_layout_ = VK_NULL_HANDLE;
    VkRenderPass render_pass_ = VK_NULL_HANDLE;
    VkPipeline pipeline_ = VK_NULL_HANDLE;
    // The swapped split's feathered seam: its own push constants, a pass that loads the image (the
    // upsample's pass need not), and the blending pipeline; null where the format cannot blend.
    VkPipelineLayout feather_layout_ = VK_NULL_HANDLE;
    VkRenderPass seam_pass_ = VK_NULL_HANDLE;
    VkPipeline feather_pipeline_ = VK_NULL_HANDLE;

    std::mutex mutex_;                            // one present at a time per swapchain; guards the slots
    std::vector<std::unique_ptr<Slot>> slots_;    // by image index, made on first use
    std::vector<VkBufferImageCopy> copy_regions_; // this frame's tiles, for record()
    std::vector<VkBuffer> copy_buffers_;          // the buffer of each of copy_regions_
    // composite_periphery() with a feather: each kept fovea's seam rectangle (split::seam_rect), the
    // fovea, and where the rectangle's pixels go in the slot's seam image.
    struct Seam {
        VkRect2D rect{};
        VkRect2D fovea{};
        int32_t x = 0; // in the seam image (its rectangles side by side, at y 0)
    };
    std::vector<Seam> seams_;
    uint32_t feather_ = 0; // this composite's

    // composite_periphery(): the agent's latest periphery (TRANSFER_SRC|DST, the swapchain's
    // format, exactly its size), under mutex_. Its layout is the one the last submitted composite
    // left it in; `latest_filled_` once a composite uploaded into it.
    CompositorImage latest_;
    VkImageLayout latest_layout_ = VK_IMAGE_LAYOUT_UNDEFINED;
    bool latest_filled_ = false;
};

// The parts of an `image` that the upsample draws when `tiles` (non-overlapping, inside the
// image) are copied over it afterwards: the rects around them, in horizontal bands, top to bottom.
std::vector<VkRect2D> periphery_bands(VkExtent2D image, std::span<const VkBufferImageCopy> tiles);

// The regions of the blit that upsamples `periphery` to `image` around `tiles` (the same kind):
// bands whose edges map onto whole periphery texels, each scaled exactly as the whole image is.
std::vector<VkImageBlit> blit_regions(VkExtent2D image, VkExtent2D periphery,
                                      std::span<const VkBufferImageCopy> tiles);

// The compositor of a swapchain, created on first use (for `queue_family`, the present queue's);
// nullptr, with one log line per swapchain, when the swapchain is not composable or the
// compositor cannot be made. A later call with another queue family replaces it. `timed`: see
// Compositor::create (the first call decides).
Compositor *compositor_for(DeviceState &device, const SwapchainState &swapchain, uint32_t queue_family,
                           bool timed = false);
// vkDestroySwapchainKHR (swapchain.cpp): frees the swapchain's compositor.
void release_compositor(DeviceState &device, VkSwapchainKHR swapchain);
// vkDestroyDevice: frees the compositors of swapchains the application did not destroy.
void release_compositors(DeviceState &device);

} // namespace splitvk
