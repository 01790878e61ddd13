// Command line of splitvk-atrium.
#pragma once

#include <vulkan/vulkan.h>

#include <cstdint>
#include <optional>
#include <string>

namespace atrium {

// --path: how a frame is drawn (render_path.h).
enum class PathKind { direct, hdr, deferred, multiview, secondary, compute };
const char *path_name(PathKind kind);

enum class BufferAddressMode { none, push, uniform };

struct Options {
    uint32_t width = 2400;
    uint32_t height = 1080;
    uint32_t eyes = 2;
    uint64_t frames = 300;
    VkPresentModeKHR present_mode = VK_PRESENT_MODE_MAILBOX_KHR;
    bool srgb = false;
    bool static_viewports = false;
    bool clear_depth_per_eye = false;
    bool dynamic_rendering = false;
    bool linear_textures = false;
    // --engine-extensions (--path direct): conditional rendering, transform feedback and extended
    // dynamic state 3 markers over the scene (engine_markers.h).
    bool engine_extensions = false;
    // --buffer-address push|uniform: the scene's vertex shader reads the frame's matrices through a
    // buffer device address (VK_KHR_buffer_device_address) in push constants, or in the frame's
    // uniform block.
    BufferAddressMode buffer_address = BufferAddressMode::none;
    // --screen-layers (--path multiview): eye layers at the window's size, each squeezed into its half.
    bool screen_layers = false;
    // --scene-in-secondaries (--path hdr, deferred, compute): the offscreen scene pass's draws in
    // secondary command buffers.
    bool scene_in_secondaries = false;
    PathKind path = PathKind::direct;
    bool hold = false;
    // --resize-at N WxH: before frame N, resize the window (the swapchain is then recreated).
    std::optional<uint64_t> resize_frame;
    uint32_t resize_width = 0;
    uint32_t resize_height = 0;
    std::optional<uint64_t> screenshot_frame;
    std::string screenshot_path;
    std::string model_path;
    // --frame-times PATH: one line per frame, 'frame,ms', written after the last frame.
    std::string frame_times_path;
    // --xr: through OpenXR into the runtime's eye swapchains (xr_app.h) instead of a window;
    // --multiview: one two-layer swapchain drawn with VK_KHR_multiview (--xr --path multiview too).
    bool xr = false;
    bool multiview = false;
    // --side-by-side (--xr): one swapchain twice an eye's width, each eye a half (two imageRects).
    bool side_by_side = false;
    // --xr-eye-size WxH: the eye swapchains' size instead of the runtime's recommended one.
    uint32_t eye_width = 0;
    uint32_t eye_height = 0;
    // --xr-format NAME: the eye swapchains' format, if the runtime offers it (UNDEFINED: atrium's
    // own preference, 8-bit sRGB first).
    VkFormat xr_format = VK_FORMAT_UNDEFINED;
    // --xr-mirror: each frame's left eye blitted into a desktop window of atrium's and presented.
    bool xr_mirror = false;
    bool help = false;
};

// Throws std::invalid_argument with a one-line message on unknown or malformed options.
Options parse_options(int argc, char **argv);

const char *usage();

} // namespace atrium
