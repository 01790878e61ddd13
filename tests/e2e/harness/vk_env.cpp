#include "vk_env.h"

#include <cstdlib>
#include <fstream>

#include <gtest/gtest.h>

extern char **environ;

namespace splitvk::e2e {

namespace {

std::filesystem::path env_or(const char *name, const char *fallback) {
    const char *v = std::getenv(name);
    return std::filesystem::path(v && *v ? v : fallback);
}

bool starts_with(const std::string &s, const std::string &prefix) {
    return s.rfind(prefix, 0) == 0;
}

bool leaked(const std::string &name) {
    static const char *const exact[] = {
        "VK_INSTANCE_LAYERS",  "VK_DEVICE_LAYERS", "VK_ADD_LAYER_PATH", "VK_ICD_FILENAMES", "VK_DRIVER_FILES",
        "VK_ADD_DRIVER_FILES", "DISPLAY",          "WAYLAND_DISPLAY",   "XDG_DATA_DIRS",    "XDG_CONFIG_DIRS",
        "XDG_DATA_HOME",       "XDG_CONFIG_HOME",  "NODEVICE_SELECT"};
    for (const char *e : exact)
        if (name == e) return true;
    return starts_with(name, "VK_LAYER_") || starts_with(name, "VK_LOADER_") || starts_with(name, "SPLITVK_");
}

} // namespace

// SPLITVK_E2E_* overrides exist so the suite can be pointed at another build by hand; they are read
// here by the test binary and never passed on to applications (clean_env strips SPLITVK_*).
const std::filesystem::path &build_dir() {
    static const auto p = env_or("SPLITVK_E2E_BUILD_DIR", SPLITVK_BUILD_DIR);
    return p;
}
const std::filesystem::path &bin_dir() {
    static const auto p =
        std::getenv("SPLITVK_E2E_BUILD_DIR") ? build_dir() / "bin" : std::filesystem::path(SPLITVK_BIN_DIR);
    return p;
}
const std::filesystem::path &source_dir() {
    static const auto p = std::filesystem::path(SPLITVK_SOURCE_DIR);
    return p;
}
const std::filesystem::path &output_root() {
    static const auto p = env_or("SPLITVK_E2E_OUTPUT_DIR", SPLITVK_E2E_OUTPUT_DIR);
    return p;
}
std::filesystem::path explicit_layer_dir() {
    if (const char *v = std::getenv("SPLITVK_E2E_EXPLICIT_LAYER_DIR")) return v;
    return build_dir() / "manifest" / "explicit_layer.d";
}
std::filesystem::path implicit_data_dir() {
    if (const char *v = std::getenv("SPLITVK_E2E_IMPLICIT_DATA_DIR")) return v;
    return build_dir() / "share";
}
std::filesystem::path atrium_path() {
    return bin_dir() / "splitvk-atrium";
}
std::filesystem::path probe_path() {
    return std::filesystem::path(SPLITVK_E2E_PROBE);
}

std::filesystem::path test_output_dir() {
    const auto *info = ::testing::UnitTest::GetInstance()->current_test_info();
    std::string name = info ? std::string(info->test_suite_name()) + "." + info->name() : "no-test";
    for (char &c : name)
        if (c == '/') c = '_';
    auto dir = output_root() / name;
    std::error_code ec;
    std::filesystem::remove_all(dir, ec);
    std::filesystem::create_directories(dir);
    return dir;
}

Env clean_env() {
    Env env;
    for (char **e = environ; e && *e; ++e) {
        std::string kv(*e);
        auto eq = kv.find('=');
        if (eq == std::string::npos) continue;
        std::string k = kv.substr(0, eq);
        if (!leaked(k)) env[k] = kv.substr(eq + 1);
    }
    env["VK_DRIVER_FILES"] = kLavapipeIcd;
    env["XDG_DATA_DIRS"] = "/usr/share";
    env["XDG_CONFIG_DIRS"] = "/etc/xdg";
    auto empty_home = output_root() / "empty-xdg-home";
    std::error_code ec;
    std::filesystem::create_directories(empty_home, ec);
    env["XDG_CONFIG_HOME"] = empty_home.string();
    env["XDG_DATA_HOME"] = empty_home.string();
    if (env.find("PATH") == env.end()) env["PATH"] = "/usr/local/bin:/usr/bin:/bin";
    // The suites judge the split on frames too small for it to pay, which the default verdict would
    // pass through after a few dozen presents; a test of the verdict erases this.
    env["SPLITVK_SPLIT"] = "always";
    return env;
}

Env app_env(const std::string &display) {
    Env env = clean_env();
    env["DISPLAY"] = display;
    return env;
}

void use_explicit_layers(Env &env, const std::vector<std::string> &layers) {
    std::string joined;
    for (auto &l : layers)
        joined += (joined.empty() ? "" : ":") + l;
    env["VK_INSTANCE_LAYERS"] = joined;
    env["VK_ADD_LAYER_PATH"] = explicit_layer_dir().string();
}

void use_hold_layer(Env &env, int frame) {
    const std::string hold = "VK_LAYER_SPLITVK_test_hold";
    const auto layers = env.find("VK_INSTANCE_LAYERS");
    env["VK_INSTANCE_LAYERS"] =
        layers == env.end() || layers->second.empty() ? hold : hold + ":" + layers->second;
    const auto path = env.find("VK_ADD_LAYER_PATH");
    env["VK_ADD_LAYER_PATH"] = path == env.end() || path->second.empty()
                                   ? std::string(SPLITVK_E2E_HOLD_LAYER_DIR)
                                   : std::string(SPLITVK_E2E_HOLD_LAYER_DIR) + ":" + path->second;
    env["TEST_HOLD_FRAME"] = std::to_string(frame);
}

void use_bottom_layer(Env &env, const std::string &name, const std::filesystem::path &dir) {
    const auto layers = env.find("VK_INSTANCE_LAYERS");
    env["VK_INSTANCE_LAYERS"] =
        layers == env.end() || layers->second.empty() ? name : layers->second + ":" + name;
    // One folder after the other, top first: this loader chains explicit layers in the order their
    // manifests are found, and VK_LAYER_PATH replaces the system's folders (which VK_ADD_LAYER_PATH
    // is searched before).
    const auto added = env.find("VK_ADD_LAYER_PATH");
    std::string path = added == env.end() || added->second.empty() ? "" : added->second + ":";
    path += std::string(kSystemExplicitLayers) + ":" + dir.string();
    env.erase("VK_ADD_LAYER_PATH");
    env["VK_LAYER_PATH"] = path;
}

void use_present_fault_layer(Env &env, const std::string &fault) {
    use_bottom_layer(env, kPresentFaultLayerName, SPLITVK_E2E_PRESENT_FAULT_LAYER_DIR);
    env["TEST_PRESENT_FAULT"] = fault;
}

void make_implicit_layer_visible(Env &env) {
    env["XDG_DATA_DIRS"] = implicit_data_dir().string() + ":/usr/share";
}

void enable_loader_debug(Env &env) {
    env["VK_LOADER_DEBUG"] = "layer";
}

void enable_layer_info_log(Env &env) {
    env["SPLITVK_LOG_LEVEL"] = "info";
}

std::filesystem::path configure_validation(Env &env, const std::filesystem::path &dir) {
    std::filesystem::create_directories(dir);
    auto log = dir / "validation.log";
    std::ofstream settings(dir / "vk_layer_settings.txt");
    settings << "khronos_validation.enables = VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT\n"
             << "khronos_validation.debug_action = VK_DBG_LAYER_ACTION_LOG_MSG\n"
             << "khronos_validation.log_filename = " << log.string() << "\n"
             << "khronos_validation.report_flags = error,warn,perf\n";
    env["VK_LAYER_SETTINGS_PATH"] = dir.string();
    return log;
}

std::vector<std::filesystem::path> manifests_in(const std::filesystem::path &dir) {
    std::vector<std::filesystem::path> out;
    std::error_code ec;
    for (auto &entry : std::filesystem::directory_iterator(dir, ec))
        if (entry.path().extension() == ".json") out.push_back(entry.path());
    return out;
}

std::string layer_active_line(const std::string &app_name) {
    return std::string("[splitvk] info: ") + kLayerName + " active in '" + app_name + "'";
}

bool layer_reported_active(const std::string &stderr_text, const std::string &app_name) {
    return !grep(stderr_text, layer_active_line(app_name)).empty();
}

// Debian's loader 1.3.239 prints, under VK_LOADER_DEBUG=layer:
//   INFO | LAYER:     Insert instance layer "VK_LAYER_KHRONOS_validation" (libVkLayer_khronos_validation.so)
bool loader_inserted(const std::string &stderr_text, const std::string &layer_name) {
    return !grep(stderr_text, "Insert instance layer \"" + layer_name + "\"").empty();
}

// The loader's block (1.3.239):
//   LAYER:            vkCreateInstance layer callstack setup to:
//   LAYER:               <Application>
//   LAYER:                 ||
//   LAYER:               <Loader>
//   LAYER:                 ||
//   LAYER:               VK_LAYER_MESA_device_select
//   LAYER:                       Type: Implicit
//   LAYER:                       Manifest: /usr/share/vulkan/implicit_layer.d/VkLayer_MESA_device_select.json
//   ...
//   LAYER:               <Drivers>
std::vector<StackEntry> instance_layer_stack(const std::string &stderr_text) {
    std::vector<StackEntry> stack;
    bool in_block = false;
    for (auto &raw : split_lines(stderr_text)) {
        if (raw.find("vkCreateInstance layer callstack setup to:") != std::string::npos) {
            in_block = true;
            stack.clear();
            continue;
        }
        if (!in_block) continue;
        auto pos = raw.find("LAYER:");
        if (pos == std::string::npos) continue;
        std::string line = raw.substr(pos + 6);
        auto first = line.find_first_not_of(' ');
        if (first == std::string::npos) continue;
        std::string word = line.substr(first);
        if (word == "<Drivers>") {
            in_block = false;
            continue;
        }
        if (starts_with(word, "VK_LAYER_")) {
            stack.push_back({word, {}});
        } else if (starts_with(word, "Manifest:") && !stack.empty()) {
            auto m = word.substr(9);
            m.erase(0, m.find_first_not_of(' '));
            stack.back().manifest = m;
        }
    }
    return stack;
}

int stack_index(const std::vector<StackEntry> &stack, const std::string &layer_name) {
    for (size_t i = 0; i < stack.size(); ++i)
        if (stack[i].name == layer_name) return static_cast<int>(i);
    return -1;
}

std::vector<std::string> lines_starting_with(const std::string &text, const std::string &prefix) {
    std::vector<std::string> out;
    for (auto &l : split_lines(text))
        if (starts_with(l, prefix)) out.push_back(l);
    return out;
}

} // namespace splitvk::e2e
