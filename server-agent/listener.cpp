#include "listener.h"

#include "agent_session.h"
#include "confinement.h"
#include "log.h"
#include "transport.h"

#include <csignal>
#include <cstring>
#include <fstream>
#include <iterator>
#include <map>

#include <sys/wait.h>
#include <unistd.h>

namespace splitvk::agent {

using namespace std::chrono_literals;

namespace {

volatile std::sig_atomic_t g_stop = 0;

void on_stop_signal(int) {
    g_stop = 1;
}

struct Child {
    uint64_t session_id = 0;
    std::string dir; // its private directory; empty with --no-confine
};

void log_exit(const Child &child, pid_t pid, int status) {
    if (WIFEXITED(status)) {
        const int code = WEXITSTATUS(status);
        SPLITVK_INFO("session %llu (pid %d) ended: %s (exit status %d)",
                     static_cast<unsigned long long>(child.session_id), static_cast<int>(pid),
                     session_exit_name(code), code);
    } else if (WIFSIGNALED(status)) {
        SPLITVK_ERROR("session %llu (pid %d) ended: killed by signal %d (%s)",
                      static_cast<unsigned long long>(child.session_id), static_cast<int>(pid),
                      WTERMSIG(status), strsignal(WTERMSIG(status)));
    }
}

void reap(std::map<pid_t, Child> &children, SessionDirectories &dirs, bool block) {
    for (;;) {
        int status = 0;
        const pid_t pid = waitpid(-1, &status, block ? 0 : WNOHANG);
        if (pid <= 0) return;
        auto it = children.find(pid);
        if (it == children.end()) continue;
        // Before the line that says it ended: whoever waits for that line finds the corpus there.
        dirs.release(it->second.session_id, it->second.dir);
        log_exit(it->second, pid, status);
        children.erase(it);
        if (block && children.empty()) return;
    }
}

bool read_token(const std::string &path, std::vector<uint8_t> *token, std::string *error) {
    std::ifstream in(path, std::ios::binary);
    if (!in) {
        *error = "--token-file " + path + ": cannot read it";
        return false;
    }
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    while (!text.empty() &&
           (text.back() == '\n' || text.back() == '\r' || text.back() == ' ' || text.back() == '\t'))
        text.pop_back();
    if (text.empty()) {
        *error = "--token-file " + path + ": the file is empty";
        return false;
    }
    token->assign(text.begin(), text.end());
    return true;
}

} // namespace

int run_listener(const AgentOptions &options, const std::string &gpu_name,
                 const protocol::DeviceDescription &device, std::shared_ptr<protocol::TlsContext> tls,
                 const std::optional<Advertisement> &advertisement) {
    std::vector<uint8_t> token;
    std::string error;
    if (!options.token_file.empty() && !read_token(options.token_file, &token, &error)) {
        SPLITVK_ERROR("%s", error.c_str());
        return 2;
    }
    const auto plan = plan_confinement(options, &error);
    if (!plan) {
        SPLITVK_ERROR("%s", error.c_str());
        return 2;
    }
    SessionDirectories dirs;
    if (plan->enabled && !dirs.open(*plan, &error)) {
        SPLITVK_ERROR("session directories: %s", error.c_str());
        return 2;
    }
    auto acceptor = protocol::Acceptor::listen(options.listen_host, options.listen_port);
    if (!acceptor) {
        SPLITVK_ERROR("cannot listen on %s:%u: %s", options.listen_host.c_str(), options.listen_port,
                      acceptor.error().c_str());
        return 2;
    }
    struct sigaction action {};
    action.sa_handler = on_stop_signal;
    sigemptyset(&action.sa_mask);
    sigaction(SIGTERM, &action, nullptr);
    sigaction(SIGINT, &action, nullptr);
    std::signal(SIGPIPE, SIG_IGN);

    SPLITVK_INFO("listening on %s:%u, GPU %u (%s)%s", options.listen_host.c_str(), (*acceptor)->port(),
                 options.device_index, gpu_name.c_str(), options.validate ? ", validation on" : "");
    if (plan->enabled) SPLITVK_INFO("session directories under %s", dirs.base().c_str());
    SPLITVK_INFO("per session: messages up to %u bytes, %llu bytes of host memory, %llu bytes of GPU memory",
                 options.max_message_bytes, static_cast<unsigned long long>(options.max_host_memory),
                 static_cast<unsigned long long>(options.max_gpu_memory));
    if (!options.record_corpus.empty())
        SPLITVK_WARN("--record-corpus %s: every session's messages are written there, in the clear",
                     options.record_corpus.c_str());
    std::map<pid_t, Child> children;
    const auto free_slots = [&] {
        return children.size() >= options.max_sessions
                   ? 0u
                   : options.max_sessions - static_cast<uint32_t>(children.size());
    };
    std::unique_ptr<Advertiser> advertiser;
    if (advertisement) {
        protocol::AgentRecord record = advertisement->record;
        record.free_slots = free_slots();
        record.max_slots = options.max_sessions;
        advertiser =
            std::make_unique<Advertiser>(advertisement->name, (*acceptor)->port(), std::move(record));
    }
    uint64_t next_session = 1;
    while (!g_stop) {
        reap(children, dirs, false);
        if (advertiser) {
            advertiser->set_free_slots(free_slots());
            advertiser->poll();
        }
        auto fd = (*acceptor)->accept(200ms);
        if (!fd) {
            if (g_stop) break;
            SPLITVK_ERROR("accept: %s", fd.error().c_str());
            continue;
        }
        if (!*fd) continue; // timeout: reap and check the stop flag
        SessionConfig config;
        config.session_id = next_session++;
        config.device_index = options.device_index;
        config.validate = options.validate;
        config.full = children.size() >= options.max_sessions;
        config.token = token;
        config.gpu_name = gpu_name;
        config.max_message_bytes = options.max_message_bytes;
        config.max_host_memory = options.max_host_memory;
        config.max_gpu_memory = options.max_gpu_memory;
        config.record_corpus = options.record_corpus;
        config.capabilities = agent_capabilities(options);
        config.device = device;
        config.tls = tls;
        std::string dir;
        if (plan->enabled) {
            dir = dirs.create(config.session_id, &error);
            if (dir.empty()) {
                SPLITVK_ERROR("session %llu: %s; not served",
                              static_cast<unsigned long long>(config.session_id), error.c_str());
                continue;
            }
            // A confined session writes only inside its directory; the listener copies the files out.
            if (!config.record_corpus.empty()) config.record_corpus = dir;
        }
        std::fflush(nullptr);
        const pid_t pid = fork();
        if (pid < 0) {
            SPLITVK_ERROR("session %llu: fork failed: %s", static_cast<unsigned long long>(config.session_id),
                          std::strerror(errno));
            dirs.release(config.session_id, dir);
            continue;
        }
        if (pid == 0) {
            // The session's process: default signal handling, no listening socket.
            std::signal(SIGTERM, SIG_DFL);
            std::signal(SIGINT, SIG_DFL);
            (*acceptor)->close();
            dirs.close_in_session();
            if (advertiser) advertiser->close_in_session();
            // Confined before the first byte from the client is decoded.
            if (!confine_session(*plan, dir, &error)) {
                SPLITVK_ERROR("session %llu: cannot confine the session process: %s; closing",
                              static_cast<unsigned long long>(config.session_id), error.c_str());
                std::fflush(nullptr);
                _exit(kSessionConfinement);
            }
            const int status = run_session(std::move(*fd), config);
            std::fflush(nullptr);
            _exit(status);
        }
        children[pid] = Child{config.session_id, dir};
        if (advertiser) advertiser->set_free_slots(free_slots());
        SPLITVK_INFO("session %llu (pid %d) started%s", static_cast<unsigned long long>(config.session_id),
                     static_cast<int>(pid), config.full ? " over --max-sessions: it will be rejected" : "");
    }
    // Withdrawn first: nobody should pick an agent that is going away.
    advertiser.reset();
    (*acceptor)->close();
    SPLITVK_INFO("stopping: %zu sessions still running get SIGTERM", children.size());
    for (const auto &[pid, child] : children)
        kill(pid, SIGTERM);
    if (!children.empty()) reap(children, dirs, true);
    SPLITVK_INFO("stopped");
    return 0;
}

} // namespace splitvk::agent
