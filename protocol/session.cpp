#include "session.h"

#include "wire.h"

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
    const auto pixels = r.blob(max_bytes, "pixels");
    if (r.ok() && (m.width > kMaxVerifyExtent || m.height > kMaxVerifyExtent ||
                   pixels.size() != uint64_t{m.width} * m.height * 4))
        r.fail("pixel data does not match " + std::to_string(m.width) + "x" + std::to_string(m.height) +
               " at 4 bytes per pixel");
    m.pixels.assign(pixels.begin(), pixels.end());
    return finish(r, std::move(m), "VerifyFrame");
}

} // namespace splitvk::protocol
