#include "core/layer_settings.h"

#include <cstdlib>
#include <cstring>
#include <mutex>

namespace splitvk {

bool disabled_by_environment() {
    const char *value = std::getenv("SPLITVK_DISABLE");
    return value && std::strcmp(value, "1") == 0;
}

const LoadedSettings &layer_settings() {
    static LoadedSettings loaded;
    static std::once_flag once;
    std::call_once(once, [] {
        loaded = load_process_settings();
        set_log_level(loaded.settings.log_level);
        for (const auto &warning : loaded.warnings)
            SPLITVK_WARN("%s", warning.c_str());
        // A bad value never stops the application: splitvk reports it and stays out of the way.
        for (const auto &error : loaded.errors)
            SPLITVK_ERROR("%s; running unsplit", error.c_str());
        if (!loaded.file_path.empty()) SPLITVK_DEBUG("settings file: %s", loaded.file_path.c_str());
    });
    return loaded;
}

} // namespace splitvk
