#include "metadata.h"

#include <cmath>

#include <gtest/gtest.h>

namespace splitvk::protocol {
namespace {

// Every cut of a valid message is refused with a one-line error, and so is a trailing byte.
template <typename Decode>
void expect_truncations_refused(const std::vector<uint8_t> &bytes, Decode decode) {
    for (size_t cut = 0; cut < bytes.size(); ++cut) {
        const auto result = decode(std::span<const uint8_t>(bytes.data(), cut));
        ASSERT_FALSE(result.ok()) << "accepted a message cut at " << cut << " of " << bytes.size();
        EXPECT_EQ(result.error().find('\n'), std::string::npos);
    }
    auto longer = bytes;
    longer.push_back(0);
    EXPECT_FALSE(decode(longer).ok()) << "accepted trailing bytes";
    EXPECT_TRUE(decode(bytes).ok());
}

TEST(ProtocolSession, MemoryDataRoundTrip) {
    const MemoryData m{1, 0xabc000, 4096, {1, 2, 3, 4, 5}};
    const auto bytes = encode(m);
    const auto back = decode_memory_data(bytes, 1 << 20);
    ASSERT_TRUE(back.ok()) << back.error();
    EXPECT_EQ(back->memory_id, m.memory_id);
    EXPECT_EQ(back->offset, m.offset);
    EXPECT_EQ(back->bytes, m.bytes);
    EXPECT_FALSE(decode_memory_data(bytes, 4).ok()) << "the byte cap is enforced";
    expect_truncations_refused(bytes, [](auto p) { return decode_memory_data(p, 1 << 20); });
}

TEST(ProtocolSession, SwapchainImagesRoundTripAndLimits) {
    SwapchainImages m{7, 0x55, 2400, 1080, 44, 0x10, 1, {0x100, 0x200, 0x300}};
    const auto bytes = encode(m);
    const auto back = decode_swapchain_images(bytes);
    ASSERT_TRUE(back.ok()) << back.error();
    EXPECT_EQ(back->image_ids, m.image_ids);
    EXPECT_EQ(back->width, 2400u);
    EXPECT_EQ(back->format, 44u);
    expect_truncations_refused(bytes, decode_swapchain_images);

    m.image_ids.assign(kMaxSwapchainImages + 1, 1);
    EXPECT_FALSE(decode_swapchain_images(encode(m)).ok());
    m.image_ids = {1};
    m.width = 0;
    EXPECT_FALSE(decode_swapchain_images(encode(m)).ok());
}

// An OpenXR runtime's swapchain: adopted images, and the layout a frame ends in (trailing fields
// that a window's swapchain leaves out).
TEST(ProtocolSession, RuntimeSwapchainImagesRoundTrip) {
    SwapchainImages window{7, 0x55, 2400, 1080, 44, 0x10, 1, {0x100}};
    SwapchainImages runtime = window;
    runtime.source = SwapchainImages::Source::Runtime;
    runtime.presented_layout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
    EXPECT_EQ(encode(runtime).size(), encode(window).size() + 8);
    const auto back = decode_swapchain_images(encode(runtime));
    ASSERT_TRUE(back.ok()) << back.error();
    EXPECT_EQ(back->source, SwapchainImages::Source::Runtime);
    EXPECT_EQ(back->presented_layout, uint32_t{VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL});
    const auto plain = decode_swapchain_images(encode(window));
    ASSERT_TRUE(plain.ok()) << plain.error();
    EXPECT_EQ(plain->source, SwapchainImages::Source::Window);
    EXPECT_EQ(plain->presented_layout, uint32_t{VK_IMAGE_LAYOUT_PRESENT_SRC_KHR});
    runtime.presented_layout = VK_IMAGE_LAYOUT_GENERAL;
    EXPECT_FALSE(decode_swapchain_images(encode(runtime)).ok());
    runtime.presented_layout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
    std::vector<uint8_t> bad = encode(runtime);
    bad[bad.size() - 8] = 9; // an unknown source
    EXPECT_FALSE(decode_swapchain_images(bad).ok());
}

TEST(ProtocolSession, SwapchainViewRoundTripAndRange) {
    // The right eye of a side-by-side image 2400 wide, in layer 1.
    SwapchainView m{7, 0x55, -0.8f, 0.6f, 0.7f, -0.9f, 1, 1200, 0, 1200, 1080};
    const auto bytes = encode(m);
    const auto back = decode_swapchain_view(bytes);
    ASSERT_TRUE(back.ok()) << back.error();
    EXPECT_EQ(back->swapchain_id, 0x55u);
    EXPECT_EQ(back->angle_left, -0.8f);
    EXPECT_EQ(back->angle_down, -0.9f);
    EXPECT_EQ(back->array_layer, 1u);
    EXPECT_EQ(back->x, 1200u);
    EXPECT_EQ(back->y, 0u);
    EXPECT_EQ(back->width, 1200u);
    EXPECT_EQ(back->height, 1080u);
    expect_truncations_refused(bytes, decode_swapchain_view);
    auto longer = bytes;
    longer.push_back(0);
    EXPECT_FALSE(decode_swapchain_view(longer).ok()) << "trailing bytes";
    const auto with = [&](auto change) {
        SwapchainView v = m;
        change(v);
        return v;
    };
    for (SwapchainView bad : {
             with([](SwapchainView &v) { std::swap(v.angle_left, v.angle_right); }), // right < left
             with([](SwapchainView &v) { std::swap(v.angle_up, v.angle_down); }),    // up < down
             with([](SwapchainView &v) { v.angle_left = -1.6f; }),                   // past -pi/2
             with([](SwapchainView &v) { v.angle_right = NAN; }),                    // not a number
             with([](SwapchainView &v) { v.width = 0; }),                            // an empty rectangle
             with([](SwapchainView &v) { v.height = 0; }),
             with([](SwapchainView &v) { v.x = kMaxImageExtent; }), // past the largest image
             with([](SwapchainView &v) { v.width = kMaxImageExtent; }),
             with([](SwapchainView &v) { v.y = 0xFFFFFFF0u; }), // y + height wraps around
             with([](SwapchainView &v) { v.array_layer = kMaxImageArrayLayers; }),
         }) {
        const auto refused = decode_swapchain_view(encode(bad));
        ASSERT_FALSE(refused.ok());
        EXPECT_EQ(refused.error().find('\n'), std::string::npos) << "one line: " << refused.error();
    }
}

TEST(ProtocolSession, BufferAddressRoundTripRefusesAddressZero) {
    const BufferAddress m{7, 0xb0, 0x7f00'1234'5000};
    const auto bytes = encode(m);
    const auto back = decode_buffer_address(bytes);
    ASSERT_TRUE(back.ok()) << back.error();
    EXPECT_EQ(back->device_id, 7u);
    EXPECT_EQ(back->buffer_id, 0xb0u);
    EXPECT_EQ(back->address, 0x7f00'1234'5000u);
    expect_truncations_refused(bytes, decode_buffer_address);
    EXPECT_FALSE(decode_buffer_address(encode(BufferAddress{7, 0xb0, 0})).ok());
}

TEST(ProtocolSession, FrameMarksRoundTrip) {
    const FrameBegin begin{41, 0x55, 2};
    const auto b = decode_frame_begin(encode(begin));
    ASSERT_TRUE(b.ok());
    EXPECT_EQ(b->frame, 41u);
    EXPECT_EQ(b->image_index, 2u);
    expect_truncations_refused(encode(begin), decode_frame_begin);

    const FramePresent present{41, 0x99, kPresentVerify, {{0x55, 2}, {0x66, 0}}, {}, {}};
    const auto p = decode_frame_present(encode(present));
    ASSERT_TRUE(p.ok());
    EXPECT_EQ(p->flags, kPresentVerify);
    ASSERT_EQ(p->images.size(), 2u);
    EXPECT_EQ(p->images[1].swapchain_id, 0x66u);
    expect_truncations_refused(encode(present), decode_frame_present);

    EXPECT_FALSE(decode_frame_present(encode(FramePresent{1, 1, 0, {}, {}, {}})).ok())
        << "a present shows something";
    const auto d = decode_swapchain_destroyed(encode(SwapchainDestroyed{3, 4}));
    ASSERT_TRUE(d.ok());
    EXPECT_EQ(d->swapchain_id, 4u);
}

// SPLITVK_GAZE: every FramePresent carries its frame's gaze, fixed or a point per eye.
TEST(ProtocolSession, FramePresentCarriesTheGaze) {
    FramePresent present{7, 0x99, 0, {{0x55, 1}}, {}, {}};
    const auto fixed = decode_frame_present(encode(present));
    ASSERT_TRUE(fixed.ok()) << fixed.error();
    EXPECT_TRUE(fixed->gaze.fixed);

    present.gaze.fixed = false;
    present.gaze.eyes[0] = {0, split::kGazeOne};
    present.gaze.eyes[1] = {split::kGazeOne / 4, 12345};
    const auto bytes = encode(present);
    const auto moved = decode_frame_present(bytes);
    ASSERT_TRUE(moved.ok()) << moved.error();
    EXPECT_FALSE(moved->gaze.fixed);
    EXPECT_EQ(moved->gaze.eyes[0].x, 0u);
    EXPECT_EQ(moved->gaze.eyes[0].y, split::kGazeOne);
    EXPECT_EQ(moved->gaze.eyes[1].x, split::kGazeOne / 4);
    EXPECT_EQ(moved->gaze.eyes[1].y, 12345u);
    expect_truncations_refused(bytes, decode_frame_present);
}

// A gaze point outside the eye would place a fovea outside it: refused, never clamped into a
// rectangle the agent did not shade or the layer did not ask for.
TEST(ProtocolSession, FramePresentRefusesAGazeOutsideTheEye) {
    FramePresent present{7, 0x99, 0, {{0x55, 1}}, {}, {}};
    present.gaze.fixed = false;
    present.gaze.eyes[1] = {split::kGazeOne + 1, 0};
    const auto wide = decode_frame_present(encode(present));
    ASSERT_FALSE(wide.ok());
    EXPECT_NE(wide.error().find("outside the eye"), std::string::npos) << wide.error();
    EXPECT_EQ(wide.error().find('\n'), std::string::npos);
    present.gaze.eyes[1] = {0, 0xFFFFFFFFu};
    EXPECT_FALSE(decode_frame_present(encode(present)).ok()) << "y beyond the eye";

    present.gaze = {};
    auto bytes = encode(present);
    bytes[bytes.size() - 12] = 2; // the gaze kind (before the size kind and the first eye): neither 0 nor 1
    const auto unknown = decode_frame_present(bytes);
    ASSERT_FALSE(unknown.ok());
    EXPECT_NE(unknown.error().find("gaze kind 2 unknown"), std::string::npos) << unknown.error();
}

// SPLITVK_FOVEA=auto: a FramePresent may name its frame's fovea size, never beyond the eye.
TEST(ProtocolSession, FramePresentCarriesTheFoveaSize) {
    FramePresent present{7, 0x99, 0, {{0x55, 1}}, {}, {}};
    const auto unset = decode_frame_present(encode(present));
    ASSERT_TRUE(unset.ok()) << unset.error();
    EXPECT_FALSE(unset->fovea_size.set());

    present.fovea_size = {split::kGazeOne, 1234};
    const auto bytes = encode(present);
    const auto sized = decode_frame_present(bytes);
    ASSERT_TRUE(sized.ok()) << sized.error();
    EXPECT_EQ(sized->fovea_size, (split::FrameFoveaSize{split::kGazeOne, 1234}));
    expect_truncations_refused(bytes, decode_frame_present);

    present.fovea_size = {split::kGazeOne + 1, 1234};
    const auto wide = decode_frame_present(encode(present));
    ASSERT_FALSE(wide.ok());
    EXPECT_NE(wide.error().find("outside the eye"), std::string::npos) << wide.error();
    present.fovea_size = {5, 7};
    auto zero = encode(present);
    zero[zero.size() - 8] = 0; // the height: 5x0, before the first eye
    EXPECT_FALSE(decode_frame_present(zero).ok()) << "a fovea of no pixels";
}

// An agent per eye: a swapchain per eye's image names its view, whose agent sends its fovea.
TEST(ProtocolSession, FramePresentNumbersTheImagesFirstEye) {
    FramePresent present{7, 0x99, 0, {{0x55, 1}}, {}, {}};
    EXPECT_EQ(decode_frame_present(encode(present))->first_eye, 0u);
    present.first_eye = 1;
    const auto back = decode_frame_present(encode(present));
    ASSERT_TRUE(back.ok()) << back.error();
    EXPECT_EQ(back->first_eye, 1u);
    EXPECT_TRUE((FoveaAgents{1, 2}.owns(back->first_eye + 0)))
        << "the right eye's image is the second agent's";
    present.first_eye = kMaxFirstEye;
    EXPECT_FALSE(decode_frame_present(encode(present)).ok());
}

TEST(ProtocolSession, VerifyFrameChecksPixelCount) {
    VerifyFrame m{5, 0x55, 1, 3, 2, 44, std::vector<uint8_t>(3 * 2 * 4, 7)};
    const auto back = decode_verify_frame(encode(m), 1 << 20);
    ASSERT_TRUE(back.ok()) << back.error();
    EXPECT_EQ(back->pixels, m.pixels);
    expect_truncations_refused(encode(m), [](auto p) { return decode_verify_frame(p, 1 << 20); });
    m.pixels.pop_back();
    EXPECT_FALSE(decode_verify_frame(encode(m), 1 << 20).ok());
    // A layered image: every layer, one after the other.
    m.layers = 2;
    m.pixels.assign(3 * 2 * 4 * 2, 9);
    const auto layered = decode_verify_frame(encode(m), 1 << 20);
    ASSERT_TRUE(layered.ok()) << layered.error();
    EXPECT_EQ(layered->layers, 2u);
    EXPECT_EQ(layered->pixels, m.pixels);
    m.pixels.resize(3 * 2 * 4); // one layer's pixels for two layers
    EXPECT_FALSE(decode_verify_frame(encode(m), 1 << 20).ok());
    m.layers = 0;
    m.pixels.clear();
    EXPECT_FALSE(decode_verify_frame(encode(m), 1 << 20).ok());
}

// The pixels of an RGBA16 image are 8 bytes each, as its tiles are; a format tiles do not carry
// has no read-back to verify.
TEST(ProtocolSession, VerifyFramePixelsAreTheFormatsTexelSize) {
    VerifyFrame m{5, 0x55, 1, 3, 2, VK_FORMAT_R16G16B16A16_UNORM, std::vector<uint8_t>(3 * 2 * 8, 7)};
    const auto back = decode_verify_frame(encode(m), 1 << 20);
    ASSERT_TRUE(back.ok()) << back.error();
    EXPECT_EQ(back->pixels, m.pixels);
    m.pixels.resize(3 * 2 * 4);
    const auto short_pixels = decode_verify_frame(encode(m), 1 << 20);
    ASSERT_FALSE(short_pixels.ok());
    EXPECT_NE(short_pixels.error().find("at 8 bytes per pixel"), std::string::npos) << short_pixels.error();
    m.format = VK_FORMAT_R32G32B32A32_SFLOAT;
    m.pixels.assign(3 * 2 * 16, 7);
    const auto wide = decode_verify_frame(encode(m), 1 << 20);
    ASSERT_FALSE(wide.ok());
    EXPECT_NE(wide.error().find("VK_FORMAT_R32G32B32A32_SFLOAT, not a format tiles carry"), std::string::npos)
        << wide.error();
}

TEST(ProtocolSession, ImageLayoutsRoundTripAndRanges) {
    ImageLayouts m;
    m.device_id = 3;
    m.image_id = 0xa000;
    m.format = 37; // VK_FORMAT_R8G8B8A8_UNORM
    m.width = 4;
    m.height = 8;
    m.mip_levels = 2;
    m.array_layers = 2;
    m.subresources = {{1, 0, 0, 0, 640, 80, 1024, 0},
                      {1, 0, 1, 1024, 640, 80, 1024, 0},
                      {1, 1, 0, 2048, 320, 80, 1024, 0},
                      {1, 1, 1, 3072, 320, 80, 1024, 0}};
    const auto bytes = encode(m);
    const auto back = decode_image_layouts(bytes);
    ASSERT_TRUE(back.ok()) << back.error();
    EXPECT_EQ(back->image_id, m.image_id);
    EXPECT_EQ(back->format, 37u);
    EXPECT_EQ(back->height, 8u);
    ASSERT_EQ(back->subresources.size(), 4u);
    EXPECT_EQ(back->subresources[3].offset, 3072u);
    EXPECT_EQ(back->subresources[3].row_pitch, 80u);
    EXPECT_EQ(back->subresources[2].mip_level, 1u);
    EXPECT_EQ(back->subresources[1].array_layer, 1u);
    EXPECT_EQ(back->subresources[1].array_pitch, 1024u);
    expect_truncations_refused(bytes, decode_image_layouts);

    const auto refused = [](ImageLayouts bad, const char *why) {
        const auto r = decode_image_layouts(encode(bad));
        ASSERT_FALSE(r.ok()) << why;
        EXPECT_EQ(r.error().find('\n'), std::string::npos);
    };
    auto bad = m;
    bad.subresources[1] = bad.subresources[0];
    refused(bad, "a subresource twice");
    bad = m;
    bad.subresources[0].aspect = 0x3; // COLOR | DEPTH: not one aspect
    refused(bad, "two aspects");
    bad.subresources[0].aspect = 0x8; // METADATA
    refused(bad, "an aspect that has no layout");
    bad = m;
    bad.subresources[0].mip_level = 2;
    refused(bad, "a mip the image lacks");
    bad = m;
    bad.subresources[0].array_layer = 2;
    refused(bad, "a layer the image lacks");
    bad = m;
    bad.subresources[0].row_pitch = kMaxLayoutBytes + 1;
    refused(bad, "a pitch over the cap");
    bad = m;
    bad.width = 0;
    refused(bad, "width 0");
    bad = m;
    bad.depth = kMaxImageExtent + 1;
    refused(bad, "depth over the cap");
    bad = m;
    bad.mip_levels = kMaxImageMipLevels + 1;
    refused(bad, "mip levels over the cap");
    bad = m;
    bad.subresources.clear();
    refused(bad, "no subresources");
    bad = m;
    bad.array_layers = kMaxImageArrayLayers;
    bad.subresources.clear();
    for (uint32_t i = 0; i <= kMaxImageSubresources; ++i)
        bad.subresources.push_back({1, i % 2, i / 2, 0, 0, 0, 0, 0});
    refused(bad, "more subresources than the cap");
}

TEST(ProtocolSession, SplitConfigRoundTripAndRanges) {
    SplitConfig m;
    m.eyes = EyeMode::Two;
    m.fovea = FoveaSize{false, 512, 360};
    m.codec = TileCodec::Zstd;
    const auto bytes = encode(m);
    const auto back = decode_split_config(bytes);
    ASSERT_TRUE(back.ok()) << back.error();
    EXPECT_EQ(back->eyes, EyeMode::Two);
    EXPECT_FALSE(back->fovea.fractional);
    EXPECT_EQ(back->fovea.width, 512.0);
    EXPECT_EQ(back->codec, TileCodec::Zstd);
    expect_truncations_refused(bytes, decode_split_config);

    m.fovea = FoveaSize{true, 1.5, 0.3};
    EXPECT_FALSE(decode_split_config(encode(m)).ok()) << "a fraction over 1";
    m.fovea = FoveaSize{true, std::nan(""), 0.3};
    EXPECT_FALSE(decode_split_config(encode(m)).ok()) << "NaN";
    auto bad = encode(SplitConfig{});
    bad[0] = 9; // eyes
    EXPECT_FALSE(decode_split_config(bad).ok());

    m.fovea = FoveaSize{};
    EXPECT_FALSE(decode_split_config(encode(m))->moving_gaze);
    m.moving_gaze = true;
    const auto moving = decode_split_config(encode(m));
    ASSERT_TRUE(moving.ok()) << moving.error();
    EXPECT_TRUE(moving->moving_gaze);
    auto unknown = encode(m);
    unknown[unknown.size() - 12] = 5; // the gaze, before the fovea agents
    EXPECT_FALSE(decode_split_config(unknown).ok());
}

// SPLITVK_AGENTS: the agent an eye's foveae come from, and the one rule both sides number them by.
TEST(ProtocolSession, SplitConfigFoveaAgents) {
    SplitConfig m;
    EXPECT_EQ(decode_split_config(encode(m))->fovea_agents.count, 1u) << "one agent renders every fovea";
    m.fovea_agents = {1, 2};
    const auto back = decode_split_config(encode(m));
    ASSERT_TRUE(back.ok()) << back.error();
    EXPECT_EQ(back->fovea_agents.index, 1u);
    EXPECT_EQ(back->fovea_agents.count, 2u);
    EXPECT_FALSE(back->fovea_agents.owns(0));
    EXPECT_TRUE(back->fovea_agents.owns(1));
    EXPECT_TRUE((FoveaAgents{0, 2}.owns(0)));
    EXPECT_TRUE((FoveaAgents{0, 1}.owns(1)));
    for (const FoveaAgents bad :
         {FoveaAgents{0, 0}, FoveaAgents{2, 2}, FoveaAgents{0, kMaxFoveaAgents + 1}}) {
        m.fovea_agents = bad;
        EXPECT_FALSE(decode_split_config(encode(m)).ok()) << bad.index << " of " << bad.count;
    }
}

// SPLITVK_AGENT_SCISSOR rides as a trailer: off encodes no trailer, and a message without it decodes
// as off.
TEST(ProtocolSession, SplitConfigAgentScissorTrailer) {
    SplitConfig m;
    const auto off = encode(m);
    EXPECT_EQ(off.size(), 40u) << "off adds no trailer";
    ASSERT_TRUE(decode_split_config(off).ok());
    EXPECT_FALSE(decode_split_config(off)->agent_scissor.guard);
    m.agent_scissor = {true, 64};
    const auto on = encode(m);
    const auto back = decode_split_config(on);
    ASSERT_TRUE(back.ok()) << back.error();
    EXPECT_TRUE(back->agent_scissor.guard);
    EXPECT_EQ(back->agent_scissor.pixels, 64u);
    m.agent_scissor = {true, kMaxAgentScissorGuard + 1};
    EXPECT_FALSE(decode_split_config(encode(m)).ok()) << "a guard over the cap";
    auto truncated = on;
    truncated.resize(on.size() - 2);
    EXPECT_FALSE(decode_split_config(truncated).ok()) << "half a trailer";
}

TEST(ProtocolSession, TilesRoundTripAndLimits) {
    Tiles m;
    m.frame = 42;
    m.swapchain_id = 0x77;
    m.image_index = 2;
    m.format = 44;
    m.timings = {1000, 200, 3000, 4500};
    m.tiles.push_back({344, 360, 512, 360, TileCodec::X264, kTileKeyframe, {1, 2, 3}});
    m.tiles.push_back({1544, 360, 512, 360, TileCodec::X264, 0, {4, 5}, 1}); // a layered eye image's layer 1
    const auto bytes = encode(m);
    const auto back = decode_tiles(bytes, 1 << 20);
    ASSERT_TRUE(back.ok()) << back.error();
    EXPECT_EQ(back->frame, 42u);
    EXPECT_EQ(back->timings.encode_us, 3000u);
    ASSERT_EQ(back->tiles.size(), 2u);
    EXPECT_EQ(back->tiles[1].x, 1544u);
    EXPECT_EQ(back->tiles[0].flags, kTileKeyframe);
    EXPECT_EQ(back->tiles[1].data, (std::vector<uint8_t>{4, 5}));
    EXPECT_EQ(back->tiles[0].array_layer, 0u);
    EXPECT_EQ(back->tiles[1].array_layer, 1u);
    expect_truncations_refused(bytes, [](auto p) { return decode_tiles(p, 1 << 20); });
    EXPECT_FALSE(decode_tiles(bytes, 2).ok()) << "the per-tile byte cap is enforced";

    auto wide = m;
    wide.tiles[0].x = kMaxVerifyExtent - 10; // x + width overflows the largest image
    EXPECT_FALSE(decode_tiles(encode(wide), 1 << 20).ok());
    auto deep = m;
    deep.tiles[1].array_layer = kMaxImageArrayLayers;
    EXPECT_FALSE(decode_tiles(encode(deep), 1 << 20).ok());
    auto flagged = m;
    flagged.tiles[0].flags = 0x80;
    EXPECT_FALSE(decode_tiles(encode(flagged), 1 << 20).ok());
    auto many = m;
    many.tiles.assign(kMaxTilesPerFrame + 1, m.tiles[0]);
    EXPECT_FALSE(decode_tiles(encode(many), 1 << 20).ok());
    auto empty = m;
    empty.tiles.clear();
    EXPECT_TRUE(decode_tiles(encode(empty), 1 << 20).ok()) << "a frame without split passes has no tiles";
}

// The swapped split's periphery config: the scale within [0.1, 1] (NaN refused), the crf
// within x264's 0..51, the whole-frames flag, the codec one of h264, hevc and rgb.
TEST(ProtocolSession, PeripheryConfigRoundTripAndLimits) {
    PeripheryConfig m;
    m.scale = 0.6;
    m.quality = {false, 28};
    m.codec = PeripheryCodec::Hevc;
    const auto bytes = encode(m);
    EXPECT_EQ(bytes.size(), 24u);
    const auto back = decode_periphery_config(bytes);
    ASSERT_TRUE(back.ok()) << back.error();
    EXPECT_EQ(back->scale, 0.6);
    EXPECT_EQ(back->codec, PeripheryCodec::Hevc);
    EXPECT_FALSE(back->quality.lossless);
    EXPECT_EQ(back->quality.crf, 28u);
    EXPECT_FALSE(back->whole_frames);
    expect_truncations_refused(bytes, decode_periphery_config);

    m.whole_frames = true; // a verifying client's: the agent replays whole frames
    const auto whole = decode_periphery_config(encode(m));
    ASSERT_TRUE(whole.ok()) << whole.error();
    EXPECT_TRUE(whole->whole_frames);
    m.whole_frames = false;

    m.quality = {true, 23};
    const auto lossless = decode_periphery_config(encode(m));
    ASSERT_TRUE(lossless.ok()) << lossless.error();
    EXPECT_TRUE(lossless->quality.lossless);

    for (double scale : {split::kMinPeripheryScale, split::kMaxPeripheryScale}) {
        m.scale = scale;
        EXPECT_TRUE(decode_periphery_config(encode(m)).ok()) << scale;
    }
    for (double scale : {0.0, 0.09, 1.01, -0.5, std::nan(""), HUGE_VAL}) {
        m.scale = scale;
        const auto refused = decode_periphery_config(encode(m));
        ASSERT_FALSE(refused.ok()) << scale;
        EXPECT_NE(refused.error().find("scale"), std::string::npos) << refused.error();
    }
    m.scale = 0.5;
    m.quality = {false, kMaxPeripheryCrf};
    EXPECT_TRUE(decode_periphery_config(encode(m)).ok());
    m.quality.crf = kMaxPeripheryCrf + 1;
    EXPECT_FALSE(decode_periphery_config(encode(m)).ok()) << "a crf above 51";
    auto flag = encode(PeripheryConfig{});
    flag[8] = 2; // the lossless flag
    EXPECT_FALSE(decode_periphery_config(flag).ok());
    flag = encode(PeripheryConfig{});
    flag[16] = 2; // the whole-frames flag
    EXPECT_FALSE(decode_periphery_config(flag).ok());
    auto codec = encode(PeripheryConfig{});
    codec[20] = 3; // one past rgb
    const auto unknown = decode_periphery_config(codec);
    ASSERT_FALSE(unknown.ok());
    EXPECT_NE(unknown.error().find("periphery codec"), std::string::npos) << unknown.error();
}

// Periphery tiles carry kTilePeriphery; a frame is all periphery or all foveae.
TEST(ProtocolSession, TilesCarryThePeripheryFlagUnmixed) {
    Tiles m;
    m.frame = 7;
    const auto parts = split::periphery_parts({1440, 648});
    for (const VkRect2D &part : parts)
        m.tiles.push_back({static_cast<uint32_t>(part.offset.x),
                           static_cast<uint32_t>(part.offset.y),
                           part.extent.width,
                           part.extent.height,
                           TileCodec::X264,
                           kTileKeyframe | kTilePeriphery,
                           {1, 2, 3}});
    const auto back = decode_tiles(encode(m), 1 << 20);
    ASSERT_TRUE(back.ok()) << back.error();
    ASSERT_EQ(back->tiles.size(), 2u);
    EXPECT_EQ(back->tiles[1].flags, kTileKeyframe | kTilePeriphery);
    EXPECT_EQ(back->tiles[1].x, 720u);

    auto mixed = m;
    mixed.tiles[1].flags = kTileKeyframe;
    const auto refused = decode_tiles(encode(mixed), 1 << 20);
    ASSERT_FALSE(refused.ok());
    EXPECT_NE(refused.error().find("mixes periphery and fovea"), std::string::npos) << refused.error();
    mixed.tiles[0].flags = kTileKeyframe;
    mixed.tiles[1].flags = kTilePeriphery;
    EXPECT_FALSE(decode_tiles(encode(mixed), 1 << 20).ok()) << "whichever comes first";
    auto unknown = m;
    unknown.tiles[0].flags |= 1u << 2;
    EXPECT_FALSE(decode_tiles(encode(unknown), 1 << 20).ok());
}

} // namespace
} // namespace splitvk::protocol
