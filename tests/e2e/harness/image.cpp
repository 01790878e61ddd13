#include "image.h"

#include "png_writer.h"

#include <algorithm>
#include <sstream>
#include <unordered_set>

namespace splitvk::e2e {

std::string CompareResult::summary() const {
    std::ostringstream ss;
    if (!same_size) {
        ss << "images differ in size";
        return ss.str();
    }
    ss << mismatched_pixels << " of " << pixels << " pixels differ";
    if (mismatched_pixels) ss << " (first at " << first_x << "," << first_y << ")";
    return ss.str();
}

CompareResult compare_exact(const Image &a, const Image &b) {
    CompareResult r;
    r.same_size = a.width == b.width && a.height == b.height && a.bgr0.size() == b.bgr0.size() &&
                  a.bgr0.size() == a.stride() * a.height;
    if (!r.same_size) return r;
    r.pixels = uint64_t{a.width} * a.height;
    for (uint32_t y = 0; y < a.height; ++y) {
        const uint8_t *pa = a.pixel(0, y);
        const uint8_t *pb = b.pixel(0, y);
        for (uint32_t x = 0; x < a.width; ++x, pa += 4, pb += 4) {
            if (pa[0] != pb[0] || pa[1] != pb[1] || pa[2] != pb[2]) {
                if (r.mismatched_pixels == 0) {
                    r.first_x = x;
                    r.first_y = y;
                }
                ++r.mismatched_pixels;
            }
        }
    }
    return r;
}

size_t distinct_colours(const Image &img) {
    std::unordered_set<uint32_t> colours;
    for (size_t i = 0; i + 3 < img.bgr0.size(); i += 4)
        colours.insert(uint32_t{img.bgr0[i]} | uint32_t{img.bgr0[i + 1]} << 8 |
                       uint32_t{img.bgr0[i + 2]} << 16);
    return colours.size();
}

bool save_png(const std::filesystem::path &path, const Image &img, std::string *error) {
    std::vector<uint8_t> bgra(img.bgr0);
    for (size_t i = 3; i < bgra.size(); i += 4)
        bgra[i] = 255;
    return splitvk::write_png(path.string(), img.width, img.height, bgra.data(), img.stride(), true, error);
}

std::string save_mismatch_artefacts(const std::filesystem::path &dir, const std::string &stem,
                                    const Image &expected, const Image &actual) {
    std::ostringstream msg;
    std::string err;
    auto expected_png = dir / (stem + ".expected.png");
    auto actual_png = dir / (stem + ".actual.png");
    auto diff_png = dir / (stem + ".diff.png");
    msg << "artefacts:";
    if (save_png(expected_png, expected, &err))
        msg << "\n  expected: " << expected_png.string();
    else
        msg << "\n  (could not write " << expected_png.string() << ": " << err << ")";
    if (save_png(actual_png, actual, &err))
        msg << "\n  actual:   " << actual_png.string();
    else
        msg << "\n  (could not write " << actual_png.string() << ": " << err << ")";
    if (expected.width == actual.width && expected.height == actual.height &&
        expected.bgr0.size() == actual.bgr0.size()) {
        Image diff = expected;
        for (uint32_t y = 0; y < diff.height; ++y) {
            for (uint32_t x = 0; x < diff.width; ++x) {
                const uint8_t *e = expected.pixel(x, y);
                const uint8_t *a = actual.pixel(x, y);
                uint8_t *d = diff.pixel(x, y);
                if (e[0] != a[0] || e[1] != a[1] || e[2] != a[2]) {
                    d[0] = 255, d[1] = 0, d[2] = 255;
                } else {
                    d[0] = e[0] / 4, d[1] = e[1] / 4, d[2] = e[2] / 4;
                }
            }
        }
        if (save_png(diff_png, diff, &err))
            msg << "\n  diff:     " << diff_png.string() << " (magenta = differs)";
        else
            msg << "\n  (could not write " << diff_png.string() << ": " << err << ")";
    }
    return msg.str();
}

} // namespace splitvk::e2e
