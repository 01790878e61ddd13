// ffmpeg's x11grab: a rectangle of the X server's screen copied to a file, independently of the
// Vulkan layer under test. The one place the harness, its CLI (splitvk-harness) and the scripts
// grab the screen from.
#pragma once

#include "process.h"

#include <cstdint>
#include <filesystem>
#include <string>

namespace splitvk::e2e {

struct ScreenGrab {
    std::string display; // ":N"
    int x = 0;
    int y = 0;
    uint32_t width = 0;
    uint32_t height = 0;
    int frames = 1;    // consecutive frames, one after the other in `output`
    int framerate = 0; // frames per second when frames > 1; 0 = ffmpeg's default
    // Raw frames in this pixel format ("bgr0", "bgra"); empty: the format ffmpeg picks from the
    // output's extension (.png).
    std::string pix_fmt;
    std::filesystem::path output;  // overwritten
    std::filesystem::path log_dir; // for ffmpeg's own output; empty: beside `output`
};

// Runs ffmpeg under `env` (at most 30 s). False with *error (ffmpeg's last words) on failure.
bool grab_to_file(const ScreenGrab &grab, const Env &env, std::string *error);

} // namespace splitvk::e2e
