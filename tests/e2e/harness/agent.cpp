#include "agent.h"

#include <chrono>
#include <thread>

namespace splitvk::e2e {

using namespace std::chrono_literals;

std::filesystem::path agent_path() {
    return bin_dir() / "splitvk-agent";
}

::testing::AssertionResult agent_session_validation_clean(const std::filesystem::path &log_path) {
    std::string log = read_file(log_path);
    const auto deadline = std::chrono::steady_clock::now() + 20s;
    while (log.find("closed after") == std::string::npos && std::chrono::steady_clock::now() < deadline) {
        std::this_thread::sleep_for(50ms);
        log = read_file(log_path);
    }
    if (log.find("; 0 validation") != std::string::npos) return ::testing::AssertionSuccess();
    std::string tail_lines;
    const auto lines = split_lines(log);
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
