#include "screen_grab.h"

#include <chrono>

namespace splitvk::e2e {

bool grab_to_file(const ScreenGrab &grab, const Env &env, std::string *error) {
    ProcessSpec spec;
    // -draw_mouse 0: x11grab paints the X pointer into the picture by default (Xvfb parks it in
    // the middle of the screen, inside a 2400x1080 window); it is not the application's output.
    spec.argv = {"ffmpeg", "-nostdin", "-loglevel", "error", "-f", "x11grab", "-draw_mouse", "0"};
    if (grab.framerate > 0) spec.argv.insert(spec.argv.end(), {"-framerate", std::to_string(grab.framerate)});
    spec.argv.insert(spec.argv.end(),
                     {"-video_size", std::to_string(grab.width) + "x" + std::to_string(grab.height), "-i",
                      grab.display + "+" + std::to_string(grab.x) + "," + std::to_string(grab.y), "-frames:v",
                      std::to_string(grab.frames)});
    if (!grab.pix_fmt.empty())
        spec.argv.insert(spec.argv.end(), {"-f", "rawvideo", "-pix_fmt", grab.pix_fmt});
    spec.argv.insert(spec.argv.end(), {"-y", grab.output.string()});
    spec.env = env;
    spec.out_dir = !grab.log_dir.empty()               ? grab.log_dir
                   : grab.output.parent_path().empty() ? std::filesystem::path(".")
                                                       : grab.output.parent_path();
    spec.name = grab.output.filename().string() + ".ffmpeg";
    const auto r = run_process(spec, std::chrono::seconds(30));
    if (!r.ok()) {
        *error = "ffmpeg x11grab failed: " + r.describe() + "\n" + r.err();
        return false;
    }
    return true;
}

} // namespace splitvk::e2e
