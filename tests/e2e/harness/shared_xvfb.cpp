// The one Xvfb of a test binary (xvfb.h): started on first use, in the suites' output folder.
#include "vk_env.h"
#include "xvfb.h"

#include <mutex>

namespace splitvk::e2e {

namespace {
std::mutex g_mutex;
std::unique_ptr<Xvfb> g_xvfb;
bool g_failed = false;
std::string g_error;
} // namespace

Xvfb *shared_xvfb() {
    std::lock_guard<std::mutex> lock(g_mutex);
    if (g_xvfb) return g_xvfb.get();
    if (g_failed) return nullptr; // do not retry a broken X server for every test
    auto x = std::make_unique<Xvfb>();
    std::filesystem::path dir = output_root() / "xvfb";
    if (!x->start(dir, clean_env())) {
        g_failed = true;
        g_error = x->error();
        return nullptr;
    }
    g_xvfb = std::move(x);
    return g_xvfb.get();
}

std::string shared_xvfb_error() {
    std::lock_guard<std::mutex> lock(g_mutex);
    return g_error;
}

void stop_shared_xvfb() {
    std::lock_guard<std::mutex> lock(g_mutex);
    g_xvfb.reset();
}

} // namespace splitvk::e2e
