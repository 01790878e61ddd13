// Where the build put things, and the environments the tests give applications: the parent's
// environment minus anything Vulkan/splitvk-related that leaked in, lavapipe pinned, the user's
// own layer folders hidden, then exactly what each test asks for.
#pragma once

#include "process.h"

#include <filesystem>
#include <string>
#include <vector>

namespace splitvk::e2e {

inline constexpr const char *kLayerName = "VK_LAYER_SPLITVK_split_render";
inline constexpr const char *kValidationLayerName = "VK_LAYER_KHRONOS_validation";
inline constexpr const char *kLavapipeIcd = "/usr/share/vulkan/icd.d/lvp_icd.x86_64.json";

// Paths baked in by CMake (see tests/e2e/CMakeLists.txt).
const std::filesystem::path &build_dir();
const std::filesystem::path &bin_dir();
const std::filesystem::path &source_dir();
const std::filesystem::path &output_root(); // <build>/tests/e2e/output
std::filesystem::path explicit_layer_dir(); // for VK_ADD_LAYER_PATH
std::filesystem::path implicit_data_dir();  // <build>/share, for XDG_DATA_DIRS
std::filesystem::path atrium_path();        // <build>/bin/splitvk-atrium
std::filesystem::path probe_path();         // <build>/bin/splitvk-e2e-probe

// A fresh, empty output folder for the running gtest test: <output_root>/<Suite>.<Test>/.
std::filesystem::path test_output_dir();

// Parent environment minus VK_INSTANCE_LAYERS, VK_DEVICE_LAYERS, VK_LAYER_*, VK_LOADER_*,
// VK_ADD_LAYER_PATH, VK_ICD_FILENAMES, VK_*DRIVER_FILES, SPLITVK_*, DISPLAY and XDG_*_DIRS/_HOME;
// then VK_DRIVER_FILES = lavapipe, XDG_DATA_DIRS = /usr/share (system layers such as validation,
// but not /usr/local/share where an installed splitvk could shadow the build tree's), and
// XDG_CONFIG_HOME / XDG_DATA_HOME pointing at an empty folder so ~/.local layers stay out; and
// SPLITVK_SPLIT=always, so that every frame the layer can split is split (erase it to test the
// default, which splits only where the split pays).
Env clean_env();

// clean_env() plus DISPLAY for the given X server.
Env app_env(const std::string &display);

// VK_INSTANCE_LAYERS = `layers` joined with ':' (first = closest to the app), VK_ADD_LAYER_PATH =
// the build tree's explicit manifest folder.
void use_explicit_layers(Env &env, const std::vector<std::string> &layers);
// Puts VK_LAYER_SPLITVK_test_hold (tests/e2e/hold_layer) first in VK_INSTANCE_LAYERS, closest to
// the app: after presenting frame `frame` the app prints "holding frame N" and freezes until
// signalled. Call after use_explicit_layers() (or on an env without layers).
void use_hold_layer(Env &env, int frame);
// Puts the layer `name`, whose manifest is in `dir`, in VK_INSTANCE_LAYERS at the bottom of the
// chain, next to the driver: below the layers found through VK_ADD_LAYER_PATH (splitvk) and below
// the system's explicit layers (validation). Call after use_explicit_layers() (or on an env without
// layers).
inline constexpr const char *kSystemExplicitLayers = "/usr/share/vulkan/explicit_layer.d";
void use_bottom_layer(Env &env, const std::string &name, const std::filesystem::path &dir);
// Puts VK_LAYER_SPLITVK_test_present_fault (tests/e2e/present_fault_layer) at the bottom of the
// chain (use_bottom_layer; validation so sees the answer the layer above it got). The driver's
// present answers `fault` ("out_of_date:N", "suboptimal:N") once.
inline constexpr const char *kPresentFaultLayerName = "VK_LAYER_SPLITVK_test_present_fault";
void use_present_fault_layer(Env &env, const std::string &fault);
// The build tree's implicit manifest becomes visible (XDG_DATA_DIRS = <build>/share:/usr/share);
// the layer is then enabled only through SPLITVK_ENABLE=1, which this does not set.
void make_implicit_layer_visible(Env &env);
// VK_LOADER_DEBUG=layer: the loader prints the layers it inserts on stderr.
void enable_loader_debug(Env &env);
// SPLITVK_LOG_LEVEL=info: the layer says on stderr that it is active (layer_active_line).
void enable_layer_info_log(Env &env);

// Validation below (or without) our layer: writes <dir>/vk_layer_settings.txt with synchronization
// validation on and messages (error, warning, performance) logged to <dir>/validation.log, points
// VK_LAYER_SETTINGS_PATH at it, and returns the log path. VK_INSTANCE_LAYERS is set by the caller.
std::filesystem::path configure_validation(Env &env, const std::filesystem::path &dir);

// The *.json files in a manifest folder.
std::vector<std::filesystem::path> manifests_in(const std::filesystem::path &dir);

// What the layer and the loader say on stderr.
std::string layer_active_line(const std::string &app_name); // "[splitvk] info: ... active in '<app>'"
bool layer_reported_active(const std::string &stderr_text, const std::string &app_name);
bool loader_inserted(const std::string &stderr_text, const std::string &layer_name);

struct StackEntry {
    std::string name;
    std::string manifest;
};
// The instance call stack the loader printed under VK_LOADER_DEBUG=layer, application side first.
std::vector<StackEntry> instance_layer_stack(const std::string &stderr_text);
int stack_index(const std::vector<StackEntry> &stack, const std::string &layer_name); // -1 if absent

// Lines of `text` starting with `prefix`.
std::vector<std::string> lines_starting_with(const std::string &text, const std::string &prefix);

} // namespace splitvk::e2e
