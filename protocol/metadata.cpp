#include "metadata.h"

#include "wire.h"

#include <algorithm>
#include <cmath>
#include <tuple>

namespace splitvk::protocol {
namespace {

template <typename T>
Result<T> finish(WireReader &r, T value, const char *what) {
    r.expect_end();
    if (!r.ok()) return Error{std::string("malformed ") + what + ": " + r.error()};
    return value;
}

} // namespace

std::vector<uint8_t> encode(const MemoryData &m) {
    WireWriter w(32 + m.bytes.size());
    w.u64(m.device_id);
    w.u64(m.memory_id);
    w.u64(m.offset);
    w.blob(m.bytes);
    return w.take();
}

Result<MemoryData> decode_memory_data(std::span<const uint8_t> payload, uint32_t max_bytes) {
    WireReader r(payload);
    MemoryData m;
    m.device_id = r.u64("device_id");
    m.memory_id = r.u64("memory_id");
    m.offset = r.u64("offset");
    const auto bytes = r.blob(max_bytes, "bytes");
    m.bytes.assign(bytes.begin(), bytes.end());
    return finish(r, std::move(m), "MemoryData");
}

std::vector<uint8_t> encode(const SwapchainImages &m) {
    WireWriter w(48 + 8 * m.image_ids.size());
    w.u64(m.device_id);
    w.u64(m.swapchain_id);
    w.u32(m.width);
    w.u32(m.height);
    w.u32(m.format);
    w.u32(m.usage);
    w.u32(m.array_layers);
    w.u32(static_cast<uint32_t>(m.image_ids.size()));
    for (uint64_t id : m.image_ids)
        w.u64(id);
    // Appended for an OpenXR runtime's swapchain; a window's is laid out as before.
    if (m.source != SwapchainImages::Source::Window ||
        m.presented_layout != VK_IMAGE_LAYOUT_PRESENT_SRC_KHR) {
        w.u32(static_cast<uint32_t>(m.source));
        w.u32(m.presented_layout);
    }
    return w.take();
}

Result<SwapchainImages> decode_swapchain_images(std::span<const uint8_t> payload) {
    WireReader r(payload);
    SwapchainImages m;
    m.device_id = r.u64("device_id");
    m.swapchain_id = r.u64("swapchain_id");
    m.width = r.u32("width");
    m.height = r.u32("height");
    m.format = r.u32("format");
    m.usage = r.u32("usage");
    m.array_layers = r.u32("array_layers");
    const uint32_t count = r.u32("image count");
    if (r.ok() && (count == 0 || count > kMaxSwapchainImages))
        r.fail("image count " + std::to_string(count) + " outside 1.." + std::to_string(kMaxSwapchainImages));
    if (r.ok() && (m.width == 0 || m.height == 0 || m.width > kMaxVerifyExtent ||
                   m.height > kMaxVerifyExtent || m.array_layers == 0 || m.array_layers > 16))
        r.fail("swapchain extent or layers out of range");
    for (uint32_t i = 0; r.ok() && i < count; ++i)
        m.image_ids.push_back(r.u64("image id"));
    if (r.remaining() > 0) {
        const uint32_t source = r.u32("source");
        m.presented_layout = r.u32("presented layout");
        if (r.ok() && source > static_cast<uint32_t>(SwapchainImages::Source::Runtime))
            r.fail("unknown image source " + std::to_string(source));
        m.source = static_cast<SwapchainImages::Source>(source);
        if (r.ok() && m.presented_layout != VK_IMAGE_LAYOUT_PRESENT_SRC_KHR &&
            m.presented_layout != VK_IMAGE_LAYOUT_SHARED_PRESENT_KHR &&
            m.presented_layout != VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL)
            r.fail("presented layout " + std::to_string(m.presented_layout) + " is not one a frame ends in");
    }
    return finish(r, std::move(m), "SwapchainImages");
}

std::vector<uint8_t> encode(const SwapchainDestroyed &m) {
    WireWriter w(16);
    w.u64(m.device_id);
    w.u64(m.swapchain_id);
    return w.take();
}

Result<SwapchainDestroyed> decode_swapchain_destroyed(std::span<const uint8_t> payload) {
    WireReader r(payload);
    SwapchainDestroyed m;
    m.device_id = r.u64("device_id");
    m.swapchain_id = r.u64("swapchain_id");
    return finish(r, m, "SwapchainDestroyed");
}

std::vector<uint8_t> encode(const SwapchainView &m) {
    WireWriter w(52);
    w.u64(m.device_id);
    w.u64(m.swapchain_id);
    w.f32(m.angle_left);
    w.f32(m.angle_right);
    w.f32(m.angle_up);
    w.f32(m.angle_down);
    w.u32(m.array_layer);
    w.u32(m.x);
    w.u32(m.y);
    w.u32(m.width);
    w.u32(m.height);
    return w.take();
}

Result<SwapchainView> decode_swapchain_view(std::span<const uint8_t> payload) {
    WireReader r(payload);
    SwapchainView m;
    m.device_id = r.u64("device_id");
    m.swapchain_id = r.u64("swapchain_id");
    m.angle_left = r.f32("angle_left");
    m.angle_right = r.f32("angle_right");
    m.angle_up = r.f32("angle_up");
    m.angle_down = r.f32("angle_down");
    m.array_layer = r.u32("array_layer");
    m.x = r.u32("x");
    m.y = r.u32("y");
    m.width = r.u32("width");
    m.height = r.u32("height");
    constexpr float kHalfPi = 1.5707963f;
    const auto within = [&](float a) { return std::isfinite(a) && a > -kHalfPi && a < kHalfPi; };
    if (r.ok() && !(within(m.angle_left) && within(m.angle_right) && within(m.angle_up) &&
                    within(m.angle_down) && m.angle_right > m.angle_left && m.angle_up > m.angle_down))
        r.fail("field of view out of range");
    else if (r.ok() && (m.width == 0 || m.height == 0 || m.x >= kMaxImageExtent || m.y >= kMaxImageExtent ||
                        m.width > kMaxImageExtent - m.x || m.height > kMaxImageExtent - m.y))
        r.fail("sub-image rectangle out of range");
    else if (r.ok() && m.array_layer >= kMaxImageArrayLayers)
        r.fail("array layer " + std::to_string(m.array_layer) + " out of range");
    return finish(r, m, "SwapchainView");
}

std::vector<uint8_t> encode(const FrameBegin &m) {
    WireWriter w(20);
    w.u64(m.frame);
    w.u64(m.swapchain_id);
    w.u32(m.image_index);
    return w.take();
}

Result<FrameBegin> decode_frame_begin(std::span<const uint8_t> payload) {
    WireReader r(payload);
    FrameBegin m;
    m.frame = r.u64("frame");
    m.swapchain_id = r.u64("swapchain_id");
    m.image_index = r.u32("image_index");
    return finish(r, m, "FrameBegin");
}

std::vector<uint8_t> encode(const FramePresent &m) {
    WireWriter w(24 + 12 * m.images.size());
    w.u64(m.frame);
    w.u64(m.queue_id);
    w.u32(m.flags);
    w.u32(static_cast<uint32_t>(m.images.size()));
    for (const auto &image : m.images) {
        w.u64(image.swapchain_id);
        w.u32(image.image_index);
    }
    w.u32(m.gaze.fixed ? 0 : 1);
    if (!m.gaze.fixed)
        for (const split::GazePoint &eye : m.gaze.eyes) {
            w.u32(eye.x);
            w.u32(eye.y);
        }
    return w.take();
}

Result<FramePresent> decode_frame_present(std::span<const uint8_t> payload) {
    WireReader r(payload);
    FramePresent m;
    m.frame = r.u64("frame");
    m.queue_id = r.u64("queue_id");
    m.flags = r.u32("flags");
    const uint32_t count = r.u32("image count");
    if (r.ok() && (count == 0 || count > kMaxPresentedImages))
        r.fail("presented image count " + std::to_string(count) + " outside 1.." +
               std::to_string(kMaxPresentedImages));
    for (uint32_t i = 0; r.ok() && i < count; ++i) {
        PresentedImage image;
        image.swapchain_id = r.u64("swapchain_id");
        image.image_index = r.u32("image_index");
        m.images.push_back(image);
    }
    const uint32_t gaze = r.u32("gaze");
    if (r.ok() && gaze > 1) r.fail("gaze kind " + std::to_string(gaze) + " unknown");
    m.gaze.fixed = gaze == 0;
    for (int eye = 0; r.ok() && !m.gaze.fixed && eye < 2; ++eye) {
        split::GazePoint &point = m.gaze.eyes[eye];
        point.x = r.u32("gaze x");
        point.y = r.u32("gaze y");
        // Never trusted: a fovea placed from it must lie inside the eye.
        if (r.ok() && (point.x > split::kGazeOne || point.y > split::kGazeOne))
            r.fail("gaze point (" + std::to_string(point.x) + ", " + std::to_string(point.y) + ") of eye " +
                   std::to_string(eye) + " outside the eye (0.." + std::to_string(split::kGazeOne) + ")");
    }
    return finish(r, std::move(m), "FramePresent");
}

std::vector<uint8_t> encode(const VerifyFrame &m) {
    WireWriter w(40 + m.pixels.size());
    w.u64(m.frame);
    w.u64(m.swapchain_id);
    w.u32(m.image_index);
    w.u32(m.width);
    w.u32(m.height);
    w.u32(m.format);
    w.u32(m.layers);
    w.blob(m.pixels);
    return w.take();
}

Result<VerifyFrame> decode_verify_frame(std::span<const uint8_t> payload, uint32_t max_bytes) {
    WireReader r(payload);
    VerifyFrame m;
    m.frame = r.u64("frame");
    m.swapchain_id = r.u64("swapchain_id");
    m.image_index = r.u32("image_index");
    m.width = r.u32("width");
    m.height = r.u32("height");
    m.format = r.u32("format");
    m.layers = r.u32("layers");
    const auto pixels = r.blob(max_bytes, "pixels");
    if (r.ok() && (m.layers == 0 || m.layers >= kMaxImageArrayLayers))
        r.fail("layer count " + std::to_string(m.layers) + " out of range");
    else if (r.ok() && (m.width > kMaxVerifyExtent || m.height > kMaxVerifyExtent ||
                        pixels.size() != uint64_t{m.width} * m.height * m.layers * 4))
        r.fail("pixel data does not match " + std::to_string(m.layers) + " layer(s) of " +
               std::to_string(m.width) + "x" + std::to_string(m.height) + " at 4 bytes per pixel");
    m.pixels.assign(pixels.begin(), pixels.end());
    return finish(r, std::move(m), "VerifyFrame");
}

std::vector<uint8_t> encode(const SplitConfig &m) {
    WireWriter w(32);
    w.u32(static_cast<uint32_t>(m.eyes));
    w.u32(m.fovea.fractional ? 1 : 0);
    w.f64(m.fovea.width);
    w.f64(m.fovea.height);
    w.u32(static_cast<uint32_t>(m.codec));
    w.u32(m.moving_gaze ? 1 : 0);
    if (m.agent_scissor.guard) {
        w.u32(1);
        w.u32(m.agent_scissor.pixels);
    }
    return w.take();
}

Result<SplitConfig> decode_split_config(std::span<const uint8_t> payload) {
    WireReader r(payload);
    SplitConfig m;
    const uint32_t eyes = r.u32("eyes");
    const uint32_t fractional = r.u32("fovea kind");
    m.fovea.width = r.f64("fovea width");
    m.fovea.height = r.f64("fovea height");
    const uint32_t codec = r.u32("codec");
    const uint32_t gaze = r.u32("gaze");
    if (r.ok() && gaze > 1) r.fail("gaze " + std::to_string(gaze) + " unknown");
    m.moving_gaze = gaze == 1;
    if (!r.at_end()) {
        const uint32_t guard = r.u32("agent scissor");
        m.agent_scissor.pixels = r.u32("agent scissor guard");
        if (r.ok() && guard != 1) r.fail("agent scissor " + std::to_string(guard) + " unknown");
        if (r.ok() && m.agent_scissor.pixels > kMaxAgentScissorGuard)
            r.fail("agent scissor guard out of range");
        m.agent_scissor.guard = true;
    }
    if (r.ok() && eyes > static_cast<uint32_t>(EyeMode::Two))
        r.fail("eyes " + std::to_string(eyes) + " unknown");
    if (r.ok() && codec > static_cast<uint32_t>(TileCodec::Raw))
        r.fail("codec " + std::to_string(codec) + " unknown");
    if (r.ok() && fractional > 1) r.fail("fovea kind " + std::to_string(fractional) + " unknown");
    m.fovea.fractional = fractional == 1;
    // Written as !(in range) so that NaN fails too.
    const double limit = m.fovea.fractional ? 1.0 : double{kMaxVerifyExtent};
    if (r.ok() &&
        !(m.fovea.width > 0 && m.fovea.width <= limit && m.fovea.height > 0 && m.fovea.height <= limit))
        r.fail("fovea size out of range");
    m.eyes = static_cast<EyeMode>(eyes);
    m.codec = static_cast<TileCodec>(codec);
    return finish(r, m, "SplitConfig");
}

std::vector<uint8_t> encode(const Tiles &m) {
    size_t size = 64;
    for (const auto &t : m.tiles)
        size += 36 + t.data.size();
    WireWriter w(size);
    w.u64(m.frame);
    w.u64(m.swapchain_id);
    w.u32(m.image_index);
    w.u32(m.format);
    w.u32(m.timings.draw_us);
    w.u32(m.timings.readback_us);
    w.u32(m.timings.encode_us);
    w.u32(m.timings.present_to_send_us);
    w.u32(static_cast<uint32_t>(m.tiles.size()));
    for (const auto &t : m.tiles) {
        w.u32(t.x);
        w.u32(t.y);
        w.u32(t.width);
        w.u32(t.height);
        w.u32(t.array_layer);
        w.u32(static_cast<uint32_t>(t.codec));
        w.u32(t.flags);
        w.blob(t.data);
    }
    w.u32(m.flags);
    return w.take();
}

Result<Tiles> decode_tiles(std::span<const uint8_t> payload, uint32_t max_bytes) {
    WireReader r(payload);
    Tiles m;
    m.frame = r.u64("frame");
    m.swapchain_id = r.u64("swapchain_id");
    m.image_index = r.u32("image_index");
    m.format = r.u32("format");
    m.timings.draw_us = r.u32("draw_us");
    m.timings.readback_us = r.u32("readback_us");
    m.timings.encode_us = r.u32("encode_us");
    m.timings.present_to_send_us = r.u32("present_to_send_us");
    const uint32_t count = r.u32("tile count");
    if (r.ok() && count > kMaxTilesPerFrame)
        r.fail("tile count " + std::to_string(count) + " over " + std::to_string(kMaxTilesPerFrame));
    for (uint32_t i = 0; r.ok() && i < count; ++i) {
        EncodedTile t;
        t.x = r.u32("x");
        t.y = r.u32("y");
        t.width = r.u32("width");
        t.height = r.u32("height");
        t.array_layer = r.u32("array_layer");
        const uint32_t codec = r.u32("codec");
        t.flags = r.u32("flags");
        const auto data = r.blob(max_bytes, "tile data");
        if (!r.ok()) break;
        if (t.width == 0 || t.height == 0 || t.x >= kMaxVerifyExtent || t.y >= kMaxVerifyExtent ||
            t.width > kMaxVerifyExtent - t.x || t.height > kMaxVerifyExtent - t.y)
            r.fail("tile " + std::to_string(i) + " rectangle out of range");
        else if (t.array_layer >= kMaxImageArrayLayers)
            r.fail("tile " + std::to_string(i) + " array layer out of range");
        else if (codec > static_cast<uint32_t>(TileCodec::Raw))
            r.fail("tile " + std::to_string(i) + " codec " + std::to_string(codec) + " unknown");
        else if (t.flags & ~kTileKeyframe)
            r.fail("tile " + std::to_string(i) + " has unknown flags");
        t.codec = static_cast<TileCodec>(codec);
        t.data.assign(data.begin(), data.end());
        m.tiles.push_back(std::move(t));
    }
    m.flags = r.u32("flags");
    if (r.ok() && (m.flags & ~kTilesInvalid)) r.fail("unknown Tiles flags");
    if (r.ok() && (m.flags & kTilesInvalid) && !m.tiles.empty()) r.fail("an invalid frame with tiles");
    return finish(r, std::move(m), "Tiles");
}

std::vector<uint8_t> encode(const ImageLayouts &m) {
    WireWriter w(48 + 52 * m.subresources.size());
    w.u64(m.device_id);
    w.u64(m.image_id);
    w.u32(m.format);
    w.u32(m.width);
    w.u32(m.height);
    w.u32(m.depth);
    w.u32(m.mip_levels);
    w.u32(m.array_layers);
    w.u32(static_cast<uint32_t>(m.subresources.size()));
    for (const auto &s : m.subresources) {
        w.u32(s.aspect);
        w.u32(s.mip_level);
        w.u32(s.array_layer);
        w.u64(s.offset);
        w.u64(s.size);
        w.u64(s.row_pitch);
        w.u64(s.array_pitch);
        w.u64(s.depth_pitch);
    }
    return w.take();
}

Result<ImageLayouts> decode_image_layouts(std::span<const uint8_t> payload) {
    // VK_IMAGE_ASPECT_COLOR/DEPTH/STENCIL_BIT and PLANE_0/1/2_BIT.
    constexpr uint32_t kAspects = 0x1 | 0x2 | 0x4 | 0x10 | 0x20 | 0x40;
    WireReader r(payload);
    ImageLayouts m;
    m.device_id = r.u64("device_id");
    m.image_id = r.u64("image_id");
    m.format = r.u32("format");
    m.width = r.u32("width");
    m.height = r.u32("height");
    m.depth = r.u32("depth");
    m.mip_levels = r.u32("mip_levels");
    m.array_layers = r.u32("array_layers");
    const uint32_t count = r.u32("subresource count");
    if (r.ok() && (m.width == 0 || m.height == 0 || m.depth == 0 || m.width > kMaxImageExtent ||
                   m.height > kMaxImageExtent || m.depth > kMaxImageExtent))
        r.fail("extent " + std::to_string(m.width) + "x" + std::to_string(m.height) + "x" +
               std::to_string(m.depth) + " outside 1.." + std::to_string(kMaxImageExtent));
    if (r.ok() && (m.mip_levels == 0 || m.mip_levels > kMaxImageMipLevels || m.array_layers == 0 ||
                   m.array_layers > kMaxImageArrayLayers))
        r.fail("mip levels or array layers out of range");
    if (r.ok() && (count == 0 || count > kMaxImageSubresources))
        r.fail("subresource count " + std::to_string(count) + " outside 1.." +
               std::to_string(kMaxImageSubresources));
    for (uint32_t i = 0; r.ok() && i < count; ++i) {
        SubresourceLayout s;
        s.aspect = r.u32("aspect");
        s.mip_level = r.u32("mip_level");
        s.array_layer = r.u32("array_layer");
        s.offset = r.u64("offset");
        s.size = r.u64("size");
        s.row_pitch = r.u64("row_pitch");
        s.array_pitch = r.u64("array_pitch");
        s.depth_pitch = r.u64("depth_pitch");
        if (!r.ok()) break;
        const std::string which = "subresource " + std::to_string(i);
        if ((s.aspect & kAspects) != s.aspect || s.aspect == 0 || (s.aspect & (s.aspect - 1)) != 0)
            r.fail(which + " aspect " + std::to_string(s.aspect) + " is not one known aspect");
        else if (s.mip_level >= m.mip_levels || s.array_layer >= m.array_layers)
            r.fail(which + " names mip " + std::to_string(s.mip_level) + ", layer " +
                   std::to_string(s.array_layer) + " of an image with " + std::to_string(m.mip_levels) +
                   " and " + std::to_string(m.array_layers));
        else if (s.offset > kMaxLayoutBytes || s.size > kMaxLayoutBytes || s.row_pitch > kMaxLayoutBytes ||
                 s.array_pitch > kMaxLayoutBytes || s.depth_pitch > kMaxLayoutBytes)
            r.fail(which + " has an offset, size or pitch over " + std::to_string(kMaxLayoutBytes));
        m.subresources.push_back(s);
    }
    if (r.ok()) {
        auto keys = m.subresources;
        const auto key = [](const SubresourceLayout &s) {
            return std::tie(s.aspect, s.mip_level, s.array_layer);
        };
        std::sort(keys.begin(), keys.end(), [&](const auto &a, const auto &b) { return key(a) < key(b); });
        if (std::adjacent_find(keys.begin(), keys.end(),
                               [&](const auto &a, const auto &b) { return key(a) == key(b); }) != keys.end())
            r.fail("a subresource is listed twice");
    }
    return finish(r, std::move(m), "ImageLayouts");
}

std::vector<uint8_t> encode(const BufferAddress &m) {
    WireWriter w(24);
    w.u64(m.device_id);
    w.u64(m.buffer_id);
    w.u64(m.address);
    return w.take();
}

Result<BufferAddress> decode_buffer_address(std::span<const uint8_t> payload) {
    WireReader r(payload);
    BufferAddress m;
    m.device_id = r.u64("device_id");
    m.buffer_id = r.u64("buffer_id");
    m.address = r.u64("address");
    if (r.ok() && m.address == 0) r.fail("address 0 names no buffer");
    return finish(r, m, "BufferAddress");
}

} // namespace splitvk::protocol
