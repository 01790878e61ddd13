// Screen images as the X server holds them (ffmpeg's bgr0: B, G, R, padding per pixel), exact
// comparison, and failure artefacts (PNGs of both images and of their difference).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace splitvk::e2e {

struct Image {
    uint32_t width = 0;
    uint32_t height = 0;
    std::vector<uint8_t> bgr0; // width * height * 4 bytes, rows packed

    size_t stride() const { return size_t{width} * 4; }
    const uint8_t *pixel(uint32_t x, uint32_t y) const {
        return bgr0.data() + size_t{y} * stride() + size_t{x} * 4;
    }
    uint8_t *pixel(uint32_t x, uint32_t y) { return bgr0.data() + size_t{y} * stride() + size_t{x} * 4; }
};

struct CompareResult {
    bool same_size = false;
    uint64_t pixels = 0;
    uint64_t mismatched_pixels = 0; // pixels whose B, G or R differ
    uint32_t first_x = 0, first_y = 0;
    bool equal() const { return same_size && mismatched_pixels == 0; }
    std::string summary() const;
};

// Bit-exact comparison of the colour bytes. The fourth byte of each pixel is X server padding (a
// depth-24 visual has no alpha), invisible on screen, and is ignored.
CompareResult compare_exact(const Image &a, const Image &b);

// The same, within the rectangle (x, y, w, h) of both images only.
CompareResult compare_exact(const Image &a, const Image &b, uint32_t x, uint32_t y, uint32_t w, uint32_t h);

// Whole-image quality against a reference, over the colour bytes. PSNR in dB over B, G and R
// (infinity for equal images). SSIM as Wang et al. 2004 on luma (BT.601 weights), 11x11
// Gaussian window with sigma 1.5, K1 0.01, K2 0.03, averaged over the valid windows.
double psnr(const Image &reference, const Image &test);
double ssim(const Image &reference, const Image &test);

// A file VK_LAYER_SPLITVK_test_xr_readback (xr_readback_layer/) wrote: a PAM of 4-byte texels, rows
// packed, read into *texels unconverted (a B8G8R8A8 image's texels are what Image::bgr0 holds).
// False unless the file is one, whole.
bool read_pam(const std::filesystem::path &path, uint32_t *width, uint32_t *height,
              std::vector<uint8_t> *texels);

// Number of distinct colours, to tell a rendered picture from a blank or nearly blank window.
size_t distinct_colours(const Image &img);

// PNG of an image (opaque). False with *error on failure.
bool save_png(const std::filesystem::path &path, const Image &img, std::string *error);

// On a mismatch: <dir>/<stem>.expected.png, <stem>.actual.png and <stem>.diff.png (matching pixels
// dimmed to a quarter, mismatching ones magenta). Returns a message naming the files.
std::string save_mismatch_artefacts(const std::filesystem::path &dir, const std::string &stem,
                                    const Image &expected, const Image &actual);

} // namespace splitvk::e2e
