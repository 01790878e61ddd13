// The layer under AddressSanitizer and UBSan, inside real rendering. In the sanitizer build
// (scripts/test's build-asan/, label `sanitize`) the probe and splitvk-atrium are instrumented
// like the layer, so an out-of-bounds access or undefined behaviour anywhere in the layer's
// hooks aborts the app and fails the test. In the Release build the same tests are plain
// smoke tests.
#include "e2e_test.h"

namespace splitvk::e2e {
namespace {

class Sanitize : public XTest {
protected:
    // A run must end normally, with the layer active and no sanitizer report. Leak checking is off
    // in the children: LeakSanitizer reports allocations of the (uninstrumented) driver module
    // after it was unloaded, which it cannot attribute or suppress; the unit tests keep leak
    // checking for splitvk's own code.
    ProcessResult run_with_layer(const std::vector<std::string> &argv, const std::string &app_name) {
        Env e = env();
        use_explicit_layers(e, {kLayerName});
        enable_layer_info_log(e);
        e["ASAN_OPTIONS"] = "detect_leaks=0:abort_on_error=1";
        e["UBSAN_OPTIONS"] = "print_stacktrace=1:halt_on_error=1";
        auto r = run_app(argv, e, out_, app_name, std::chrono::seconds(240));
        EXPECT_TRUE(r.ok()) << r.describe() << "\n" << tail(r.err());
        EXPECT_TRUE(layer_reported_active(r.err(), app_name)) << r.describe();
        for (const char *report : {"ERROR: AddressSanitizer", "runtime error:"}) {
            EXPECT_EQ(r.err().find(report), std::string::npos) << tail(r.err(), 40);
        }
        return r;
    }
};

TEST_F(Sanitize, ProbeWithLayer) {
    ASSERT_TRUE(built(explicit_layer_dir()));
    run_with_layer({probe_path().string()}, "splitvk-e2e-probe");
}

TEST_F(Sanitize, AtriumWithLayer) {
    ASSERT_TRUE(built(explicit_layer_dir()));
    ASSERT_TRUE(built(atrium_path()));
    run_with_layer({atrium_path().string(), "--width", "480", "--height", "216", "--frames", "8"},
                   "splitvk-atrium");
}

} // namespace
} // namespace splitvk::e2e
