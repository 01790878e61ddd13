// splitvk-agent: the server side of splitvk.

#include "agent_options.h"
#include "devices.h"
#include "listener.h"
#include "log.h"

#include <vulkan/vulkan.h>

#include <cstdio>

namespace {

int list_devices() {
    std::string error;
    const auto gpus = splitvk::agent::enumerate_gpus(&error);
    if (gpus.empty()) {
        SPLITVK_ERROR("%s", error.c_str());
        return 1;
    }
    for (const auto &gpu : gpus) {
        std::printf("%u: %s (%s, Vulkan %u.%u.%u, %s)\n", gpu.index, gpu.name.c_str(), gpu.type.c_str(),
                    VK_API_VERSION_MAJOR(gpu.api_version), VK_API_VERSION_MINOR(gpu.api_version),
                    VK_API_VERSION_PATCH(gpu.api_version), gpu.driver.c_str());
    }
    return 0;
}

} // namespace

int main(int argc, char **argv) {
    splitvk::set_log_prefix("[splitvk-agent]");
    splitvk::set_log_level(splitvk::LogLevel::Info);

    const auto parsed = splitvk::agent::parse_agent_options({argv + 1, argv + argc});
    if (!parsed.error.empty()) {
        SPLITVK_ERROR("%s", parsed.error.c_str());
        return 2;
    }
    const auto &options = parsed.options;
    if (options.help) {
        std::fputs(splitvk::agent::agent_usage(), stdout);
        return 0;
    }
    if (options.list_devices) return list_devices();

    std::string error;
    const auto gpus = splitvk::agent::enumerate_gpus(&error);
    if (options.device_index >= gpus.size()) {
        SPLITVK_ERROR("--device %u: %s", options.device_index,
                      gpus.empty() ? error.c_str() : "no such GPU (see --list-devices)");
        return 2;
    }
    return splitvk::agent::run_listener(options, gpus[options.device_index].name);
}
