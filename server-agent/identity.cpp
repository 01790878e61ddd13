#include "identity.h"

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

namespace splitvk::agent {
namespace {

using namespace std::chrono_literals;

// Ten years: a pinned self-signed certificate is trusted for its key, not its dates, and an
// agent that expires while a headset is on its shelf would only teach users to ignore the error.
// An hour back, for clients whose clock is a little behind.
constexpr std::chrono::seconds kValidFrom = -1h;
constexpr std::chrono::seconds kValidFor = std::chrono::hours(24 * 3650);

protocol::Result<std::string> read_text(const std::string &path, const char *what) {
    std::ifstream in(path, std::ios::binary);
    if (!in) return protocol::Error{std::string(what) + " " + path + ": cannot read it"};
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// Writes a new file with `mode`, failing if it exists (two agents starting at once on one state
// directory: the second loads what the first made).
std::string write_new(const std::string &path, const std::string &text, mode_t mode) {
    const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, mode);
    if (fd < 0) return path + ": " + std::strerror(errno);
    const ssize_t n = ::write(fd, text.data(), text.size());
    const int saved = errno;
    const bool synced = ::fsync(fd) == 0;
    ::close(fd);
    if (n != static_cast<ssize_t>(text.size()) || !synced)
        return path + ": " + (n < 0 ? std::strerror(saved) : "short write");
    return {};
}

std::string host_name() {
    char name[256] = {};
    if (::gethostname(name, sizeof(name) - 1) != 0 || !name[0]) return "localhost";
    return name;
}

protocol::Result<AgentIdentity> checked(protocol::TlsIdentity identity, std::string source, bool generated) {
    auto certificate = protocol::check_identity(identity);
    if (!certificate) return protocol::Error{source + ": " + certificate.error()};
    return AgentIdentity{std::move(identity), std::move(certificate).value(), std::move(source), generated};
}

} // namespace

std::string agent_state_dir(const AgentOptions &options) {
    if (!options.state_dir.empty()) return options.state_dir;
    if (const char *systemd = std::getenv("STATE_DIRECTORY"); systemd && systemd[0] == '/') {
        const std::string list = systemd;
        return list.substr(0, list.find(':'));
    }
    if (const char *xdg = std::getenv("XDG_STATE_HOME"); xdg && xdg[0] == '/')
        return std::string(xdg) + "/splitvk-agent";
    if (const char *home = std::getenv("HOME"); home && home[0] == '/')
        return std::string(home) + "/.local/state/splitvk-agent";
    return {};
}

protocol::Result<AgentIdentity> load_agent_identity(const AgentOptions &options) {
    if (!options.tls_cert.empty()) {
        auto cert = read_text(options.tls_cert, "--tls-cert");
        if (!cert) return protocol::Error{cert.error()};
        auto key = read_text(options.tls_key, "--tls-key");
        if (!key) return protocol::Error{key.error()};
        return checked({std::move(cert).value(), std::move(key).value()},
                       "--tls-cert " + options.tls_cert + " --tls-key " + options.tls_key, false);
    }
    const std::string dir = agent_state_dir(options);
    if (dir.empty())
        return protocol::Error{"no state directory for the TLS identity: give --state-dir, or --tls-cert and "
                               "--tls-key (none of STATE_DIRECTORY, XDG_STATE_HOME and HOME is set)"};
    const std::string key_path = dir + "/agent.key";
    const std::string cert_path = dir + "/agent.crt";
    std::error_code ec;
    const bool has_key = std::filesystem::exists(key_path, ec);
    const bool has_cert = std::filesystem::exists(cert_path, ec);
    if (has_key != has_cert)
        return protocol::Error{dir + " holds " +
                               (has_key ? "agent.key without agent.crt" : "agent.crt without agent.key") +
                               ": remove it to make a new identity (clients will see a changed key)"};
    if (!has_key) {
        std::filesystem::create_directories(dir, ec);
        if (ec) return protocol::Error{"cannot create the state directory " + dir + ": " + ec.message()};
        ::chmod(dir.c_str(), 0700);
        auto fresh = protocol::generate_tls_identity("splitvk-agent " + host_name(), kValidFrom, kValidFor);
        if (!fresh) return protocol::Error{"cannot make a TLS identity: " + fresh.error()};
        std::string failed = write_new(key_path, fresh->private_key_pem, 0600);
        if (failed.empty()) {
            failed = write_new(cert_path, fresh->certificate_pem, 0644);
            if (!failed.empty()) std::filesystem::remove(key_path, ec);
        }
        if (failed.empty()) return checked(std::move(fresh).value(), dir, true);
        if (!std::filesystem::exists(cert_path, ec))
            return protocol::Error{"cannot store the TLS identity: " + failed};
        // Another agent made one meanwhile: use that.
    }
    auto key = read_text(key_path, "TLS key");
    if (!key) return protocol::Error{key.error()};
    auto cert = read_text(cert_path, "TLS certificate");
    if (!cert) return protocol::Error{cert.error()};
    return checked({std::move(cert).value(), std::move(key).value()}, dir, false);
}

} // namespace splitvk::agent
