// splitvk-link end to end: the real binary on loopback between this test's client and server
// sockets. Correctness (bytes, ends, resets) is asserted; the shaping is asserted in generous
// windows, because delay and rate are this tool's function; its own overhead is only printed.

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <iostream>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

std::string read_file(const std::string &path) {
    std::ifstream in(path);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

size_t occurrences(const std::string &text, const std::string &what) {
    size_t n = 0;
    for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1))
        ++n;
    return n;
}

// An owned socket.
class Socket {
public:
    Socket() = default;
    explicit Socket(int fd) : fd_(fd) {}
    ~Socket() { reset(); }
    Socket(Socket &&other) noexcept : fd_(std::exchange(other.fd_, -1)) {}
    Socket &operator=(Socket &&other) noexcept {
        reset();
        fd_ = std::exchange(other.fd_, -1);
        return *this;
    }
    int get() const { return fd_; }
    void reset() {
        if (fd_ >= 0) ::close(fd_);
        fd_ = -1;
    }

private:
    int fd_ = -1;
};

void set_nodelay(int fd) {
    const int one = 1;
    ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
}

// A listening socket on a free loopback port; accept() hands out blocking, TCP_NODELAY sockets.
class Server {
public:
    Server() : fd_(::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0)) {
        sockaddr_in addr{};
        addr.sin_family = AF_INET;
        addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        socklen_t length = sizeof(addr);
        if (::bind(fd_.get(), reinterpret_cast<sockaddr *>(&addr), sizeof(addr)) != 0 ||
            ::listen(fd_.get(), 16) != 0 ||
            ::getsockname(fd_.get(), reinterpret_cast<sockaddr *>(&addr), &length))
            return;
        port_ = ntohs(addr.sin_port);
    }
    uint16_t port() const { return port_; }
    Socket accept() const {
        Socket s(::accept4(fd_.get(), nullptr, nullptr, SOCK_CLOEXEC));
        set_nodelay(s.get());
        return s;
    }

private:
    Socket fd_;
    uint16_t port_ = 0;
};

Socket connect_loopback(uint16_t port) {
    Socket s(::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0));
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    addr.sin_port = htons(port);
    if (::connect(s.get(), reinterpret_cast<sockaddr *>(&addr), sizeof(addr)) != 0) return Socket();
    set_nodelay(s.get());
    return s;
}

bool send_all(int fd, const uint8_t *data, size_t size) {
    while (size > 0) {
        const ssize_t n = ::send(fd, data, size, MSG_NOSIGNAL);
        if (n <= 0) {
            if (n < 0 && errno == EINTR) continue;
            return false;
        }
        data += n;
        size -= static_cast<size_t>(n);
    }
    return true;
}

// Reads until EOF or an error; `error` gets errno of an error (0 at a clean EOF).
std::vector<uint8_t> receive_to_end(int fd, int *error = nullptr) {
    std::vector<uint8_t> data;
    std::vector<uint8_t> buffer(256 << 10);
    for (;;) {
        const ssize_t n = ::recv(fd, buffer.data(), buffer.size(), 0);
        if (n > 0) {
            data.insert(data.end(), buffer.begin(), buffer.begin() + n);
            continue;
        }
        if (n < 0 && errno == EINTR) continue;
        if (error) *error = n < 0 ? errno : 0;
        return data;
    }
}

// Reads until EOF, counting: the sink of a throughput measurement must cost next to nothing.
size_t count_to_end(int fd) {
    std::vector<uint8_t> buffer(256 << 10);
    size_t total = 0;
    for (;;) {
        const ssize_t n = ::recv(fd, buffer.data(), buffer.size(), 0);
        if (n > 0)
            total += static_cast<size_t>(n);
        else if (n == 0 || errno != EINTR)
            return total;
    }
}

bool receive_exactly(int fd, uint8_t *data, size_t size) {
    while (size > 0) {
        const ssize_t n = ::recv(fd, data, size, 0);
        if (n <= 0) {
            if (n < 0 && errno == EINTR) continue;
            return false;
        }
        data += n;
        size -= static_cast<size_t>(n);
    }
    return true;
}

std::vector<uint8_t> random_bytes(size_t size, uint64_t seed) {
    std::mt19937_64 generator(seed);
    std::vector<uint8_t> bytes(size);
    for (size_t i = 0; i < size; i += 8) {
        const uint64_t word = generator();
        std::memcpy(bytes.data() + i, &word, std::min<size_t>(8, size - i));
    }
    return bytes;
}

// splitvk-link itself, between a free port of its choosing and `target_port`.
class Link {
public:
    Link(uint16_t target_port, std::vector<std::string> shaping) {
        char dir[] = "/tmp/splitvk-link-test-XXXXXX";
        dir_ = ::mkdtemp(dir);
        log_ = dir_ + "/link.log";
        std::vector<std::string> args = {SPLITVK_LINK_BINARY, "--listen", "127.0.0.1:0", "--connect",
                                         "127.0.0.1:" + std::to_string(target_port)};
        args.insert(args.end(), shaping.begin(), shaping.end());
        pid_ = ::fork();
        if (pid_ == 0) {
            std::FILE *f = std::freopen(log_.c_str(), "w", stderr);
            (void)f;
            std::vector<char *> argv;
            for (auto &a : args)
                argv.push_back(a.data());
            argv.push_back(nullptr);
            ::execv(argv[0], argv.data());
            ::_exit(127);
        }
        const auto deadline = Clock::now() + 10s;
        while (Clock::now() < deadline && port_ == 0) {
            const std::string l = log();
            const size_t at = l.find("listening on 127.0.0.1:");
            if (at != std::string::npos) port_ = static_cast<uint16_t>(std::atoi(l.c_str() + at + 23));
            std::this_thread::sleep_for(5ms);
        }
    }
    ~Link() {
        stop();
        std::remove(log_.c_str());
        ::rmdir(dir_.c_str());
    }
    int stop() {
        int status = -1;
        if (pid_ > 0) {
            ::kill(pid_, SIGTERM);
            ::waitpid(pid_, &status, 0);
            pid_ = -1;
        }
        return status;
    }
    uint16_t port() const { return port_; }
    std::string log() const { return read_file(log_); }
    bool wait_for_log(const std::string &text, size_t count = 1,
                      std::chrono::milliseconds timeout = 10s) const {
        const auto deadline = Clock::now() + timeout;
        while (Clock::now() < deadline) {
            if (occurrences(log(), text) >= count) return true;
            std::this_thread::sleep_for(10ms);
        }
        return false;
    }

private:
    pid_t pid_ = -1;
    uint16_t port_ = 0;
    std::string dir_;
    std::string log_;
};

// Echoes everything back until EOF, then closes. One connection per thread.
class EchoServer {
public:
    EchoServer() {
        thread_ = std::thread([this] {
            for (;;) {
                Socket s = server_.accept();
                if (s.get() < 0 || stopping_) return;
                connections_.emplace_back([s = std::move(s)] {
                    std::vector<uint8_t> buffer(64 << 10);
                    for (;;) {
                        const ssize_t n = ::recv(s.get(), buffer.data(), buffer.size(), 0);
                        if (n <= 0 || !send_all(s.get(), buffer.data(), static_cast<size_t>(n))) return;
                    }
                });
            }
        });
    }
    ~EchoServer() {
        stopping_ = true;
        connect_loopback(server_.port()); // wakes the accept
        thread_.join();
        for (auto &t : connections_)
            t.join();
    }
    uint16_t port() const { return server_.port(); }

private:
    Server server_;
    std::atomic<bool> stopping_{false};
    std::thread thread_;
    std::vector<std::thread> connections_;
};

// Median round trip of `count` one-byte pings on `fd`, in milliseconds.
double median_rtt_ms(int fd, int count) {
    std::vector<double> rtts;
    for (int i = 0; i < count; ++i) {
        uint8_t byte = static_cast<uint8_t>(i);
        const auto start = Clock::now();
        if (!send_all(fd, &byte, 1) || !receive_exactly(fd, &byte, 1)) return -1;
        rtts.push_back(std::chrono::duration<double, std::milli>(Clock::now() - start).count());
    }
    std::sort(rtts.begin(), rtts.end());
    return rtts[rtts.size() / 2];
}

// Seconds to move `size` bytes from a client on `port` to a server that counts them and answers one
// byte at EOF: first byte sent to that answer (the answer adds one one-way delay).
double transfer_seconds(const Server &server, uint16_t port, size_t size, size_t *received) {
    const std::vector<uint8_t> payload(size, 0x5a);
    std::thread sink([&] {
        Socket s = server.accept();
        *received = count_to_end(s.get());
        const uint8_t done = 1;
        send_all(s.get(), &done, 1);
    });
    Socket client = connect_loopback(port);
    const auto start = Clock::now();
    send_all(client.get(), payload.data(), payload.size());
    ::shutdown(client.get(), SHUT_WR);
    uint8_t done = 0;
    receive_exactly(client.get(), &done, 1);
    const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
    sink.join();
    return seconds;
}

// Several connections at once, each carrying a different random payload both ways at the same
// time; each side half-closes when it has sent everything and reads to the end. A connection
// starts with its index (8 bytes), so the server side knows which payload to send back whatever
// order the connections are accepted in. Returns what each side received, by index.
struct Exchange {
    std::vector<std::vector<uint8_t>> server_got, client_got;
};

Exchange exchange(const Server &server, uint16_t port, size_t size, int connections) {
    const auto up = [&](size_t c) { return random_bytes(size, 2 * c + 1); };
    const auto down = [&](size_t c) { return random_bytes(size, 2 * c + 2); };
    const size_t n = static_cast<size_t>(connections);
    Exchange result{std::vector<std::vector<uint8_t>>(n), std::vector<std::vector<uint8_t>>(n)};

    std::thread server_side([&] {
        std::vector<std::thread> handlers;
        for (size_t i = 0; i < n; ++i) {
            handlers.emplace_back([&, s = server.accept()] {
                uint64_t index = 0;
                if (!receive_exactly(s.get(), reinterpret_cast<uint8_t *>(&index), sizeof(index)) ||
                    index >= n)
                    return;
                std::thread writer([&] {
                    const auto payload = down(index);
                    send_all(s.get(), payload.data(), payload.size());
                    ::shutdown(s.get(), SHUT_WR);
                });
                result.server_got[index] = receive_to_end(s.get());
                writer.join();
            });
        }
        for (auto &h : handlers)
            h.join();
    });
    std::vector<std::thread> clients;
    for (size_t c = 0; c < n; ++c) {
        clients.emplace_back([&, c] {
            Socket s = connect_loopback(port);
            std::thread writer([&] {
                const uint64_t index = c;
                const auto payload = up(c);
                send_all(s.get(), reinterpret_cast<const uint8_t *>(&index), sizeof(index));
                send_all(s.get(), payload.data(), payload.size());
                ::shutdown(s.get(), SHUT_WR);
            });
            result.client_got[c] = receive_to_end(s.get());
            writer.join();
        });
    }
    for (auto &c : clients)
        c.join();
    server_side.join();
    for (size_t c = 0; c < n; ++c) {
        EXPECT_TRUE(result.server_got[c] == up(c)) << "connection " << c << ": the server got "
                                                   << result.server_got[c].size() << " bytes of " << size;
        EXPECT_TRUE(result.client_got[c] == down(c)) << "connection " << c << ": the client got "
                                                     << result.client_got[c].size() << " bytes of " << size;
    }
    return result;
}

void expect_bytes_unchanged(const std::vector<std::string> &shaping) {
    constexpr size_t kSize = 4 << 20;
    constexpr int kConnections = 3;
    Server server;
    Link link(server.port(), shaping);
    ASSERT_NE(link.port(), 0) << link.log();
    exchange(server, link.port(), kSize, kConnections);
    // One line per connection at close, with what went through each way.
    EXPECT_TRUE(link.wait_for_log("closed after", kConnections)) << link.log();
    const std::string both_ways = std::to_string(kSize + 8) + " bytes up, " + std::to_string(kSize) +
                                  " bytes down (up closed, down closed)";
    EXPECT_EQ(occurrences(link.log(), both_ways), static_cast<size_t>(kConnections)) << link.log();
    EXPECT_EQ(occurrences(link.log(), ": open to 127.0.0.1:"), static_cast<size_t>(kConnections));
}

} // namespace

TEST(SplitvkLink, BytesCrossUnchangedBothWaysAtOnceOnSeveralConnections) {
    expect_bytes_unchanged({"--profile", "wifi6"});
}

TEST(SplitvkLink, BytesCrossUnchangedWithoutShaping) {
    expect_bytes_unchanged({"--profile", "none"});
}

TEST(SplitvkLink, BytesCrossUnchangedOnAnAsymmetricLink) {
    expect_bytes_unchanged(
        {"--up-rate", "300M", "--down-rate", "1G", "--up-delay", "3ms", "--down-delay", "0"});
}

// The shaping is the tool's function, so it is asserted, in windows wide enough for a loaded
// 2-core VM: the lower bounds are the model's, the upper ones only catch gross failures.
TEST(SplitvkLink, OneBytePingPongTakesTwiceTheDelay) {
    EchoServer echo;
    Link link(echo.port(), {"--rate", "100M", "--delay", "5ms"});
    ASSERT_NE(link.port(), 0) << link.log();
    Socket s = connect_loopback(link.port());
    const double rtt = median_rtt_ms(s.get(), 20);
    std::cout << "ping-pong through 100 Mbit/s + 5 ms each way: median RTT " << rtt
              << " ms (model: 10.0002 ms)\n";
    RecordProperty("rtt_ms", std::to_string(rtt));
    EXPECT_GE(rtt, 9.5);
    EXPECT_LE(rtt, 20.0);
}

TEST(SplitvkLink, EachDirectionHasItsOwnDelay) {
    EchoServer echo;
    Link link(echo.port(), {"--rate", "1G", "--up-delay", "1ms", "--down-delay", "7ms"});
    ASSERT_NE(link.port(), 0) << link.log();
    Socket s = connect_loopback(link.port());
    const double rtt = median_rtt_ms(s.get(), 20);
    std::cout << "ping-pong through 1 ms up, 7 ms down: median RTT " << rtt << " ms (model: 8 ms)\n";
    EXPECT_GE(rtt, 7.6);
    EXPECT_LE(rtt, 16.0);
}

TEST(SplitvkLink, TransferIsCappedAtTheRate) {
    constexpr size_t kSize = 10'000'000;
    Server server;
    Link link(server.port(), {"--rate", "100M", "--delay", "5ms"});
    ASSERT_NE(link.port(), 0) << link.log();
    size_t received = 0;
    const double seconds = transfer_seconds(server, link.port(), kSize, &received);
    std::cout << "10 MB through 100 Mbit/s + 5 ms: " << seconds << " s, "
              << static_cast<double>(kSize) * 8 / seconds / 1e6 << " Mbit/s (model: 0.81 s)\n";
    RecordProperty("seconds", std::to_string(seconds));
    EXPECT_EQ(received, kSize);
    EXPECT_GE(seconds, 0.8);
    EXPECT_LE(seconds, 4.0);
}

// What the proxy costs when it shapes nothing, against the same sockets connected directly.
// Printed, never asserted: it is a property of the machine as much as of the tool.
TEST(SplitvkLink, OverheadWithoutShapingIsPrinted) {
    constexpr int kPings = 400;
    constexpr size_t kBulk = 64 << 20;
    EchoServer echo;
    Link rtt_link(echo.port(), {"--profile", "none"});
    ASSERT_NE(rtt_link.port(), 0) << rtt_link.log();
    Server server;
    Link bulk_link(server.port(), {"--profile", "none"});
    ASSERT_NE(bulk_link.port(), 0) << bulk_link.log();

    // Alternating, best of three, so that a burst of other work on the machine hits both sides.
    double rtt_direct = 1e9, rtt_proxied = 1e9, seconds_direct = 1e9, seconds_proxied = 1e9;
    for (int round = 0; round < 3; ++round) {
        Socket direct = connect_loopback(echo.port());
        Socket proxied = connect_loopback(rtt_link.port());
        rtt_direct = std::min(rtt_direct, median_rtt_ms(direct.get(), kPings));
        rtt_proxied = std::min(rtt_proxied, median_rtt_ms(proxied.get(), kPings));
        size_t received = 0;
        seconds_direct = std::min(seconds_direct, transfer_seconds(server, server.port(), kBulk, &received));
        EXPECT_EQ(received, kBulk);
        seconds_proxied =
            std::min(seconds_proxied, transfer_seconds(server, bulk_link.port(), kBulk, &received));
        EXPECT_EQ(received, kBulk);
    }
    const double gbit_direct = static_cast<double>(kBulk) * 8 / seconds_direct / 1e9;
    const double gbit_proxied = static_cast<double>(kBulk) * 8 / seconds_proxied / 1e9;
    char line[256];
    std::snprintf(line, sizeof(line),
                  "splitvk-link --profile none: RTT %.1f us direct, %.1f us proxied (+%.1f us); "
                  "throughput %.2f Gbit/s direct, %.2f Gbit/s proxied (%.2fx)\n",
                  rtt_direct * 1e3, rtt_proxied * 1e3, (rtt_proxied - rtt_direct) * 1e3, gbit_direct,
                  gbit_proxied, gbit_proxied / gbit_direct);
    std::cout << line;
    RecordProperty("rtt_direct_us", std::to_string(rtt_direct * 1e3));
    RecordProperty("rtt_proxied_us", std::to_string(rtt_proxied * 1e3));
    RecordProperty("gbit_direct", std::to_string(gbit_direct));
    RecordProperty("gbit_proxied", std::to_string(gbit_proxied));
}

// A client that resets: what it sent before still arrives, then the server's side ends too.
TEST(SplitvkLink, ResetArrivesAfterTheQueuedData) {
    constexpr size_t kSize = 20'000;
    Server server;
    Link link(server.port(), {"--rate", "100M", "--delay", "200ms"});
    ASSERT_NE(link.port(), 0) << link.log();
    Socket client = connect_loopback(link.port());
    Socket accepted = server.accept();
    const auto payload = random_bytes(kSize, 7);
    const auto start = Clock::now();
    ASSERT_TRUE(send_all(client.get(), payload.data(), payload.size()));
    std::this_thread::sleep_for(50ms); // the link has read it all: it is on its way
    const linger abort{1, 0};
    ::setsockopt(client.get(), SOL_SOCKET, SO_LINGER, &abort, sizeof(abort));
    client.reset();
    int error = -1;
    const auto got = receive_to_end(accepted.get(), &error);
    const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
    EXPECT_TRUE(got == payload) << got.size() << " bytes of " << kSize;
    EXPECT_TRUE(error == 0 || error == ECONNRESET) << std::strerror(error);
    EXPECT_GE(seconds, 0.19);
    EXPECT_LE(seconds, 3.0);
    EXPECT_TRUE(link.wait_for_log("(up reset, down closed)")) << link.log();
}

// The server end closes: the client reads everything the server sent, then EOF, and the
// other direction stays open until the client closes too (a half-closed connection).
TEST(SplitvkLink, HalfCloseTravelsAfterTheData) {
    Server server;
    Link link(server.port(), {"--profile", "wifi5"});
    ASSERT_NE(link.port(), 0) << link.log();
    Socket client = connect_loopback(link.port());
    Socket accepted = server.accept();
    const auto down = random_bytes(100'000, 3);
    ASSERT_TRUE(send_all(accepted.get(), down.data(), down.size()));
    ::shutdown(accepted.get(), SHUT_WR);
    EXPECT_TRUE(receive_to_end(client.get()) == down);
    const auto up = random_bytes(1000, 4);
    ASSERT_TRUE(send_all(client.get(), up.data(), up.size()));
    ::shutdown(client.get(), SHUT_WR);
    EXPECT_TRUE(receive_to_end(accepted.get()) == up);
    EXPECT_TRUE(link.wait_for_log("1000 bytes up, 100000 bytes down (up closed, down closed)")) << link.log();
}

TEST(SplitvkLink, UnreachableServerResetsTheClientAndTheLinkStaysUp) {
    uint16_t dead_port = 0;
    {
        Server gone; // a port nobody listens on once this closes
        dead_port = gone.port();
    }
    Link link(dead_port, {"--profile", "gige"});
    ASSERT_NE(link.port(), 0) << link.log();
    for (int attempt = 0; attempt < 2; ++attempt) {
        Socket client = connect_loopback(link.port());
        ASSERT_GE(client.get(), 0);
        int error = -1;
        EXPECT_TRUE(receive_to_end(client.get(), &error).empty());
        EXPECT_EQ(error, ECONNRESET) << std::strerror(error);
    }
    EXPECT_EQ(occurrences(link.log(), "cannot connect to 127.0.0.1:" + std::to_string(dead_port)), 2u)
        << link.log();
}

TEST(SplitvkLink, BadFlagIsOneLineAndExitStatusTwo) {
    char dir[] = "/tmp/splitvk-link-test-XXXXXX";
    const std::string log = std::string(::mkdtemp(dir)) + "/err";
    const std::string command =
        std::string(SPLITVK_LINK_BINARY) + " --listen 127.0.0.1:0 --connect 127.0.0.1:1 --rate fast 2>" + log;
    const int status = std::system(command.c_str());
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 2) << status;
    EXPECT_EQ(read_file(log),
              "[splitvk-link] error: --rate 'fast' is invalid: expected bits per second such as "
              "400M, 1.5G or 100k\n");
    std::remove(log.c_str());
    ::rmdir(dir);
}

TEST(SplitvkLink, StopsCleanlyOnSigterm) {
    Server server;
    Link link(server.port(), {"--profile", "wifi5"});
    ASSERT_NE(link.port(), 0) << link.log();
    Socket client = connect_loopback(link.port());
    Socket accepted = server.accept();
    ASSERT_TRUE(link.wait_for_log(": open to "));
    const int status = link.stop();
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << status;
    EXPECT_EQ(occurrences(link.log(), "stopping, 1 connection(s) open"), 1u) << link.log();
    EXPECT_EQ(occurrences(link.log(), "connection 1: closed after"), 1u) << link.log();
    int error = -1;
    receive_to_end(accepted.get(), &error); // the server side ends with the proxy
}
