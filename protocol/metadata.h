#pragma once

// The metadata messages of a replication session (docs/architecture.md §2-3): what is not a Vulkan call but
// the agent needs to reproduce the client's frames. Vulkan calls travel as MessageType::Commands,
// a sequence of codec-encoded commands (protocol/codec). Ids are the client's handle values.
//
//   client -> server  MemoryData        bytes the host wrote into a mapped range of a VkDeviceMemory
//   client -> server  SwapchainImages   a swapchain was created: the server makes offscreen images
//   client -> server  SwapchainDestroyed
//   client -> server  SwapchainView     an OpenXR eye's field of view: where that swapchain's
//                                       fovea sits from the next frame on (docs/architecture.md §9)
//   client -> server  FrameBegin        vkAcquireNextImageKHR returned an image
//   client -> server  FramePresent      vkQueuePresentKHR: the frame's commands are all submitted
//   server -> client  VerifyFrame       a presented image read back whole (SPLITVK_VERIFY=full)
//   client -> server  SplitConfig       the split settings the agent must agree on (eyes, fovea,
//                                       codec); sent once, before the first command
//   client -> server  PeripheryConfig   the swapped split (capability kSwappedSplit): the periphery's
//                                       scale and quality; sent once, right after SplitConfig
//   server -> client  Tiles             the encoded fovea tiles of one presented frame, or
//                                       in the swapped split its downsampled periphery
//   client -> server  ImageLayouts      a linear image was created: where the client's driver puts
//                                       each of its subresources, so that the agent can re-lay
//                                       MemoryData into its own driver's layout
//   client -> server  BufferAddress     vkGetBufferDeviceAddress returned an address on the client:
//                                       the agent maps it to its own buffer's (buffer_addresses.h)

#include "periphery.h"
#include "result.h"
#include "settings.h"
#include "split_geometry.h"

#include <vulkan/vulkan.h>

#include <cstdint>
#include <span>
#include <vector>

namespace splitvk::protocol {

// Caps the decoders enforce before allocating.
inline constexpr uint32_t kMaxSwapchainImages = 16;
inline constexpr uint32_t kMaxPresentedImages = 8;
inline constexpr uint32_t kMaxVerifyExtent = 16384;
inline constexpr uint32_t kMaxTilesPerFrame = 8;
inline constexpr uint32_t kMaxImageSubresources = 4096; // ImageLayouts entries
inline constexpr uint32_t kMaxImageExtent = 65536;      // ImageLayouts width, height, depth
inline constexpr uint32_t kMaxImageMipLevels = 32;
inline constexpr uint32_t kMaxImageArrayLayers = 2048;
inline constexpr uint64_t kMaxLayoutBytes = uint64_t{1} << 40; // offsets, sizes and pitches

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
    // Where the images come from. A window swapchain's images exist only on the client, so the agent
    // makes offscreen ones under these ids. An OpenXR runtime's swapchain images (docs/architecture.md §9)
    // are images the client created with vkCreateImage, which the agent already replays: it adopts them. No
    // capability bit guards the two trailing fields: the codec that forwards what an OpenXR runtime needs
    // (external memory) came with them, and peers of different codecs refuse each other at the handshake
    // (Hello's codec fingerprint).
    enum class Source : uint32_t { Window = 0, Runtime = 1 };
    Source source = Source::Window;
    // The layout the images are in when a frame ends with them (FramePresent): PRESENT_SRC_KHR (or
    // SHARED_PRESENT_KHR) for a window; COLOR_ATTACHMENT_OPTIMAL for an OpenXR runtime's, released
    // with xrReleaseSwapchainImage before the runtime's own barrier.
    uint32_t presented_layout = VK_IMAGE_LAYOUT_PRESENT_SRC_KHR; // VkImageLayout
};

struct SwapchainDestroyed {
    uint64_t device_id = 0;
    uint64_t swapchain_id = 0;
};

// An eye of an OpenXR runtime's swapchain (SwapchainImages::Source::Runtime; split::RuntimeEye):
// which array layer and sub-image rectangle of its images hold the eye, and the eye's field of
// view, whose view direction is where its fovea belongs rather than at the rectangle's centre (real
// headsets have asymmetric fields of view: split::fovea_at_view_direction). A swapchain per eye has
// one eye, the whole image; a layered one drawn with multiview, one per layer; a side-by-side one,
// two rectangles of one layer. The OpenXR layer learns them from xrEndFrame's projection views and
// sends each eye when it changes; both sides record it (split::note_runtime_eye) and place that
// swapchain's foveae with its eyes from the frames that follow in the stream. The angles are
// XrFovf's, in radians, each within (-pi/2, pi/2), right > left and up > down; the rectangle is not
// empty and within kMaxImageExtent, the layer below kMaxImageArrayLayers (whether they lie inside
// the swapchain's images is the receiver's to check against them).
struct SwapchainView {
    uint64_t device_id = 0;
    uint64_t swapchain_id = 0;
    float angle_left = 0;
    float angle_right = 0;
    float angle_up = 0;
    float angle_down = 0;
    uint32_t array_layer = 0;
    uint32_t x = 0, y = 0, width = 0, height = 0; // the sub-image rectangle
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
// The client takes no tiles for this frame: replay it, and read back and send nothing. A frame
// SPLITVK_FOVEA=auto passes through, and the frame a resync brings the agent in at, whose
// submits were made before it answered (its images hold nothing of the frame). An agent that ignores
// it sends tiles the client drops.
inline constexpr uint32_t kPresentNoTiles = 1u << 1;

struct FramePresent {
    uint64_t frame = 0;
    uint64_t queue_id = 0;
    uint32_t flags = 0;
    std::vector<PresentedImage> images;
    // Where the eyes looked for this frame (SPLITVK_GAZE): both sides place the foveae of the
    // window images it presents with it (split::frame_foveae), so that the tiles the agent sends are
    // the rectangles this frame's composite expects. Carried by every frame, so that an agent that
    // joins mid-run has it from its first frame. The decoder refuses a point outside the eye
    // (coordinates beyond split::kGazeOne). For an OpenXR runtime's eye image, the points are those
    // of the image's first two eyes in the order both sides hold them (split::runtime_eye_foveae),
    // whichever of the application's views they are: the client maps views to eyes.
    split::Gaze gaze;
    // SPLITVK_FOVEA=auto: this frame's fovea size, for every fovea of the images it presents (an
    // OpenXR runtime's eye images' too); unset: SplitConfig's. The decoder refuses one beyond the eye
    // (above split::kGazeOne); the agent one larger than SplitConfig's.
    split::FrameFoveaSize fovea_size;
    // The number of the presented image's first fovea among the frame's eyes, which
    // FoveaAgents::owns takes (fovea i of the image is number first_eye + i): the view an OpenXR
    // swapchain per eye's image was released for, 0 for every image that holds all the eyes (a
    // window's, a layered or side-by-side eye image). The decoder refuses one of kMaxFirstEye or more.
    uint32_t first_eye = 0;
};
inline constexpr uint32_t kMaxFirstEye = 16;

// Pixels are tightly packed rows of the image's format (4 bytes per pixel for the 8-bit BGRA/RGBA
// formats verification supports).
struct VerifyFrame {
    uint64_t frame = 0;
    uint64_t swapchain_id = 0;
    uint32_t image_index = 0;
    uint32_t width = 0;
    uint32_t height = 0;
    uint32_t format = 0;
    // Every array layer of the image (a layered OpenXR eye image holds an eye per layer), one after
    // the other, each width x height, 4 bytes per pixel.
    std::vector<uint8_t> pixels;
    uint32_t layers = 1;
};

// SPLITVK_AGENTS: which of a frame's foveae an agent reads back, encodes and sends when each eye has
// an agent of its own. The foveae of a presented image are numbered from FramePresent::first_eye in
// the order both sides hold them (split::LayerFovea lists: an eye each, left first); agent `index`
// of `count` owns those whose number is `index` modulo `count`. One rule for both sides: the agent
// sends exactly what it owns, and the client expects from each agent exactly that.
struct FoveaAgents {
    uint32_t index = 0;
    uint32_t count = 1;
    bool owns(size_t fovea) const { return fovea % count == index; }
};
// The most agents one client splits its foveae between: one per eye.
inline constexpr uint32_t kMaxFoveaAgents = 2;

// The settings both sides need to draw the same fovea rects from the same commands.
struct SplitConfig {
    EyeMode eyes = EyeMode::Auto;
    FoveaSize fovea;
    TileCodec codec = TileCodec::X264;
    // SPLITVK_GAZE other than fixed: FramePresent may move the foveae from frame to frame, so the
    // agent's fovea scissors cover every place they can move to (split::fovea_scissor); a frame
    // that carries a gaze without it is refused.
    bool moving_gaze = false;
    // The decoder refuses a count of 0 or above kMaxFoveaAgents, and an index not below it.
    FoveaAgents fovea_agents;
    // A trailer, encoded only when guard is on (capability::kAgentScissor); absent: off.
    AgentScissor agent_scissor;
};

// The swapped split (SPLITVK_CLIENT_RENDERS=fovea; sent only when capability
// kSwappedSplit was granted, right after SplitConfig): the client renders only the foveae, and the
// agent draws its passes into each window's swapchain image scaled into the top-left
// split::scaled_extent(image, scale) (split::swapchain_pass_draw) and sends that rectangle as
// periphery tiles (kTilePeriphery). The decoder refuses a scale outside
// [split::kMinPeripheryScale, split::kMaxPeripheryScale] (NaN too), a crf above kMaxPeripheryCrf and
// an unknown codec.
struct PeripheryConfig {
    double scale = 0.5; // SPLITVK_SCALE
    PeripheryQuality quality;
    // The client verifies (SPLITVK_VERIFY=full) and compares with the agent's frame, which must then
    // be the native one: the agent replays every pass whole at full size and downsamples the
    // presented image to the periphery with a linear blit instead.
    bool whole_frames = false;
    PeripheryCodec codec = PeripheryCodec::H264; // SPLITVK_PERIPHERY_CODEC
};

inline constexpr uint32_t kTileKeyframe = 1u << 0; // decodable alone (an IDR for x264)
// A part of the swapped split's periphery (split::periphery_parts): x, y, width and height are in
// the scaled image, and its data may be lossy (tile_codec.h). A Tiles message holds periphery tiles
// or fovea tiles, never both.
inline constexpr uint32_t kTilePeriphery = 1u << 1;
// Tiles flags: the agent replayed something its GPU cannot honour in this frame
// (server-agent/limit_guard.h); the message carries no tiles and the client shows the periphery.
inline constexpr uint32_t kTilesInvalid = 1u << 0;

// One eye's fovea, encoded by `codec` (tile_codec.h) as one frame of that eye's stream.
struct EncodedTile {
    // In the full-resolution image; in the scaled one for a periphery tile.
    uint32_t x = 0, y = 0, width = 0, height = 0;
    TileCodec codec = TileCodec::X264;
    uint32_t flags = 0; // kTileKeyframe, kTilePeriphery
    std::vector<uint8_t> data;
    uint32_t array_layer = 0; // of a layered OpenXR eye image (its eye's); 0 otherwise
};

// What the agent spent on a frame, in microseconds, for the client's statistics.
struct AgentTimings {
    uint32_t draw_us = 0;            // first replayed submit of the frame to its GPU work done
    uint32_t readback_us = 0;        // the fovea copies to host memory
    uint32_t encode_us = 0;          // the slowest eye's encode (eyes encode in parallel)
    uint32_t present_to_send_us = 0; // FramePresent received to Tiles queued
};

// The fovea tiles of one presented frame: every fovea a split pass drew into the image, in the
// order both sides compute (split_geometry.h); none when no split pass drew into it.
struct Tiles {
    uint64_t frame = 0;
    uint64_t swapchain_id = 0;
    uint32_t image_index = 0;
    uint32_t format = 0; // VkFormat of the image the pixels come from
    AgentTimings timings;
    std::vector<EncodedTile> tiles;
    uint32_t flags = 0; // kTilesInvalid
};

// One VkSubresourceLayout as vkGetImageSubresourceLayout returned it on the client. Offsets are
// from the first byte the image is bound at; `array_layer`'s offset already counts its layer.
struct SubresourceLayout {
    uint32_t aspect = 1; // one VkImageAspectFlagBits: COLOR, DEPTH, STENCIL or PLANE_0..2
    uint32_t mip_level = 0;
    uint32_t array_layer = 0;
    uint64_t offset = 0;
    uint64_t size = 0;
    uint64_t row_pitch = 0;
    uint64_t array_pitch = 0;
    uint64_t depth_pitch = 0;
};

// The client's layout of a VK_IMAGE_TILING_LINEAR image (sent after its vkCreateImage, before
// its bind). The create parameters are repeated so the agent can check they describe its image.
struct ImageLayouts {
    uint64_t device_id = 0;
    uint64_t image_id = 0;
    uint32_t format = 0; // VkFormat
    uint32_t width = 1, height = 1, depth = 1;
    uint32_t mip_levels = 1;
    uint32_t array_layers = 1;
    std::vector<SubresourceLayout> subresources; // each (aspect, mip, layer) at most once
};

// What the client's vkGetBufferDeviceAddress returned for a bound buffer. The agent asks its own
// driver for the same buffer's address and translates the client's addresses in what it replays.
struct BufferAddress {
    uint64_t device_id = 0;
    uint64_t buffer_id = 0;
    uint64_t address = 0; // VkDeviceAddress on the client, never 0
};

std::vector<uint8_t> encode(const MemoryData &m);
std::vector<uint8_t> encode(const SwapchainImages &m);
std::vector<uint8_t> encode(const SwapchainDestroyed &m);
std::vector<uint8_t> encode(const SwapchainView &m);
std::vector<uint8_t> encode(const FrameBegin &m);
std::vector<uint8_t> encode(const FramePresent &m);
std::vector<uint8_t> encode(const VerifyFrame &m);
std::vector<uint8_t> encode(const SplitConfig &m);
std::vector<uint8_t> encode(const PeripheryConfig &m);
std::vector<uint8_t> encode(const Tiles &m);
std::vector<uint8_t> encode(const ImageLayouts &m);
std::vector<uint8_t> encode(const BufferAddress &m);

// Decoders check every length against the bytes present and the caps above, and reject trailing
// bytes; errors are one line. `max_bytes` caps MemoryData and VerifyFrame payloads.
Result<MemoryData> decode_memory_data(std::span<const uint8_t> payload, uint32_t max_bytes);
Result<SwapchainImages> decode_swapchain_images(std::span<const uint8_t> payload);
Result<SwapchainDestroyed> decode_swapchain_destroyed(std::span<const uint8_t> payload);
Result<SwapchainView> decode_swapchain_view(std::span<const uint8_t> payload);
Result<FrameBegin> decode_frame_begin(std::span<const uint8_t> payload);
Result<FramePresent> decode_frame_present(std::span<const uint8_t> payload);
Result<VerifyFrame> decode_verify_frame(std::span<const uint8_t> payload, uint32_t max_bytes);
Result<SplitConfig> decode_split_config(std::span<const uint8_t> payload);
Result<PeripheryConfig> decode_periphery_config(std::span<const uint8_t> payload);
// `max_bytes` caps each tile's data. Refuses a message mixing periphery and fovea tiles.
Result<Tiles> decode_tiles(std::span<const uint8_t> payload, uint32_t max_bytes);
Result<ImageLayouts> decode_image_layouts(std::span<const uint8_t> payload);
Result<BufferAddress> decode_buffer_address(std::span<const uint8_t> payload);

} // namespace splitvk::protocol
