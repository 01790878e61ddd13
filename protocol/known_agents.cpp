#include "known_agents.h"

#include "settings.h"

#include <cctype>
#include <cerrno>
#include <cstring>
#include <filesystem>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

namespace splitvk::protocol {
namespace {

bool is_space(char c) {
    return c == ' ' || c == '\t' || c == '\r';
}

// HOST:PORT or [V6]:PORT with a port of 1-65535 and no whitespace or control characters.
bool plausible_address(std::string_view address) {
    const auto colon = address.rfind(':');
    if (colon == std::string_view::npos || colon == 0 || colon + 1 == address.size()) return false;
    const std::string_view port = address.substr(colon + 1);
    if (port.size() > 5) return false;
    unsigned value = 0;
    for (char c : port) {
        if (c < '0' || c > '9') return false;
        value = value * 10 + static_cast<unsigned>(c - '0');
    }
    if (value == 0 || value > 65535) return false;
    const std::string_view host = address.substr(0, colon);
    if (host.front() == '[' && (host.size() < 3 || host.back() != ']')) return false;
    for (char c : host)
        if (!std::isgraph(static_cast<unsigned char>(c))) return false;
    return true;
}

} // namespace

KnownAgents parse_known_agents(std::string_view text, const std::string &path) {
    KnownAgents known;
    int number = 0;
    while (!text.empty()) {
        ++number;
        const auto end = text.find('\n');
        std::string_view line = text.substr(0, end);
        text.remove_prefix(end == std::string_view::npos ? text.size() : end + 1);
        while (!line.empty() && is_space(line.front()))
            line.remove_prefix(1);
        while (!line.empty() && is_space(line.back()))
            line.remove_suffix(1);
        if (line.empty() || line.front() == '#') continue;
        std::vector<std::string_view> fields;
        while (!line.empty()) {
            size_t n = 0;
            while (n < line.size() && !is_space(line[n]))
                ++n;
            fields.push_back(line.substr(0, n));
            line.remove_prefix(n);
            while (!line.empty() && is_space(line.front()))
                line.remove_prefix(1);
        }
        const std::string where = path + ":" + std::to_string(number) + ": ";
        if (fields.size() != 2) {
            known.problems.push_back(where + "expected ADDRESS SHA256-FINGERPRINT, found " +
                                     std::to_string(fields.size()) + " fields; line ignored");
            continue;
        }
        if (!plausible_address(fields[0])) {
            known.problems.push_back(where + "'" + std::string(fields[0].substr(0, 80)) +
                                     "' is not HOST:PORT; line ignored");
            continue;
        }
        const auto fingerprint = normalize_fingerprint(fields[1]);
        if (!fingerprint) {
            known.problems.push_back(where + "'" + std::string(fields[1].substr(0, 100)) +
                                     "' is not a SHA-256 fingerprint; line ignored");
            continue;
        }
        known.entries.push_back(KnownAgent{std::string(fields[0]), *fingerprint, number});
    }
    return known;
}

const KnownAgent *find_known_agent(const KnownAgents &known, std::string_view address) {
    for (const auto &entry : known.entries)
        if (entry.address == address) return &entry;
    return nullptr;
}

std::string known_agents_path(const char *xdg_config_home, const char *home) {
    // As the XDG spec says: a relative XDG_CONFIG_HOME is invalid and ignored.
    if (xdg_config_home && xdg_config_home[0] == '/')
        return std::string(xdg_config_home) + "/splitvk/known_agents";
    if (home && home[0] == '/') return std::string(home) + "/.config/splitvk/known_agents";
    return {};
}

std::string append_known_agent(const std::string &path, const std::string &address,
                               const std::string &fingerprint) {
    std::error_code ec;
    const auto directory = std::filesystem::path(path).parent_path();
    if (!directory.empty() && !std::filesystem::exists(directory, ec)) {
        std::filesystem::create_directories(directory, ec);
        if (ec) return "cannot create " + directory.string() + ": " + ec.message();
        ::chmod(directory.c_str(), 0700);
    }
    const int fd = ::open(path.c_str(), O_WRONLY | O_APPEND | O_CREAT | O_CLOEXEC, 0600);
    if (fd < 0) return "cannot open " + path + ": " + std::strerror(errno);
    // One write of a whole line: concurrent appenders (two processes meeting a new agent at
    // once) never interleave within a line.
    const std::string line = address + " " + fingerprint + "\n";
    const ssize_t written = ::write(fd, line.data(), line.size());
    const int saved = errno;
    ::close(fd);
    if (written != static_cast<ssize_t>(line.size()))
        return "cannot write " + path + ": " + (written < 0 ? std::strerror(saved) : "short write");
    return {};
}

} // namespace splitvk::protocol
