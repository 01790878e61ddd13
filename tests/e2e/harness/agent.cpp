#include "agent.h"

#include <chrono>
#include <thread>

namespace splitvk::e2e {

using namespace std::chrono_literals;

std::filesystem::path agent_path() {
    return bin_dir() / "splitvk-agent";
}

namespace {

size_t count_lines_with(const std::vector<std::string> &lines, const char *what) {
    size_t n = 0;
    for (const std::string &line : lines)
        n += line.find(what) != std::string::npos;
    return n;
}

} // namespace

::testing::AssertionResult agent_session_validation_clean(const std::filesystem::path &log_path) {
    std::vector<std::string> lines = split_lines(read_file(log_path));
    const auto deadline = std::chrono::steady_clock::now() + 20s;
    // A session ends with "session N (pid P) ended"; one killed outright never does, so the wait is
    // bounded and the sessions closed are what is checked.
    const auto settled = [&] {
        return count_lines_with(lines, "closed after") > 0 &&
               count_lines_with(lines, ") started") == count_lines_with(lines, ") ended");
    };
    while (!settled() && std::chrono::steady_clock::now() < deadline) {
        std::this_thread::sleep_for(50ms);
        lines = split_lines(read_file(log_path));
    }
    size_t closed = 0, clean = 0;
    for (const std::string &line : lines) {
        if (line.find("closed after") == std::string::npos) continue;
        ++closed;
        clean += line.find("; 0 validation errors") != std::string::npos;
    }
    if (closed > 0 && clean == closed) return ::testing::AssertionSuccess();
    std::string tail_lines;
    for (size_t i = lines.size() > 15 ? lines.size() - 15 : 0; i < lines.size(); ++i)
        tail_lines += lines[i] + "\n";
    return ::testing::AssertionFailure()
           << "the agent's session did not end cleanly under validation (" << log_path.string() << "):\n"
           << tail_lines;
}

::testing::AssertionResult client_validation_clean(const std::filesystem::path &validation_log) {
    if (!std::filesystem::exists(validation_log))
        return ::testing::AssertionFailure()
               << "client-side validation was not loaded (no " << validation_log.string() << ")";
    const std::string messages = read_file(validation_log);
    if (messages.empty()) return ::testing::AssertionSuccess();
    return ::testing::AssertionFailure() << "client-side validation reported:\n" << messages.substr(0, 2000);
}

} // namespace splitvk::e2e
