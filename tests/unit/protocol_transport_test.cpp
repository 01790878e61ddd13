// The TCP transport over real loopback sockets (127.0.0.1 and ::1 only).

#include "transport.h"

#include <atomic>
#include <condition_variable>
#include <cstring>
#include <future>
#include <mutex>
#include <random>
#include <thread>

#include <arpa/inet.h>
#include <fcntl.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

namespace splitvk::protocol {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

constexpr auto kPatience = 5s; // only ever spent when a test fails

std::vector<uint8_t> bytes_of(std::string_view text) {
    return std::vector<uint8_t>(text.begin(), text.end());
}

struct Pair {
    std::unique_ptr<Acceptor> acceptor;
    std::unique_ptr<Connection> client;
    std::unique_ptr<Connection> server;
};

Pair make_pair(ConnectionOptions client_options = {}, ConnectionOptions server_options = {},
               const std::string &host = "127.0.0.1") {
    Pair pair;
    auto acceptor = Acceptor::listen(host, 0);
    EXPECT_TRUE(acceptor.ok()) << acceptor.error();
    if (!acceptor) return pair;
    pair.acceptor = std::move(acceptor).value();
    client_options.name = "client";
    auto client = Connection::connect(host, pair.acceptor->port(), 2s, std::move(client_options));
    EXPECT_TRUE(client.ok()) << client.error();
    if (!client) return pair;
    pair.client = std::move(client).value();
    auto fd = pair.acceptor->accept(2s);
    EXPECT_TRUE(fd.ok() && *fd) << fd.error();
    if (!fd || !*fd) return pair;
    server_options.name = "server";
    auto server = Connection::adopt(std::move(fd).value(), std::move(server_options));
    EXPECT_TRUE(server.ok()) << server.error();
    if (server) pair.server = std::move(server).value();
    return pair;
}

// Collects on_closed calls.
struct CloseWatch {
    std::mutex mutex;
    std::condition_variable cv;
    std::vector<std::string> reasons;

    Connection::ClosedHandler handler() {
        return [this](const std::string &reason) {
            std::lock_guard lock(mutex);
            reasons.push_back(reason);
            cv.notify_all();
        };
    }
    bool wait(std::chrono::milliseconds timeout = kPatience) {
        std::unique_lock lock(mutex);
        return cv.wait_for(lock, timeout, [&] { return !reasons.empty(); });
    }
    size_t count() {
        std::lock_guard lock(mutex);
        return reasons.size();
    }
    std::string first() {
        std::lock_guard lock(mutex);
        return reasons.empty() ? std::string() : reasons.front();
    }
};

std::vector<uint8_t> numbered_payload(uint32_t i) {
    WireWriter w;
    w.u32(i);
    w.bytes(std::vector<uint8_t>(i % 97, static_cast<uint8_t>(i)));
    return w.take();
}

TEST(ProtocolTransport, HandshakeThenThousandMessagesEachWayInOrder) {
    CloseWatch client_closed, server_closed;
    Pair pair = make_pair();
    ASSERT_TRUE(pair.client && pair.server);
    pair.client->start(client_closed.handler());
    pair.server->start(server_closed.handler());
    EXPECT_EQ(pair.client->peer_address(), "127.0.0.1:" + std::to_string(pair.acceptor->port()));
    EXPECT_EQ(pair.server->local_address(), pair.client->peer_address());

    Hello hello;
    hello.client_name = "test";
    hello.token = bytes_of("tok");
    auto welcome_future =
        std::async(std::launch::async, [&] { return client_handshake(*pair.client, hello, 5s); });
    ServerHandshakeConfig config;
    config.token = bytes_of("tok");
    config.session_id = 42;
    auto accepted = server_handshake(*pair.server, config, 5s);
    ASSERT_TRUE(accepted.ok()) << accepted.error();
    EXPECT_EQ(accepted->hello.client_name, "test");
    auto welcome = welcome_future.get();
    ASSERT_TRUE(welcome.ok()) << welcome.error();
    EXPECT_EQ(welcome->session_id, 42u);

    constexpr uint32_t kCount = 1000;
    auto sender = std::async(std::launch::async, [&] {
        for (uint32_t i = 0; i < kCount; ++i)
            EXPECT_EQ(pair.client->send(uint16_t(0x0100 + i % 16), numbered_payload(i)), SendResult::Queued);
    });
    for (uint32_t i = 0; i < kCount; ++i) {
        auto message = pair.server->receive(kPatience);
        ASSERT_TRUE(message) << "message " << i << ": " << pair.server->close_reason();
        EXPECT_EQ(message->sequence, i + 2); // Hello was 1
        EXPECT_EQ(message->type, 0x0100 + i % 16);
        EXPECT_EQ(message->payload, numbered_payload(i));
        EXPECT_EQ(pair.server->send(to_wire(MessageType::Pong), message->payload), SendResult::Queued);
    }
    sender.get();
    for (uint32_t i = 0; i < kCount; ++i) {
        auto message = pair.client->receive(kPatience);
        ASSERT_TRUE(message) << "reply " << i;
        EXPECT_EQ(message->sequence, i + 2); // Welcome was 1
        EXPECT_EQ(message->type, to_wire(MessageType::Pong));
        EXPECT_EQ(message->payload, numbered_payload(i));
    }
    EXPECT_FALSE(pair.client->try_receive());
    EXPECT_TRUE(pair.client->flush(kPatience));
    const auto stats = pair.client->stats();
    EXPECT_EQ(stats.messages_sent, kCount + 1);
    EXPECT_EQ(stats.messages_received, kCount + 1);
    EXPECT_EQ(stats.send_queue_bytes, 0u);
    EXPECT_EQ(client_closed.count(), 0u);
    EXPECT_EQ(server_closed.count(), 0u);
}

void shrink_socket_buffers(const Connection &client, const Connection &server) {
    const int size = 64 * 1024;
    EXPECT_EQ(::setsockopt(client.native_handle(), SOL_SOCKET, SO_SNDBUF, &size, sizeof(size)), 0);
    EXPECT_EQ(::setsockopt(server.native_handle(), SOL_SOCKET, SO_RCVBUF, &size, sizeof(size)), 0);
}

bool has_option(int fd, int level, int name) {
    int value = 0;
    socklen_t length = sizeof(value);
    return ::getsockopt(fd, level, name, &value, &length) == 0 && value != 0;
}

TEST(ProtocolTransport, SocketsAreNoDelayAndCloseOnExec) {
    Pair pair = make_pair();
    ASSERT_TRUE(pair.client && pair.server);
    for (const Connection *connection : {pair.client.get(), pair.server.get()}) {
        const int fd = connection->native_handle();
        ASSERT_GE(fd, 0);
        EXPECT_TRUE(has_option(fd, IPPROTO_TCP, TCP_NODELAY));
        EXPECT_TRUE(::fcntl(fd, F_GETFD) & FD_CLOEXEC);
    }
    EXPECT_TRUE(::fcntl(pair.acceptor->native_handle(), F_GETFD) & FD_CLOEXEC);
    // A raw accepted fd comes with TCP_NODELAY already.
    auto raw = Connection::connect("127.0.0.1", pair.acceptor->port(), 2s);
    ASSERT_TRUE(raw.ok());
    auto fd = pair.acceptor->accept(2s);
    ASSERT_TRUE(fd.ok() && *fd);
    EXPECT_TRUE(has_option(fd->get(), IPPROTO_TCP, TCP_NODELAY));
    EXPECT_TRUE(::fcntl(fd->get(), F_GETFD) & FD_CLOEXEC);
}

TEST(ProtocolTransport, LargeMessagesCompressedWhenItPays) {
    CloseWatch closed;
    Pair pair = make_pair();
    ASSERT_TRUE(pair.client && pair.server);
    pair.client->start(closed.handler());
    pair.server->start(closed.handler());

    std::vector<uint8_t> big(24u << 20);
    for (size_t i = 0; i < big.size(); ++i)
        big[i] = static_cast<uint8_t>((i / 4096) ^ (i % 251 == 0 ? 0xFF : 0));
    std::vector<uint8_t> noise(1u << 20);
    std::mt19937 engine(7);
    for (auto &b : noise)
        b = static_cast<uint8_t>(engine());

    ASSERT_EQ(pair.client->send(MessageType::MemoryData, big), SendResult::Queued);
    ASSERT_EQ(pair.client->send(MessageType::MemoryData, noise), SendResult::Queued);
    auto first = pair.server->receive(kPatience);
    ASSERT_TRUE(first) << pair.server->close_reason();
    EXPECT_TRUE(first->was_compressed);
    EXPECT_LT(first->wire_payload_bytes, big.size() / 8);
    EXPECT_EQ(first->payload, big);
    auto second = pair.server->receive(kPatience);
    ASSERT_TRUE(second);
    EXPECT_FALSE(second->was_compressed);
    EXPECT_EQ(second->wire_payload_bytes, noise.size());
    EXPECT_EQ(second->payload, noise);
    const auto stats = pair.client->stats();
    EXPECT_EQ(stats.compressed_messages_sent, 1u);
    EXPECT_EQ(stats.payload_bytes_sent, big.size() + noise.size());

    // Compression can be switched off after the handshake (a peer without kZstdPayloads).
    pair.client->set_compression(CompressionPolicy{.enabled = false});
    ASSERT_EQ(pair.client->send(MessageType::MemoryData, std::span(big).first(1 << 20)), SendResult::Queued);
    auto third = pair.server->receive(kPatience);
    ASSERT_TRUE(third);
    EXPECT_FALSE(third->was_compressed);
    EXPECT_EQ(closed.count(), 0u);
}

// A resync's snapshot: many messages, large and small, compressible and not, compressed on several
// threads at once. They must arrive exactly as sent and in order, with the sequence unbroken.
TEST(ProtocolTransport, SendAllKeepsOrderWhileCompressingInParallel) {
    CloseWatch closed;
    Pair pair = make_pair();
    ASSERT_TRUE(pair.client && pair.server);
    pair.client->start(closed.handler());
    pair.server->start(closed.handler());

    std::mt19937 engine(11);
    std::vector<OutboundMessage> batch;
    std::vector<std::vector<uint8_t>> expected;
    for (uint32_t i = 0; i < 64; ++i) {
        std::vector<uint8_t> payload = numbered_payload(i);
        if (i % 3 == 0) payload.resize(payload.size() + (256u << 10) * (1 + i % 5), static_cast<uint8_t>(i));
        if (i % 7 == 0)
            for (size_t k = 0; k < (64u << 10); ++k)
                payload.push_back(static_cast<uint8_t>(engine()));
        expected.push_back(payload);
        batch.push_back({i % 2 ? MessageType::MemoryData : MessageType::Commands, std::move(payload)});
    }
    ASSERT_EQ(pair.client->send(MessageType::Commands, numbered_payload(1000)), SendResult::Queued);
    ASSERT_EQ(pair.client->send_all(std::move(batch), kPatience, 4), SendResult::Queued);
    ASSERT_EQ(pair.client->send(MessageType::Commands, numbered_payload(1001)), SendResult::Queued);

    auto first = pair.server->receive(kPatience);
    ASSERT_TRUE(first) << pair.server->close_reason();
    EXPECT_EQ(first->payload, numbered_payload(1000));
    size_t compressed = 0;
    for (uint32_t i = 0; i < expected.size(); ++i) {
        auto message = pair.server->receive(kPatience);
        ASSERT_TRUE(message) << "message " << i << ": " << pair.server->close_reason();
        EXPECT_EQ(message->type, to_wire(i % 2 ? MessageType::MemoryData : MessageType::Commands));
        EXPECT_EQ(message->sequence, first->sequence + 1 + i);
        ASSERT_EQ(message->payload, expected[i]) << "message " << i;
        compressed += message->was_compressed ? 1 : 0;
    }
    EXPECT_GT(compressed, 0u) << "the large runs compress";
    auto last = pair.server->receive(kPatience);
    ASSERT_TRUE(last);
    EXPECT_EQ(last->payload, numbered_payload(1001));
    EXPECT_EQ(closed.count(), 0u);
}

// A batch stops at the first message the link will not take; it never queues past a hole.
TEST(ProtocolTransport, SendAllStopsAtTheFirstRefusal) {
    Pair pair = make_pair();
    ASSERT_TRUE(pair.client && pair.server);
    std::vector<OutboundMessage> batch;
    batch.push_back({MessageType::Commands, numbered_payload(1)});
    pair.client->close();
    EXPECT_EQ(pair.client->send_all(std::move(batch)), SendResult::Closed);

    ConnectionOptions options;
    options.max_payload = 1000;
    Pair second = make_pair(options);
    ASSERT_TRUE(second.client && second.server);
    std::vector<OutboundMessage> oversized;
    oversized.push_back({MessageType::Commands, numbered_payload(2)});
    oversized.push_back({MessageType::Commands, std::vector<uint8_t>(1001)});
    EXPECT_EQ(second.client->send_all(std::move(oversized)), SendResult::TooLarge);
    EXPECT_EQ(second.client->stats().messages_sent, 0u) << "an oversized message refuses the whole batch";
}

TEST(ProtocolTransport, PeerCloseReportedOnce) {
    CloseWatch client_closed, server_closed;
    Pair pair = make_pair();
    ASSERT_TRUE(pair.client && pair.server);
    pair.client->start(client_closed.handler());
    pair.server->start(server_closed.handler());

    ASSERT_EQ(pair.server->send(MessageType::Goodbye, encode_goodbye({"bye"})), SendResult::Queued);
    ASSERT_TRUE(pair.server->flush(kPatience));
    pair.server->close("test over");
    pair.server->close("again"); // idempotent
    EXPECT_EQ(pair.server->close_reason(), "test over");
    EXPECT_EQ(server_closed.count(), 0u); // this side asked for it: no callback

    ASSERT_TRUE(client_closed.wait());
    EXPECT_EQ(client_closed.first(), "peer closed the connection");
    EXPECT_FALSE(pair.client->is_open());
    EXPECT_EQ(pair.client->close_reason(), "peer closed the connection");
    EXPECT_TRUE(pair.client->closed_by_peer());
    EXPECT_FALSE(pair.server->closed_by_peer()) << "this side's own close";
    // What arrived before the EOF is still there.
    auto goodbye = pair.client->try_receive();
    ASSERT_TRUE(goodbye);
    EXPECT_EQ(goodbye->type, to_wire(MessageType::Goodbye));
    EXPECT_EQ(pair.client->send(MessageType::Ping, {}), SendResult::Closed);
    EXPECT_FALSE(pair.client->receive(1s)); // closed and empty: returns at once
    pair.client->close();
    pair.client.reset();
    EXPECT_EQ(client_closed.count(), 1u);
}

TEST(ProtocolTransport, PeerResetReportedOnce) {
    // The server side aborts with a RST (SO_LINGER 0, then close).
    auto listener = Acceptor::listen("127.0.0.1", 0);
    ASSERT_TRUE(listener.ok());
    CloseWatch reset_watch;
    auto raw_client = Connection::connect("127.0.0.1", (*listener)->port(), 2s);
    ASSERT_TRUE(raw_client.ok());
    auto fd = (*listener)->accept(2s);
    ASSERT_TRUE(fd.ok() && *fd);
    (*raw_client)->start(reset_watch.handler());
    linger abort_now{1, 0};
    ASSERT_EQ(::setsockopt(fd->get(), SOL_SOCKET, SO_LINGER, &abort_now, sizeof(abort_now)), 0);
    fd->reset();
    ASSERT_TRUE(reset_watch.wait());
    EXPECT_EQ(reset_watch.first(), "connection reset by peer");
    EXPECT_TRUE((*raw_client)->closed_by_peer()) << "a reset between messages is the peer's end";
    (*raw_client)->close();
    EXPECT_EQ(reset_watch.count(), 1u);
}

// A peer that closes while this side is still sending to it, with what it was sent unread (the
// layer closing while the agent sends the tiles of its last frames): its kernel answers with a
// reset, and the send or the read that meets it fails. That is the peer's end, not an error.
TEST(ProtocolTransport, PeerClosingWhileThisSideSendsIsThePeersEnd) {
    auto acceptor = Acceptor::listen("127.0.0.1", 0);
    ASSERT_TRUE(acceptor.ok());
    UniqueFd raw(::socket(AF_INET, SOCK_STREAM, 0));
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    address.sin_port = htons((*acceptor)->port());
    ASSERT_EQ(::connect(raw.get(), reinterpret_cast<sockaddr *>(&address), sizeof(address)), 0);
    auto fd = (*acceptor)->accept(2s);
    ASSERT_TRUE(fd.ok() && *fd);
    CloseWatch closed;
    ConnectionOptions options;
    options.compression.enabled = false;
    auto server = Connection::adopt(std::move(fd).value(), options);
    ASSERT_TRUE(server.ok());
    (*server)->start(closed.handler());
    const std::vector<uint8_t> payload(256 * 1024, 0x5a);
    for (int i = 0; i < 16; ++i)
        ASSERT_EQ((*server)->send(MessageType::Tiles, payload, 5000ms), SendResult::Queued);
    char some[4096];
    ASSERT_GT(::recv(raw.get(), some, sizeof(some), 0), 0);
    raw.reset(); // with most of it unread
    SendResult result = SendResult::Queued;
    for (int i = 0; i < 1000 && result == SendResult::Queued; ++i) {
        result = (*server)->send(MessageType::Tiles, payload, 1000ms);
        if (result == SendResult::QueueFull) result = SendResult::Queued;
    }
    EXPECT_EQ(result, SendResult::Closed);
    ASSERT_TRUE(closed.wait());
    // Whichever the kernel reports first: the EOF to the read, or the reset to a read or a write.
    EXPECT_TRUE(closed.first() == "peer closed the connection" ||
                closed.first().rfind("connection reset by peer", 0) == 0)
        << closed.first();
    EXPECT_TRUE((*server)->closed_by_peer()) << (*server)->close_reason();
    (*server)->close();
}

TEST(ProtocolTransport, LocalCloseFromAnyThreadIsIdempotent) {
    CloseWatch closed, peer_closed;
    Pair pair = make_pair();
    ASSERT_TRUE(pair.client && pair.server);
    pair.client->start(closed.handler());
    std::vector<std::thread> closers;
    for (int i = 0; i < 4; ++i)
        closers.emplace_back([&] { pair.client->close("closed by test"); });
    for (auto &t : closers)
        t.join();
    EXPECT_EQ(pair.client->close_reason(), "closed by test");
    EXPECT_FALSE(pair.client->closed_by_peer());
    EXPECT_FALSE(pair.client->is_open());
    EXPECT_EQ(pair.client->send(MessageType::Ping, {}), SendResult::Closed);
    pair.client.reset(); // the destructor after close is fine too
    EXPECT_EQ(closed.count(), 0u);

    // The peer of a locally closed connection hears of it.
    ASSERT_TRUE(pair.server);
    pair.server->start(peer_closed.handler());
    ASSERT_TRUE(peer_closed.wait());
    EXPECT_EQ(peer_closed.first(), "peer closed the connection");
    pair.server.reset();
    EXPECT_EQ(peer_closed.count(), 1u);
}

TEST(ProtocolTransport, CloseAndDestroyFromInsideTheHandler) {
    CloseWatch closed;
    Pair pair = make_pair();
    ASSERT_TRUE(pair.client && pair.server);
    std::promise<void> got_message;
    Connection *server = pair.server.get();
    pair.server->start(closed.handler(), [&, server](Message &&) {
        server->close("handler closed it");
        got_message.set_value();
    });
    ASSERT_EQ(pair.client->send(MessageType::Ping, {}), SendResult::Queued);
    ASSERT_EQ(got_message.get_future().wait_for(kPatience), std::future_status::ready);
    EXPECT_EQ(pair.server->close_reason(), "handler closed it");
    EXPECT_EQ(pair.server->send(MessageType::Ping, {}), SendResult::Closed);
    pair.server.reset();
    EXPECT_EQ(closed.count(), 0u);

    // Destroying a connection from its own on_closed handler must not deadlock or crash.
    Pair second = make_pair();
    ASSERT_TRUE(second.client && second.server);
    std::promise<void> destroyed;
    std::unique_ptr<Connection> owned = std::move(second.client);
    Connection *raw = owned.get();
    raw->start([&](const std::string &) {
        owned.reset();
        destroyed.set_value();
    });
    second.server->close();
    ASSERT_EQ(destroyed.get_future().wait_for(kPatience), std::future_status::ready);
}

TEST(ProtocolTransport, CallbackModeDeliversInOrderOnTheIoThread) {
    CloseWatch closed;
    Pair pair = make_pair();
    ASSERT_TRUE(pair.client && pair.server);
    std::mutex mutex;
    std::condition_variable cv;
    std::vector<uint64_t> sequences;
    std::thread::id handler_thread;
    pair.server->start(closed.handler(), [&](Message &&message) {
        std::lock_guard lock(mutex);
        handler_thread = std::this_thread::get_id();
        sequences.push_back(message.sequence);
        cv.notify_all();
    });
    for (int i = 0; i < 200; ++i)
        ASSERT_EQ(pair.client->send(MessageType::Ping, numbered_payload(uint32_t(i))), SendResult::Queued);
    std::unique_lock lock(mutex);
    ASSERT_TRUE(cv.wait_for(lock, kPatience, [&] { return sequences.size() == 200; }));
    for (size_t i = 0; i < sequences.size(); ++i)
        EXPECT_EQ(sequences[i], i + 1);
    EXPECT_NE(handler_thread, std::this_thread::get_id());
    EXPECT_FALSE(pair.server->try_receive()); // nothing goes to the queue in callback mode
}

TEST(ProtocolTransport, HandlerExceptionClosesWithAReason) {
    CloseWatch closed;
    Pair pair = make_pair();
    ASSERT_TRUE(pair.client && pair.server);
    pair.server->start(closed.handler(), [](Message &&) { throw std::runtime_error("replay failed"); });
    ASSERT_EQ(pair.client->send(MessageType::Ping, {}), SendResult::Queued);
    ASSERT_TRUE(closed.wait());
    EXPECT_EQ(closed.first(), "the message handler threw: replay failed");
}

TEST(ProtocolTransport, ConnectToAClosedPortFailsFast) {
    // A bound socket that does not listen: connections to it are refused (RST), and nobody else
    // can take the port meanwhile.
    UniqueFd holder(::socket(AF_INET, SOCK_STREAM, 0));
    ASSERT_TRUE(holder);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ASSERT_EQ(::bind(holder.get(), reinterpret_cast<sockaddr *>(&address), sizeof(address)), 0);
    socklen_t length = sizeof(address);
    ::getsockname(holder.get(), reinterpret_cast<sockaddr *>(&address), &length);
    const uint16_t port = ntohs(address.sin_port);

    const auto start = Clock::now();
    auto result = Connection::connect("127.0.0.1", port, 5s);
    const auto elapsed = Clock::now() - start;
    ASSERT_FALSE(result.ok());
    EXPECT_LT(elapsed, 1s);
    EXPECT_EQ(result.error(), "cannot connect to 127.0.0.1:" + std::to_string(port) + ": Connection refused");
}

TEST(ProtocolTransport, ConnectTimesOutWhenNobodyAnswers) {
    // A listener whose accept queue is full and which never accepts: Linux drops further SYNs, so
    // a connect stays in SYN_SENT, which is what an unreachable host looks like.
    UniqueFd listener(::socket(AF_INET, SOCK_STREAM, 0));
    ASSERT_TRUE(listener);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ASSERT_EQ(::bind(listener.get(), reinterpret_cast<sockaddr *>(&address), sizeof(address)), 0);
    ASSERT_EQ(::listen(listener.get(), 0), 0);
    socklen_t length = sizeof(address);
    ::getsockname(listener.get(), reinterpret_cast<sockaddr *>(&address), &length);

    std::vector<UniqueFd> fillers;
    bool full = false;
    for (int i = 0; i < 16 && !full; ++i) {
        UniqueFd fd(::socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK, 0));
        ASSERT_TRUE(fd);
        const int rc = ::connect(fd.get(), reinterpret_cast<sockaddr *>(&address), sizeof(address));
        if (rc != 0 && errno != EINPROGRESS) break;
        pollfd entry{fd.get(), POLLOUT, 0};
        if (rc != 0 && ::poll(&entry, 1, 200) == 0) full = true; // this one hangs: the queue is full
        fillers.push_back(std::move(fd));
    }
    if (!full)
        GTEST_SKIP() << "this kernel answers SYNs on a full accept queue; no unanswered address to test";

    const auto start = Clock::now();
    auto result = Connection::connect("127.0.0.1", ntohs(address.sin_port), 300ms);
    const auto elapsed = Clock::now() - start;
    ASSERT_FALSE(result.ok());
    EXPECT_EQ(result.error(), "connection to 127.0.0.1:" + std::to_string(ntohs(address.sin_port)) +
                                  " timed out after 300 ms");
    EXPECT_GE(elapsed, 290ms);
    EXPECT_LT(elapsed, 2s);
}

TEST(ProtocolTransport, ResolveFailureIsOneLine) {
    auto result = Connection::connect("not a host name", 7447, 1s);
    ASSERT_FALSE(result.ok());
    EXPECT_EQ(result.error().rfind("cannot resolve 'not a host name': ", 0), 0u) << result.error();
}

TEST(ProtocolTransport, Ipv6Loopback) {
    auto probe = Acceptor::listen("::1", 0);
    if (!probe) GTEST_SKIP() << "no IPv6 loopback here: " << probe.error();
    probe.value().reset();
    CloseWatch closed;
    Pair pair = make_pair({}, {}, "::1");
    ASSERT_TRUE(pair.client && pair.server);
    EXPECT_EQ(pair.acceptor->local_address(), "[::1]:" + std::to_string(pair.acceptor->port()));
    EXPECT_EQ(pair.client->peer_address(), "[::1]:" + std::to_string(pair.acceptor->port()));
    pair.server->start(closed.handler());
    ASSERT_EQ(pair.client->send(MessageType::Ping, bytes_of("v6")), SendResult::Queued);
    auto message = pair.server->receive(kPatience);
    ASSERT_TRUE(message);
    EXPECT_EQ(message->payload, bytes_of("v6"));
}

TEST(ProtocolTransport, AcceptTimesOutQuietly) {
    auto acceptor = Acceptor::listen("127.0.0.1", 0);
    ASSERT_TRUE(acceptor.ok());
    const auto start = Clock::now();
    auto fd = (*acceptor)->accept(50ms);
    ASSERT_TRUE(fd.ok()) << fd.error();
    EXPECT_FALSE(*fd);
    EXPECT_GE(Clock::now() - start, 45ms);
    (*acceptor)->close();
    EXPECT_FALSE((*acceptor)->accept(0ms).ok());
}

TEST(ProtocolTransport, SendingABufferMovesItOnlyWhenQueued) {
    CloseWatch closed;
    ConnectionOptions options;
    options.compression.enabled = false;
    Pair pair = make_pair(options);
    ASSERT_TRUE(pair.client && pair.server);
    pair.server->start(closed.handler());
    std::vector<uint8_t> tile(100000, 0x42);
    ASSERT_EQ(pair.client->send_owned(MessageType::Tiles, std::move(tile)), SendResult::Queued);
    EXPECT_TRUE(tile.empty()); // moved into the queue, not copied
    auto message = pair.server->receive(kPatience);
    ASSERT_TRUE(message);
    EXPECT_EQ(message->payload, std::vector<uint8_t>(100000, 0x42));

    pair.client->close();
    std::vector<uint8_t> kept(10, 1);
    EXPECT_EQ(pair.client->send_owned(MessageType::Tiles, std::move(kept)), SendResult::Closed);
    EXPECT_EQ(kept, std::vector<uint8_t>(10, 1)); // refused: the caller still has it
}

TEST(ProtocolTransport, SendFailureBeforeStartIsReportedByStart) {
    CloseWatch closed;
    ConnectionOptions options;
    options.compression.enabled = false;
    Pair pair = make_pair(options);
    ASSERT_TRUE(pair.client && pair.server);
    // The peer goes away; the client only writes (it has not started reading), so it learns of it
    // from a failed write, which must not raise SIGPIPE.
    pair.server.reset();
    const std::vector<uint8_t> chunk(1u << 20, 0x11);
    const auto deadline = Clock::now() + kPatience;
    while (pair.client->is_open() && Clock::now() < deadline) {
        pair.client->send(MessageType::MemoryData, chunk);
        std::this_thread::sleep_for(5ms);
    }
    ASSERT_FALSE(pair.client->is_open());
    const std::string reason = pair.client->close_reason();
    EXPECT_TRUE(reason == "connection reset by peer (while sending)" || reason.rfind("send failed: ", 0) == 0)
        << reason;
    pair.client->start(closed.handler()); // reports the earlier failure, once, right here
    EXPECT_EQ(closed.count(), 1u);
    EXPECT_EQ(closed.first(), reason);
}

TEST(ProtocolTransport, PayloadOverTheCapIsNeverSent) {
    ConnectionOptions options;
    options.max_payload = 1000;
    CloseWatch closed;
    Pair pair = make_pair(options);
    ASSERT_TRUE(pair.client && pair.server);
    EXPECT_EQ(pair.client->send(MessageType::Ping, std::vector<uint8_t>(1001)), SendResult::TooLarge);
    EXPECT_EQ(pair.client->send(MessageType::Ping, std::vector<uint8_t>(1000)), SendResult::Queued);
    pair.server->start(closed.handler());
    auto message = pair.server->receive(kPatience);
    ASSERT_TRUE(message);
    EXPECT_EQ(message->sequence, 1u); // the refused message took no sequence number
}

TEST(ProtocolTransport, FullSendQueueIsReportedNotBlocking) {
    ConnectionOptions options;
    options.send_queue_limit = 1u << 20;
    options.compression.enabled = false;
    CloseWatch closed;
    Pair pair = make_pair(options);
    ASSERT_TRUE(pair.client && pair.server);
    shrink_socket_buffers(*pair.client, *pair.server);
    // The server does not read yet: the kernel's buffers fill, then the client's queue.
    const std::vector<uint8_t> chunk(256 * 1024, 0x5A);
    uint32_t queued = 0;
    SendResult result = SendResult::Queued;
    const auto start = Clock::now();
    while (queued < 4000 &&
           (result = pair.client->send(MessageType::MemoryData, chunk)) == SendResult::Queued)
        ++queued;
    ASSERT_EQ(result, SendResult::QueueFull) << "after " << queued << " messages";
    EXPECT_LT(Clock::now() - start, 2s); // nothing waited for the network
    EXPECT_LE(pair.client->stats().send_queue_bytes, options.send_queue_limit);
    // The kernel may still grow its buffers (autotuning) and take a little more: top the queue up
    // until it stays full.
    for (int settled = 0; settled < 2;) {
        std::this_thread::sleep_for(30ms);
        if (pair.client->send(MessageType::MemoryData, chunk) == SendResult::Queued) {
            ++queued;
            settled = 0;
        } else {
            ++settled;
        }
    }

    // A bounded wait gives up after about that long.
    const auto wait_start = Clock::now();
    EXPECT_EQ(pair.client->send(MessageType::MemoryData, chunk, 50ms), SendResult::QueueFull);
    EXPECT_GE(Clock::now() - wait_start, 45ms);

    // Once the server reads, a waiting sender gets through, and the stream has no gaps.
    pair.server->start(closed.handler());
    EXPECT_EQ(pair.client->send(MessageType::MemoryData, chunk, kPatience), SendResult::Queued);
    ++queued;
    for (uint32_t i = 0; i < queued; ++i) {
        auto message = pair.server->receive(kPatience);
        ASSERT_TRUE(message) << i << ": " << pair.server->close_reason();
        ASSERT_EQ(message->sequence, i + 1);
        ASSERT_EQ(message->payload.size(), chunk.size());
    }
    EXPECT_EQ(closed.count(), 0u);
}

TEST(ProtocolTransport, SlowConsumerPushesBackThroughTcp) {
    ConnectionOptions client_options;
    client_options.compression.enabled = false;
    client_options.send_queue_limit = 256u << 20;
    ConnectionOptions server_options;
    server_options.receive_queue_limit = 256 * 1024;
    CloseWatch closed;
    Pair pair = make_pair(client_options, server_options);
    ASSERT_TRUE(pair.client && pair.server);
    // Small, fixed kernel buffers (no autotuning), so what the kernel can hold is known.
    shrink_socket_buffers(*pair.client, *pair.server);
    pair.server->start(closed.handler());

    constexpr uint32_t kMessages = 512; // 32 MiB
    const std::vector<uint8_t> chunk(64 * 1024, 0x33);
    for (uint32_t i = 0; i < kMessages; ++i)
        ASSERT_EQ(pair.client->send(MessageType::MemoryData, chunk), SendResult::Queued);
    // Give the I/O threads time to move what they can.
    const auto deadline = Clock::now() + 300ms;
    while (Clock::now() < deadline)
        std::this_thread::sleep_for(20ms);
    const auto server_stats = pair.server->stats();
    // The inbound queue stopped near its limit (one read's worth of overshoot at most)...
    EXPECT_LE(server_stats.receive_queue_bytes, server_options.receive_queue_limit + 2 * 64 * 1024);
    EXPECT_GT(server_stats.receive_queue_bytes, 0u);
    // ...and the rest waits on the client's side instead of in the server's memory.
    EXPECT_GT(pair.client->stats().send_queue_bytes, 24u << 20);
    for (uint32_t i = 0; i < kMessages; ++i) {
        auto message = pair.server->receive(kPatience);
        ASSERT_TRUE(message) << i;
        ASSERT_EQ(message->sequence, i + 1);
    }
    EXPECT_EQ(closed.count(), 0u);
}

TEST(ProtocolTransport, UnknownTypesSkippedByPolicy) {
    ConnectionOptions server_options;
    server_options.unknown_types = UnknownTypePolicy::Skip;
    CloseWatch closed;
    Pair pair = make_pair({}, server_options);
    ASSERT_TRUE(pair.client && pair.server);
    pair.server->start(closed.handler());
    ASSERT_EQ(pair.client->send(uint16_t{0x7777}, std::vector<uint8_t>(100000, 1)), SendResult::Queued);
    ASSERT_EQ(pair.client->send(MessageType::Ping, bytes_of("after")), SendResult::Queued);
    auto message = pair.server->receive(kPatience);
    ASSERT_TRUE(message) << pair.server->close_reason();
    EXPECT_EQ(message->type, to_wire(MessageType::Ping));
    EXPECT_EQ(message->sequence, 2u);
    EXPECT_EQ(pair.server->stats().messages_skipped, 1u);
    EXPECT_TRUE(pair.server->is_open());
}

TEST(ProtocolTransport, HandshakeRejections) {
    {
        CloseWatch a, b;
        Pair pair = make_pair();
        ASSERT_TRUE(pair.client && pair.server);
        pair.client->start(a.handler());
        pair.server->start(b.handler());
        Hello hello;
        hello.token = bytes_of("wrong");
        auto client =
            std::async(std::launch::async, [&] { return client_handshake(*pair.client, hello, 5s); });
        ServerHandshakeConfig config;
        config.token = bytes_of("right");
        auto server = server_handshake(*pair.server, config, 5s);
        ASSERT_FALSE(server.ok());
        EXPECT_EQ(server.error(), "rejected the client: bad token: the token does not match the server's");
        pair.server->close();
        auto result = client.get();
        ASSERT_FALSE(result.ok());
        EXPECT_EQ(result.error(),
                  "server rejected the session: bad token: the token does not match the server's");
    }
    {
        // A command before the handshake.
        CloseWatch a, b;
        Pair pair = make_pair();
        ASSERT_TRUE(pair.client && pair.server);
        pair.client->start(a.handler());
        pair.server->start(b.handler());
        ASSERT_EQ(pair.client->send(uint16_t{0x0150}, bytes_of("vkCreateBuffer")), SendResult::Queued);
        auto server = server_handshake(*pair.server, {}, 5s);
        ASSERT_FALSE(server.ok());
        EXPECT_EQ(server.error(), "rejected the client: malformed handshake: expected Hello first, got "
                                  "Vulkan command (type 0x0150)");
        auto reply = pair.client->receive(kPatience);
        ASSERT_TRUE(reply);
        EXPECT_EQ(reply->type, to_wire(MessageType::Reject));
        EXPECT_EQ(decode_reject(reply->payload)->reason, RejectReason::Malformed);
    }
    {
        // Nobody says anything.
        CloseWatch a;
        Pair pair = make_pair();
        ASSERT_TRUE(pair.client && pair.server);
        pair.server->start(a.handler());
        auto server = server_handshake(*pair.server, {}, 100ms);
        ASSERT_FALSE(server.ok());
        EXPECT_EQ(server.error(), "no Hello within 100 ms");
    }
}

// --- malformed bytes from a raw socket ---------------------------------------------------------

struct RawCase {
    const char *name;
    std::vector<uint8_t> bytes;
    bool then_close; // half-close the raw socket after writing
    const char *reason;
};

std::vector<uint8_t> concat(std::vector<uint8_t> a, const std::vector<uint8_t> &b) {
    a.insert(a.end(), b.begin(), b.end());
    return a;
}

std::vector<RawCase> raw_cases() {
    const auto ping = [](uint64_t sequence) {
        return encode_frame(to_wire(MessageType::Ping), sequence, {});
    };
    MessageHeader huge{0xFFFFFFF0u, to_wire(MessageType::MemoryData), 0, 1};
    const auto huge_bytes = encode_header(huge);
    auto truncated = encode_frame(to_wire(MessageType::MemoryData), 1, std::vector<uint8_t>(1000, 7));
    truncated.resize(500);
    return {
        {"bad flags", encode_frame(to_wire(MessageType::Ping), 1, {}, 0x0100), false,
         "protocol error: message 1 (type 0x0005): unknown flags 0x0100 at stream offset 0"},
        {"sequence gap", concat(ping(1), ping(3)), false,
         "protocol error: sequence 3 where 2 was expected (type 0x0005) at stream offset 16"},
        {"length over the cap", std::vector<uint8_t>(huge_bytes.begin(), huge_bytes.end()), false,
         "protocol error: message 1 (type 0x1000): payload length 4294967280 exceeds the limit 67108864 at "
         "stream "
         "offset 0"},
        {"unknown type", encode_frame(0x7777, 1, {}), false,
         "protocol error: message 1 (type 0x7777): unknown message type at stream offset 0"},
        {"truncated message", truncated, true,
         "peer closed the connection in the middle of a message (stream offset 500)"},
        {"garbage", std::vector<uint8_t>(64, 0xFF), false, "protocol error: message 18446744073709551615"},
    };
}

TEST(ProtocolTransport, MalformedBytesCloseTheConnectionWithAReason) {
    for (const RawCase &c : raw_cases()) {
        SCOPED_TRACE(c.name);
        auto acceptor = Acceptor::listen("127.0.0.1", 0);
        ASSERT_TRUE(acceptor.ok());
        UniqueFd raw(::socket(AF_INET, SOCK_STREAM, 0));
        sockaddr_in address{};
        address.sin_family = AF_INET;
        address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        address.sin_port = htons((*acceptor)->port());
        ASSERT_EQ(::connect(raw.get(), reinterpret_cast<sockaddr *>(&address), sizeof(address)), 0);
        auto fd = (*acceptor)->accept(2s);
        ASSERT_TRUE(fd.ok() && *fd);
        CloseWatch closed;
        auto server = Connection::adopt(std::move(fd).value());
        ASSERT_TRUE(server.ok());
        (*server)->start(closed.handler());

        ASSERT_EQ(::send(raw.get(), c.bytes.data(), c.bytes.size(), MSG_NOSIGNAL), ssize_t(c.bytes.size()));
        if (c.then_close) ::shutdown(raw.get(), SHUT_WR);
        ASSERT_TRUE(closed.wait());
        EXPECT_EQ(closed.first().rfind(c.reason, 0), 0u) << closed.first();
        EXPECT_EQ(closed.first().find('\n'), std::string::npos);
        EXPECT_FALSE((*server)->closed_by_peer()) << "an error, a message cut short included";
        // The server hung up: the raw socket reads EOF (or a reset).
        pollfd entry{raw.get(), POLLIN, 0};
        ASSERT_EQ(::poll(&entry, 1, 5000), 1);
        char buffer[64];
        EXPECT_LE(::recv(raw.get(), buffer, sizeof(buffer), 0), 0);
        (*server)->close();
        EXPECT_EQ(closed.count(), 1u);
    }
}

// --- the fork story ----------------------------------------------------------------------------

TEST(ProtocolTransport, ForkedChildAbandonsTheParentsConnection) {
    // An application forks while the layer's connection is live (its I/O thread running).
    CloseWatch closed;
    Pair pair = make_pair();
    ASSERT_TRUE(pair.client && pair.server);
    pair.client->start(closed.handler());
    pair.server->start(closed.handler());
    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
        // Neither may hang on the I/O thread that stayed in the parent, nor disturb the parent.
        pair.client->close();
        pair.client.reset();
        pair.server.reset();
        ::_exit(0);
    }
    int status = -1;
    for (auto deadline = Clock::now() + kPatience; Clock::now() < deadline;) {
        if (::waitpid(child, &status, WNOHANG) == child) break;
        std::this_thread::sleep_for(2ms);
    }
    if (!WIFEXITED(status)) {
        ::kill(child, SIGKILL);
        ::waitpid(child, &status, 0);
        FAIL() << "the child hung closing an inherited connection";
    }
    EXPECT_EQ(WEXITSTATUS(status), 0);
    // The parent's connection still works both ways.
    ASSERT_EQ(pair.client->send(MessageType::Ping, bytes_of("still here")), SendResult::Queued);
    auto ping = pair.server->receive(kPatience);
    ASSERT_TRUE(ping) << pair.server->close_reason();
    EXPECT_EQ(ping->payload, bytes_of("still here"));
    ASSERT_EQ(pair.server->send(MessageType::Pong, ping->payload), SendResult::Queued);
    ASSERT_TRUE(pair.client->receive(kPatience));
    EXPECT_EQ(closed.count(), 0u);
}

TEST(ProtocolTransport, ChildProcessAdoptsAnAcceptedSocket) {
    // The parent stays single-threaded: a raw client socket and the Acceptor, no Connection.
    auto acceptor = Acceptor::listen("127.0.0.1", 0);
    ASSERT_TRUE(acceptor.ok());
    UniqueFd raw(::socket(AF_INET, SOCK_STREAM, 0));
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    address.sin_port = htons((*acceptor)->port());
    ASSERT_EQ(::connect(raw.get(), reinterpret_cast<sockaddr *>(&address), sizeof(address)), 0);
    auto accepted = (*acceptor)->accept(2s);
    ASSERT_TRUE(accepted.ok() && *accepted);

    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
        // One session: adopt, handshake, echo a Ping as a Pong, leave.
        (*acceptor)->close();
        raw.reset();
        auto session = Connection::adopt(std::move(accepted).value());
        if (!session) ::_exit(10);
        (*session)->start([](const std::string &) {});
        ServerHandshakeConfig config;
        config.session_id = 9;
        auto handshake = server_handshake(**session, config, 5s);
        if (!handshake) ::_exit(11);
        auto ping = (*session)->receive(5s);
        if (!ping || ping->type != to_wire(MessageType::Ping)) ::_exit(12);
        (*session)->send(MessageType::Pong, ping->payload);
        if (!(*session)->flush(5s)) ::_exit(13);
        (*session)->close();
        ::_exit(0);
    }
    accepted->reset(); // the parent's copy: the child's close must be the one the client sees

    std::vector<uint8_t> out = encode_frame(to_wire(MessageType::Hello), 1, encode_hello(Hello{}));
    const auto ping = encode_frame(to_wire(MessageType::Ping), 2, bytes_of("from parent"));
    out.insert(out.end(), ping.begin(), ping.end());
    ASSERT_EQ(::send(raw.get(), out.data(), out.size(), MSG_NOSIGNAL), ssize_t(out.size()));

    FrameDecoder decoder;
    std::vector<Message> got;
    bool eof = false;
    while (!eof) {
        pollfd entry{raw.get(), POLLIN, 0};
        ASSERT_EQ(::poll(&entry, 1, 5000), 1);
        uint8_t buffer[4096];
        const ssize_t n = ::recv(raw.get(), buffer, sizeof(buffer), 0);
        ASSERT_GE(n, 0);
        if (n == 0) eof = true;
        ASSERT_TRUE(decoder.feed(std::span<const uint8_t>(buffer, size_t(n)), got)) << decoder.error();
    }
    int status = 0;
    ASSERT_EQ(::waitpid(child, &status, 0), child);
    ASSERT_TRUE(WIFEXITED(status));
    EXPECT_EQ(WEXITSTATUS(status), 0);
    ASSERT_EQ(got.size(), 2u);
    EXPECT_EQ(got[0].type, to_wire(MessageType::Welcome));
    EXPECT_EQ(decode_welcome(got[0].payload)->session_id, 9u);
    EXPECT_EQ(got[1].type, to_wire(MessageType::Pong));
    EXPECT_EQ(got[1].payload, bytes_of("from parent"));
}

} // namespace
} // namespace splitvk::protocol
