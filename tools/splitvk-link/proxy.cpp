#include "proxy.h"

#include "log.h"
#include "shaped_link.h"
#include "transport.h"

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

namespace splitvk::link {
namespace {

using namespace std::chrono_literals;
using protocol::Error;
using protocol::Result;
using protocol::UniqueFd;
using Clock = std::chrono::steady_clock;

volatile std::sig_atomic_t g_stop = 0;

std::string format_address(const std::string &host, uint16_t port) {
    const bool ipv6 = host.find(':') != std::string::npos;
    std::string text;
    text.append(ipv6 ? "[" : "").append(host).append(ipv6 ? "]:" : ":").append(std::to_string(port));
    return text;
}

std::string peer_address(int fd) {
    sockaddr_storage peer{};
    socklen_t length = sizeof(peer);
    char host[NI_MAXHOST] = "?";
    char service[NI_MAXSERV] = "?";
    if (::getpeername(fd, reinterpret_cast<sockaddr *>(&peer), &length) == 0)
        ::getnameinfo(reinterpret_cast<sockaddr *>(&peer), length, host, sizeof(host), service,
                      sizeof(service), NI_NUMERICHOST | NI_NUMERICSERV);
    return format_address(host, static_cast<uint16_t>(std::atoi(service)));
}

void set_nodelay(int fd) {
    // Every write the endpoints make must reach the link as they made it: the link, not Nagle,
    // decides when bytes move. (The accepted socket has it from Acceptor already.)
    const int one = 1;
    ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
}

// The next close() sends a reset instead of a FIN: how a failure on one side reaches the other.
void reset_on_close(int fd) {
    const linger abort{1, 0};
    ::setsockopt(fd, SOL_SOCKET, SO_LINGER, &abort, sizeof(abort));
}

// A blocking TCP connection to host:port, attempted for at most `timeout` per address.
Result<UniqueFd> connect_to(const std::string &host, uint16_t port, std::chrono::milliseconds timeout) {
    addrinfo hints{};
    hints.ai_family = AF_UNSPEC;
    hints.ai_socktype = SOCK_STREAM;
    hints.ai_flags = AI_NUMERICSERV;
    addrinfo *found = nullptr;
    const std::string service = std::to_string(port);
    if (const int status = ::getaddrinfo(host.c_str(), service.c_str(), &hints, &found); status != 0)
        return Error{"cannot resolve '" + host + "': " + ::gai_strerror(status)};
    std::string error = "no address";
    for (const addrinfo *ai = found; ai; ai = ai->ai_next) {
        UniqueFd fd(::socket(ai->ai_family, ai->ai_socktype | SOCK_CLOEXEC | SOCK_NONBLOCK, ai->ai_protocol));
        if (!fd) {
            error = std::strerror(errno);
            continue;
        }
        if (::connect(fd.get(), ai->ai_addr, ai->ai_addrlen) != 0) {
            if (errno != EINPROGRESS) {
                error = std::strerror(errno);
                continue;
            }
            pollfd entry{fd.get(), POLLOUT, 0};
            int ready;
            do {
                ready = ::poll(&entry, 1, static_cast<int>(timeout.count()));
            } while (ready < 0 && errno == EINTR);
            int so_error = 0;
            socklen_t length = sizeof(so_error);
            ::getsockopt(fd.get(), SOL_SOCKET, SO_ERROR, &so_error, &length);
            if (ready <= 0 || so_error != 0) {
                error = ready == 0 ? "timed out" : std::strerror(so_error ? so_error : errno);
                continue;
            }
        }
        ::fcntl(fd.get(), F_SETFL, ::fcntl(fd.get(), F_GETFL) & ~O_NONBLOCK);
        set_nodelay(fd.get());
        ::freeaddrinfo(found);
        return fd;
    }
    ::freeaddrinfo(found);
    return Error{error};
}

// One proxied TCP connection: a ShapedLink each way, each on its own thread.
class ProxiedConnection {
public:
    ProxiedConnection(uint64_t id, UniqueFd client, UniqueFd server, const LinkOptions &options)
        : id_(id), client_(std::move(client)), server_(std::move(server)), up_(options.up),
          down_(options.down) {}
    ~ProxiedConnection() {
        stop();
        join();
    }
    ProxiedConnection(const ProxiedConnection &) = delete;
    ProxiedConnection &operator=(const ProxiedConnection &) = delete;

    void start() {
        enable_arrival_timestamps(client_.get());
        enable_arrival_timestamps(server_.get());
        opened_ = Clock::now();
        up_thread_ = std::thread([this] { carry(up_, client_.get(), server_.get(), up_end_); });
        down_thread_ = std::thread([this] { carry(down_, server_.get(), client_.get(), down_end_); });
    }

    bool finished() const { return finished_.load(std::memory_order_acquire); }

    // Ends the connection now: both links read end-of-file at once and finish.
    void stop() {
        std::lock_guard lock(mutex_);
        if (!client_) return;
        ::shutdown(client_.get(), SHUT_RDWR);
        ::shutdown(server_.get(), SHUT_RDWR);
    }

    void join() {
        if (up_thread_.joinable()) up_thread_.join();
        if (down_thread_.joinable()) down_thread_.join();
    }

private:
    void carry(ShapedLink &link, int from, int to, LinkEnd &end_slot) {
        const LinkEnd end = link.run(from, to);
        switch (end) {
        case LinkEnd::Eof:
            // A clean end travels as TCP carries it: a FIN after the last byte, and the other
            // direction goes on (a half-closed connection).
            ::shutdown(to, SHUT_WR);
            break;
        case LinkEnd::ReadError:
            // `from` is gone. Everything it sent has been delivered; now wake the opposite link
            // (it reads `to`) so it ends too, and let the close reset `to`.
            reset_.store(true);
            ::shutdown(to, SHUT_RD);
            break;
        case LinkEnd::WriteError:
            // `to` is gone; the opposite link learns it from its own read of `to`.
            reset_.store(true);
            break;
        }
        end_slot = end;
        if (running_.fetch_sub(1, std::memory_order_acq_rel) == 1) close();
    }

    // The last link out closes both sockets and says what went through.
    void close() {
        std::lock_guard lock(mutex_);
        if (reset_.load()) {
            reset_on_close(client_.get());
            reset_on_close(server_.get());
        }
        client_.reset();
        server_.reset();
        const double seconds = std::chrono::duration<double>(Clock::now() - opened_).count();
        SPLITVK_INFO("connection %llu: closed after %.3f s: %llu bytes up, %llu bytes down (up %s, down %s)",
                     static_cast<unsigned long long>(id_), seconds,
                     static_cast<unsigned long long>(up_.bytes_delivered()),
                     static_cast<unsigned long long>(down_.bytes_delivered()), to_string(up_end_),
                     to_string(down_end_));
        finished_.store(true, std::memory_order_release);
    }

    const uint64_t id_;
    std::mutex mutex_; // the sockets' lifetime: stop() against close()
    UniqueFd client_;
    UniqueFd server_;
    ShapedLink up_;
    ShapedLink down_;
    LinkEnd up_end_ = LinkEnd::Eof;
    LinkEnd down_end_ = LinkEnd::Eof;
    Clock::time_point opened_;
    std::atomic<int> running_{2};
    std::atomic<bool> reset_{false};
    std::atomic<bool> finished_{false};
    std::thread up_thread_;
    std::thread down_thread_;
};

} // namespace

int run_proxy(const LinkOptions &options) {
    // SIGINT and SIGTERM are blocked everywhere (the link threads inherit the mask) and let through
    // only inside the accept loop's ppoll(), so the flag is never missed between a test and a wait.
    struct sigaction action {};
    action.sa_handler = [](int) { g_stop = 1; };
    sigemptyset(&action.sa_mask);
    ::sigaction(SIGINT, &action, nullptr);
    ::sigaction(SIGTERM, &action, nullptr);
    std::signal(SIGPIPE, SIG_IGN);
    sigset_t stop_signals;
    sigset_t waiting_mask;
    sigemptyset(&stop_signals);
    sigaddset(&stop_signals, SIGINT);
    sigaddset(&stop_signals, SIGTERM);
    ::pthread_sigmask(SIG_BLOCK, &stop_signals, &waiting_mask);
    sigdelset(&waiting_mask, SIGINT);
    sigdelset(&waiting_mask, SIGTERM);

    auto acceptor = protocol::Acceptor::listen(options.listen_host, options.listen_port);
    if (!acceptor) {
        SPLITVK_ERROR("cannot listen on %s: %s",
                      format_address(options.listen_host, options.listen_port).c_str(),
                      acceptor.error().c_str());
        return 1;
    }
    const std::string target = format_address(options.connect_host, options.connect_port);
    const std::string profile = options.profile.empty() ? "" : " (" + options.profile + ")";
    SPLITVK_INFO("listening on %s, forwarding to %s%s: up %s, down %s", (*acceptor)->local_address().c_str(),
                 target.c_str(), profile.c_str(), describe(options.up).c_str(),
                 describe(options.down).c_str());

    std::vector<std::unique_ptr<ProxiedConnection>> connections;
    uint64_t next_id = 1;
    while (!g_stop) {
        pollfd entry{(*acceptor)->native_handle(), POLLIN, 0};
        const timespec reap_interval{1, 0};
        const int ready = ::ppoll(&entry, 1, &reap_interval, &waiting_mask);
        std::erase_if(connections, [](const auto &c) { return c->finished(); });
        if (ready <= 0) continue;

        auto accepted = (*acceptor)->accept(0ms);
        if (!accepted) {
            SPLITVK_ERROR("%s", accepted.error().c_str()); // out of descriptors, say: try again later
            continue;
        }
        if (!*accepted) continue;
        UniqueFd client = std::move(*accepted);
        const uint64_t id = next_id++;
        const std::string from = peer_address(client.get());
        auto server = connect_to(options.connect_host, options.connect_port, 5000ms);
        if (!server) {
            // The client sees a reset, as it would see a refused connection without the proxy.
            SPLITVK_WARN("connection %llu from %s: cannot connect to %s: %s",
                         static_cast<unsigned long long>(id), from.c_str(), target.c_str(),
                         server.error().c_str());
            reset_on_close(client.get());
            continue;
        }
        SPLITVK_INFO("connection %llu from %s: open to %s", static_cast<unsigned long long>(id), from.c_str(),
                     target.c_str());
        connections.push_back(
            std::make_unique<ProxiedConnection>(id, std::move(client), std::move(*server), options));
        connections.back()->start();
    }
    SPLITVK_INFO("stopping, %zu connection(s) open", connections.size());
    for (auto &c : connections)
        c->stop();
    connections.clear();
    return 0;
}

} // namespace splitvk::link
