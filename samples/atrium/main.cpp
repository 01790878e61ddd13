// splitvk-atrium: the split-rendering paper's workload (a camera walking through an atrium),
// procedurally generated so that it can ship. See --help and samples/README.md.

#include "camera.h"
#include "error.h"
#include "frame_stats.h"
#include "obj_loader.h"
#include "options.h"
#include "png_writer.h"
#include "renderer.h"
#include "scene.h"
#include "textures.h"
#include "vk_context.h"
#include "xcb_window.h"
#include "xr_app.h"

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <exception>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace {

using namespace atrium;

// --frame-times: every frame's present-to-present time, for distributions (scripts/bench paper).
void write_frame_times(const std::string &path, const std::vector<double> &frame_ms) {
    std::FILE *file = std::fopen(path.c_str(), "w");
    if (!file) throw std::runtime_error("--frame-times: cannot write " + path);
    std::fprintf(file, "frame,ms\n");
    for (size_t i = 0; i < frame_ms.size(); ++i)
        std::fprintf(file, "%zu,%.3f\n", i, frame_ms[i]);
    if (std::fclose(file) != 0) throw std::runtime_error("--frame-times: cannot write " + path);
}

// 512x512 keeps surfaces sharp at 1200x1080 per eye; all 49 with mips generate in well under a
// second on two cores.
constexpr uint32_t texture_size = 512;

volatile std::sig_atomic_t stop_requested = 0;

extern "C" void on_stop_signal(int) {
    stop_requested = 1;
}

void install_signal_handlers() {
    struct sigaction action = {};
    action.sa_handler = on_stop_signal;
    // Restarted, so that a stop never interrupts a call under way: Monado's client fails its IPC
    // (XR_ERROR_INSTANCE_LOST) when recvmsg returns EINTR. sigsuspend returns all the same.
    action.sa_flags = SA_RESTART;
    sigemptyset(&action.sa_mask);
    sigaction(SIGTERM, &action, nullptr);
    sigaction(SIGINT, &action, nullptr);
}

// Sleeps until SIGTERM or SIGINT; blocking them first closes the window between the check and
// the wait.
void wait_for_stop_signal() {
    sigset_t stop_signals, previous;
    sigemptyset(&stop_signals);
    sigaddset(&stop_signals, SIGTERM);
    sigaddset(&stop_signals, SIGINT);
    sigprocmask(SIG_BLOCK, &stop_signals, &previous);
    while (!stop_requested)
        sigsuspend(&previous);
    sigprocmask(SIG_SETMASK, &previous, nullptr);
}

int run(const Options &options) {
    install_signal_handlers();
    if (options.xr) return run_xr(options, &stop_requested);

    XcbWindow window(options.width, options.height, "splitvk-atrium");
    VkContext context(window, options.dynamic_rendering, options.path == PathKind::multiview,
                      options.engine_extensions, options.buffer_address != BufferAddressMode::none);
    const Scene scene = options.model_path.empty() ? build_atrium() : load_obj(options.model_path);
    Swapchain swapchain(context, {options.srgb ? VK_FORMAT_B8G8R8A8_SRGB : VK_FORMAT_B8G8R8A8_UNORM,
                                  options.present_mode, options.screenshot_frame.has_value(),
                                  options.path == PathKind::compute});
    const CameraPath camera = CameraPath::for_scene(scene);
    std::optional<Renderer> renderer;
    { // the CPU copy of the textures is dropped once they are uploaded
        const unsigned threads = std::clamp(std::thread::hardware_concurrency(), 1u, 8u);
        const std::vector<Texture> textures = generate_textures(texture_size, threads);
        renderer.emplace(context, swapchain, scene, textures, camera,
                         RendererOptions{options.eyes, options.screenshot_frame, options.static_viewports,
                                         options.clear_depth_per_eye, options.dynamic_rendering,
                                         options.linear_textures, options.path, options.screen_layers,
                                         options.scene_in_secondaries, options.engine_extensions,
                                         options.buffer_address});
    }
    const VkExtent2D extent = swapchain.extent();
    std::printf("atrium: %s triangles, %u textures, %ux%u per eye, path %s\n",
                with_thousands(scene.triangle_count()).c_str(), texture_count, extent.width / options.eyes,
                extent.height, path_name(options.path));
    std::fflush(stdout);

    // Present-to-present CPU time; frame 0 is timed from the start of the loop.
    std::vector<double> frame_ms;
    frame_ms.reserve(size_t(std::min<uint64_t>(options.frames, 1 << 20)));
    uint64_t frame = 0;
    auto last = std::chrono::steady_clock::now();
    for (; frame < options.frames && !stop_requested && !window.close_requested(); ++frame) {
        if (options.resize_frame && frame == *options.resize_frame)
            window.resize(options.resize_width, options.resize_height);
        renderer->draw_frame(frame);
        const auto now = std::chrono::steady_clock::now();
        frame_ms.push_back(std::chrono::duration<double, std::milli>(now - last).count());
        last = now;
    }
    renderer->wait_idle();
    if (!options.frame_times_path.empty()) write_frame_times(options.frame_times_path, frame_ms);
    std::printf("%s\n", format_frame_times(summarize(std::move(frame_ms))).c_str());
    std::fflush(stdout);

    if (options.screenshot_frame) {
        const auto shot = renderer->screenshot();
        if (!shot) { // stopped by a signal or the window manager before that frame
            std::fprintf(stderr, "splitvk-atrium: stopped before frame %llu, no screenshot written\n",
                         static_cast<unsigned long long>(*options.screenshot_frame));
            return 0;
        }
        std::string error;
        if (!splitvk::write_png(options.screenshot_path, shot->width, shot->height, shot->pixels,
                                shot->row_stride, shot->bgra, &error))
            throw Error(error);
    }

    if (options.hold && frame == options.frames && !stop_requested) {
        // Make sure the X server has put the last image on the window before saying so.
        window.sync();
        std::printf("holding frame %llu\n", static_cast<unsigned long long>(frame - 1));
        std::fflush(stdout);
        wait_for_stop_signal();
    }
    return 0;
}

} // namespace

int main(int argc, char **argv) {
    Options options;
    try {
        options = parse_options(argc, argv);
    } catch (const std::invalid_argument &e) {
        std::fprintf(stderr, "splitvk-atrium: %s\n", e.what());
        return 2;
    }
    if (options.help) {
        std::fputs(usage(), stdout);
        return 0;
    }
    try {
        return run(options);
    } catch (const std::exception &e) {
        std::fprintf(stderr, "splitvk-atrium: %s\n", e.what());
        return 1;
    }
}
