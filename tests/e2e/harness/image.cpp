#include "image.h"

#include "png_writer.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
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

CompareResult compare_exact(const Image &a, const Image &b, uint32_t x0, uint32_t y0, uint32_t w,
                            uint32_t h) {
    CompareResult r;
    r.same_size = a.width == b.width && a.height == b.height && a.bgr0.size() == b.bgr0.size() &&
                  a.bgr0.size() == a.stride() * a.height && x0 + w <= a.width && y0 + h <= a.height;
    if (!r.same_size) return r;
    r.pixels = uint64_t{w} * h;
    for (uint32_t y = y0; y < y0 + h; ++y)
        for (uint32_t x = x0; x < x0 + w; ++x) {
            const uint8_t *pa = a.pixel(x, y);
            const uint8_t *pb = b.pixel(x, y);
            if (pa[0] != pb[0] || pa[1] != pb[1] || pa[2] != pb[2]) {
                if (r.mismatched_pixels == 0) {
                    r.first_x = x;
                    r.first_y = y;
                }
                ++r.mismatched_pixels;
            }
        }
    return r;
}

double psnr(const Image &reference, const Image &test) {
    if (reference.bgr0.size() != test.bgr0.size() || reference.bgr0.empty()) return 0;
    double squared = 0;
    uint64_t samples = 0;
    for (size_t i = 0; i < reference.bgr0.size(); i += 4)
        for (size_t c = 0; c < 3; ++c) {
            const double d =
                static_cast<double>(reference.bgr0[i + c]) - static_cast<double>(test.bgr0[i + c]);
            squared += d * d;
            ++samples;
        }
    if (squared == 0) return std::numeric_limits<double>::infinity();
    return 10 * std::log10(255.0 * 255.0 / (squared / static_cast<double>(samples)));
}

namespace {

std::vector<float> luma(const Image &img) {
    std::vector<float> y(size_t{img.width} * img.height);
    for (size_t i = 0; i < y.size(); ++i) {
        const uint8_t *p = img.bgr0.data() + i * 4;
        y[i] = 0.114f * p[0] + 0.587f * p[1] + 0.299f * p[2];
    }
    return y;
}

// Separable 11x11 Gaussian (sigma 1.5) over the windows that fit entirely: output is
// (w - 10) x (h - 10).
std::vector<float> gaussian_valid(const std::vector<float> &in, uint32_t w, uint32_t h) {
    float kernel[11];
    float sum = 0;
    for (int i = 0; i < 11; ++i) {
        kernel[i] = std::exp(-float((i - 5) * (i - 5)) / (2 * 1.5f * 1.5f));
        sum += kernel[i];
    }
    for (float &k : kernel)
        k /= sum;
    const uint32_t ow = w - 10, oh = h - 10;
    std::vector<float> rows(size_t{ow} * h);
    for (uint32_t y = 0; y < h; ++y)
        for (uint32_t x = 0; x < ow; ++x) {
            float acc = 0;
            for (int k = 0; k < 11; ++k)
                acc += kernel[k] * in[size_t{y} * w + x + k];
            rows[size_t{y} * ow + x] = acc;
        }
    std::vector<float> out(size_t{ow} * oh);
    for (uint32_t y = 0; y < oh; ++y)
        for (uint32_t x = 0; x < ow; ++x) {
            float acc = 0;
            for (int k = 0; k < 11; ++k)
                acc += kernel[k] * rows[size_t{y + k} * ow + x];
            out[size_t{y} * ow + x] = acc;
        }
    return out;
}

} // namespace

double ssim(const Image &reference, const Image &test) {
    if (reference.width != test.width || reference.height != test.height || reference.width < 11 ||
        reference.height < 11)
        return 0;
    const uint32_t w = reference.width, h = reference.height;
    const auto a = luma(reference);
    const auto b = luma(test);
    std::vector<float> aa(a.size()), bb(a.size()), ab(a.size());
    for (size_t i = 0; i < a.size(); ++i) {
        aa[i] = a[i] * a[i];
        bb[i] = b[i] * b[i];
        ab[i] = a[i] * b[i];
    }
    const auto mu_a = gaussian_valid(a, w, h);
    const auto mu_b = gaussian_valid(b, w, h);
    const auto e_aa = gaussian_valid(aa, w, h);
    const auto e_bb = gaussian_valid(bb, w, h);
    const auto e_ab = gaussian_valid(ab, w, h);
    const double c1 = (0.01 * 255) * (0.01 * 255), c2 = (0.03 * 255) * (0.03 * 255);
    double total = 0;
    for (size_t i = 0; i < mu_a.size(); ++i) {
        const double ma = mu_a[i], mb = mu_b[i];
        const double va = e_aa[i] - ma * ma, vb = e_bb[i] - mb * mb, cov = e_ab[i] - ma * mb;
        total += ((2 * ma * mb + c1) * (2 * cov + c2)) / ((ma * ma + mb * mb + c1) * (va + vb + c2));
    }
    return total / static_cast<double>(mu_a.size());
}

bool read_pam(const std::filesystem::path &path, uint32_t *width, uint32_t *height,
              std::vector<uint8_t> *texels) {
    std::ifstream in(path, std::ios::binary);
    std::string line;
    uint32_t depth = 0;
    *width = *height = 0;
    while (std::getline(in, line) && line != "ENDHDR") {
        std::istringstream fields(line);
        std::string name;
        fields >> name;
        if (name == "WIDTH") fields >> *width;
        if (name == "HEIGHT") fields >> *height;
        if (name == "DEPTH") fields >> depth;
    }
    if (depth != 4 || *width == 0 || *height == 0) return false;
    texels->resize(size_t{*width} * *height * 4);
    in.read(reinterpret_cast<char *>(texels->data()), static_cast<std::streamsize>(texels->size()));
    return in.gcount() == static_cast<std::streamsize>(texels->size());
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
