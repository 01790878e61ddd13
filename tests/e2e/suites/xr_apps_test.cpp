// What public OpenXR applications do that splitvk-atrium --xr reproduces, on Monado (scripts/xr-runtime,
// headless), native against split, judged by what the runtime receives (VK_LAYER_SPLITVK_test_xr_readback
// below splitvk and validation) or, for a desktop mirror, by what the X server shows:
//  - Eye images of 8 bytes a texel (--xr-format rgba16, as xrgears has them; rgba16f, as HDR engines
//    do): the frames split with tiles, every eye image's fovea bit-exact against native per image and
//    release, its periphery not native's, and Khronos validation reports no message ID that the
//    native run lacks.
//  - A mirror window (--xr-mirror, as openxr-vulkan-example and many engines have one): each frame's
//    left eye blitted into a desktop window in the frame's command buffer before the eye image is
//    released. The window must show the composited eye: its fovea bit-exact against native's window,
//    its top-left quarter close to native's (not the client's scaled periphery, a miniature of the
//    whole eye), and the whole window above an SSIM floor.
//  - Odd eye sizes (--xr-eye-size, as a windowed OpenXR Tutorials app gets them): no row or column of
//    a split eye image is the clear colour where native drew, and the foveae are bit-exact.
#include "agent.h"
#include "e2e_test.h"
#include "fovea.h"
#include "xr_readback.h"

#include <csignal>
#include <fstream>
#include <iostream>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include <dirent.h>

namespace splitvk::e2e {
namespace {

using namespace std::chrono_literals;

class XrApps : public ::testing::Test {
protected:
    void SetUp() override {
        out_ = test_output_dir();
        ASSERT_TRUE(built(explicit_layer_dir()));
        ASSERT_TRUE(built(agent_path()));
        ASSERT_TRUE(built(atrium_path()));
        ASSERT_TRUE(built(SPLITVK_E2E_XR_READBACK_LAYER_DIR));
        ASSERT_TRUE(built(build_dir() / "manifest" / "openxr"));
    }

    // The readback layer at the bottom of the chain, every readback kept; with `validation`, Khronos
    // validation above it (synchronization on), its log in <run>/validation.log. `display`: the X
    // server of a mirror window.
    Env native_env(const std::string &run, bool validation, const std::string &display = "") {
        Env e = display.empty() ? clean_env() : app_env(display);
        // The Monado build in the cache: scripts/xr-runtime's location (clean_env drops SPLITVK_*).
        if (const char *cache = std::getenv("SPLITVK_CACHE")) e["SPLITVK_CACHE"] = cache;
        const auto dir = out_ / run;
        std::filesystem::create_directories(dir / "images");
        e["TEST_XR_READBACK_DIR"] = (dir / "images").string();
        if (validation) {
            // The loader chains explicit layers in the order their folders are listed.
            e["VK_LAYER_PATH"] = std::string(kSystemExplicitLayers) + ":" + SPLITVK_E2E_XR_READBACK_LAYER_DIR;
            e["VK_INSTANCE_LAYERS"] = std::string(kValidationLayerName) + ":" + kReadbackLayerName;
            validation_logs_[run] = configure_validation(e, dir);
            enable_loader_debug(e);
        } else {
            e["VK_LAYER_PATH"] = SPLITVK_E2E_XR_READBACK_LAYER_DIR;
            e["VK_INSTANCE_LAYERS"] = kReadbackLayerName;
        }
        return e;
    }

    // splitvk's Vulkan layer on top and its OpenXR API layer on.
    Env split_env(const std::string &run, const Agent &agent, bool validation,
                  const std::string &display = "") {
        Env e = native_env(run, validation, display);
        e["VK_LAYER_PATH"] = explicit_layer_dir().string() + ":" + e["VK_LAYER_PATH"];
        e["VK_INSTANCE_LAYERS"] = std::string(kLayerName) + ":" + e["VK_INSTANCE_LAYERS"];
        e["XR_API_LAYER_PATH"] = (build_dir() / "manifest" / "openxr").string();
        e["XR_ENABLE_API_LAYERS"] = kXrLayerName;
        e["SPLITVK_SERVER"] = agent.address();
        e["SPLITVK_STATS"] = (out_ / run / "stats.csv").string();
        e["SPLITVK_LOG_LEVEL"] = "info";
        e["SPLITVK_TILE_WAIT"] = "60000"; // a busy machine must not turn the compared frames late
        return e;
    }

    ProcessSpec atrium(const Env &env, const std::string &run, const std::vector<std::string> &args) {
        ProcessSpec spec;
        spec.argv = {(source_dir() / "scripts" / "xr-runtime").string(), "run", "--", atrium_path().string(),
                     "--xr"};
        spec.argv.insert(spec.argv.end(), args.begin(), args.end());
        spec.env = env;
        spec.out_dir = out_;
        spec.name = run;
        return spec;
    }

    ProcessResult run_atrium(const Env &env, const std::string &run, const std::vector<std::string> &args) {
        const auto started = Clock::now();
        ProcessResult r = run_process(atrium(env, run, args), std::chrono::seconds(240));
        std::cout << "  " << run << ": " << std::chrono::duration<double>(Clock::now() - started).count()
                  << " s\n";
        return r;
    }

    void expect_split_stats(const std::string &run, int min_frames) {
        e2e::expect_split_stats(out_ / run / "stats.csv", min_frames);
    }

    void expect_no_new_validation(const std::string &native_run, const std::string &split_run) {
        e2e::expect_no_new_validation(validation_logs_[native_run], validation_logs_[split_run]);
    }

    std::filesystem::path out_;
    std::map<std::string, std::filesystem::path> validation_logs_;
};

// ------------------------------------------------------------------------ 8-byte eye images

struct EyeFormat {
    const char *option; // --xr-format
    const char *vk;     // what atrium's xr: line and the readback's TUPLTYPE name
};
void PrintTo(const EyeFormat &f, std::ostream *os) {
    *os << f.option;
}

class XrAppsEyeFormat : public XrApps, public ::testing::WithParamInterface<EyeFormat> {};

// Image K's release N is the same frame in both runs (the runtime hands out each eye's images in
// the same order, and atrium draws frame N alike on every run).
TEST_P(XrAppsEyeFormat, FoveaeExactAgainstNativeFrameByFrame) {
    constexpr int kFrames = 8;
    constexpr int kMaxLevels = 2;
    constexpr uint32_t w = 192, h = 160;
    const EyeFormat format = GetParam();
    const std::vector<std::string> args = {"--xr-format", format.option, "--xr-eye-size",
                                           "192x160",     "--frames",    std::to_string(kFrames)};
    const auto native = run_atrium(native_env("native", true), "native", args);
    ASSERT_TRUE(native.ok()) << native.describe() << "\n" << tail(native.err(), 30);
    ASSERT_FALSE(grep(native.out(), std::string(", ") + format.vk + ", one swapchain per eye").empty())
        << tail(native.out(), 10);
    // The same picture as in an 8-bit sRGB image: the eyes are drawn in linear colours into the
    // 16-bit format (an encoding applied twice is far brighter). Only rounding differs.
    std::vector<std::string> srgb_args = args;
    srgb_args[1] = "srgb";
    const auto srgb = run_atrium(native_env("native-srgb", false), "native-srgb", srgb_args);
    ASSERT_TRUE(srgb.ok()) << srgb.describe() << "\n" << tail(srgb.err(), 30);
    EyeImage wide, narrow;
    ASSERT_TRUE(load_pam(out_ / "native" / "images" / "image0-00000.pam", &wide) &&
                load_pam(out_ / "native-srgb" / "images" / "image0-00000.pam", &narrow));
    ASSERT_EQ(wide.width, narrow.width);
    ASSERT_EQ(wide.height, narrow.height);
    const Image wide_shown = to_image(wide), narrow_shown = to_image(narrow);
    int max_difference = 0;
    for (size_t i = 0; i < wide_shown.bgr0.size(); ++i)
        if (i % 4 != 3)
            max_difference = std::max(max_difference, std::abs(wide_shown.bgr0[i] - narrow_shown.bgr0[i]));
    const double wide_psnr = psnr(narrow_shown, wide_shown);
    std::cout << "  " << format.vk << " against R8G8B8A8_SRGB, frame 0 of eye 0: PSNR " << wide_psnr
              << " dB, at most " << max_difference << " levels apart\n";
    EXPECT_LE(max_difference, kMaxLevels)
        << save_mismatch_artefacts(out_, "wide-against-srgb", narrow_shown, wide_shown);

    Agent agent;
    ASSERT_TRUE(agent.start(clean_env(), out_)) << agent.error();
    const auto split = run_atrium(split_env("split", agent, true), "split", args);
    ASSERT_TRUE(split.ok()) << split.describe() << "\n" << tail(split.err(), 30);
    EXPECT_TRUE(grep(split.err(), "[splitvk] error:").empty()) << tail(split.err(), 30);
    EXPECT_FALSE(grep(split.err(), "OpenXR session: eye images of its Vulkan device are split").empty());
    EXPECT_TRUE(grep(split.err(), "is not composable").empty())
        << joined(grep(split.err(), "is not composable"));
    for (const ProcessResult *r : {&native, &split})
        EXPECT_GE(stack_index(instance_layer_stack(r->err()), kValidationLayerName), 0)
            << "validation is not in the chain\n"
            << tail(r->err(), 30);

    const auto n = readbacks(out_ / "native" / "images");
    const auto s = readbacks(out_ / "split" / "images");
    ASSERT_EQ(n.size(), static_cast<size_t>(2 * kFrames)) << "native eye images read back";
    ASSERT_EQ(s.size(), n.size()) << "split eye images read back";
    uint64_t compared = 0, mismatched = 0;
    int periphery_differs = 0;
    for (const auto &[key, native_path] : n) {
        SCOPED_TRACE(native_path.filename().string());
        const auto it = s.find(key);
        ASSERT_NE(it, s.end()) << "no split readback of the same image and release";
        EyeImage a, b;
        ASSERT_NO_FATAL_FAILURE(load_pair(native_path, it->second, w, h, &a, &b));
        ASSERT_EQ(a.bytes, 8u) << "the readback layer wrote " << a.bytes << "-byte texels";
        ASSERT_EQ(a.format, format.vk);
        const Rect f = default_foveae(w, h, 1)[0];
        const Mismatch m = compare_rect(a, b, f);
        compared += m.pixels;
        mismatched += m.mismatched;
        EXPECT_EQ(m.mismatched, 0u) << "fovea " << f.w << "x" << f.h << " at " << f.x << "," << f.y << ": "
                                    << m.mismatched << " of " << m.pixels << " texels differ\n"
                                    << save_mismatch_artefacts(out_, native_path.stem().string(), to_image(a),
                                                               to_image(b));
        periphery_differs += compare_rect(a, b, Rect{0, 0, w, h}).mismatched > m.mismatched;
    }
    std::cout << "  " << format.vk << ": " << compared << " fovea texels compared in " << n.size()
              << " eye images, " << mismatched << " differ; periphery differs in " << periphery_differs
              << "\n";
    RecordProperty("fovea_texels", std::to_string(compared));
    RecordProperty("fovea_mismatches", std::to_string(mismatched));
    EXPECT_EQ(periphery_differs, 2 * kFrames) << "eye images whose periphery is native's were not split";
    expect_split_stats("split", 2 * kFrames);
    expect_no_new_validation("native", "split");
}

INSTANTIATE_TEST_SUITE_P(, XrAppsEyeFormat,
                         ::testing::Values(EyeFormat{"rgba16f", "R16G16B16A16_SFLOAT"},
                                           EyeFormat{"rgba16", "R16G16B16A16_UNORM"}),
                         [](const ::testing::TestParamInfo<EyeFormat> &p) {
                             return std::string(p.param.option);
                         });

// ------------------------------------------------------------------------ the mirror window

// The first process among the descendants of `root` whose name is `name` (scripts/xr-runtime runs
// atrium as its child), or -1.
pid_t descendant_named(pid_t root, const std::string &name) {
    std::map<pid_t, pid_t> parent;
    std::map<pid_t, std::string> names;
    if (DIR *proc = opendir("/proc")) {
        while (const dirent *entry = readdir(proc)) {
            const pid_t pid = static_cast<pid_t>(std::atoi(entry->d_name));
            if (pid <= 0) continue;
            const std::string stat = read_file(std::filesystem::path("/proc") / entry->d_name / "stat");
            const auto open = stat.find('('), close = stat.rfind(')');
            if (open == std::string::npos || close == std::string::npos || close + 4 >= stat.size()) continue;
            names[pid] = stat.substr(open + 1, close - open - 1);
            parent[pid] = static_cast<pid_t>(std::atoi(stat.c_str() + close + 4)); // ") S PPID"
        }
        closedir(proc);
    }
    for (const auto &[pid, n] : names) {
        if (n != name) continue;
        for (pid_t p = parent[pid]; p > 1; p = parent.count(p) ? parent[p] : 0)
            if (p == root) return pid;
    }
    return -1;
}

// The image a downscaled copy of `img` in its top-left corner (nearest texel, `scale` of its size)
// would leave: what a mirror that reads the client's periphery before the composite shows there.
Image with_miniature(const Image &img, double scale) {
    Image out = img;
    const auto mw = static_cast<uint32_t>(img.width * scale), mh = static_cast<uint32_t>(img.height * scale);
    for (uint32_t y = 0; y < mh; ++y)
        for (uint32_t x = 0; x < mw; ++x)
            std::memcpy(out.pixel(x, y),
                        img.pixel(std::min(img.width - 1, static_cast<uint32_t>(x / scale)),
                                  std::min(img.height - 1, static_cast<uint32_t>(y / scale))),
                        4);
    return out;
}

Image crop(const Image &img, uint32_t w, uint32_t h) {
    Image out;
    out.width = w;
    out.height = h;
    out.bgr0.resize(size_t{w} * h * 4);
    for (uint32_t y = 0; y < h; ++y)
        std::memcpy(out.pixel(0, y), img.pixel(0, y), size_t{w} * 4);
    return out;
}

class XrAppsMirror : public XrApps {
protected:
    void SetUp() override {
        XrApps::SetUp();
        xvfb_ = shared_xvfb();
        ASSERT_NE(xvfb_, nullptr) << "cannot start Xvfb: " << shared_xvfb_error();
    }

    // atrium --xr --xr-mirror holding its last frame; the mirror window (at 0,0, the eye's size) as
    // the X server shows it, then atrium is asked to stop (SIGTERM to atrium alone, so that
    // scripts/xr-runtime stops Monado and exits with atrium's status).
    void run_and_grab(Env env, const std::string &run, int frames, Image *grab, EyeImage *left_eye) {
        env["TEST_XR_READBACK_KEEP"] = "2"; // the held frame is released again and again
        const auto started = Clock::now();
        Process p(
            atrium(env, run,
                   {"--xr-mirror", "--xr-eye-size", std::to_string(kWidth) + "x" + std::to_string(kHeight),
                    "--frames", std::to_string(frames), "--hold"}));
        ASSERT_TRUE(p.start()) << p.error();
        const std::string holding = "holding frame " + std::to_string(frames - 1);
        if (!p.wait_for_line(holding, 240s)) {
            const auto r = p.terminate(10s);
            FAIL() << run << " never printed '" << holding << "': " << r.describe() << "\n"
                   << tail(r.err(), 30);
        }
        std::string error;
        const bool grabbed =
            grab_stable(xvfb_->display(), 0, 0, kWidth, kHeight, out_ / (run + ".raw"), grab, &error);
        const pid_t app = descendant_named(p.pid(), "splitvk-atrium");
        if (app > 0) kill(app, SIGTERM);
        const ProcessResult r = app > 0 ? p.wait(60s) : p.terminate(10s);
        std::cout << "  " << run << ": " << std::chrono::duration<double>(Clock::now() - started).count()
                  << " s\n";
        ASSERT_TRUE(grabbed) << error;
        ASSERT_GT(app, 0) << "no splitvk-atrium under scripts/xr-runtime";
        ASSERT_TRUE(r.ok()) << run << " did not exit 0 on SIGTERM: " << r.describe() << "\n"
                            << tail(r.err(), 30);
        EXPECT_FALSE(grep(r.out(), "xr: the left eye mirrored into a " + std::to_string(kWidth) + "x" +
                                       std::to_string(kHeight) + " window")
                         .empty())
            << tail(r.out(), 10);
        // The left eye's last release (images 0-2 are its swapchain's, created first): the held frame
        // as the runtime received it.
        std::pair<int, std::filesystem::path> last{-1, {}};
        for (const auto &[key, path] : readbacks(out_ / run / "images"))
            if (key.first < 3 && key.second > last.first) last = {key.second, path};
        ASSERT_TRUE(load_pam(last.second, left_eye)) << "no readback of the left eye in " << run;
    }

    static constexpr uint32_t kWidth = 320, kHeight = 240;
    Xvfb *xvfb_ = nullptr;
};

// The window shows the eye the runtime receives: composited, not the client's scaled periphery.
// Natively the window is the left eye exactly. The floors, measured at 320x240: the split eye
// images themselves (as released, which a 1:1 blit copies) score SSIM 0.895 in the top-left quarter
// and 0.903 whole against native's; the mirror that read the image before the composite (the
// periphery at SPLITVK_SCALE 0.6 in the top-left corner over the image's older contents) scored
// 0.456 and 0.745, and a synthetic 0.6 miniature of native's own window 0.324 and 0.734. The test
// checks both ends against its floors, 0.8 and 0.85, on every run.
TEST_F(XrAppsMirror, WindowShowsTheCompositedEye) {
    constexpr int kFrames = 3;
    constexpr double kMinQuarterSsim = 0.8, kMinSsim = 0.85;
    Image native, split;
    EyeImage native_eye, split_eye;
    ASSERT_NO_FATAL_FAILURE(
        run_and_grab(native_env("native", false, xvfb_->display()), "native", kFrames, &native, &native_eye));
    ASSERT_GT(distinct_colours(native), 1000u) << "the native mirror looks blank\n"
                                               << save_mismatch_artefacts(out_, "native", native, native);
    Agent agent;
    ASSERT_TRUE(agent.start(clean_env(), out_)) << agent.error();
    ASSERT_NO_FATAL_FAILURE(run_and_grab(split_env("split", agent, false, xvfb_->display()), "split", kFrames,
                                         &split, &split_eye));
    EXPECT_TRUE(grep(read_file(out_ / "split.stderr"), "[splitvk] error:").empty())
        << tail(read_file(out_ / "split.stderr"), 30);

    // The eye image itself was split: the mirror is judged against a split eye.
    expect_split_stats("split", 2 * kFrames);

    const Rect f = default_foveae(kWidth, kHeight, 1)[0];
    const auto fovea = compare_exact(native, split, f.x, f.y, f.w, f.h);
    EXPECT_TRUE(fovea.equal()) << "the mirror's fovea " << f.w << "x" << f.h << " at " << f.x << "," << f.y
                               << " differs from native's: " << fovea.summary() << "\n"
                               << save_mismatch_artefacts(out_, "mirror", native, split);

    const uint32_t qw = kWidth / 2, qh = kHeight / 2;
    const double quarter = ssim(crop(native, qw, qh), crop(split, qw, qh));
    const double whole = ssim(native, split);
    const Image miniature = with_miniature(native, 0.6);
    const double miniature_quarter = ssim(crop(native, qw, qh), crop(miniature, qw, qh));
    const double miniature_whole = ssim(native, miniature);
    // What the mirror ought to show: the eye as the runtime received it, composited.
    const Image eye_native = to_image(native_eye), eye_split = to_image(split_eye);
    const double eye_quarter = ssim(crop(eye_native, qw, qh), crop(eye_split, qw, qh));
    const double eye_whole = ssim(eye_native, eye_split);
    std::cout << "  mirror against native: top-left quarter SSIM " << quarter << ", whole SSIM " << whole
              << "; the released eye images: " << eye_quarter << ", " << eye_whole
              << "; a 0.6 miniature of native's window: " << miniature_quarter << ", " << miniature_whole
              << "\n";
    const auto native_mirrors_eye = compare_exact(eye_native, native);
    EXPECT_TRUE(native_mirrors_eye.equal())
        << "native's window is not its left eye: " << native_mirrors_eye.summary() << "\n"
        << save_mismatch_artefacts(out_, "native-eye", eye_native, native);
    RecordProperty("quarter_ssim", std::to_string(quarter));
    RecordProperty("ssim", std::to_string(whole));
    ASSERT_GE(eye_quarter, kMinQuarterSsim) << "the quarter's floor is above the split eye's own score";
    ASSERT_GE(eye_whole, kMinSsim) << "the whole window's floor is above the split eye's own score";
    ASSERT_LT(miniature_quarter, kMinQuarterSsim) << "the quarter's floor would not notice a miniature";
    ASSERT_LT(miniature_whole, kMinSsim) << "the whole window's floor would not notice a miniature";
    EXPECT_GE(quarter, kMinQuarterSsim) << "the mirror's top-left quarter is not native's: a scaled copy?\n"
                                        << save_mismatch_artefacts(out_, "mirror-quarter", native, split);
    EXPECT_GE(whole, kMinSsim) << save_mismatch_artefacts(out_, "mirror-whole", native, split);
    // A mirror equal to native everywhere would have been taken from an eye that was not split.
    const auto all = compare_exact(native, split);
    EXPECT_GT(all.mismatched_pixels, all.pixels / 100) << "the mirror equals native: was the eye split?";
}

// ------------------------------------------------------------------------ odd eye sizes

struct EyeSize {
    uint32_t width, height;
};
void PrintTo(const EyeSize &s, std::ostream *os) {
    *os << s.width << "x" << s.height;
}

class XrAppsEyeSize : public XrApps, public ::testing::WithParamInterface<EyeSize> {};

// A line of texels (a row or a column) all of the clear colour: atrium's sky, R8G8B8A8_SRGB
// (135, 180, 235, 255).
bool clear_line(const EyeImage &img, uint32_t x0, uint32_t y0, uint32_t dx, uint32_t dy, uint32_t n) {
    static const uint8_t sky[4] = {135, 180, 235, 255};
    for (uint32_t i = 0; i < n; ++i)
        if (std::memcmp(img.at(x0 + i * dx, y0 + i * dy), sky, 4) != 0) return false;
    return true;
}

// Each eye image of three frames (each of a swapchain's three images released once), native against
// split: no row or column of the split image is all the clear colour unless native's is, the fovea
// is bit-exact, and the periphery is not native's.
TEST_P(XrAppsEyeSize, NoClearRowOrColumnAndFoveaeExact) {
    constexpr int kFrames = 3;
    const EyeSize size = GetParam();
    const uint32_t w = size.width, h = size.height;
    const std::vector<std::string> args = {"--xr-format",   "srgb",
                                           "--xr-eye-size", std::to_string(w) + "x" + std::to_string(h),
                                           "--frames",      std::to_string(kFrames)};
    const auto native = run_atrium(native_env("native", false), "native", args);
    ASSERT_TRUE(native.ok()) << native.describe() << "\n" << tail(native.err(), 30);
    Agent agent;
    ASSERT_TRUE(agent.start(clean_env(), out_)) << agent.error();
    const auto split = run_atrium(split_env("split", agent, false), "split", args);
    ASSERT_TRUE(split.ok()) << split.describe() << "\n" << tail(split.err(), 30);
    EXPECT_TRUE(grep(split.err(), "[splitvk] error:").empty()) << tail(split.err(), 30);

    const auto n = readbacks(out_ / "native" / "images");
    const auto s = readbacks(out_ / "split" / "images");
    ASSERT_EQ(n.size(), static_cast<size_t>(2 * kFrames)) << "native eye images read back";
    ASSERT_EQ(s.size(), n.size()) << "split eye images read back";
    uint64_t compared = 0, mismatched = 0;
    int native_clear_rows = 0;
    for (const auto &[key, native_path] : n) {
        SCOPED_TRACE(native_path.filename().string());
        const auto it = s.find(key);
        ASSERT_NE(it, s.end()) << "no split readback of the same image and release";
        EyeImage a, b;
        ASSERT_NO_FATAL_FAILURE(load_pair(native_path, it->second, w, h, &a, &b));
        ASSERT_EQ(a.format, "RGB_ALPHA");
        std::vector<std::string> clear;
        for (uint32_t y = 0; y < h; ++y) {
            const bool native_clear = clear_line(a, 0, y, 1, 0, w);
            native_clear_rows += native_clear;
            if (!native_clear && clear_line(b, 0, y, 1, 0, w)) clear.push_back("row " + std::to_string(y));
        }
        for (uint32_t x = 0; x < w; ++x)
            if (!clear_line(a, x, 0, 0, 1, h) && clear_line(b, x, 0, 0, 1, h))
                clear.push_back("column " + std::to_string(x));
        EXPECT_TRUE(clear.empty()) << clear.size()
                                   << " lines of the clear colour where native drew:" << joined(clear) << "\n"
                                   << save_mismatch_artefacts(out_, native_path.stem().string() + "-clear",
                                                              to_image(a), to_image(b));
        const Rect f = default_foveae(w, h, 1)[0];
        const Mismatch m = compare_rect(a, b, f);
        compared += m.pixels;
        mismatched += m.mismatched;
        EXPECT_EQ(m.mismatched, 0u) << "fovea " << f.w << "x" << f.h << " at " << f.x << "," << f.y << ": "
                                    << m.mismatched << " of " << m.pixels << " texels differ\n"
                                    << save_mismatch_artefacts(out_, native_path.stem().string(), to_image(a),
                                                               to_image(b));
        EXPECT_GT(compare_rect(a, b, Rect{0, 0, w, h}).mismatched, m.mismatched)
            << "the periphery is native's: the eye image was not split";
    }
    std::cout << "  " << w << "x" << h << ": " << compared << " fovea texels compared in " << n.size()
              << " eye images, " << mismatched << " differ; " << native_clear_rows
              << " rows all sky in native's\n";
    RecordProperty("fovea_texels", std::to_string(compared));
    RecordProperty("fovea_mismatches", std::to_string(mismatched));
    expect_split_stats("split", 2 * kFrames);
}

// Small odd sizes mostly, and one as large as the eye where a windowed OpenXR Tutorials app lost its
// bottom row (896x1007 there).
INSTANTIATE_TEST_SUITE_P(, XrAppsEyeSize,
                         ::testing::Values(EyeSize{193, 161}, EyeSize{321, 239}, EyeSize{897, 601},
                                           EyeSize{895, 1007}),
                         [](const ::testing::TestParamInfo<EyeSize> &p) {
                             return std::to_string(p.param.width) + "x" + std::to_string(p.param.height);
                         });

} // namespace
} // namespace splitvk::e2e
