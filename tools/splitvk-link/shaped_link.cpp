#include "shaped_link.h"

#include <algorithm>
#include <bit>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <deque>
#include <memory>

#include <poll.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/uio.h>
#include <time.h>

namespace splitvk::link {
namespace {

using namespace std::chrono_literals;
// CLOCK_MONOTONIC: the clock ppoll() measures its timeout on, so deadlines and sleeps agree.
using Clock = std::chrono::steady_clock;

// The longest a chunk may take to serialise: the model's time granularity (see the header).
constexpr std::chrono::nanoseconds kQuantum = 100us;
constexpr size_t kMinChunk = 1500;           // one Ethernet frame: slow links still send packets
constexpr size_t kUnshapedChunk = 256 << 10; // no rate: as much as one read returns
// How far ahead of the serialiser the link reads. Reading early changes no timestamp (a chunk read
// early starts when the serialiser frees up); it only keeps the serialiser busy when this thread
// wakes up late, which on a loaded 2-core machine can take a few milliseconds.
constexpr std::chrono::nanoseconds kLead = 5ms;
// Waking from ppoll() on a VM takes 20-130 us longer than asked, more after a long sleep (measured on
// the 2-core development VM, timer slack 1 ns). So a wait longer than kSpinAbove ends kSpinWindow
// early and polls without sleeping until the deadline: at most 0.15 ms of a core per wait, paid
// only by sparse traffic (a message, a frame's tiles), where a late wake-up would be the whole
// error. Back-to-back chunks wait less than kSpinAbove and never spin; they are late by the short
// sleep's 20-30 us.
constexpr std::chrono::nanoseconds kSpinAbove = 500us;
constexpr std::chrono::nanoseconds kSpinWindow = 150us;
constexpr size_t kMinCapacity = 256 << 10;
// A link with a delay and no rate holds delay x (whatever loopback carries) in flight; this caps it,
// and with it such a link's throughput at 64 MiB per delay (about 33 GB/s at 2 ms).
constexpr size_t kMaxCapacity = 64 << 20;

std::chrono::nanoseconds serialisation_time(uint64_t bytes, uint64_t rate_bps) {
    // bytes <= kMaxCapacity keeps bytes * 8e9 far below 2^64.
    return std::chrono::nanoseconds(bytes * 8 * 1'000'000'000 / rate_bps);
}

timespec to_timespec(std::chrono::nanoseconds d) {
    const auto seconds = std::chrono::duration_cast<std::chrono::seconds>(d);
    return {static_cast<time_t>(seconds.count()), static_cast<long>((d - seconds).count())};
}

// Writes ring bytes [begin, end) (positions count every byte ever read; the ring wraps at mask+1).
bool write_all(int fd, const uint8_t *ring, size_t mask, uint64_t begin, uint64_t end) {
    while (begin < end) {
        const size_t at = begin & mask;
        const size_t first = std::min<uint64_t>(end - begin, mask + 1 - at);
        iovec iov[2] = {{const_cast<uint8_t *>(ring + at), first},
                        {const_cast<uint8_t *>(ring), static_cast<size_t>(end - begin - first)}};
        msghdr message{};
        message.msg_iov = iov;
        message.msg_iovlen = iov[1].iov_len ? 2 : 1;
        const ssize_t n = ::sendmsg(fd, &message, MSG_NOSIGNAL);
        if (n < 0) {
            if (errno == EINTR) continue;
            return false;
        }
        begin += static_cast<uint64_t>(n);
    }
    return true;
}

// When the bytes just read reached this socket: the kernel's receive timestamp of the last of them
// (SO_TIMESTAMPNS, on CLOCK_REALTIME, moved onto the steady clock). Taking the time after the read
// instead would add the wake-up from ppoll, 20-60 us here, to every arrival.
Clock::time_point arrival_time(msghdr &message) {
    const Clock::time_point now = Clock::now();
    for (cmsghdr *c = CMSG_FIRSTHDR(&message); c; c = CMSG_NXTHDR(&message, c)) {
        if (c->cmsg_level != SOL_SOCKET || c->cmsg_type != SCM_TIMESTAMPNS) continue;
        timespec stamp;
        std::memcpy(&stamp, CMSG_DATA(c), sizeof(stamp));
        if (stamp.tv_sec == 0 && stamp.tv_nsec == 0) break; // arrived before timestamps were on
        timespec real;
        ::clock_gettime(CLOCK_REALTIME, &real);
        const auto age = std::chrono::seconds(real.tv_sec - stamp.tv_sec) +
                         std::chrono::nanoseconds(real.tv_nsec - stamp.tv_nsec);
        // A negative age is the wall clock stepping back; an old one a backlog this link let wait.
        return now - std::clamp<std::chrono::nanoseconds>(age, {}, kLead);
    }
    return now;
}

} // namespace

void enable_arrival_timestamps(int fd) {
    const int one = 1;
    ::setsockopt(fd, SOL_SOCKET, SO_TIMESTAMPNS, &one, sizeof(one));
}

const char *to_string(LinkEnd end) {
    switch (end) {
    case LinkEnd::Eof:
        return "closed";
    case LinkEnd::ReadError:
        return "reset";
    case LinkEnd::WriteError:
        return "undeliverable";
    }
    return "?";
}

ShapedLink::ShapedLink(const LinkShape &shape) : shape_(shape) {
    if (shape_.rate_bps == 0) {
        chunk_ = kUnshapedChunk;
        capacity_ = shape_.delay.count() ? kMaxCapacity : 2 * kUnshapedChunk;
        return;
    }
    const double bytes_per_ns = static_cast<double>(shape_.rate_bps) / 8e9;
    chunk_ = std::clamp<size_t>(static_cast<size_t>(bytes_per_ns * static_cast<double>(kQuantum.count())),
                                kMinChunk, kUnshapedChunk);
    // In flight at most: what the pipe holds (delay), what the serialiser was handed ahead of time
    // (kLead) and the chunk it was handed last, plus one chunk of slack for a late wake-up.
    const double in_flight =
        bytes_per_ns * static_cast<double>((shape_.delay + kLead).count()) + static_cast<double>(3 * chunk_);
    capacity_ = std::bit_ceil(std::clamp<size_t>(static_cast<size_t>(in_flight), kMinCapacity, kMaxCapacity));
}

LinkEnd ShapedLink::run(int from, int to) {
    // The default slack of 50 us lets the kernel merge timer expiries that far apart; the model's
    // precision is 100 us. This applies to the calling thread only.
    ::prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL);

    struct Chunk {
        Clock::time_point due; // when its last byte reaches the other end
        uint64_t end;          // ring position one past its last byte
    };
    const auto ring = std::make_unique_for_overwrite<uint8_t[]>(capacity_);
    const size_t mask = capacity_ - 1;
    std::deque<Chunk> in_flight;
    uint64_t read_end = 0;    // bytes read from `from`
    uint64_t written_end = 0; // bytes written to `to`
    Clock::time_point serialiser_free{};
    Clock::time_point spin_until{}; // the deadline whose long wait ended early
    bool eof = false;
    LinkEnd end = LinkEnd::Eof;

    for (;;) {
        const Clock::time_point now = Clock::now();
        uint64_t due_end = written_end;
        while (!in_flight.empty() && in_flight.front().due <= now) {
            due_end = in_flight.front().end;
            in_flight.pop_front();
        }
        if (due_end > written_end) {
            // Everything due goes in one write: chunks that came due together (a late wake-up, or
            // back-to-back chunks at a high rate) cost one system call, not one each.
            if (!write_all(to, ring.get(), mask, written_end, due_end)) return LinkEnd::WriteError;
            written_end = due_end;
            delivered_.store(written_end, std::memory_order_relaxed);
            continue;
        }
        if (eof && in_flight.empty()) return end;

        const bool room = read_end - written_end < capacity_;
        const bool serialiser_ready = shape_.rate_bps == 0 || serialiser_free - now <= kLead;
        const bool want_read = !eof && room && serialiser_ready;
        Clock::time_point wake = Clock::time_point::max();
        if (!in_flight.empty()) wake = in_flight.front().due;
        if (!eof && room && !serialiser_ready) wake = std::min(wake, serialiser_free - kLead);

        // With nothing to read, poll no descriptor at all: a socket in error would report POLLERR
        // whatever the events asked for, and turn the sleep into a spin.
        pollfd entry{from, POLLIN, 0};
        timespec timeout{};
        if (wake != Clock::time_point::max()) {
            std::chrono::nanoseconds left = std::max(wake - now, Clock::duration::zero());
            if (left > kSpinAbove && !in_flight.empty() && wake == in_flight.front().due) {
                left -= kSpinWindow;
                spin_until = wake;
            } else if (wake == spin_until) {
                left = {}; // the end of a long wait: poll, do not sleep
            }
            timeout = to_timespec(left);
        }
        const int ready = ::ppoll(&entry, want_read ? 1 : 0,
                                  wake == Clock::time_point::max() ? nullptr : &timeout, nullptr);
        if (ready < 0 && errno != EINTR) {
            eof = true; // ppoll fails only on exhausted kernel memory: end as if reset
            end = LinkEnd::ReadError;
            continue;
        }
        if (ready <= 0 || !want_read) continue;

        const size_t want = std::min<uint64_t>(chunk_, capacity_ - (read_end - written_end));
        const size_t at = read_end & mask;
        const size_t first = std::min(want, capacity_ - at);
        iovec iov[2] = {{ring.get() + at, first}, {ring.get(), want - first}};
        alignas(cmsghdr) char control[CMSG_SPACE(sizeof(timespec))];
        msghdr message{};
        message.msg_iov = iov;
        message.msg_iovlen = iov[1].iov_len ? 2 : 1;
        message.msg_control = control;
        message.msg_controllen = sizeof(control);
        const ssize_t n = ::recvmsg(from, &message, 0);
        if (n > 0) {
            // If the serialiser is busy, the bytes wait for it, as they would in the sender's queue.
            const Clock::time_point arrived = arrival_time(message);
            const Clock::time_point start = std::max(arrived, serialiser_free);
            serialiser_free = shape_.rate_bps
                                  ? start + serialisation_time(static_cast<uint64_t>(n), shape_.rate_bps)
                                  : start;
            read_end += static_cast<uint64_t>(n);
            in_flight.push_back({serialiser_free + shape_.delay, read_end});
        } else if (n == 0) {
            eof = true;
        } else if (errno != EINTR && errno != EAGAIN) {
            eof = true;
            end = LinkEnd::ReadError;
        }
    }
}

} // namespace splitvk::link
