#include "x11grab.h"

#include "screen_grab.h"
#include "vk_env.h"

#include <chrono>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <thread>

namespace splitvk::e2e {

bool grab_screen(const std::string &display, int x, int y, uint32_t w, uint32_t h,
                 const std::filesystem::path &raw_path, Image *out, std::string *error) {
    ScreenGrab grab;
    grab.display = display;
    grab.x = x;
    grab.y = y;
    grab.width = w;
    grab.height = h;
    grab.pix_fmt = "bgr0";
    grab.output = raw_path;
    if (!grab_to_file(grab, clean_env(), error)) return false;
    std::string data = read_file(raw_path);
    const size_t expected = size_t{w} * h * 4;
    if (data.size() != expected) {
        *error = "grab " + raw_path.string() + " has " + std::to_string(data.size()) + " bytes, expected " +
                 std::to_string(expected);
        return false;
    }
    out->width = w;
    out->height = h;
    out->bgr0.assign(data.begin(), data.end());
    return true;
}

bool grab_stable(const std::string &display, int x, int y, uint32_t w, uint32_t h,
                 const std::filesystem::path &raw_path, Image *out, std::string *error, int attempts) {
    Image previous;
    if (!grab_screen(display, x, y, w, h, raw_path, &previous, error)) return false;
    for (int i = 1; i < attempts; ++i) {
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
        Image next;
        if (!grab_screen(display, x, y, w, h, raw_path, &next, error)) return false;
        if (next.bgr0 == previous.bgr0) {
            *out = std::move(next);
            return true;
        }
        previous = std::move(next);
    }
    *error = "the screen kept changing over " + std::to_string(attempts) + " grabs of " + raw_path.string();
    return false;
}

bool window_origin(const std::string &display, uint32_t w, uint32_t h, int *x, int *y,
                   const std::filesystem::path &out_dir, std::string *error) {
    ProcessSpec spec;
    spec.argv = {"xwininfo", "-root", "-tree"};
    spec.env = {{"DISPLAY", display}, {"PATH", "/usr/bin:/bin"}};
    spec.out_dir = out_dir;
    spec.name = "xwininfo";
    const ProcessResult r = run_process(spec, std::chrono::seconds(10));
    if (!r.ok()) {
        *error = "xwininfo failed: " + r.describe();
        return false;
    }
    // Child lines read "0x200000 (has no name): ()  600x600+100+100  +100+100".
    const std::string size = std::to_string(w) + "x" + std::to_string(h) + "+";
    int found = 0;
    std::istringstream lines(r.out());
    for (std::string line; std::getline(lines, line);) {
        const auto at = line.find(size);
        if (at == std::string::npos) continue;
        if (std::sscanf(line.c_str() + at + size.size(), "%d+%d", x, y) == 2) ++found;
    }
    if (found != 1) {
        *error = std::to_string(found) + " windows of " + std::to_string(w) + "x" + std::to_string(h) +
                 " on " + display + ":\n" + r.out();
        return false;
    }
    return true;
}

} // namespace splitvk::e2e
