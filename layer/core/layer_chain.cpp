// Where splitvk sits among the other layers of an instance's chain. A layer that draws at present
// (a HUD) and sits above splitvk draws into swapchain images before splitvk composites them: its
// passes are split like the application's, so what it draws becomes part of the upsampled
// periphery and its text is blurred. Below splitvk it draws on the finished frame, sharp.
//
// The loader builds the chain from the bottom up and has opened every active layer's library
// before it calls the top one's vkCreateInstance. The layers below us are those whose
// vkGetInstanceProcAddr the VkLayerInstanceLink list hands us; a known overlay's library that is
// loaded in the process but not among them is above us.

#include "core/layer_chain.h"

#include "core/chain_info.h"
#include "core/layer_settings.h"
#include "log.h"

#include <atomic>
#include <cstring>
#include <set>
#include <string>

#include <dlfcn.h>
#include <link.h>

namespace splitvk {
namespace {

struct Overlay {
    const char *library; // the file name of its shared library
    const char *name;
};

// Layers that draw into the presented image.
constexpr Overlay kOverlays[] = {
    {"libMangoHud.so", "MangoHud (VK_LAYER_MANGOHUD_overlay)"},
    {"libVkLayer_MESA_overlay.so", "the Mesa overlay (VK_LAYER_MESA_overlay)"},
    {"libvkbasalt.so", "vkBasalt (VK_LAYER_VKBASALT_post_processing)"},
};

std::string file_name(const char *path) {
    const char *slash = std::strrchr(path, '/');
    return slash ? slash + 1 : path;
}

const Overlay *known_overlay(const char *path) {
    const std::string name = file_name(path);
    for (const Overlay &overlay : kOverlays)
        if (name == overlay.library) return &overlay;
    return nullptr;
}

// The paths of the libraries below us, as the dynamic linker names them.
std::set<std::string> libraries_below(const VkLayerInstanceLink *link) {
    std::set<std::string> below;
    for (; link; link = link->pNext) {
        Dl_info info{};
        if (dladdr(reinterpret_cast<void *>(link->pfnNextGetInstanceProcAddr), &info) && info.dli_fname)
            below.insert(info.dli_fname);
    }
    return below;
}

std::atomic<bool> g_reported{false};

} // namespace

void report_layer_position(const VkLayerInstanceLink *link) {
    layer_settings(); // the log level
    if (!log_enabled(LogLevel::Info) || g_reported.load()) return;
    struct Search {
        std::set<std::string> below;
        std::set<const Overlay *> above;
    } search{libraries_below(link), {}};
    dl_iterate_phdr(
        [](dl_phdr_info *info, size_t, void *data) {
            auto &s = *static_cast<Search *>(data);
            const char *path = info->dlpi_name;
            if (!path || !*path || s.below.count(path)) return 0;
            if (const Overlay *overlay = known_overlay(path)) s.above.insert(overlay);
            return 0;
        },
        &search);
    // Once per process, from the first instance that has one above it (a probing instance first
    // created without the overlay does not use the line up).
    if (search.above.empty() || g_reported.exchange(true)) return;
    for (const Overlay *overlay : search.above)
        SPLITVK_INFO(
            "%s is above splitvk in the layer chain: what it draws at present is split like the "
            "application's passes, so its text is blurred; to keep it sharp, enable splitvk above it "
            "(docs/user-guide.md, \"Using splitvk with other layers\")",
            overlay->name);
}

} // namespace splitvk
