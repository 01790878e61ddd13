#include "options.h"

#include <algorithm>
#include <charconv>
#include <iterator>
#include <stdexcept>
#include <string_view>

namespace atrium {

namespace {

template <typename T>
T parse_number(std::string_view option, std::string_view text, T min, T max) {
    T value{};
    const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    if (text.empty() || ec != std::errc() || ptr != text.data() + text.size() || value < min || value > max)
        throw std::invalid_argument(std::string(option) + ": expected an integer in [" + std::to_string(min) +
                                    ", " + std::to_string(max) + "], got '" + std::string(text) + "'");
    return value;
}

struct PathName {
    PathKind kind;
    const char *name;
};
struct XrFormatName {
    VkFormat format;
    const char *name;
};
constexpr XrFormatName xr_format_names[] = {
    {VK_FORMAT_R8G8B8A8_SRGB, "srgb"},
    {VK_FORMAT_R8G8B8A8_UNORM, "rgba8"},
    {VK_FORMAT_R16G16B16A16_UNORM, "rgba16"},
    {VK_FORMAT_R16G16B16A16_SFLOAT, "rgba16f"},
};

constexpr PathName path_names[] = {
    {PathKind::direct, "direct"},       {PathKind::hdr, "hdr"},
    {PathKind::deferred, "deferred"},   {PathKind::multiview, "multiview"},
    {PathKind::secondary, "secondary"}, {PathKind::compute, "compute"},
};

} // namespace

const char *path_name(PathKind kind) {
    for (const PathName &p : path_names)
        if (kind == p.kind) return p.name;
    return "?";
}

const char *usage() {
    return R"(usage: splitvk-atrium [options]

Renders a deterministic walk through a procedural atrium (columns, arches, drapes; about 300k
triangles and 49 procedurally generated textures), the stand-in for the Sponza workload of the
split-rendering paper: side-by-side stereo, both eyes in one render pass straight into the
swapchain image, or through one of the render paths of real engines (--path). Frame N is a
function of N only, so every run shows the same pictures.

options:
  --width W, --height H  window size, both eyes together (default 2400x1080: 1200x1080 per eye)
  --eyes 1|2             mono, or side-by-side stereo with eye 0 on the left half (default 2)
  --frames N             number of frames to render, numbered 0..N-1 (default 300)
  --path NAME            how a frame is drawn; all paths show the same moving atrium:
                           direct     the scene straight into the swapchain image (default)
                           hdr        into an RGBA16F target, bloom at 1/2, 1/4, 1/8 size,
                                      tone mapping into the swapchain image
                           deferred   G-buffer (albedo, normal, depth), full-screen lighting
                                      with texelFetch, post pass (tone map, vignette)
                           multiview  both eyes in one VK_KHR_multiview pass into a 2-layer
                                      eye texture, composed side by side
                           secondary  the direct pass recorded in secondary command buffers
                                      by 4 threads
                           compute    into an RGBA16F target, a compute pass (blur, tone map)
                                      into a storage image, blitted into the swapchain image
  --present-mode MODE    fifo, mailbox or immediate (default mailbox: not throttled to the
                         display, no tearing); unsupported modes fall back to fifo with a note
  --srgb                 use a B8G8R8A8_SRGB swapchain instead of B8G8R8A8_UNORM (same picture)
  --static-viewports     one pipeline per eye with static viewport and scissor (for the startup
                         extent) instead of dynamic state (same picture)
  --clear-depth-per-eye  clear each eye's depth with vkCmdClearAttachments before drawing it
                         (same picture)
  --dynamic-rendering    draw with VK_KHR_dynamic_rendering instead of a render pass (same picture;
                         with --path secondary, its secondaries inherit the rendering's formats)
                         (all three vary --path direct or secondary)
  --screen-layers        with --path multiview: eye layers at the window's size instead of one
                         eye's, each squeezed into its half of the window when composed
  --scene-in-secondaries with --path hdr, deferred or compute: the offscreen scene pass's draws
                         recorded in secondary command buffers, one per eye, whose inheritance
                         names the render pass but not the framebuffer (same picture)
  --engine-extensions    with --path direct: enable VK_EXT_conditional_rendering, VK_EXT_transform_feedback
                         and VK_EXT_extended_dynamic_state3 as engines do, and draw a small triangle at
                         each eye's centre that uses all three (captured by transform feedback, drawn
                         from its byte count under a GPU-written predicate, with EDS3 state)
  --linear-textures      upload the textures through linear-tiling images that the host writes at
                         the driver's row pitch, instead of a staging buffer (same picture, any
                         --path)
  --buffer-address push|uniform
                         the scene's vertex shader reads the view-projection matrices through a
                         buffer device address (VK_KHR_buffer_device_address) passed in push
                         constants, or written by the host into the frame's uniform block, instead
                         of through the uniform descriptor (same picture; --path direct only)
  --screenshot N PATH    write frame N (0-based) as a PNG, read back from its swapchain image
                         before it is presented
  --resize-at N WxH      resize the window to WxH before frame N; the swapchain is recreated when
                         the driver reports it out of date (window resizes without a user)
  --hold                 after the last frame (N-1), keep it on screen, print 'holding frame N-1'
                         and wait for SIGTERM or SIGINT, then exit 0
  --model PATH.obj       draw a Wavefront OBJ model instead (y up; positions, normals, texture
                         coordinates, polygons, usemtl). Material libraries and image files are
                         not read: each material gets a procedural texture chosen by its name.
                         The camera walk is fitted to the model's bounds.
  --frame-times PATH     after the last frame, write every frame's time to PATH as CSV
                         ('frame,ms', the same present-to-present times the summary uses)
  --xr                   draw through OpenXR (XR_KHR_vulkan_enable2, a head-mounted display, a LOCAL
                         or STAGE space) into the runtime's eye swapchains instead of a window: one
                         swapchain per eye, each eye a mono frame of --path direct, hdr or deferred,
                         at the runtime's recommended size (or --xr-eye-size), with the runtime's eye
                         offsets and fields of view (--width, --height, --srgb and --present-mode do
                         not apply). --frames N ends the session after N frames; --hold re-renders
                         frame N-1 until SIGTERM or SIGINT, printing 'holding frame N-1' once the
                         runtime has had it. Input as applications have it: a left-hand grip pose
                         action (khr/simple_controller), attached and synchronised every frame
  --multiview            with --xr: one swapchain of two layers, both eyes drawn in one
                         VK_KHR_multiview pass straight into it (--xr --path multiview is the same)
  --side-by-side         with --xr: one swapchain twice an eye's width, the left eye drawn into its
                         left half and the right eye into its right half (a stereo frame of --path
                         direct, hdr or deferred), each half an imageRect of the projection layer
  --xr-eye-size WxH      with --xr: create the eye swapchains (or the two-layer one) at WxH instead
                         of the runtime's recommended size, odd sizes included; at most the system's
                         maximum image size (the paper's eyes: --xr-eye-size 1200x1080)
  --xr-format NAME       with --xr: the eye swapchains' format, which the runtime must offer
                         (xrEnumerateSwapchainFormats), instead of the first 8-bit one it offers:
                           srgb     R8G8B8A8_SRGB
                           rgba8    R8G8B8A8_UNORM (the shaders encode sRGB; not --multiview)
                           rgba16   R16G16B16A16_UNORM (8 bytes a texel, as xrgears has it)
                           rgba16f  R16G16B16A16_SFLOAT (an HDR engine's)
                         Every format but rgba8 holds linear colours, as OpenXR reads them
  --xr-mirror            with --xr: a desktop window of the eye's size (on DISPLAY) that shows each
                         frame's left eye, as engines mirror it: blitted from the eye image in the
                         frame's command buffer after the eye is drawn and before the image is
                         released to the runtime, then presented
  --help                 show this text

On start it prints 'atrium: T triangles, 49 textures, WxH per eye, path NAME'. When the last frame has been
presented it prints 'frame-time: median M ms, IQR Q ms, N frames' (CPU time between successive
presents; frame 0 counts from the start of the render loop). With --xr a second line follows the
first, 'xr: RUNTIME, SYSTEM, LOCAL space, FORMAT, LAYOUT', then at the first frame one line per eye
with its offset from the head and its field of view; frame times are between xrEndFrame calls
(the runtime's xrWaitFrame paces them: they are at least its display period).
)";
}

Options parse_options(int argc, char **argv) {
    Options o;
    for (int i = 1; i < argc; ++i) {
        const std::string_view arg = argv[i];
        const auto value = [&]() -> std::string_view {
            if (i + 1 >= argc) throw std::invalid_argument(std::string(arg) + " needs a value");
            return argv[++i];
        };
        if (arg == "--help" || arg == "-h") {
            o.help = true;
        } else if (arg == "--width") {
            o.width = parse_number<uint32_t>(arg, value(), 16, 16384);
        } else if (arg == "--height") {
            o.height = parse_number<uint32_t>(arg, value(), 16, 16384);
        } else if (arg == "--eyes") {
            o.eyes = parse_number<uint32_t>(arg, value(), 1, 2);
        } else if (arg == "--frames") {
            o.frames = parse_number<uint64_t>(arg, value(), 1, uint64_t(1) << 40);
        } else if (arg == "--present-mode") {
            const std::string_view mode = value();
            if (mode == "fifo")
                o.present_mode = VK_PRESENT_MODE_FIFO_KHR;
            else if (mode == "mailbox")
                o.present_mode = VK_PRESENT_MODE_MAILBOX_KHR;
            else if (mode == "immediate")
                o.present_mode = VK_PRESENT_MODE_IMMEDIATE_KHR;
            else
                throw std::invalid_argument("--present-mode: expected fifo, mailbox or immediate, got '" +
                                            std::string(mode) + "'");
        } else if (arg == "--srgb") {
            o.srgb = true;
        } else if (arg == "--static-viewports") {
            o.static_viewports = true;
        } else if (arg == "--clear-depth-per-eye") {
            o.clear_depth_per_eye = true;
        } else if (arg == "--engine-extensions") {
            o.engine_extensions = true;
        } else if (arg == "--dynamic-rendering") {
            o.dynamic_rendering = true;
        } else if (arg == "--screen-layers") {
            o.screen_layers = true;
        } else if (arg == "--scene-in-secondaries") {
            o.scene_in_secondaries = true;
        } else if (arg == "--linear-textures") {
            o.linear_textures = true;
        } else if (arg == "--buffer-address") {
            const std::string_view mode = value();
            if (mode == "push")
                o.buffer_address = BufferAddressMode::push;
            else if (mode == "uniform")
                o.buffer_address = BufferAddressMode::uniform;
            else
                throw std::invalid_argument("--buffer-address: expected push or uniform, got '" +
                                            std::string(mode) + "'");
        } else if (arg == "--path") {
            const std::string_view name = value();
            const auto known = std::find_if(std::begin(path_names), std::end(path_names),
                                            [&](const PathName &p) { return name == p.name; });
            if (known == std::end(path_names))
                throw std::invalid_argument(
                    "--path: expected direct, hdr, deferred, multiview, secondary or compute, got '" +
                    std::string(name) + "'");
            o.path = known->kind;
        } else if (arg == "--screenshot") {
            o.screenshot_frame = parse_number<uint64_t>(arg, value(), 0, uint64_t(1) << 40);
            o.screenshot_path = value();
            if (o.screenshot_path.empty()) throw std::invalid_argument("--screenshot: empty path");
        } else if (arg == "--resize-at") {
            o.resize_frame = parse_number<uint64_t>(arg, value(), 0, uint64_t(1) << 40);
            const std::string size(value());
            const auto x = size.find('x');
            if (x == std::string::npos)
                throw std::invalid_argument("--resize-at: expected WxH, got '" + size + "'");
            o.resize_width = parse_number<uint32_t>(arg, size.substr(0, x), 16, 16384);
            o.resize_height = parse_number<uint32_t>(arg, size.substr(x + 1), 16, 16384);
        } else if (arg == "--xr-eye-size") {
            const std::string size(value());
            const auto x = size.find('x');
            if (x == std::string::npos)
                throw std::invalid_argument("--xr-eye-size: expected WxH, got '" + size + "'");
            o.eye_width = parse_number<uint32_t>(arg, size.substr(0, x), 16, 16384);
            o.eye_height = parse_number<uint32_t>(arg, size.substr(x + 1), 16, 16384);
        } else if (arg == "--xr-format") {
            const std::string_view name = value();
            const auto known = std::find_if(std::begin(xr_format_names), std::end(xr_format_names),
                                            [&](const XrFormatName &f) { return name == f.name; });
            if (known == std::end(xr_format_names))
                throw std::invalid_argument("--xr-format: expected srgb, rgba8, rgba16 or rgba16f, got '" +
                                            std::string(name) + "'");
            o.xr_format = known->format;
        } else if (arg == "--xr-mirror") {
            o.xr_mirror = true;
        } else if (arg == "--xr") {
            o.xr = true;
        } else if (arg == "--multiview") {
            o.multiview = true;
        } else if (arg == "--side-by-side") {
            o.side_by_side = true;
        } else if (arg == "--hold") {
            o.hold = true;
        } else if (arg == "--frame-times") {
            o.frame_times_path = value();
            if (o.frame_times_path.empty()) throw std::invalid_argument("--frame-times: empty path");
        } else if (arg == "--model") {
            o.model_path = value();
            if (o.model_path.empty()) throw std::invalid_argument("--model: empty path");
        } else {
            throw std::invalid_argument("unknown option '" + std::string(arg) + "' (see --help)");
        }
    }
    if (o.screenshot_frame && *o.screenshot_frame >= o.frames)
        throw std::invalid_argument("--screenshot " + std::to_string(*o.screenshot_frame) +
                                    ": only frames 0.." + std::to_string(o.frames - 1) + " are rendered");
    if (o.screen_layers && (o.path != PathKind::multiview || o.xr))
        throw std::invalid_argument("--screen-layers goes with --path multiview only (not --xr)");
    if (o.width < o.eyes) throw std::invalid_argument("--width must be at least --eyes");
    if (o.xr) {
        if (o.path == PathKind::multiview) o.multiview = true;
        if (o.path == PathKind::secondary || o.path == PathKind::compute)
            throw std::invalid_argument("--xr goes with --path direct, hdr, deferred or multiview only");
        if (o.multiview && o.path != PathKind::direct && o.path != PathKind::multiview)
            throw std::invalid_argument(
                "--multiview draws the scene straight into the eye images: not with --path " +
                std::string(path_name(o.path)));
        if (o.multiview && (o.static_viewports || o.clear_depth_per_eye || o.dynamic_rendering))
            throw std::invalid_argument("--static-viewports, --clear-depth-per-eye and --dynamic-rendering "
                                        "do not go with --multiview");
        if (o.screenshot_frame || o.resize_frame)
            throw std::invalid_argument(
                "--screenshot and --resize-at do not go with --xr (there is no window)");
        if (o.eyes != 2)
            throw std::invalid_argument("--xr renders the runtime's two views: not with --eyes 1");
        if (o.multiview && o.side_by_side)
            throw std::invalid_argument("--side-by-side and --multiview are two layouts: one at a time");
        if (o.multiview && o.xr_format == VK_FORMAT_R8G8B8A8_UNORM)
            throw std::invalid_argument(
                "--xr-format rgba8 does not go with --multiview (its shader writes linear colours)");
        if (o.multiview) o.path = PathKind::direct; // the multiview pass is the path
    } else if (o.multiview) {
        throw std::invalid_argument("--multiview goes with --xr (in a window: --path multiview)");
    } else if (o.side_by_side) {
        throw std::invalid_argument(
            "--side-by-side goes with --xr (a window's frame is side by side already)");
    } else if (o.eye_width) {
        throw std::invalid_argument("--xr-eye-size goes with --xr (in a window: --width and --height)");
    } else if (o.xr_format != VK_FORMAT_UNDEFINED || o.xr_mirror) {
        throw std::invalid_argument("--xr-format and --xr-mirror go with --xr");
    }
    if (o.path != PathKind::direct && o.path != PathKind::secondary &&
        (o.static_viewports || o.clear_depth_per_eye))
        throw std::invalid_argument(
            "--static-viewports and --clear-depth-per-eye go with --path direct or secondary only");
    if (o.scene_in_secondaries &&
        (o.xr || (o.path != PathKind::hdr && o.path != PathKind::deferred && o.path != PathKind::compute)))
        throw std::invalid_argument(
            "--scene-in-secondaries goes with --path hdr, deferred or compute only (not --xr)");
    if (o.engine_extensions &&
        (o.path != PathKind::direct || o.dynamic_rendering || o.static_viewports || o.xr))
        throw std::invalid_argument(
            "--engine-extensions goes with --path direct only (not --dynamic-rendering, "
            "--static-viewports or --xr)");
    if ((o.path != PathKind::direct || o.xr) && o.buffer_address != BufferAddressMode::none)
        throw std::invalid_argument("--buffer-address goes with --path direct in a window only");
    if (o.path != PathKind::direct && o.path != PathKind::secondary && o.dynamic_rendering)
        throw std::invalid_argument("--dynamic-rendering goes with --path direct or secondary only");
    return o;
}

} // namespace atrium
