// splitvk-link: a TCP proxy that emulates a network link, to measure splitvk on one machine.

#include "link_options.h"
#include "log.h"
#include "proxy.h"

#include <cstdio>

int main(int argc, char **argv) {
    splitvk::set_log_prefix("[splitvk-link]");
    splitvk::set_log_level(splitvk::LogLevel::Info);

    const auto parsed = splitvk::link::parse_link_options({argv + 1, argv + argc});
    if (!parsed.error.empty()) {
        SPLITVK_ERROR("%s", parsed.error.c_str());
        return 2;
    }
    if (parsed.options.help) {
        std::fputs(splitvk::link::link_usage().c_str(), stdout);
        return 0;
    }
    return splitvk::link::run_proxy(parsed.options);
}
