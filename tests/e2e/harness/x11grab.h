// Reads what a person would see: ffmpeg's x11grab copies a rectangle of the X server's screen,
// independently of the Vulkan layer under test.
#pragma once

#include "image.h"
#include "process.h"

#include <filesystem>
#include <string>

namespace splitvk::e2e {

// One grab of (x,y,w,h) on `display` (":N"); the raw bgr0 file is kept at raw_path.
bool grab_screen(const std::string &display, int x, int y, uint32_t w, uint32_t h,
                 const std::filesystem::path &raw_path, Image *out, std::string *error);

// Grabs until two consecutive grabs are identical (the X server may still be taking the last
// present when the app reports it), at most `attempts` grabs. The result is the last grab.
bool grab_stable(const std::string &display, int x, int y, uint32_t w, uint32_t h,
                 const std::filesystem::path &raw_path, Image *out, std::string *error, int attempts = 6);

// Where the one top-level window of size w x h on `display` sits (xwininfo -root -tree): apps
// such as vkcube choose their own window position. False with *error when there is no such window
// or more than one.
bool window_origin(const std::string &display, uint32_t w, uint32_t h, int *x, int *y,
                   const std::filesystem::path &out_dir, std::string *error);

} // namespace splitvk::e2e
