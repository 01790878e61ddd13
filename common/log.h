#pragma once

// One-line logging with the "[splitvk]" prefix, shared by the layer and the agent.
// The layer writes to the application's stderr, so every message is a single write().

#include <string_view>

namespace splitvk {

enum class LogLevel { Off, Error, Warn, Info, Debug };

void set_log_level(LogLevel level);
LogLevel log_level();
bool log_enabled(LogLevel level);

// Prefix for every line, "[splitvk]" in the layer; the agent uses "[splitvk-agent]".
void set_log_prefix(std::string_view prefix);

[[gnu::format(printf, 2, 3)]] void log(LogLevel level, const char *format, ...);

// A result line without a level word ("[splitvk] verify: 12 frames, 0 mismatching pixels"), for
// summaries tools parse; shown unless the log level is off.
[[gnu::format(printf, 1, 2)]] void log_result(const char *format, ...);

} // namespace splitvk

#define SPLITVK_LOG(level, ...)                                                                              \
    do {                                                                                                     \
        if (::splitvk::log_enabled(level)) ::splitvk::log(level, __VA_ARGS__);                               \
    } while (false)
#define SPLITVK_ERROR(...) SPLITVK_LOG(::splitvk::LogLevel::Error, __VA_ARGS__)
#define SPLITVK_WARN(...) SPLITVK_LOG(::splitvk::LogLevel::Warn, __VA_ARGS__)
#define SPLITVK_INFO(...) SPLITVK_LOG(::splitvk::LogLevel::Info, __VA_ARGS__)
#define SPLITVK_DEBUG(...) SPLITVK_LOG(::splitvk::LogLevel::Debug, __VA_ARGS__)
