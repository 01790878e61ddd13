#pragma once

// The TCP transport (docs/architecture.md §2-3): one Connection per session, each with its own Asio
// io_context and I/O thread, TCP_NODELAY on. Asio stays inside transport.cpp: this header is
// cheap to include from the layer's many files.
//
// Threading model. Every Connection owns one io_context run by one I/O thread of its own (not a
// process-wide pool):
//  - the layer has one connection per VkDevice and the agent one per session process, so a thread
//    per connection costs nothing and no global state has to be set up or torn down inside a
//    dlopen'd layer;
//  - the agent forks one process per session: with no shared io_context, nothing of a parent's
//    reactor or threads leaks into a child (see Acceptor below);
//  - close() can join exactly the thread it owns, and one connection's stall cannot delay another.
//
// Sending: send() is one-way and never blocks on the network. It compresses (on the caller's
// thread, per CompressionPolicy), assigns the sequence number, queues and returns; the I/O thread
// writes queued messages in order, gathering many small ones into one system call. The queue is
// bounded in bytes: when full, send() returns SendResult::QueueFull at once (or after at most the
// wait the caller asked for) and the message is not queued and consumes no sequence number. A
// message is always accepted into an empty queue, so the limit cannot make one message unsendable.
//
// Receiving: the I/O thread validates every header (flags, length cap, sequence, type) before it
// buffers the payload, decompresses, and hands over whole messages in order, in one of two modes
// chosen at start():
//  - queue mode (no message handler): messages wait in an inbound queue for try_receive() (never
//    blocks: the layer's render thread) or receive(timeout) (a worker; the agent's replay thread).
//    When the queue holds more than receive_queue_limit bytes the I/O thread stops reading until
//    the consumer catches up, so a slow consumer pushes back on the peer through TCP instead of
//    growing memory;
//  - callback mode: on_message runs on the I/O thread. It must return quickly: while it runs,
//    nothing is read or written on this connection.
//
// Closing: the first of peer EOF, reset, a protocol violation, a send or receive error, a handler
// that throws, or close() / the destructor closes the connection; close_reason() tells which, in
// one line ("peer closed the connection", "protocol error: sequence 7 where 6 was expected ...").
// When the closure is one this side did not ask for, on_closed(reason) runs exactly once, on the
// I/O thread (or from start(), if it happened before start). It never runs for close() or the
// destructor: the owner knows, and a callback into an owner that is being destroyed is a classic
// use-after-free. Nothing throws out of the I/O thread.
// Messages received before the close stay in the inbound queue and can still be taken (a Reject
// followed by EOF is read as the Reject).

#include "compression.h"
#include "handshake.h"
#include "result.h"
#include "tls.h"
#include "wire.h"

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace splitvk::protocol {

// An owned file descriptor.
class UniqueFd {
public:
    UniqueFd() = default;
    explicit UniqueFd(int fd) : fd_(fd) {}
    ~UniqueFd() { reset(); }
    UniqueFd(UniqueFd &&other) noexcept : fd_(other.release()) {}
    UniqueFd &operator=(UniqueFd &&other) noexcept {
        if (this != &other) reset(other.release());
        return *this;
    }
    UniqueFd(const UniqueFd &) = delete;
    UniqueFd &operator=(const UniqueFd &) = delete;

    int get() const { return fd_; }
    explicit operator bool() const { return fd_ >= 0; }
    int release() {
        const int fd = fd_;
        fd_ = -1;
        return fd;
    }
    void reset(int fd = -1);

private:
    int fd_ = -1;
};

struct ConnectionOptions {
    std::string name = "connection"; // prefixes debug log lines
    // Cap on any payload, raw or decompressed, in both directions.
    uint32_t max_payload = kDefaultMaxPayload;
    // A different cap for what this end receives (0: max_payload). The agent's --max-message-bytes
    // bounds what a client may send without bounding the frames the agent itself sends back.
    uint32_t max_receive_payload = 0;
    std::string max_receive_payload_name;          // named in the error when a message is over the cap
    size_t send_queue_limit = size_t{128} << 20;   // bytes (headers + payloads as sent)
    size_t receive_queue_limit = size_t{64} << 20; // queue mode: reading pauses above this
    CompressionPolicy compression;                 // set enabled = false unless the peer has kZstdPayloads
    UnknownTypePolicy unknown_types = UnknownTypePolicy::Reject;
    std::function<bool(uint16_t)> is_known_type; // empty: is_defined_type()
    // Set: the connection runs TLS 1.3 over its socket (tls.h). connect() shakes hands as the
    // client (the context must be a client one) and adopt() as the server, each within
    // tls_handshake_timeout, before they return; a failed handshake is their one-line error.
    std::shared_ptr<TlsContext> tls;
    std::chrono::milliseconds tls_handshake_timeout{5000};
};

// One message to queue with Connection::send_all.
struct OutboundMessage {
    MessageType type = MessageType::Commands;
    std::vector<uint8_t> payload;
};

enum class SendResult {
    Queued,    // accepted; it will be written in order
    QueueFull, // back-pressure: not queued (the peer or the network is not keeping up)
    TooLarge,  // payload over max_payload: never sendable
    Closed,    // the connection is closed
};
const char *to_string(SendResult result);

struct ConnectionStats {
    uint64_t messages_sent = 0;
    uint64_t messages_received = 0;
    uint64_t messages_skipped = 0;   // unknown types stepped over (UnknownTypePolicy::Skip)
    uint64_t payload_bytes_sent = 0; // before compression
    uint64_t wire_bytes_sent = 0;    // headers + payloads written to the socket
    uint64_t wire_bytes_received = 0;
    uint64_t compressed_messages_sent = 0;
    size_t send_queue_bytes = 0;
    size_t receive_queue_bytes = 0;
};

class Connection {
public:
    using MessageHandler = std::function<void(Message &&message)>;
    using ClosedHandler = std::function<void(const std::string &reason)>;

    // Connects with a timeout covering the whole attempt (every address the host resolves to).
    // A refused connection fails at once; an address that does not answer fails after `timeout`.
    // The host is resolved with getaddrinfo before the timeout starts, which a timeout cannot
    // interrupt: give numeric addresses where a DNS stall matters. Blocks the caller for at most
    // the resolution plus `timeout`. The connection is open but not yet reading: call start().
    static Result<std::unique_ptr<Connection>> connect(const std::string &host, uint16_t port,
                                                       std::chrono::milliseconds timeout,
                                                       ConnectionOptions options = {});

    // Takes over a connected TCP socket, typically one from Acceptor::accept(), possibly in a
    // child process forked after the accept. The I/O thread is created here, so a process that
    // forks must adopt after the fork (see Acceptor).
    static Result<std::unique_ptr<Connection>> adopt(UniqueFd socket, ConnectionOptions options = {});

    // Closes (see close(); no on_closed) and joins the I/O thread. Must not run while another
    // thread is inside a member function of this Connection. May run inside this connection's own
    // handlers (the thread then finishes on its own).
    ~Connection();
    Connection(const Connection &) = delete;
    Connection &operator=(const Connection &) = delete;

    // Starts reading. on_closed is required; without on_message, messages go to the inbound queue.
    // Call once. If the connection has already failed (a send error before start), on_closed is
    // called from start() itself.
    void start(ClosedHandler on_closed, MessageHandler on_message = {});

    // Queues one message; see the header comment. Safe from any thread, also before start().
    // `wait_for_space` > 0 waits at most that long for room when the queue is full; 0 never waits
    // (and on the I/O thread, inside a handler, nothing ever waits).
    SendResult send(uint16_t type, std::span<const uint8_t> payload,
                    std::chrono::milliseconds wait_for_space = std::chrono::milliseconds(0));
    SendResult send(MessageType type, std::span<const uint8_t> payload,
                    std::chrono::milliseconds wait_for_space = std::chrono::milliseconds(0)) {
        return send(to_wire(type), payload, wait_for_space);
    }
    // The same, taking the buffer: a payload sent raw is moved into the queue rather than copied
    // (tiles, memory data). On anything but Queued the caller's vector still holds the payload.
    SendResult send_owned(uint16_t type, std::vector<uint8_t> &&payload,
                          std::chrono::milliseconds wait_for_space = std::chrono::milliseconds(0));
    SendResult send_owned(MessageType type, std::vector<uint8_t> &&payload,
                          std::chrono::milliseconds wait_for_space = std::chrono::milliseconds(0)) {
        return send_owned(to_wire(type), std::move(payload), wait_for_space);
    }

    // Queues `messages` in order, as send_owned() would one by one, but compresses them on
    // `workers` threads at once while the first ones are already being written. For a large batch
    // that must reach the peer quickly: a resync's snapshot. Stops at the first message that is not
    // Queued and returns its result; the messages before it are queued, the rest are dropped.
    SendResult send_all(std::vector<OutboundMessage> &&messages,
                        std::chrono::milliseconds wait_for_space = std::chrono::milliseconds(0),
                        unsigned workers = 2);

    // Queue mode. try_receive never blocks; receive waits at most `timeout`. Both return nothing
    // when no message is waiting (receive: also at once when closed and empty).
    std::optional<Message> try_receive();
    std::optional<Message> receive(std::chrono::milliseconds timeout);

    // Waits at most `timeout` until a message of `bytes` would be queued without waiting (or the
    // connection closed). True if it would. For a sender that must not wait for room while it holds
    // a lock others need: it waits here first, with no lock held.
    bool wait_for_room(size_t bytes, std::chrono::milliseconds timeout);

    // Waits at most `timeout` until every queued message has been written to the socket. True if
    // the queue drained. Use before close() to deliver a final Reject or Goodbye. (On the I/O
    // thread it does not wait.)
    bool flush(std::chrono::milliseconds timeout);

    // Closes the connection and joins the I/O thread: idempotent, from any thread, also from inside
    // on_message / on_closed (then it does not join: it cannot join its own thread). Queued
    // messages not yet written are dropped; flush() first to deliver them. Does not call
    // on_closed; close_reason() becomes `reason` if this is what closed the connection. Must not
    // be called while holding a lock that on_message / on_closed take (it waits for them).
    void close(std::string_view reason = "closed by this side");

    bool is_open() const;
    std::string close_reason() const; // empty while open
    // Whether the peer ended the connection between two messages, however it did (EOF, a TLS
    // close_notify, a reset, or a write failing because of one): its normal end, not an error.
    // False while open, and for a close of this side's or an error.
    bool closed_by_peer() const;
    std::string peer_address() const; // "127.0.0.1:7447", "[::1]:7447"
    std::string local_address() const;
    // "TLS 1.3 (TLS_AES_256_GCM_SHA384)" or "plaintext", for logs.
    std::string security() const;
    ConnectionStats stats() const;
    // The socket, for getsockopt() and diagnostics only, and only while open: never read, write
    // or close it.
    int native_handle() const;
    // The current compression policy, and a way to change it after the handshake (e.g. off when
    // the peer lacks capability::kZstdPayloads). Affects messages sent after the call.
    void set_compression(CompressionPolicy policy);

    struct Impl;

private:
    explicit Connection(std::shared_ptr<Impl> impl);
    bool abandon_if_forked();
    std::shared_ptr<Impl> impl_;
};

// A listening TCP socket for the agent (IPv4 or IPv6: "127.0.0.1", "::1", "0.0.0.0", "::",
// or a name). It is plain POSIX, with no io_context and no thread, which is the fork story:
//
//   auto acceptor = Acceptor::listen("127.0.0.1", 7447);      // parent: single-threaded
//   for (;;) {
//       auto fd = acceptor->accept(timeout);                    // poll() + accept4(), nothing else
//       if (fork() == 0) {                                      // child: one session
//           acceptor->close();                                  // its copy of the listening socket
//           auto session = Connection::adopt(std::move(*fd));   // io_context + thread created here
//           ...
//       }
//       // parent: *fd goes out of scope and closes its copy; reap children (SIGCHLD)
//   }
//
// Since no reactor (epoll set) exists before the fork, a child can neither share one with its
// parent nor deregister the parent's sockets from it, and since the parent runs no threads, the
// child does not inherit locks held by threads that no longer exist.
//
// The other direction, an application that forks while the layer holds a Connection: the child
// cannot use that Connection (its I/O thread stayed in the parent). Its close() and destructor
// notice the fork, close the child's copy of the socket, leak the state and return at once
// without touching locks or threads; the parent's connection is unaffected. Sockets are
// close-on-exec, so fork + exec leaves nothing behind at all.
class Acceptor {
public:
    // Binds and listens (SO_REUSEADDR). Port 0 picks a free port: see port().
    static Result<std::unique_ptr<Acceptor>> listen(const std::string &host, uint16_t port, int backlog = 16);
    ~Acceptor();
    Acceptor(const Acceptor &) = delete;
    Acceptor &operator=(const Acceptor &) = delete;

    // Waits at most `timeout` (negative: for ever) for one connection. On timeout, an empty fd
    // and no error; on failure, an error. The fd is close-on-exec, blocking, with TCP_NODELAY.
    Result<UniqueFd> accept(std::chrono::milliseconds timeout);

    uint16_t port() const { return port_; }
    std::string local_address() const;
    int native_handle() const { return fd_.get(); } // to poll() it alongside other fds
    void close() { fd_.reset(); }

private:
    Acceptor() = default;
    UniqueFd fd_;
    uint16_t port_ = 0;
};

// Handshake over a Connection in queue mode (started without a message handler).
//
// Client: sends Hello, waits at most `timeout` for Welcome or Reject, checks the Welcome. A Reject
// becomes an error such as "server rejected the session: bad token: the token does not match".
Result<Welcome> client_handshake(Connection &connection, const Hello &hello,
                                 std::chrono::milliseconds timeout);

// Server: waits at most `timeout` for the first message, which must be a Hello, and answers it.
// On success returns the Hello and the Welcome sent. On failure a Reject has been sent (when the
// peer spoke at all) and flushed; the caller closes the connection.
struct ServerHandshake {
    Hello hello;
    Welcome welcome;
};
Result<ServerHandshake> server_handshake(Connection &connection, const ServerHandshakeConfig &config,
                                         std::chrono::milliseconds timeout);

} // namespace splitvk::protocol
