#include "metadata.h"

#include "tile_format.h"
#include "wire.h"

#include <algorithm>
#include <cmath>
#include <concepts>
#include <tuple>
#include <type_traits>

namespace splitvk::protocol {
namespace {

// Each message's fields are listed once, in wire order, by a fields() overload below, and walked
// by both directions: Encoder appends them, Decoder reads them into the message, naming each in
// its errors. What the wire format alone does not say (ranges, which values name something) is
// checked by the decode_* functions after the walk; counts are checked before any element is read,
// so that a hostile count allocates nothing.
template <class M, class T>
concept MessageOf = std::same_as<std::remove_const_t<M>, T>;

class Encoder {
public:
    explicit Encoder(size_t reserve) : w_(reserve) {}
    void u32(uint32_t v, const char *) { w_.u32(v); }
    void u64(uint64_t v, const char *) { w_.u64(v); }
    void f32(float v, const char *) { w_.f32(v); }
    void f64(double v, const char *) { w_.f64(v); }
    void flag(bool v, const char *) { w_.u32(v ? 1 : 0); }
    void constant(uint32_t v, const char *) { w_.u32(v); }
    template <class E>
    void enumeration(E v, E, const char *) {
        w_.u32(static_cast<uint32_t>(v));
    }
    void blob(const std::vector<uint8_t> &v, const char *) { w_.blob(v); }
    // A u32 count, then each element's fields.
    template <class T>
    void array(const std::vector<T> &v, uint32_t, uint32_t, const char *) {
        w_.u32(static_cast<uint32_t>(v.size()));
        for (const T &element : v)
            fields(*this, element);
    }
    // Trailing fields, written only where they say more than their absence (older layouts end
    // before them).
    template <class Write>
    void trailer(bool present, Write write) {
        if (present) write();
    }
    std::vector<uint8_t> take() { return w_.take(); }

private:
    WireWriter w_;
};

class Decoder {
public:
    Decoder(std::span<const uint8_t> payload, uint32_t max_blob_bytes = 0)
        : r_(payload), max_blob_bytes_(max_blob_bytes) {}
    void u32(uint32_t &v, const char *name) { v = r_.u32(name); }
    void u64(uint64_t &v, const char *name) { v = r_.u64(name); }
    void f32(float &v, const char *name) { v = r_.f32(name); }
    void f64(double &v, const char *name) { v = r_.f64(name); }
    void flag(bool &v, const char *name) {
        const uint32_t raw = r_.u32(name);
        if (ok() && raw > 1) fail(std::string(name) + " " + std::to_string(raw) + " unknown");
        v = raw == 1;
    }
    // A field with one value so far (a kind that later versions may add to).
    void constant(uint32_t v, const char *name) {
        const uint32_t raw = r_.u32(name);
        if (ok() && raw != v) fail(std::string(name) + " " + std::to_string(raw) + " unknown");
    }
    // Values above `last` name nothing.
    template <class E>
    void enumeration(E &v, E last, const char *name) {
        const uint32_t raw = r_.u32(name);
        if (ok() && raw > static_cast<uint32_t>(last))
            fail(std::string(name) + " " + std::to_string(raw) + " unknown");
        if (ok()) v = static_cast<E>(raw);
    }
    void blob(std::vector<uint8_t> &v, const char *name) {
        const auto bytes = r_.blob(max_blob_bytes_, name);
        v.assign(bytes.begin(), bytes.end());
    }
    template <class T>
    void array(std::vector<T> &v, uint32_t min_count, uint32_t max_count, const char *name) {
        const uint32_t count = r_.u32(name);
        if (ok() && (count < min_count || count > max_count))
            fail(std::string(name) + " " + std::to_string(count) + " outside " + std::to_string(min_count) +
                 ".." + std::to_string(max_count));
        for (uint32_t i = 0; ok() && i < count; ++i)
            fields(*this, v.emplace_back());
    }
    // Trailing fields: read where the message goes on.
    template <class Read>
    void trailer(bool, Read read) {
        trailer_read_ = !r_.at_end();
        if (trailer_read_) read();
    }
    bool trailer_read() const { return trailer_read_; }

    bool ok() const { return r_.ok(); }
    void fail(std::string_view what) { r_.fail(what); }
    template <typename T>
    Result<T> finish(T value, const char *what) {
        r_.expect_end();
        if (!r_.ok()) return Error{std::string("malformed ") + what + ": " + r_.error()};
        return value;
    }

private:
    WireReader r_;
    uint32_t max_blob_bytes_;
    bool trailer_read_ = false;
};

void fields(auto &io, MessageOf<MemoryData> auto &m) {
    io.u64(m.device_id, "device_id");
    io.u64(m.memory_id, "memory_id");
    io.u64(m.offset, "offset");
    io.blob(m.bytes, "bytes");
}

// An element of a list of ids (SwapchainImages' images). Encoder and Decoder find each element's
// fields() through themselves (argument-dependent lookup), so overloads may follow them.
void fields(auto &io, MessageOf<uint64_t> auto &id) {
    io.u64(id, "image id");
}

void fields(auto &io, MessageOf<SwapchainImages> auto &m) {
    io.u64(m.device_id, "device_id");
    io.u64(m.swapchain_id, "swapchain_id");
    io.u32(m.width, "width");
    io.u32(m.height, "height");
    io.u32(m.format, "format");
    io.u32(m.usage, "usage");
    io.u32(m.array_layers, "array_layers");
    io.array(m.image_ids, 1, kMaxSwapchainImages, "image count");
    // Appended for an OpenXR runtime's swapchain; a window's is laid out as before.
    io.trailer(m.source != SwapchainImages::Source::Window ||
                   m.presented_layout != VK_IMAGE_LAYOUT_PRESENT_SRC_KHR,
               [&] {
                   io.enumeration(m.source, SwapchainImages::Source::Runtime, "image source");
                   io.u32(m.presented_layout, "presented layout");
               });
}

void fields(auto &io, MessageOf<SwapchainDestroyed> auto &m) {
    io.u64(m.device_id, "device_id");
    io.u64(m.swapchain_id, "swapchain_id");
}

void fields(auto &io, MessageOf<SwapchainView> auto &m) {
    io.u64(m.device_id, "device_id");
    io.u64(m.swapchain_id, "swapchain_id");
    io.f32(m.angle_left, "angle_left");
    io.f32(m.angle_right, "angle_right");
    io.f32(m.angle_up, "angle_up");
    io.f32(m.angle_down, "angle_down");
    io.u32(m.array_layer, "array_layer");
    io.u32(m.x, "x");
    io.u32(m.y, "y");
    io.u32(m.width, "width");
    io.u32(m.height, "height");
}

void fields(auto &io, MessageOf<FrameBegin> auto &m) {
    io.u64(m.frame, "frame");
    io.u64(m.swapchain_id, "swapchain_id");
    io.u32(m.image_index, "image_index");
}

void fields(auto &io, MessageOf<PresentedImage> auto &m) {
    io.u64(m.swapchain_id, "swapchain_id");
    io.u32(m.image_index, "image_index");
}

void fields(auto &io, MessageOf<FramePresent> auto &m) {
    io.u64(m.frame, "frame");
    io.u64(m.queue_id, "queue_id");
    io.u32(m.flags, "flags");
    io.array(m.images, 1, kMaxPresentedImages, "presented image count");
    // Where the foveae sit this frame: fixed (where the split config puts them), or at a gaze
    // point per eye.
    bool moving = !m.gaze.fixed;
    io.flag(moving, "gaze kind");
    if constexpr (!std::is_const_v<std::remove_reference_t<decltype(m)>>) m.gaze.fixed = !moving;
    if (moving)
        for (auto &eye : m.gaze.eyes) {
            io.u32(eye.x, "gaze x");
            io.u32(eye.y, "gaze y");
        }
    // The fovea's size this frame: SplitConfig's, or one the client picked (SPLITVK_FOVEA=auto).
    bool sized = m.fovea_size.set();
    io.flag(sized, "fovea size kind");
    if (sized) {
        io.u32(m.fovea_size.width, "fovea size width");
        io.u32(m.fovea_size.height, "fovea size height");
        if constexpr (!std::is_const_v<std::remove_reference_t<decltype(m)>>)
            if (!m.fovea_size.set()) io.fail("a fovea size of zero");
    }
    io.u32(m.first_eye, "first eye");
}

void fields(auto &io, MessageOf<VerifyFrame> auto &m) {
    io.u64(m.frame, "frame");
    io.u64(m.swapchain_id, "swapchain_id");
    io.u32(m.image_index, "image_index");
    io.u32(m.width, "width");
    io.u32(m.height, "height");
    io.u32(m.format, "format");
    io.u32(m.layers, "layers");
    io.blob(m.pixels, "pixels");
}

void fields(auto &io, MessageOf<SplitConfig> auto &m) {
    io.enumeration(m.eyes, EyeMode::Two, "eyes");
    io.flag(m.fovea.fractional, "fovea kind");
    io.f64(m.fovea.width, "fovea width");
    io.f64(m.fovea.height, "fovea height");
    io.enumeration(m.codec, TileCodec::Raw, "codec");
    io.flag(m.moving_gaze, "gaze");
    io.u32(m.fovea_agents.index, "fovea agent index");
    io.u32(m.fovea_agents.count, "fovea agent count");
    io.trailer(m.agent_scissor.guard, [&] {
        io.constant(1, "agent scissor"); // its kind: a guard band
        io.u32(m.agent_scissor.pixels, "agent scissor guard");
    });
}

void fields(auto &io, MessageOf<PeripheryConfig> auto &m) {
    io.f64(m.scale, "periphery scale");
    io.flag(m.quality.lossless, "periphery lossless");
    io.u32(m.quality.crf, "periphery crf");
    io.flag(m.whole_frames, "periphery whole frames");
    io.enumeration(m.codec, PeripheryCodec::Rgb, "periphery codec");
}

void fields(auto &io, MessageOf<EncodedTile> auto &t) {
    io.u32(t.x, "x");
    io.u32(t.y, "y");
    io.u32(t.width, "width");
    io.u32(t.height, "height");
    io.u32(t.array_layer, "array_layer");
    io.enumeration(t.codec, TileCodec::HevcYuv420, "tile codec");
    io.u32(t.flags, "flags");
    io.blob(t.data, "tile data");
}

void fields(auto &io, MessageOf<Tiles> auto &m) {
    io.u64(m.frame, "frame");
    io.u64(m.swapchain_id, "swapchain_id");
    io.u32(m.image_index, "image_index");
    io.u32(m.format, "format");
    io.u32(m.timings.draw_us, "draw_us");
    io.u32(m.timings.readback_us, "readback_us");
    io.u32(m.timings.encode_us, "encode_us");
    io.u32(m.timings.present_to_send_us, "present_to_send_us");
    io.array(m.tiles, 0, kMaxTilesPerFrame, "tile count");
    io.u32(m.flags, "flags");
}

void fields(auto &io, MessageOf<SubresourceLayout> auto &s) {
    io.u32(s.aspect, "aspect");
    io.u32(s.mip_level, "mip_level");
    io.u32(s.array_layer, "array_layer");
    io.u64(s.offset, "offset");
    io.u64(s.size, "size");
    io.u64(s.row_pitch, "row_pitch");
    io.u64(s.array_pitch, "array_pitch");
    io.u64(s.depth_pitch, "depth_pitch");
}

void fields(auto &io, MessageOf<ImageLayouts> auto &m) {
    io.u64(m.device_id, "device_id");
    io.u64(m.image_id, "image_id");
    io.u32(m.format, "format");
    io.u32(m.width, "width");
    io.u32(m.height, "height");
    io.u32(m.depth, "depth");
    io.u32(m.mip_levels, "mip_levels");
    io.u32(m.array_layers, "array_layers");
    io.array(m.subresources, 1, kMaxImageSubresources, "subresource count");
}

void fields(auto &io, MessageOf<BufferAddress> auto &m) {
    io.u64(m.device_id, "device_id");
    io.u64(m.buffer_id, "buffer_id");
    io.u64(m.address, "address");
}

template <class M>
std::vector<uint8_t> encode_fields(const M &m, size_t reserve) {
    Encoder e(reserve);
    fields(e, m);
    return e.take();
}

} // namespace

std::vector<uint8_t> encode(const MemoryData &m) {
    return encode_fields(m, 32 + m.bytes.size());
}

Result<MemoryData> decode_memory_data(std::span<const uint8_t> payload, uint32_t max_bytes) {
    Decoder d(payload, max_bytes);
    MemoryData m;
    fields(d, m);
    return d.finish(std::move(m), "MemoryData");
}

std::vector<uint8_t> encode(const SwapchainImages &m) {
    return encode_fields(m, 56 + 8 * m.image_ids.size());
}

namespace {

// A VkFormat field of a message: an enumerant's values stop at INT32_MAX, and a larger value is no
// VkFormat at all (holding it in one is undefined), so a decoder refuses it before anything looks
// the format up.
void check_format(Decoder &d, uint32_t format) {
    if (d.ok() && format > uint32_t{INT32_MAX})
        d.fail("format " + std::to_string(format) + " is no VkFormat");
}

} // namespace

Result<SwapchainImages> decode_swapchain_images(std::span<const uint8_t> payload) {
    Decoder d(payload);
    SwapchainImages m;
    fields(d, m);
    check_format(d, m.format);
    if (d.ok() && (m.width == 0 || m.height == 0 || m.width > kMaxVerifyExtent ||
                   m.height > kMaxVerifyExtent || m.array_layers == 0 || m.array_layers > 16))
        d.fail("swapchain extent or layers out of range");
    if (d.ok() && m.presented_layout != VK_IMAGE_LAYOUT_PRESENT_SRC_KHR &&
        m.presented_layout != VK_IMAGE_LAYOUT_SHARED_PRESENT_KHR &&
        m.presented_layout != VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL)
        d.fail("presented layout " + std::to_string(m.presented_layout) + " is not one a frame ends in");
    return d.finish(std::move(m), "SwapchainImages");
}

std::vector<uint8_t> encode(const SwapchainDestroyed &m) {
    return encode_fields(m, 16);
}

Result<SwapchainDestroyed> decode_swapchain_destroyed(std::span<const uint8_t> payload) {
    Decoder d(payload);
    SwapchainDestroyed m;
    fields(d, m);
    return d.finish(m, "SwapchainDestroyed");
}

std::vector<uint8_t> encode(const SwapchainView &m) {
    return encode_fields(m, 52);
}

Result<SwapchainView> decode_swapchain_view(std::span<const uint8_t> payload) {
    Decoder d(payload);
    SwapchainView m;
    fields(d, m);
    constexpr float kHalfPi = 1.5707963f;
    const auto within = [&](float a) { return std::isfinite(a) && a > -kHalfPi && a < kHalfPi; };
    if (d.ok() && !(within(m.angle_left) && within(m.angle_right) && within(m.angle_up) &&
                    within(m.angle_down) && m.angle_right > m.angle_left && m.angle_up > m.angle_down))
        d.fail("field of view out of range");
    else if (d.ok() && (m.width == 0 || m.height == 0 || m.x >= kMaxImageExtent || m.y >= kMaxImageExtent ||
                        m.width > kMaxImageExtent - m.x || m.height > kMaxImageExtent - m.y))
        d.fail("sub-image rectangle out of range");
    else if (d.ok() && m.array_layer >= kMaxImageArrayLayers)
        d.fail("array layer " + std::to_string(m.array_layer) + " out of range");
    return d.finish(m, "SwapchainView");
}

std::vector<uint8_t> encode(const FrameBegin &m) {
    return encode_fields(m, 20);
}

Result<FrameBegin> decode_frame_begin(std::span<const uint8_t> payload) {
    Decoder d(payload);
    FrameBegin m;
    fields(d, m);
    return d.finish(m, "FrameBegin");
}

std::vector<uint8_t> encode(const FramePresent &m) {
    return encode_fields(m, 60 + 12 * m.images.size());
}

Result<FramePresent> decode_frame_present(std::span<const uint8_t> payload) {
    Decoder d(payload);
    FramePresent m;
    fields(d, m);
    for (int eye = 0; d.ok() && !m.gaze.fixed && eye < 2; ++eye) {
        const split::GazePoint &point = m.gaze.eyes[eye];
        // Never trusted: a fovea placed from it must lie inside the eye.
        if (point.x > split::kGazeOne || point.y > split::kGazeOne)
            d.fail("gaze point (" + std::to_string(point.x) + ", " + std::to_string(point.y) + ") of eye " +
                   std::to_string(eye) + " outside the eye (0.." + std::to_string(split::kGazeOne) + ")");
    }
    const split::FrameFoveaSize &size = m.fovea_size;
    if (d.ok() && (size.width > split::kGazeOne || size.height > split::kGazeOne))
        d.fail("fovea size " + std::to_string(size.width) + "x" + std::to_string(size.height) +
               " outside the eye (1.." + std::to_string(split::kGazeOne) + ")");
    if (d.ok() && m.first_eye >= kMaxFirstEye)
        d.fail("first eye " + std::to_string(m.first_eye) + " out of range");
    return d.finish(std::move(m), "FramePresent");
}

std::vector<uint8_t> encode(const VerifyFrame &m) {
    return encode_fields(m, 40 + m.pixels.size());
}

Result<VerifyFrame> decode_verify_frame(std::span<const uint8_t> payload, uint32_t max_bytes) {
    Decoder d(payload, max_bytes);
    VerifyFrame m;
    fields(d, m);
    check_format(d, m.format);
    // The agent reads an image back at its format's tile texel size, as it reads foveae.
    const uint32_t texel_bytes = d.ok() ? tile_texel_bytes(static_cast<VkFormat>(m.format)) : 0;
    if (d.ok() && (m.layers == 0 || m.layers >= kMaxImageArrayLayers))
        d.fail("layer count " + std::to_string(m.layers) + " out of range");
    else if (d.ok() && texel_bytes == 0)
        d.fail(std::string("pixels of ") + format_name(static_cast<VkFormat>(m.format)) +
               ", not a format tiles carry");
    else if (d.ok() && (m.width > kMaxVerifyExtent || m.height > kMaxVerifyExtent ||
                        m.pixels.size() != uint64_t{m.width} * m.height * m.layers * texel_bytes))
        d.fail("pixel data does not match " + std::to_string(m.layers) + " layer(s) of " +
               std::to_string(m.width) + "x" + std::to_string(m.height) + " at " +
               std::to_string(texel_bytes) + " bytes per pixel");
    return d.finish(std::move(m), "VerifyFrame");
}

std::vector<uint8_t> encode(const SplitConfig &m) {
    return encode_fields(m, 48);
}

Result<SplitConfig> decode_split_config(std::span<const uint8_t> payload) {
    Decoder d(payload);
    SplitConfig m;
    fields(d, m);
    m.agent_scissor.guard = d.trailer_read();
    if (d.ok() && m.agent_scissor.pixels > kMaxAgentScissorGuard) d.fail("agent scissor guard out of range");
    if (d.ok() && (m.fovea_agents.count == 0 || m.fovea_agents.count > kMaxFoveaAgents ||
                   m.fovea_agents.index >= m.fovea_agents.count))
        d.fail("fovea agents out of range");
    // Written as !(in range) so that NaN fails too.
    const double limit = m.fovea.fractional ? 1.0 : double{kMaxVerifyExtent};
    if (d.ok() &&
        !(m.fovea.width > 0 && m.fovea.width <= limit && m.fovea.height > 0 && m.fovea.height <= limit))
        d.fail("fovea size out of range");
    return d.finish(m, "SplitConfig");
}

std::vector<uint8_t> encode(const PeripheryConfig &m) {
    return encode_fields(m, 20);
}

Result<PeripheryConfig> decode_periphery_config(std::span<const uint8_t> payload) {
    Decoder d(payload);
    PeripheryConfig m;
    fields(d, m);
    // Written as !(in range) so that NaN fails too.
    if (d.ok() && !(m.scale >= split::kMinPeripheryScale && m.scale <= split::kMaxPeripheryScale))
        d.fail("periphery scale out of range");
    else if (d.ok() && m.quality.crf > kMaxPeripheryCrf)
        d.fail("periphery crf " + std::to_string(m.quality.crf) + " above " +
               std::to_string(kMaxPeripheryCrf));
    return d.finish(m, "PeripheryConfig");
}

std::vector<uint8_t> encode(const Tiles &m) {
    size_t size = 64;
    for (const auto &t : m.tiles)
        size += 36 + t.data.size();
    return encode_fields(m, size);
}

Result<Tiles> decode_tiles(std::span<const uint8_t> payload, uint32_t max_bytes) {
    Decoder d(payload, max_bytes);
    Tiles m;
    fields(d, m);
    for (size_t i = 0; d.ok() && i < m.tiles.size(); ++i) {
        const EncodedTile &t = m.tiles[i];
        if (t.width == 0 || t.height == 0 || t.x >= kMaxVerifyExtent || t.y >= kMaxVerifyExtent ||
            t.width > kMaxVerifyExtent - t.x || t.height > kMaxVerifyExtent - t.y)
            d.fail("tile " + std::to_string(i) + " rectangle out of range");
        else if (t.array_layer >= kMaxImageArrayLayers)
            d.fail("tile " + std::to_string(i) + " array layer out of range");
        else if (t.flags & ~(kTileKeyframe | kTilePeriphery))
            d.fail("tile " + std::to_string(i) + " has unknown flags");
        else if ((t.flags & kTilePeriphery) != (m.tiles[0].flags & kTilePeriphery))
            d.fail("tile " + std::to_string(i) + " mixes periphery and fovea tiles in one frame");
    }
    if (d.ok() && (m.flags & ~kTilesInvalid)) d.fail("unknown Tiles flags");
    if (d.ok() && (m.flags & kTilesInvalid) && !m.tiles.empty()) d.fail("an invalid frame with tiles");
    return d.finish(std::move(m), "Tiles");
}

std::vector<uint8_t> encode(const ImageLayouts &m) {
    return encode_fields(m, 48 + 52 * m.subresources.size());
}

Result<ImageLayouts> decode_image_layouts(std::span<const uint8_t> payload) {
    // VK_IMAGE_ASPECT_COLOR/DEPTH/STENCIL_BIT and PLANE_0/1/2_BIT.
    constexpr uint32_t kAspects = 0x1 | 0x2 | 0x4 | 0x10 | 0x20 | 0x40;
    Decoder d(payload);
    ImageLayouts m;
    fields(d, m);
    check_format(d, m.format);
    if (d.ok() && (m.width == 0 || m.height == 0 || m.depth == 0 || m.width > kMaxImageExtent ||
                   m.height > kMaxImageExtent || m.depth > kMaxImageExtent))
        d.fail("extent " + std::to_string(m.width) + "x" + std::to_string(m.height) + "x" +
               std::to_string(m.depth) + " outside 1.." + std::to_string(kMaxImageExtent));
    if (d.ok() && (m.mip_levels == 0 || m.mip_levels > kMaxImageMipLevels || m.array_layers == 0 ||
                   m.array_layers > kMaxImageArrayLayers))
        d.fail("mip levels or array layers out of range");
    for (size_t i = 0; d.ok() && i < m.subresources.size(); ++i) {
        const SubresourceLayout &s = m.subresources[i];
        const std::string which = "subresource " + std::to_string(i);
        if ((s.aspect & kAspects) != s.aspect || s.aspect == 0 || (s.aspect & (s.aspect - 1)) != 0)
            d.fail(which + " aspect " + std::to_string(s.aspect) + " is not one known aspect");
        else if (s.mip_level >= m.mip_levels || s.array_layer >= m.array_layers)
            d.fail(which + " names mip " + std::to_string(s.mip_level) + ", layer " +
                   std::to_string(s.array_layer) + " of an image with " + std::to_string(m.mip_levels) +
                   " and " + std::to_string(m.array_layers));
        else if (s.offset > kMaxLayoutBytes || s.size > kMaxLayoutBytes || s.row_pitch > kMaxLayoutBytes ||
                 s.array_pitch > kMaxLayoutBytes || s.depth_pitch > kMaxLayoutBytes)
            d.fail(which + " has an offset, size or pitch over " + std::to_string(kMaxLayoutBytes));
    }
    if (d.ok()) {
        auto keys = m.subresources;
        const auto key = [](const SubresourceLayout &s) {
            return std::tie(s.aspect, s.mip_level, s.array_layer);
        };
        std::sort(keys.begin(), keys.end(), [&](const auto &a, const auto &b) { return key(a) < key(b); });
        if (std::adjacent_find(keys.begin(), keys.end(),
                               [&](const auto &a, const auto &b) { return key(a) == key(b); }) != keys.end())
            d.fail("a subresource is listed twice");
    }
    return d.finish(std::move(m), "ImageLayouts");
}

std::vector<uint8_t> encode(const BufferAddress &m) {
    return encode_fields(m, 24);
}

Result<BufferAddress> decode_buffer_address(std::span<const uint8_t> payload) {
    Decoder d(payload);
    BufferAddress m;
    fields(d, m);
    if (d.ok() && m.address == 0) d.fail("address 0 names no buffer");
    return d.finish(m, "BufferAddress");
}

} // namespace splitvk::protocol
