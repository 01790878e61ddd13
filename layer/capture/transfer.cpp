// Copies, blits, resolves and dispatches over screen-space targets and swapchain images (transfer.h).

#include "capture/transfer.h"

#include "capture/command_buffer.h"
#include "capture/descriptor_set.h"
#include "capture/screen_space.h"
#include "capture/split.h"
#include "core/gpu_timing.h"
#include "layer_entry_points.h"
#include "split_geometry.h"

#include <algorithm>
#include <vector>

namespace splitvk {

namespace {

enum class Kind { Plain, Scaled, Swapchain };

struct Side {
    const DeviceState *device = nullptr;
    Kind kind = Kind::Plain;
    VkImage image = VK_NULL_HANDLE;
    VkExtent2D extent{}; // the swapchain's
    // SPLITVK_CLIENT_RENDERS=fovea: a swapchain image written full size, not scaled (still noted as
    // drawn); the composite overwrites what lies outside the foveae.
    bool cut = false;
};

// Whether split passes of `cb` drew into `image` before now: its periphery is then scaled into its
// top-left, as every pass into it this frame has drawn it.
bool drawn_split_in(VkCommandBuffer cb, VkImage image) {
    const split::CommandTracker *tracker = split_tracker(cb);
    if (!tracker) return false;
    const uint64_t id = codec::handle_value(image);
    return std::any_of(tracker->drawn().begin(), tracker->drawn().end(),
                       [&](const split::DrawnImage &d) { return d.image == id; });
}

Side side_of(DeviceState &dev, VkCommandBuffer cb, VkImage image, bool destination) {
    Side s;
    s.device = &dev;
    s.image = image;
    if (is_screen_space(dev, image)) {
        s.kind = Kind::Scaled;
    } else if (destination && split_recording(dev) && !(split_swapped(dev) && !split_cutting(dev)) &&
               swapchain_image_extent(dev, image, &s.extent)) {
        s.kind = Kind::Swapchain;
        s.cut = split_cutting(dev);
    } else if (!destination && split_recording(dev) && !split_swapped(dev) &&
               swapchain_image_extent(dev, image, &s.extent) && drawn_split_in(cb, image)) {
        // A copy out of an image this command buffer drew split (an engine's mirror window of its
        // eye image, copied before the image is released): it reads the scaled picture the passes
        // drew, as a screen-space target's copy does. Into another swapchain image it makes that
        // image's frame split too (note_swapchain_write), whose present composites the agent's
        // foveae of it; into a full-size image it is upsampled (copy_as_blit): the periphery,
        // never the scaled miniature.
        s.kind = Kind::Swapchain;
    } else if (!destination && split_recording(dev) && swapchain_image_extent(dev, image, &s.extent)) {
        log_unscalable_once("a copy out of a swapchain image reads what the client drew: its periphery "
                            "part is scaled into the top-left (the app's own read-back, not the display)");
    }
    return s;
}

VkRect2D scale_side(const Side &s, uint32_t mip, const VkRect2D &r) {
    const double scale = split_settings().scale;
    switch (s.kind) {
    case Kind::Scaled:
        return scale_image_rect(*s.device, s.image, mip, r);
    case Kind::Swapchain:
        if (s.cut) return r;
        return split::scale_rect(r, split::axis_scale(s.extent, scale),
                                 split::scaled_extent(s.extent, scale));
    case Kind::Plain:
        break;
    }
    return r;
}

VkRect2D rect_of(VkOffset3D o, VkExtent3D e) {
    return {{o.x, o.y}, {e.width, e.height}};
}

void note_swapchain_write(VkCommandBuffer cb, const Side &dst, const VkRect2D &region) {
    split::CommandTracker *tracker = split_tracker(cb);
    if (!tracker) return;
    tracker->note_transfer(codec::handle_value(dst.image), dst.extent, region, dst.cut);
}

// Copies and resolves: one extent for both sides. Returns false when the command goes down as
// recorded (nothing to scale, or a full-size image copied into a swapchain image: unsplit).
template <class Region>
bool scale_copies(DeviceState &dev, VkCommandBuffer cb, VkImage src, VkImage dst, uint32_t count,
                  const Region *regions, std::vector<Region> &out) {
    const Side s = side_of(dev, cb, src, false), d = side_of(dev, cb, dst, true);
    if (s.kind != Kind::Scaled && d.kind != Kind::Scaled && d.kind != Kind::Swapchain) return false;
    if (s.kind == Kind::Plain && d.kind == Kind::Swapchain && d.cut) {
        // Fovea mode: full size on both sides, as recorded.
    } else if (s.kind == Kind::Plain && d.kind == Kind::Swapchain)
        log_unscalable_once("a resolve into a swapchain image from a full-size image: the client's periphery "
                            "shows its top-left part (the foveae stay exact)");
    else if (s.kind == Kind::Plain || d.kind == Kind::Plain)
        log_unscalable_once("a copy between a screen-space target and a full-size image: the full-size one "
                            "holds the scaled picture in its top-left on the client (periphery only)");
    out.assign(regions, regions + count);
    for (Region &r : out) {
        const VkRect2D sr = scale_side(s, r.srcSubresource.mipLevel, rect_of(r.srcOffset, r.extent));
        const VkRect2D dr = scale_side(d, r.dstSubresource.mipLevel, rect_of(r.dstOffset, r.extent));
        // Offsets scale on their own side; the shared extent is what both sides can hold.
        r.srcOffset.x = sr.offset.x;
        r.srcOffset.y = sr.offset.y;
        r.dstOffset.x = dr.offset.x;
        r.dstOffset.y = dr.offset.y;
        r.extent.width = std::min(s.kind == Kind::Plain ? dr.extent.width : sr.extent.width,
                                  d.kind == Kind::Plain ? sr.extent.width : dr.extent.width);
        r.extent.height = std::min(s.kind == Kind::Plain ? dr.extent.height : sr.extent.height,
                                   d.kind == Kind::Plain ? sr.extent.height : dr.extent.height);
    }
    if (d.kind == Kind::Swapchain)
        for (uint32_t i = 0; i < count; ++i)
            note_swapchain_write(cb, d, rect_of(regions[i].dstOffset, regions[i].extent));
    std::erase_if(out, [](const Region &r) { return r.extent.width == 0 || r.extent.height == 0; });
    return true;
}

// A blit's two corners (either order: a blit may mirror) scaled as a rectangle, order kept.
void scale_corners(const Side &s, uint32_t mip, VkOffset3D corners[2]) {
    const int32_t x0 = std::min(corners[0].x, corners[1].x), x1 = std::max(corners[0].x, corners[1].x);
    const int32_t y0 = std::min(corners[0].y, corners[1].y), y1 = std::max(corners[0].y, corners[1].y);
    const VkRect2D r =
        scale_side(s, mip, {{x0, y0}, {static_cast<uint32_t>(x1 - x0), static_cast<uint32_t>(y1 - y0)}});
    const int32_t nx1 = r.offset.x + static_cast<int32_t>(r.extent.width);
    const int32_t ny1 = r.offset.y + static_cast<int32_t>(r.extent.height);
    const bool flip_x = corners[0].x > corners[1].x, flip_y = corners[0].y > corners[1].y;
    corners[0].x = flip_x ? nx1 : r.offset.x;
    corners[1].x = flip_x ? r.offset.x : nx1;
    corners[0].y = flip_y ? ny1 : r.offset.y;
    corners[1].y = flip_y ? r.offset.y : ny1;
}

// A copy between a swapchain image that holds the scaled picture and a full-size image cannot keep
// one extent for both sides: it goes down as a blit of the whole region. Into a swapchain image, a
// nearest-filtered one into the scaled top-left (the periphery only; the agent replays the copy);
// out of one drawn split into a full-size image, a linear one of the scaled region over the whole
// region, so that the full-size image holds the periphery upsampled (a composable swapchain's
// format filters linearly, Compositor::supports). Same format on both sides: the blit converts
// nothing.
template <class Region>
bool copy_as_blit(DeviceState &dev, VkCommandBuffer cb, VkImage src, VkImageLayout src_layout, VkImage dst,
                  VkImageLayout dst_layout, uint32_t count, const Region *regions) {
    const Side s = side_of(dev, cb, src, false), d = side_of(dev, cb, dst, true);
    const bool into = s.kind == Kind::Plain && d.kind == Kind::Swapchain && !d.cut;
    const bool out_of = s.kind == Kind::Swapchain && d.kind == Kind::Plain;
    if (!into && !out_of) return false;
    if (out_of)
        log_unscalable_once("a copy out of an image drawn split into a full-size image holds its periphery, "
                            "upsampled (an agent's foveae come only into swapchain images)");
    std::vector<VkImageBlit> blits;
    for (uint32_t i = 0; i < count; ++i) {
        const Region &r = regions[i];
        VkImageBlit b{};
        b.srcSubresource = r.srcSubresource;
        b.dstSubresource = r.dstSubresource;
        b.srcOffsets[0] = r.srcOffset;
        b.srcOffsets[1] = {r.srcOffset.x + static_cast<int32_t>(r.extent.width),
                           r.srcOffset.y + static_cast<int32_t>(r.extent.height), r.srcOffset.z + 1};
        b.dstOffsets[0] = r.dstOffset;
        b.dstOffsets[1] = {r.dstOffset.x + static_cast<int32_t>(r.extent.width),
                           r.dstOffset.y + static_cast<int32_t>(r.extent.height), r.dstOffset.z + 1};
        if (into) {
            scale_corners(d, r.dstSubresource.mipLevel, b.dstOffsets);
            note_swapchain_write(cb, d, rect_of(r.dstOffset, r.extent));
        } else {
            scale_corners(s, r.srcSubresource.mipLevel, b.srcOffsets);
        }
        if (b.dstOffsets[0].x != b.dstOffsets[1].x && b.dstOffsets[0].y != b.dstOffsets[1].y &&
            b.srcOffsets[0].x != b.srcOffsets[1].x && b.srcOffsets[0].y != b.srcOffsets[1].y)
            blits.push_back(b);
    }
    if (!blits.empty())
        dev.dispatch.CmdBlitImage(cb, src, src_layout, dst, dst_layout, static_cast<uint32_t>(blits.size()),
                                  blits.data(), into ? VK_FILTER_NEAREST : VK_FILTER_LINEAR);
    return true;
}

template <class Region>
bool scale_blits(DeviceState &dev, VkCommandBuffer cb, VkImage src, VkImage dst, uint32_t count,
                 const Region *regions, std::vector<Region> &out) {
    const Side s = side_of(dev, cb, src, false), d = side_of(dev, cb, dst, true);
    if (s.kind == Kind::Plain && d.kind == Kind::Plain) return false;
    out.assign(regions, regions + count);
    for (uint32_t i = 0; i < count; ++i) {
        scale_corners(s, out[i].srcSubresource.mipLevel, out[i].srcOffsets);
        scale_corners(d, out[i].dstSubresource.mipLevel, out[i].dstOffsets);
        if (d.kind == Kind::Swapchain) {
            const VkOffset3D *c = regions[i].dstOffsets;
            const int32_t x0 = std::min(c[0].x, c[1].x), y0 = std::min(c[0].y, c[1].y);
            note_swapchain_write(cb, d,
                                 {{x0, y0},
                                  {static_cast<uint32_t>(std::max(c[0].x, c[1].x) - x0),
                                   static_cast<uint32_t>(std::max(c[0].y, c[1].y) - y0)}});
        }
    }
    std::erase_if(out, [](const Region &r) {
        return r.srcOffsets[0].x == r.srcOffsets[1].x || r.srcOffsets[0].y == r.srcOffsets[1].y ||
               r.dstOffsets[0].x == r.dstOffsets[1].x || r.dstOffsets[0].y == r.dstOffsets[1].y;
    });
    return true;
}

// Buffer <-> image: the image region scales; the buffer keeps the app's addressing (its row length
// and image height made explicit), so the scaled texels land within what the app's region spans.
template <class Region>
bool scale_buffer_copies(const DeviceState &dev, VkImage image, uint32_t count, const Region *regions,
                         std::vector<Region> &out) {
    if (!is_screen_space(dev, image)) return false;
    log_unscalable_once("a buffer copy to or from a screen-space target moves the scaled picture (periphery "
                        "only: the agent replays it full size)");
    out.assign(regions, regions + count);
    for (Region &r : out) {
        if (r.bufferRowLength == 0) r.bufferRowLength = r.imageExtent.width;
        if (r.bufferImageHeight == 0) r.bufferImageHeight = r.imageExtent.height;
        const VkRect2D rect =
            scale_image_rect(dev, image, r.imageSubresource.mipLevel, rect_of(r.imageOffset, r.imageExtent));
        r.imageOffset.x = rect.offset.x;
        r.imageOffset.y = rect.offset.y;
        r.imageExtent.width = rect.extent.width;
        r.imageExtent.height = rect.extent.height;
    }
    std::erase_if(out, [](const Region &r) { return r.imageExtent.width == 0 || r.imageExtent.height == 0; });
    return true;
}

// Whether a compute descriptor set bound in `cb` (its split tracker's, begun afresh with it: a set
// its previous recording bound does not count) writes a screen-space target.
bool dispatch_writes_screen_space(const DeviceState &dev, VkCommandBuffer cb) {
    const split::CommandTracker *tracker = split_tracker(cb);
    return tracker && tracker->dispatch_writes_screen_space(
                          [&](VkDescriptorSet set) { return set_writes_screen_space(dev, set); });
}

// The periphery's GPU time (SPLITVK_STATS) ends with the write into the swapchain image when that is
// a copy or blit rather than a pass (atrium --path compute).
void after_transfer(DeviceState &dev, VkCommandBuffer cb, VkImage dst) {
    VkExtent2D extent{};
    if (!split_recording(dev) || !swapchain_image_extent(dev, dst, &extent)) return;
    if (CommandTiming *timing = command_buffer_timing(cb)) time_split_pass_ended(dev, cb, *timing);
}

// A region command goes down as the application recorded it when `scaled` is false; otherwise
// with `regions` (the scaled ones; none left means nothing to do). `down` takes the count and
// regions to pass.
template <class Region, class Down>
void pass_down_regions(bool scaled, uint32_t count, const Region *recorded,
                       const std::vector<Region> &regions, Down &&down) {
    if (!scaled) return down(count, recorded);
    if (!regions.empty()) down(static_cast<uint32_t>(regions.size()), regions.data());
}

// A *2 region command goes down as the application recorded it when `scaled` is false; otherwise
// with `regions` (the scaled ones; none left means nothing to do) in a copy of its info.
template <class Info, class Region, class Next>
void pass_down_regions2(VkCommandBuffer cb, const Info *info, bool scaled, const std::vector<Region> &regions,
                        Next next) {
    if (!scaled) return next(cb, info);
    if (regions.empty()) return;
    Info copy = *info;
    copy.regionCount = static_cast<uint32_t>(regions.size());
    copy.pRegions = regions.data();
    next(cb, &copy);
}

} // namespace

namespace observe {

void CmdBindDescriptorSets(DeviceState &, VkCommandBuffer cb, VkPipelineBindPoint bind_point,
                           VkPipelineLayout, uint32_t first, uint32_t count, const VkDescriptorSet *sets,
                           uint32_t, const uint32_t *) {
    if (bind_point != VK_PIPELINE_BIND_POINT_COMPUTE) return;
    if (split::CommandTracker *tracker = split_tracker(cb)) tracker->bind_compute_sets(first, count, sets);
}

// Its group counts live in GPU memory, written by earlier GPU work the layer cannot see finish at
// record time, so they cannot be scaled: the dispatch covers the full extent, which a shader
// bound-checked with imageSize() clips to the scaled image (correct, as costly as native).
void CmdDispatchIndirect(DeviceState &dev, VkCommandBuffer cb, VkBuffer, VkDeviceSize) {
    if (dispatch_writes_screen_space(dev, cb))
        log_unscalable_once("an indirect dispatch writes a screen-space target: its group counts are in "
                            "GPU memory, so it runs unscaled (correct where the shader bound-checks "
                            "with imageSize(), at native cost)");
}

} // namespace observe

namespace rewrite {

void CmdCopyImage(DeviceState &dev, PFN_vkCmdCopyImage down, VkCommandBuffer commandBuffer, VkImage srcImage,
                  VkImageLayout srcImageLayout, VkImage dstImage, VkImageLayout dstImageLayout,
                  uint32_t regionCount, const VkImageCopy *pRegions) {
    if (copy_as_blit(dev, commandBuffer, srcImage, srcImageLayout, dstImage, dstImageLayout, regionCount,
                     pRegions))
        return after_transfer(dev, commandBuffer, dstImage);
    std::vector<VkImageCopy> out;
    const bool scaled = scale_copies(dev, commandBuffer, srcImage, dstImage, regionCount, pRegions, out);
    pass_down_regions(scaled, regionCount, pRegions, out, [&](uint32_t count, const VkImageCopy *regions) {
        down(commandBuffer, srcImage, srcImageLayout, dstImage, dstImageLayout, count, regions);
    });
    after_transfer(dev, commandBuffer, dstImage);
}

void CmdCopyImage2(DeviceState &dev, PFN_vkCmdCopyImage2 down, VkCommandBuffer commandBuffer,
                   const VkCopyImageInfo2 *info) {
    if (copy_as_blit(dev, commandBuffer, info->srcImage, info->srcImageLayout, info->dstImage,
                     info->dstImageLayout, info->regionCount, info->pRegions))
        return after_transfer(dev, commandBuffer, info->dstImage);
    std::vector<VkImageCopy2> out;
    const bool scaled = scale_copies(dev, commandBuffer, info->srcImage, info->dstImage, info->regionCount,
                                     info->pRegions, out);
    pass_down_regions2(commandBuffer, info, scaled, out, down);
    after_transfer(dev, commandBuffer, info->dstImage);
}

void CmdResolveImage(DeviceState &dev, PFN_vkCmdResolveImage down, VkCommandBuffer commandBuffer,
                     VkImage srcImage, VkImageLayout srcImageLayout, VkImage dstImage,
                     VkImageLayout dstImageLayout, uint32_t regionCount, const VkImageResolve *pRegions) {
    std::vector<VkImageResolve> out;
    const bool scaled = scale_copies(dev, commandBuffer, srcImage, dstImage, regionCount, pRegions, out);
    pass_down_regions(scaled, regionCount, pRegions, out, [&](uint32_t count, const VkImageResolve *regions) {
        down(commandBuffer, srcImage, srcImageLayout, dstImage, dstImageLayout, count, regions);
    });
    after_transfer(dev, commandBuffer, dstImage);
}

void CmdResolveImage2(DeviceState &dev, PFN_vkCmdResolveImage2 down, VkCommandBuffer commandBuffer,
                      const VkResolveImageInfo2 *info) {
    std::vector<VkImageResolve2> out;
    const bool scaled = scale_copies(dev, commandBuffer, info->srcImage, info->dstImage, info->regionCount,
                                     info->pRegions, out);
    pass_down_regions2(commandBuffer, info, scaled, out, down);
    after_transfer(dev, commandBuffer, info->dstImage);
}

void CmdBlitImage(DeviceState &dev, PFN_vkCmdBlitImage down, VkCommandBuffer commandBuffer, VkImage srcImage,
                  VkImageLayout srcImageLayout, VkImage dstImage, VkImageLayout dstImageLayout,
                  uint32_t regionCount, const VkImageBlit *pRegions, VkFilter filter) {
    std::vector<VkImageBlit> out;
    const bool scaled = scale_blits(dev, commandBuffer, srcImage, dstImage, regionCount, pRegions, out);
    pass_down_regions(scaled, regionCount, pRegions, out, [&](uint32_t count, const VkImageBlit *regions) {
        down(commandBuffer, srcImage, srcImageLayout, dstImage, dstImageLayout, count, regions, filter);
    });
    after_transfer(dev, commandBuffer, dstImage);
}

void CmdBlitImage2(DeviceState &dev, PFN_vkCmdBlitImage2 down, VkCommandBuffer commandBuffer,
                   const VkBlitImageInfo2 *info) {
    std::vector<VkImageBlit2> out;
    const bool scaled = scale_blits(dev, commandBuffer, info->srcImage, info->dstImage, info->regionCount,
                                    info->pRegions, out);
    pass_down_regions2(commandBuffer, info, scaled, out, down);
    after_transfer(dev, commandBuffer, info->dstImage);
}

void CmdCopyBufferToImage(DeviceState &dev, PFN_vkCmdCopyBufferToImage down, VkCommandBuffer commandBuffer,
                          VkBuffer srcBuffer, VkImage dstImage, VkImageLayout dstImageLayout,
                          uint32_t regionCount, const VkBufferImageCopy *pRegions) {
    std::vector<VkBufferImageCopy> out;
    const bool scaled = scale_buffer_copies(dev, dstImage, regionCount, pRegions, out);
    pass_down_regions(scaled, regionCount, pRegions, out,
                      [&](uint32_t count, const VkBufferImageCopy *regions) {
                          down(commandBuffer, srcBuffer, dstImage, dstImageLayout, count, regions);
                      });
}

void CmdCopyBufferToImage2(DeviceState &dev, PFN_vkCmdCopyBufferToImage2 down, VkCommandBuffer commandBuffer,
                           const VkCopyBufferToImageInfo2 *info) {
    std::vector<VkBufferImageCopy2> out;
    const bool scaled = scale_buffer_copies(dev, info->dstImage, info->regionCount, info->pRegions, out);
    pass_down_regions2(commandBuffer, info, scaled, out, down);
}

void CmdCopyImageToBuffer(DeviceState &dev, PFN_vkCmdCopyImageToBuffer down, VkCommandBuffer commandBuffer,
                          VkImage srcImage, VkImageLayout srcImageLayout, VkBuffer dstBuffer,
                          uint32_t regionCount, const VkBufferImageCopy *pRegions) {
    std::vector<VkBufferImageCopy> out;
    const bool scaled = scale_buffer_copies(dev, srcImage, regionCount, pRegions, out);
    pass_down_regions(scaled, regionCount, pRegions, out,
                      [&](uint32_t count, const VkBufferImageCopy *regions) {
                          down(commandBuffer, srcImage, srcImageLayout, dstBuffer, count, regions);
                      });
}

void CmdCopyImageToBuffer2(DeviceState &dev, PFN_vkCmdCopyImageToBuffer2 down, VkCommandBuffer commandBuffer,
                           const VkCopyImageToBufferInfo2 *info) {
    std::vector<VkBufferImageCopy2> out;
    const bool scaled = scale_buffer_copies(dev, info->srcImage, info->regionCount, info->pRegions, out);
    pass_down_regions2(commandBuffer, info, scaled, out, down);
}

// A dispatch with a screen-space storage image bound covers the scaled image with ceil(n·s)
// groups. Shaders that bound-check against imageSize() then shade exactly the scaled target; a
// shader that takes the extent from a uniform shades the scaled image's top-left part of it (a
// periphery artefact; docs/architecture.md §4, the agent replays it full size).
void CmdDispatch(DeviceState &dev, PFN_vkCmdDispatch down, VkCommandBuffer commandBuffer,
                 uint32_t groupCountX, uint32_t groupCountY, uint32_t groupCountZ) {
    if (dispatch_writes_screen_space(dev, commandBuffer)) {
        const double s = split_settings().scale;
        groupCountX = split::scaled_group_count(groupCountX, s);
        groupCountY = split::scaled_group_count(groupCountY, s);
    }
    down(commandBuffer, groupCountX, groupCountY, groupCountZ);
}

// Base and counts scale together (split::scaled_group_range), so that a dispatch split in parts
// over a scaled target still covers all of it; Z, like vkCmdDispatch's, is layers, not pixels.
void CmdDispatchBase(DeviceState &dev, PFN_vkCmdDispatchBase down, VkCommandBuffer commandBuffer,
                     uint32_t baseGroupX, uint32_t baseGroupY, uint32_t baseGroupZ, uint32_t groupCountX,
                     uint32_t groupCountY, uint32_t groupCountZ) {
    if (dispatch_writes_screen_space(dev, commandBuffer)) {
        const double s = split_settings().scale;
        const split::GroupRange x = split::scaled_group_range(baseGroupX, groupCountX, s);
        const split::GroupRange y = split::scaled_group_range(baseGroupY, groupCountY, s);
        baseGroupX = x.base;
        groupCountX = x.count;
        baseGroupY = y.base;
        groupCountY = y.count;
    }
    down(commandBuffer, baseGroupX, baseGroupY, baseGroupZ, groupCountX, groupCountY, groupCountZ);
}

} // namespace rewrite
} // namespace splitvk
