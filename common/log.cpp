#include "log.h"

#include <atomic>
#include <cstdarg>
#include <cstdio>
#include <mutex>
#include <string>

#include <unistd.h>

namespace splitvk {
namespace {

std::atomic<LogLevel> g_level{LogLevel::Warn};
std::mutex g_prefix_mutex;
std::string g_prefix = "[splitvk]";

const char *level_name(LogLevel level) {
    switch (level) {
    case LogLevel::Error:
        return "error";
    case LogLevel::Warn:
        return "warning";
    case LogLevel::Info:
        return "info";
    case LogLevel::Debug:
        return "debug";
    case LogLevel::Off:
        break;
    }
    return "";
}

} // namespace

void set_log_level(LogLevel level) {
    g_level.store(level, std::memory_order_relaxed);
}
LogLevel log_level() {
    return g_level.load(std::memory_order_relaxed);
}

bool log_enabled(LogLevel level) {
    return level != LogLevel::Off && static_cast<int>(level) <= static_cast<int>(log_level());
}

void set_log_prefix(std::string_view prefix) {
    std::lock_guard lock(g_prefix_mutex);
    g_prefix = prefix;
}

namespace {

// format(printf, 2, 0): a va_list consumer, so clang checks the callers' formats, not this one.
[[gnu::format(printf, 2, 0)]] void write_line(const char *level_word, const char *format, va_list args) {
    char message[1024];
    std::vsnprintf(message, sizeof(message), format, args);

    std::string line;
    {
        std::lock_guard lock(g_prefix_mutex);
        line = g_prefix;
    }
    line += ' ';
    if (level_word) {
        line += level_word;
        line += ": ";
    }
    line += message;
    line += '\n';
    // A single write() keeps lines from different threads (and the app's own output) whole.
    [[maybe_unused]] ssize_t written = ::write(STDERR_FILENO, line.data(), line.size());
}

} // namespace

void log(LogLevel level, const char *format, ...) {
    if (!log_enabled(level)) return;
    va_list args;
    va_start(args, format);
    write_line(level_name(level), format, args);
    va_end(args);
}

void log_result(const char *format, ...) {
    if (log_level() == LogLevel::Off) return;
    va_list args;
    va_start(args, format);
    write_line(nullptr, format, args);
    va_end(args);
}

} // namespace splitvk
