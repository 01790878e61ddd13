#include "transport.h"

#include "log.h"
#include "tls_internal.h"

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <deque>
#include <future>
#include <mutex>
#include <thread>
#include <vector>

#include <asio/connect.hpp>
#include <asio/executor_work_guard.hpp>
#include <asio/io_context.hpp>
#include <asio/ip/tcp.hpp>
#include <asio/post.hpp>
#include <asio/ssl/error.hpp>
#include <asio/ssl/stream.hpp>
#include <asio/steady_timer.hpp>
#include <asio/write.hpp>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

namespace splitvk::protocol {
namespace {

using asio::ip::tcp;

constexpr size_t kReadBufferSize = 64 * 1024;
constexpr size_t kMaxWriteBatch = 64; // messages gathered into one write
// Over TLS, Asio encrypts one buffer per SSL_write, so small messages are copied together into
// one buffer of at most this size rather than becoming a record and a system call each.
constexpr size_t kTlsStageBytes = size_t{1} << 20;

std::string format_endpoint(const tcp::endpoint &endpoint) {
    const std::string address = endpoint.address().to_string();
    const std::string port = std::to_string(endpoint.port());
    return endpoint.address().is_v6() ? "[" + address + "]:" + port : address + ":" + port;
}

std::string format_sockaddr(const sockaddr_storage &storage) {
    char host[NI_MAXHOST] = {};
    char service[NI_MAXSERV] = {};
    const socklen_t length = storage.ss_family == AF_INET6 ? sizeof(sockaddr_in6) : sizeof(sockaddr_in);
    if (::getnameinfo(reinterpret_cast<const sockaddr *>(&storage), length, host, sizeof(host), service,
                      sizeof(service), NI_NUMERICHOST | NI_NUMERICSERV) != 0)
        return "?";
    return storage.ss_family == AF_INET6 ? "[" + std::string(host) + "]:" + service
                                         : std::string(host) + ":" + service;
}

std::string hex16(uint16_t v) {
    char text[8];
    std::snprintf(text, sizeof(text), "0x%04x", v);
    return text;
}

void set_cloexec(int fd) {
    const int flags = ::fcntl(fd, F_GETFD);
    if (flags >= 0) ::fcntl(fd, F_SETFD, flags | FD_CLOEXEC);
}

// Starts a thread with every asynchronous signal blocked, so that the application's signal
// handlers (SIGINT, SIGTERM, SIGCHLD, ...) never run on splitvk's I/O thread. Faults (SIGSEGV and
// friends) stay deliverable: they are synchronous and must reach the thread that caused them.
template <class F>
std::thread spawn_quiet_thread(F &&function) {
    sigset_t all;
    sigset_t previous;
    sigfillset(&all);
    for (const int fault : {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGTRAP, SIGABRT, SIGSYS})
        sigdelset(&all, fault);
    pthread_sigmask(SIG_BLOCK, &all, &previous);
    std::thread thread;
    try {
        thread = std::thread(std::forward<F>(function));
    } catch (...) {
        pthread_sigmask(SIG_SETMASK, &previous, nullptr);
        throw;
    }
    pthread_sigmask(SIG_SETMASK, &previous, nullptr);
    return thread;
}

} // namespace

void UniqueFd::reset(int fd) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = fd;
}

const char *to_string(SendResult result) {
    switch (result) {
    case SendResult::Queued:
        return "queued";
    case SendResult::QueueFull:
        return "send queue full";
    case SendResult::TooLarge:
        return "payload over the size limit";
    case SendResult::Closed:
        return "connection closed";
    }
    return "?";
}

// ---------------------------------------------------------------------------------------------

struct Connection::Impl : std::enable_shared_from_this<Connection::Impl> {
    struct Outgoing {
        std::array<uint8_t, kHeaderSize> header{};
        std::vector<uint8_t> payload;
        size_t bytes = 0; // header + payload
    };

    explicit Impl(ConnectionOptions opts)
        : options(std::move(opts)), socket(io),
          decoder(
              ReceivePolicy{options.max_receive_payload ? options.max_receive_payload : options.max_payload,
                            options.unknown_types, options.is_known_type, options.max_receive_payload_name}),
          read_buffer(kReadBufferSize), compressor(std::make_shared<Compressor>(options.compression)) {}

    // --- lifetime -----------------------------------------------------------------------------

    void start_thread() {
        work.emplace(asio::make_work_guard(io));
        thread = spawn_quiet_thread([self = shared_from_this()] { self->run(); });
    }

    // The I/O thread. Nothing escapes it: a handler that throws closes the connection and the
    // loop goes on until every pending operation has completed.
    void run() {
        io_thread_id.store(std::this_thread::get_id());
        pthread_setname_np(pthread_self(), "splitvk-net");
        for (;;) {
            try {
                io.run();
                break;
            } catch (const std::exception &e) {
                fail(std::string("internal error: ") + e.what());
            } catch (...) {
                fail("internal error");
            }
        }
        // User handlers may hold resources of their own; let them go with the thread.
        std::lock_guard lock(mutex);
        on_message_handler = nullptr;
        on_closed_handler = nullptr;
    }

    bool on_io_thread() const { return std::this_thread::get_id() == io_thread_id.load(); }

    // Closes the connection with a reason. I/O thread only; the first call wins. on_closed hears
    // of closures this side did not ask for (report = false for close() and the destructor).
    void fail(const std::string &reason, bool report = true, bool by_peer = false) {
        ClosedHandler handler;
        {
            std::lock_guard lock(mutex);
            if (closed) return;
            closed = true;
            close_reason = reason;
            closed_by_peer = by_peer;
            if (started && report) handler = on_closed_handler;
            send_cv.notify_all();
            receive_cv.notify_all();
        }
        asio::error_code ignored;
        socket.shutdown(tcp::socket::shutdown_both, ignored);
        socket.close(ignored);
        work.reset();
        SPLITVK_DEBUG("%s: closed: %s", options.name.c_str(), reason.c_str());
        if (handler) {
            try {
                handler(reason);
            } catch (...) {
                SPLITVK_WARN("%s: the on_closed handler threw", options.name.c_str());
            }
        }
    }

    // From any thread: closes, and joins the I/O thread unless called on it.
    void close(std::string_view reason) {
        if (on_io_thread()) {
            fail(std::string(reason), false);
            return;
        }
        std::lock_guard close_lock(close_mutex);
        if (!thread.joinable()) return;
        asio::post(io, [this, why = std::string(reason)] { fail(why, false); });
        thread.join();
    }

    // --- receiving ----------------------------------------------------------------------------

    void read_some() {
        if (read_in_flight) return;
        {
            std::lock_guard lock(mutex);
            if (closed || read_paused) return;
        }
        read_in_flight = true;
        const auto on_done = [this](const asio::error_code &ec, size_t n) { on_read(ec, n); };
        if (tls)
            tls->async_read_some(asio::buffer(read_buffer), on_done);
        else
            socket.async_read_some(asio::buffer(read_buffer), on_done);
    }

    void on_read(const asio::error_code &ec, size_t n) {
        read_in_flight = false;
        if (ec) {
            if (is_closed()) return;
            fail(describe_receive_error(ec), true, peer_ended(ec));
            return;
        }
        {
            std::lock_guard lock(mutex);
            stats.wire_bytes_received += n;
        }
        std::vector<Message> messages;
        const bool good = decoder.feed(std::span<const uint8_t>(read_buffer.data(), n), messages);
        {
            std::lock_guard lock(mutex);
            stats.messages_skipped = decoder.skipped();
        }
        if (!deliver(messages)) return;
        if (!good) {
            fail("protocol error: " + decoder.error());
            return;
        }
        read_some();
    }

    // Whether `ec` of a read or a write is the peer ending the connection between two messages: its
    // EOF (a TLS close_notify reads as one), a TLS peer closing without close_notify, or a reset
    // (a peer that closes with bytes of ours unread resets, and a write after that fails with EPIPE).
    bool peer_ended(const asio::error_code &ec) const {
        const bool ended = ec == asio::error::eof || (tls && ec == asio::ssl::error::stream_truncated) ||
                           ec == asio::error::connection_reset || ec == asio::error::broken_pipe;
        return ended && decoder.at_message_boundary();
    }

    std::string describe_receive_error(const asio::error_code &ec) const {
        // A TLS peer that closes its socket without a close_notify: the framing, not TLS, tells
        // whether a message was cut short.
        if (ec == asio::error::eof || (tls && ec == asio::ssl::error::stream_truncated)) {
            if (!decoder.at_message_boundary())
                return "peer closed the connection in the middle of a message (stream offset " +
                       std::to_string(decoder.stream_offset()) + ")";
            return "peer closed the connection";
        }
        if (ec == asio::error::connection_reset) return "connection reset by peer";
        if (tls && ec.category() == asio::error::get_ssl_category())
            return "receive failed: TLS: " + describe_tls_error(ec, tls_server);
        return "receive failed: " + ec.message();
    }

    // Hands messages over; false if the connection closed meanwhile.
    bool deliver(std::vector<Message> &messages) {
        if (messages.empty()) return !is_closed();
        {
            std::lock_guard lock(mutex);
            if (closed) return false;
            stats.messages_received += messages.size();
            if (!on_message_handler) {
                for (Message &message : messages) {
                    receive_bytes += message.payload.size();
                    inbound.push_back(std::move(message));
                }
                if (receive_bytes > options.receive_queue_limit) read_paused = true;
                receive_cv.notify_all();
                return true;
            }
        }
        // Callback mode. The handler is set before reading starts and cleared only when the I/O
        // thread ends, so it can be called without the lock (and may call close() itself).
        for (Message &message : messages) {
            if (is_closed()) return false;
            try {
                on_message_handler(std::move(message));
            } catch (const std::exception &e) {
                fail(std::string("the message handler threw: ") + e.what());
                return false;
            } catch (...) {
                fail("the message handler threw");
                return false;
            }
        }
        return !is_closed();
    }

    // Consumer side of the inbound queue; `lock` holds `mutex`.
    Message pop_inbound([[maybe_unused]] std::unique_lock<std::mutex> &lock) {
        Message message = std::move(inbound.front());
        inbound.pop_front();
        receive_bytes -= message.payload.size();
        if (read_paused && !closed && receive_bytes <= options.receive_queue_limit / 2) {
            read_paused = false;
            asio::post(io, [this] { read_some(); });
        }
        return message;
    }

    // --- sending ------------------------------------------------------------------------------

    // A payload made ready for the queue: compressed when that pays, else moved (or copied) as is.
    struct Prepared {
        Outgoing out;
        bool compressed = false;
        size_t raw_size = 0;
    };

    std::shared_ptr<Compressor> current_compressor() {
        std::lock_guard lock(mutex);
        return closed ? nullptr : compressor;
    }

    // `owned`, when given, holds the payload and may be moved from (no copy when sent raw).
    static Prepared prepare(Compressor &active, std::span<const uint8_t> payload,
                            std::vector<uint8_t> *owned) {
        Prepared prepared;
        prepared.raw_size = payload.size();
        prepared.compressed = active.compress_if_pays(payload, prepared.out.payload);
        if (!prepared.compressed) {
            if (owned)
                prepared.out.payload = std::move(*owned);
            else
                prepared.out.payload.assign(payload.begin(), payload.end());
        }
        prepared.out.bytes = kHeaderSize + prepared.out.payload.size();
        return prepared;
    }

    SendResult send(uint16_t type, std::span<const uint8_t> payload, std::vector<uint8_t> *owned,
                    std::chrono::milliseconds wait) {
        if (payload.size() > options.max_payload) return SendResult::TooLarge;
        const std::shared_ptr<Compressor> active = current_compressor();
        if (!active) return SendResult::Closed;
        Prepared prepared = prepare(*active, payload, owned);
        return enqueue(type, prepared, owned, wait);
    }

    // Compresses on `workers` threads while this thread queues the results in their order, so the
    // I/O thread writes the first messages while later ones are still being compressed. Worth it
    // for a resync's snapshot (tens of MiB, docs/architecture.md §6), where one thread's zstd was most of the
    // time to the new agent's first frame.
    SendResult send_all(std::vector<OutboundMessage> &messages, std::chrono::milliseconds wait,
                        unsigned workers) {
        for (const OutboundMessage &message : messages)
            if (message.payload.size() > options.max_payload) return SendResult::TooLarge;
        const std::shared_ptr<Compressor> active = current_compressor();
        if (!active) return SendResult::Closed;

        std::vector<Prepared> prepared(messages.size());
        std::vector<char> ready(messages.size(), 0);
        std::mutex ready_mutex;
        std::condition_variable ready_cv;
        std::atomic<size_t> next{0};
        std::atomic<bool> abandon{false};
        const auto compress_next = [&] {
            for (size_t i = next.fetch_add(1); i < messages.size() && !abandon.load();
                 i = next.fetch_add(1)) {
                Prepared done = prepare(*active, messages[i].payload, &messages[i].payload);
                std::lock_guard lock(ready_mutex);
                prepared[i] = std::move(done);
                ready[i] = 1;
                ready_cv.notify_all();
            }
        };
        std::vector<std::thread> threads;
        workers =
            std::clamp<unsigned>(workers, 1, static_cast<unsigned>(std::max<size_t>(messages.size(), 1)));
        for (unsigned t = 0; t < workers; ++t)
            threads.emplace_back(compress_next);

        SendResult result = SendResult::Queued;
        for (size_t i = 0; i < messages.size() && result == SendResult::Queued; ++i) {
            {
                std::unique_lock lock(ready_mutex);
                ready_cv.wait(lock, [&] { return ready[i] != 0; });
            }
            result = enqueue(to_wire(messages[i].type), prepared[i], nullptr, wait);
        }
        abandon.store(true);
        for (std::thread &worker : threads)
            worker.join();
        return result;
    }

    // On refusal the caller keeps its data: a raw payload goes back into `owned`.
    SendResult enqueue(uint16_t type, Prepared &prepared, std::vector<uint8_t> *owned,
                       std::chrono::milliseconds wait) {
        Outgoing &out = prepared.out;
        // The I/O thread drains the queue: waiting on it from a handler would only time out.
        if (on_io_thread()) wait = std::chrono::milliseconds(0);
        const auto give_back = [&] {
            if (owned && !prepared.compressed) *owned = std::move(out.payload);
        };

        std::unique_lock lock(mutex);
        const auto has_room = [&] {
            return closed || send_bytes == 0 || send_bytes + out.bytes <= options.send_queue_limit;
        };
        if (!has_room()) {
            if (wait.count() <= 0 || !send_cv.wait_for(lock, wait, has_room)) {
                give_back();
                return SendResult::QueueFull;
            }
        }
        if (closed) {
            give_back();
            return SendResult::Closed;
        }
        MessageHeader header;
        header.payload_length = static_cast<uint32_t>(out.payload.size());
        header.type = type;
        header.flags = prepared.compressed ? kFlagCompressed : 0;
        header.sequence = next_sequence++;
        out.header = encode_header(header);
        send_bytes += out.bytes;
        stats.messages_sent += 1;
        stats.payload_bytes_sent += prepared.raw_size;
        if (prepared.compressed) stats.compressed_messages_sent += 1;
        send_queue.push_back(std::move(out));
        if (!write_scheduled) {
            write_scheduled = true;
            asio::post(io, [this] { write_some(); });
        }
        return SendResult::Queued;
    }

    void write_some() {
        {
            std::lock_guard lock(mutex);
            if (closed || send_queue.empty()) {
                write_scheduled = false;
                return;
            }
            // std::deque keeps elements in place when others are appended, so the buffers stay
            // valid while send() keeps queueing.
            writing = std::min(send_queue.size(), kMaxWriteBatch);
            write_buffers.clear();
            if (tls) {
                stage_for_tls();
            } else {
                for (size_t i = 0; i < writing; ++i) {
                    const Outgoing &out = send_queue[i];
                    write_buffers.push_back(asio::buffer(out.header));
                    if (!out.payload.empty()) write_buffers.push_back(asio::buffer(out.payload));
                }
            }
        }
        const auto on_done = [this](const asio::error_code &ec, size_t n) { on_written(ec, n); };
        if (tls)
            asio::async_write(*tls, write_buffers, on_done);
        else
            asio::async_write(socket, write_buffers, on_done);
    }

    // Under `mutex`: the first of `writing` messages that fit kTlsStageBytes, copied into one
    // buffer; a larger first message goes alone and uncopied. Sets `writing` to what was taken.
    void stage_for_tls() {
        const Outgoing &first = send_queue.front();
        if (first.bytes > kTlsStageBytes) {
            writing = 1;
            write_buffers.push_back(asio::buffer(first.header));
            if (!first.payload.empty()) write_buffers.push_back(asio::buffer(first.payload));
            return;
        }
        tls_staging.clear();
        size_t taken = 0;
        for (; taken < writing; ++taken) {
            const Outgoing &out = send_queue[taken];
            if (tls_staging.size() + out.bytes > kTlsStageBytes) break;
            tls_staging.insert(tls_staging.end(), out.header.begin(), out.header.end());
            tls_staging.insert(tls_staging.end(), out.payload.begin(), out.payload.end());
        }
        writing = taken;
        write_buffers.push_back(asio::buffer(tls_staging));
    }

    void on_written(const asio::error_code &ec, size_t n) {
        if (ec) {
            if (is_closed()) return;
            fail(ec == asio::error::broken_pipe || ec == asio::error::connection_reset
                     ? "connection reset by peer (while sending)"
                     : "send failed: " + ec.message(),
                 true, peer_ended(ec));
            return;
        }
        {
            std::lock_guard lock(mutex);
            for (size_t i = 0; i < writing; ++i) {
                send_bytes -= send_queue.front().bytes;
                send_queue.pop_front();
            }
            writing = 0;
            stats.wire_bytes_sent += n;
            send_cv.notify_all();
        }
        write_some();
    }

    bool is_closed() const {
        std::lock_guard lock(mutex);
        return closed;
    }

    // --- TLS ----------------------------------------------------------------------------------

    // Shakes hands over the connected socket, on the I/O thread, and waits at most `timeout` for
    // it. Empty when TLS 1.3 is up; else one line (the client's own refusal of the agent's
    // certificate, when that is what failed). Before start(): nothing else runs on the socket.
    std::string handshake(std::shared_ptr<TlsContext> context, std::chrono::milliseconds timeout) {
        struct Attempt {
            explicit Attempt(asio::io_context &io) : timer(io) {}
            std::promise<std::string> done;
            asio::steady_timer timer;
            bool timed_out = false;
            bool finished = false;
        };
        auto attempt = std::make_shared<Attempt>(io);
        auto outcome = attempt->done.get_future();
        tls_context = std::move(context);
        tls_server = tls_context->is_server();
        asio::post(io, [this, attempt, timeout] {
            tls.emplace(socket, tls_context->impl().context);
            if (!tls_server) SSL_set_ex_data(tls->native_handle(), tls_peer_check_index(), &peer_check);
            attempt->timer.expires_after(timeout);
            attempt->timer.async_wait([this, attempt](const asio::error_code &ec) {
                if (ec || attempt->finished) return;
                attempt->timed_out = true;
                asio::error_code ignored;
                socket.close(ignored); // aborts the handshake in progress
            });
            tls->async_handshake(
                tls_server ? asio::ssl::stream_base::server : asio::ssl::stream_base::client,
                [this, attempt, timeout](const asio::error_code &ec) {
                    attempt->finished = true;
                    attempt->timer.cancel();
                    std::string result;
                    if (attempt->timed_out) {
                        result = "the TLS handshake did not finish within " +
                                 std::to_string(timeout.count()) + " ms";
                    } else if (!tls_server && peer_check.decided && !peer_check.refusal.empty()) {
                        result = peer_check.refusal;
                    } else if (ec) {
                        result = "TLS handshake failed: " + describe_tls_error(ec, tls_server);
                    } else if (SSL_version(tls->native_handle()) != TLS1_3_VERSION) {
                        result = std::string("TLS handshake failed: negotiated ") +
                                 SSL_get_version(tls->native_handle()) + ", not TLS 1.3";
                    } else {
                        std::lock_guard lock(mutex);
                        security = std::string("TLS 1.3 (") + SSL_get_cipher_name(tls->native_handle()) + ")";
                    }
                    attempt->done.set_value(std::move(result));
                });
        });
        return outcome.get();
    }

    // --- state --------------------------------------------------------------------------------

    ConnectionOptions options;
    asio::io_context io{1};
    tcp::socket socket;
    std::optional<asio::executor_work_guard<asio::io_context::executor_type>> work;
    std::thread thread;
    std::atomic<std::thread::id> io_thread_id{};
    std::mutex close_mutex; // serialises close() / join

    // I/O thread only.
    FrameDecoder decoder;
    std::vector<uint8_t> read_buffer;
    bool read_in_flight = false;
    std::vector<asio::const_buffer> write_buffers;
    size_t writing = 0; // messages at the queue's front in the write in flight
    // TLS: set up by handshake() before start(), then used by the I/O thread only. The stream
    // refers to `socket`, declared above it, so it goes first.
    std::shared_ptr<TlsContext> tls_context; // keeps the SSL_CTX and its verifier alive
    bool tls_server = false;
    std::optional<asio::ssl::stream<tcp::socket &>> tls;
    TlsPeerCheck peer_check;
    std::vector<uint8_t> tls_staging;

    // Guarded by mutex.
    mutable std::mutex mutex;
    std::condition_variable send_cv;    // room in the send queue, drained, or closed
    std::condition_variable receive_cv; // an inbound message, or closed
    bool closed = false;
    bool started = false;
    std::string close_reason;
    bool closed_by_peer = false;
    ClosedHandler on_closed_handler;
    MessageHandler on_message_handler;
    std::shared_ptr<Compressor> compressor;
    std::deque<Outgoing> send_queue;
    size_t send_bytes = 0;
    uint64_t next_sequence = 1;
    bool write_scheduled = false;
    std::deque<Message> inbound;
    size_t receive_bytes = 0;
    bool read_paused = false;
    ConnectionStats stats;
    std::string peer;
    std::string local;
    std::string security = "plaintext";
    int native_fd = -1; // set once before the I/O thread runs the socket; diagnostics only
    const pid_t owner_pid = ::getpid();
    bool abandoned = false; // in a forked child only
};

// ---------------------------------------------------------------------------------------------

Connection::Connection(std::shared_ptr<Impl> impl) : impl_(std::move(impl)) {}

// In a child forked while this connection existed, its I/O thread does not exist and its mutexes
// may have been copied mid-use: touch nothing. Drop this process's copy of the socket (the parent's
// stays open and registered in the parent's reactor) and leak the state rather than join a thread
// that is not there.
bool Connection::abandon_if_forked() {
    if (::getpid() == impl_->owner_pid) return false;
    if (!impl_->abandoned) {
        impl_->abandoned = true;
        if (impl_->native_fd >= 0) ::close(impl_->native_fd);
        new std::shared_ptr<Impl>(impl_); // deliberately leaked
    }
    return true;
}

Connection::~Connection() {
    if (abandon_if_forked()) return;
    if (impl_->on_io_thread()) {
        // Destroyed from its own handler: close without joining ourselves. The thread holds a
        // reference to the state and releases it when it ends.
        impl_->fail("connection destroyed", false);
        std::lock_guard close_lock(impl_->close_mutex);
        if (impl_->thread.joinable()) impl_->thread.detach();
        return;
    }
    impl_->close("connection destroyed");
}

Result<std::unique_ptr<Connection>> Connection::connect(const std::string &host, uint16_t port,
                                                        std::chrono::milliseconds timeout,
                                                        ConnectionOptions options) {
    auto impl = std::make_shared<Impl>(std::move(options));
    const std::string target = host.find(':') != std::string::npos ? "[" + host + "]:" + std::to_string(port)
                                                                   : host + ":" + std::to_string(port);
    tcp::resolver::results_type endpoints;
    {
        tcp::resolver resolver(impl->io);
        asio::error_code ec;
        endpoints = resolver.resolve(host, std::to_string(port), tcp::resolver::numeric_service, ec);
        if (ec) return Error{"cannot resolve '" + host + "': " + ec.message()};
    }

    struct Attempt {
        explicit Attempt(asio::io_context &io) : timer(io) {}
        std::promise<asio::error_code> done;
        asio::steady_timer timer;
        bool timed_out = false;
        bool finished = false;
    };
    // Only the I/O thread holds the attempt, so the timer is created, used and destroyed there
    // (apart from its construction, before anything runs).
    auto attempt = std::make_shared<Attempt>(impl->io);
    auto outcome = attempt->done.get_future();
    Impl *state = impl.get();
    impl->start_thread();
    asio::post(impl->io, [state, attempt = std::move(attempt), endpoints = std::move(endpoints), timeout] {
        attempt->timer.expires_after(timeout);
        attempt->timer.async_wait([state, attempt](const asio::error_code &ec) {
            if (ec || attempt->finished) return;
            attempt->timed_out = true;
            asio::error_code ignored;
            state->socket.close(ignored); // aborts the connect in progress
        });
        asio::async_connect(state->socket, endpoints,
                            [state, attempt](const asio::error_code &ec, const tcp::endpoint &) {
                                attempt->finished = true;
                                attempt->timer.cancel();
                                asio::error_code result = attempt->timed_out ? asio::error::timed_out : ec;
                                if (!result) {
                                    asio::error_code ignored;
                                    state->socket.set_option(tcp::no_delay(true), ignored);
                                    set_cloexec(state->socket.native_handle());
                                    std::lock_guard lock(state->mutex);
                                    state->peer = format_endpoint(state->socket.remote_endpoint(ignored));
                                    state->local = format_endpoint(state->socket.local_endpoint(ignored));
                                }
                                attempt->done.set_value(result);
                            });
    });
    const asio::error_code ec = outcome.get();
    if (!ec) impl->native_fd = impl->socket.native_handle();
    if (ec) {
        impl->close("connect failed");
        if (ec == asio::error::timed_out)
            return Error{"connection to " + target + " timed out after " + std::to_string(timeout.count()) +
                         " ms"};
        return Error{"cannot connect to " + target + ": " + ec.message()};
    }
    if (impl->options.tls) {
        if (impl->options.tls->is_server()) {
            impl->close("TLS context of the wrong side");
            return Error{"connect: a server TLS context"};
        }
        const std::string failed = impl->handshake(impl->options.tls, impl->options.tls_handshake_timeout);
        if (!failed.empty()) {
            impl->close("TLS handshake failed");
            return Error{failed};
        }
    }
    return std::unique_ptr<Connection>(new Connection(std::move(impl)));
}

Result<std::unique_ptr<Connection>> Connection::adopt(UniqueFd socket, ConnectionOptions options) {
    if (!socket) return Error{"adopt: no socket"};
    sockaddr_storage address{};
    socklen_t length = sizeof(address);
    if (::getsockname(socket.get(), reinterpret_cast<sockaddr *>(&address), &length) != 0)
        return Error{std::string("adopt: not a socket: ") + std::strerror(errno)};
    int type = 0;
    socklen_t type_length = sizeof(type);
    if (::getsockopt(socket.get(), SOL_SOCKET, SO_TYPE, &type, &type_length) != 0 || type != SOCK_STREAM ||
        (address.ss_family != AF_INET && address.ss_family != AF_INET6))
        return Error{"adopt: not a TCP socket"};

    auto impl = std::make_shared<Impl>(std::move(options));
    asio::error_code ec;
    impl->socket.assign(address.ss_family == AF_INET6 ? tcp::v6() : tcp::v4(), socket.get(), ec);
    if (ec) return Error{"adopt: " + ec.message()};
    const int fd = socket.release(); // owned by the asio socket now
    impl->native_fd = fd;
    set_cloexec(fd);
    impl->socket.set_option(tcp::no_delay(true), ec);
    impl->peer = format_endpoint(impl->socket.remote_endpoint(ec));
    if (ec) impl->peer = "?";
    impl->local = format_endpoint(impl->socket.local_endpoint(ec));
    impl->start_thread();
    if (impl->options.tls) {
        if (!impl->options.tls->is_server()) {
            impl->close("TLS context of the wrong side");
            return Error{"adopt: a client TLS context"};
        }
        const std::string failed = impl->handshake(impl->options.tls, impl->options.tls_handshake_timeout);
        if (!failed.empty()) {
            impl->close("TLS handshake failed");
            return Error{failed};
        }
    }
    return std::unique_ptr<Connection>(new Connection(std::move(impl)));
}

void Connection::start(ClosedHandler on_closed, MessageHandler on_message) {
    std::string already_closed;
    {
        std::lock_guard lock(impl_->mutex);
        if (impl_->started) return;
        impl_->started = true;
        impl_->on_closed_handler = std::move(on_closed);
        impl_->on_message_handler = std::move(on_message);
        if (impl_->closed) already_closed = impl_->close_reason;
    }
    if (!already_closed.empty()) {
        if (impl_->on_closed_handler) impl_->on_closed_handler(already_closed);
        return;
    }
    Impl *state = impl_.get();
    asio::post(impl_->io, [state] { state->read_some(); });
}

SendResult Connection::send(uint16_t type, std::span<const uint8_t> payload,
                            std::chrono::milliseconds wait_for_space) {
    return impl_->send(type, payload, nullptr, wait_for_space);
}

SendResult Connection::send_owned(uint16_t type, std::vector<uint8_t> &&payload,
                                  std::chrono::milliseconds wait_for_space) {
    const std::span<const uint8_t> view(payload);
    return impl_->send(type, view, &payload, wait_for_space);
}

SendResult Connection::send_all(std::vector<OutboundMessage> &&messages,
                                std::chrono::milliseconds wait_for_space, unsigned workers) {
    return impl_->send_all(messages, wait_for_space, workers);
}

std::optional<Message> Connection::try_receive() {
    std::unique_lock lock(impl_->mutex);
    if (impl_->inbound.empty()) return std::nullopt;
    return impl_->pop_inbound(lock);
}

std::optional<Message> Connection::receive(std::chrono::milliseconds timeout) {
    std::unique_lock lock(impl_->mutex);
    impl_->receive_cv.wait_for(lock, timeout, [&] { return !impl_->inbound.empty() || impl_->closed; });
    if (impl_->inbound.empty()) return std::nullopt;
    return impl_->pop_inbound(lock);
}

bool Connection::wait_for_room(size_t bytes, std::chrono::milliseconds timeout) {
    if (impl_->on_io_thread()) timeout = std::chrono::milliseconds(0); // it cannot drain while we wait
    std::unique_lock lock(impl_->mutex);
    const auto has_room = [&] {
        return impl_->closed || impl_->send_bytes == 0 ||
               impl_->send_bytes + bytes <= impl_->options.send_queue_limit;
    };
    return has_room() || (timeout.count() > 0 && impl_->send_cv.wait_for(lock, timeout, has_room));
}

bool Connection::flush(std::chrono::milliseconds timeout) {
    if (impl_->on_io_thread()) timeout = std::chrono::milliseconds(0); // it cannot drain while we wait
    std::unique_lock lock(impl_->mutex);
    impl_->send_cv.wait_for(lock, timeout, [&] { return impl_->send_queue.empty() || impl_->closed; });
    return impl_->send_queue.empty();
}

void Connection::close(std::string_view reason) {
    if (abandon_if_forked()) return;
    impl_->close(reason);
}

bool Connection::is_open() const {
    return !impl_->is_closed();
}

std::string Connection::close_reason() const {
    std::lock_guard lock(impl_->mutex);
    return impl_->close_reason;
}

bool Connection::closed_by_peer() const {
    std::lock_guard lock(impl_->mutex);
    return impl_->closed_by_peer;
}

std::string Connection::peer_address() const {
    std::lock_guard lock(impl_->mutex);
    return impl_->peer;
}

std::string Connection::local_address() const {
    std::lock_guard lock(impl_->mutex);
    return impl_->local;
}

std::string Connection::security() const {
    std::lock_guard lock(impl_->mutex);
    return impl_->security;
}

ConnectionStats Connection::stats() const {
    std::lock_guard lock(impl_->mutex);
    ConnectionStats stats = impl_->stats;
    stats.send_queue_bytes = impl_->send_bytes;
    stats.receive_queue_bytes = impl_->receive_bytes;
    return stats;
}

int Connection::native_handle() const {
    return impl_->native_fd;
}

void Connection::set_compression(CompressionPolicy policy) {
    auto compressor = std::make_shared<Compressor>(policy);
    std::lock_guard lock(impl_->mutex);
    impl_->compressor = std::move(compressor);
}

// ---------------------------------------------------------------------------------------------

Result<std::unique_ptr<Acceptor>> Acceptor::listen(const std::string &host, uint16_t port, int backlog) {
    addrinfo hints{};
    hints.ai_family = AF_UNSPEC;
    hints.ai_socktype = SOCK_STREAM;
    hints.ai_flags = AI_PASSIVE | AI_NUMERICSERV;
    addrinfo *found = nullptr;
    const std::string service = std::to_string(port);
    const int status = ::getaddrinfo(host.empty() ? nullptr : host.c_str(), service.c_str(), &hints, &found);
    if (status != 0) return Error{"cannot resolve '" + host + "': " + ::gai_strerror(status)};

    std::string last_error = "no address";
    std::unique_ptr<Acceptor> acceptor(new Acceptor());
    for (addrinfo *ai = found; ai; ai = ai->ai_next) {
        UniqueFd fd(::socket(ai->ai_family, ai->ai_socktype | SOCK_CLOEXEC | SOCK_NONBLOCK, ai->ai_protocol));
        if (!fd) {
            last_error = std::strerror(errno);
            continue;
        }
        const int one = 1;
        ::setsockopt(fd.get(), SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one));
        if (::bind(fd.get(), ai->ai_addr, ai->ai_addrlen) != 0 || ::listen(fd.get(), backlog) != 0) {
            last_error = std::strerror(errno);
            continue;
        }
        sockaddr_storage bound{};
        socklen_t length = sizeof(bound);
        ::getsockname(fd.get(), reinterpret_cast<sockaddr *>(&bound), &length);
        acceptor->port_ =
            ntohs(bound.ss_family == AF_INET6 ? reinterpret_cast<sockaddr_in6 *>(&bound)->sin6_port
                                              : reinterpret_cast<sockaddr_in *>(&bound)->sin_port);
        acceptor->fd_ = std::move(fd);
        break;
    }
    ::freeaddrinfo(found);
    if (!acceptor->fd_) return Error{"cannot listen on " + host + ":" + service + ": " + last_error};
    return acceptor;
}

Acceptor::~Acceptor() = default;

std::string Acceptor::local_address() const {
    sockaddr_storage bound{};
    socklen_t length = sizeof(bound);
    if (!fd_ || ::getsockname(fd_.get(), reinterpret_cast<sockaddr *>(&bound), &length) != 0) return "?";
    return format_sockaddr(bound);
}

Result<UniqueFd> Acceptor::accept(std::chrono::milliseconds timeout) {
    if (!fd_) return Error{"accept: the acceptor is closed"};
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    for (;;) {
        int wait_ms = -1;
        if (timeout.count() >= 0) {
            const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
                deadline - std::chrono::steady_clock::now());
            wait_ms = static_cast<int>(std::clamp<int64_t>(left.count(), 0, INT32_MAX));
        }
        pollfd entry{fd_.get(), POLLIN, 0};
        const int ready = ::poll(&entry, 1, wait_ms);
        if (ready < 0) {
            if (errno == EINTR) continue;
            return Error{std::string("accept: poll: ") + std::strerror(errno)};
        }
        if (ready == 0) return UniqueFd(); // timed out
        UniqueFd fd(::accept4(fd_.get(), nullptr, nullptr, SOCK_CLOEXEC));
        if (!fd) {
            // The pending connection went away, or a signal: wait again.
            if (errno == EAGAIN || errno == EWOULDBLOCK || errno == ECONNABORTED || errno == EINTR ||
                errno == EPROTO)
                continue;
            return Error{std::string("accept: ") + std::strerror(errno)};
        }
        const int one = 1;
        ::setsockopt(fd.get(), IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
        return fd;
    }
}

// ---------------------------------------------------------------------------------------------

Result<Welcome> client_handshake(Connection &connection, const Hello &hello,
                                 std::chrono::milliseconds timeout) {
    const auto sent = connection.send(MessageType::Hello, encode_hello(hello));
    if (sent != SendResult::Queued) return Error{std::string("cannot send Hello: ") + to_string(sent)};
    auto message = connection.receive(timeout);
    if (!message) {
        if (!connection.is_open())
            return Error{"connection closed during the handshake: " + connection.close_reason()};
        return Error{"no answer to Hello within " + std::to_string(timeout.count()) + " ms"};
    }
    if (message->type == to_wire(MessageType::Reject)) {
        auto reject = decode_reject(message->payload);
        if (!reject) return Error{"server rejected the session with a malformed Reject: " + reject.error()};
        return Error{std::string("server rejected the session: ") + to_string(reject->reason) + ": " +
                     reject->message};
    }
    if (message->type != to_wire(MessageType::Welcome))
        return Error{std::string("unexpected ") + message_type_name(message->type) + " (type " +
                     hex16(message->type) + ") before Welcome"};
    auto welcome = decode_welcome(message->payload);
    if (!welcome) return Error{welcome.error()};
    if (const std::string problem = check_welcome(hello, *welcome); !problem.empty()) return Error{problem};
    return welcome;
}

Result<ServerHandshake> server_handshake(Connection &connection, const ServerHandshakeConfig &config,
                                         std::chrono::milliseconds timeout) {
    const auto reject = [&](RejectReason reason, const std::string &line) -> Error {
        connection.send(MessageType::Reject, encode_reject(Reject{reason, line}));
        connection.flush(std::chrono::seconds(1));
        return Error{std::string("rejected the client: ") + to_string(reason) + ": " + line};
    };
    auto message = connection.receive(timeout);
    if (!message) {
        if (!connection.is_open())
            return Error{"connection closed before Hello: " + connection.close_reason()};
        return Error{"no Hello within " + std::to_string(timeout.count()) + " ms"};
    }
    if (message->type != to_wire(MessageType::Hello))
        return reject(RejectReason::Malformed, std::string("expected Hello first, got ") +
                                                   message_type_name(message->type) + " (type " +
                                                   hex16(message->type) + ")");
    auto hello = decode_hello(message->payload);
    if (!hello) return reject(RejectReason::Malformed, hello.error());
    auto decision = evaluate_hello(*hello, config);
    if (const Reject *refusal = std::get_if<Reject>(&decision))
        return reject(refusal->reason, refusal->message);
    ServerHandshake result{std::move(hello).value(), std::get<Welcome>(std::move(decision))};
    const auto sent = connection.send(MessageType::Welcome, encode_welcome(result.welcome));
    if (sent != SendResult::Queued) return Error{std::string("cannot send Welcome: ") + to_string(sent)};
    return result;
}

} // namespace splitvk::protocol
