#pragma once

// The metadata messages of a replication session (DESIGN §2-3): what is not a Vulkan call but
// the agent needs to reproduce the client's frames. Vulkan calls travel as MessageType::Commands,
// a sequence of codec-encoded commands (protocol/codec). Ids are the client's handle values.
//
//   client -> server  MemoryData        bytes the host wrote into a mapped range of a VkDeviceMemory
//   client -> server  SwapchainImages   a swapchain was created: the server makes offscreen images
//   client -> server  SwapchainDestroyed
//   client -> server  FrameBegin        vkAcquireNextImageKHR returned an image
//   client -> server  FramePresent      vkQueuePresentKHR: the frame's commands are all submitted
//   server -> client  VerifyFrame       a presented image read back whole (SPLITVK_VERIFY=full)

#include "result.h"

#include <cstdint>
#include <span>
#include <vector>

namespace splitvk::protocol {

// Caps the decoders enforce before allocating.
inline constexpr uint32_t kMaxSwapchainImages = 16;
inline constexpr uint32_t kMaxPresentedImages = 8;
inline constexpr uint32_t kMaxVerifyExtent = 16384;

struct MemoryData {
    uint64_t device_id = 0;
    uint64_t memory_id = 0;
    uint64_t offset = 0;        // in the client's VkDeviceMemory
    std::vector<uint8_t> bytes; // what the host wrote there
};

struct SwapchainImages {
    uint64_t device_id = 0;
    uint64_t swapchain_id = 0;
    uint32_t width = 0;
    uint32_t height = 0;
    uint32_t format = 0;       // VkFormat
    uint32_t usage = 0;        // VkImageUsageFlags the app asked for
    uint32_t array_layers = 1; // imageArrayLayers
    std::vector<uint64_t> image_ids;
};

struct SwapchainDestroyed {
    uint64_t device_id = 0;
    uint64_t swapchain_id = 0;
};

struct FrameBegin {
    uint64_t frame = 0; // frames count from 0 per device, in present order
    uint64_t swapchain_id = 0;
    uint32_t image_index = 0;
};

struct PresentedImage {
    uint64_t swapchain_id = 0;
    uint32_t image_index = 0;
};

inline constexpr uint32_t kPresentVerify = 1u << 0; // read the images back and send VerifyFrame

struct FramePresent {
    uint64_t frame = 0;
    uint64_t queue_id = 0;
    uint32_t flags = 0;
    std::vector<PresentedImage> images;
};

// Pixels are tightly packed rows of the image's format (4 bytes per pixel for the 8-bit BGRA/RGBA
// formats verification supports).
struct VerifyFrame {
    uint64_t frame = 0;
    uint64_t swapchain_id = 0;
    uint32_t image_index = 0;
    uint32_t width = 0;
    uint32_t height = 0;
    uint32_t format = 0;
    std::vector<uint8_t> pixels;
};

std::vector<uint8_t> encode(const MemoryData &m);
std::vector<uint8_t> encode(const SwapchainImages &m);
std::vector<uint8_t> encode(const SwapchainDestroyed &m);
std::vector<uint8_t> encode(const FrameBegin &m);
std::vector<uint8_t> encode(const FramePresent &m);
std::vector<uint8_t> encode(const VerifyFrame &m);

// Decoders check every length against the bytes present and the caps above, and reject trailing
// bytes; errors are one line. `max_bytes` caps MemoryData and VerifyFrame payloads.
Result<MemoryData> decode_memory_data(std::span<const uint8_t> payload, uint32_t max_bytes);
Result<SwapchainImages> decode_swapchain_images(std::span<const uint8_t> payload);
Result<SwapchainDestroyed> decode_swapchain_destroyed(std::span<const uint8_t> payload);
Result<FrameBegin> decode_frame_begin(std::span<const uint8_t> payload);
Result<FramePresent> decode_frame_present(std::span<const uint8_t> payload);
Result<VerifyFrame> decode_verify_frame(std::span<const uint8_t> payload, uint32_t max_bytes);

} // namespace splitvk::protocol
