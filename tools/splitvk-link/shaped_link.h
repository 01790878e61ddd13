#pragma once

// One direction of an emulated link, the model ns-style simulators use for a point-to-point link:
//
//   a serialiser  bytes leave one after the other at `rate`: a chunk of n bytes that arrives at t
//                 starts when the serialiser is free, max(t, end of the previous chunk), and is
//                 on the wire n/rate later;
//   a pipe        every chunk arrives `delay` after its last byte was serialised (a FIFO of
//                 timestamped chunks), so a message of S bytes takes delay + S/rate and the
//                 throughput is capped at the rate.
//
// The link holds no queue of its own beyond what the serialiser will send in the next few
// milliseconds (kLead in the .cpp): a sender faster than the rate is held back by TCP flow control
// on the sending socket, the way a lossless link with a short buffer would hold it back. A chunk is
// at most what the serialiser sends in 100 us (and at least one Ethernet frame, as a slow real link
// still moves whole packets), so no byte arrives more than 0.1 ms later than it would on the real
// link: the model's granularity.
//
// Timing: a dedicated thread per direction sleeps until each deadline in ppoll() with its timer
// slack set to 1 ns (the default 50 us would be half the precision budget), polls through the last
// 150 us of a long wait, then writes every chunk that is due in one call. Deadlines are absolute,
// so a late wake-up delays the chunks it is late for and never the ones after it. Arrivals are the
// kernel's receive timestamps, so waking up to read them does not count as time on the link.

#include "link_options.h"

#include <atomic>
#include <cstdint>

namespace splitvk::link {

// How one direction ended.
enum class LinkEnd {
    Eof,        // `from` closed cleanly, everything read was delivered
    ReadError,  // `from` failed (a reset); what had been read was still delivered
    WriteError, // `to` failed: the rest could not be delivered
};
const char *to_string(LinkEnd end);

// Asks the kernel to timestamp what arrives on `fd` (SO_TIMESTAMPNS), so a link reading it knows
// when bytes arrived rather than when it woke up to read them. Bytes that arrived before this are
// timed by their read.
void enable_arrival_timestamps(int fd);

class ShapedLink {
public:
    explicit ShapedLink(const LinkShape &shape);

    // Moves bytes from the connected socket `from` to `to` (both blocking) until `from` ends and
    // everything read from it has been delivered, or `to` fails. Does not close, shut down or
    // otherwise touch the sockets beyond reading and writing: the caller propagates the end.
    LinkEnd run(int from, int to);

    // Bytes written to `to` so far (any thread).
    uint64_t bytes_delivered() const { return delivered_.load(std::memory_order_relaxed); }

    // The most bytes one read takes in: the link's burst size.
    size_t chunk_bytes() const { return chunk_; }

private:
    LinkShape shape_;
    size_t chunk_;
    size_t capacity_; // power of two: the byte ring between the serialiser and the pipe's exit
    std::atomic<uint64_t> delivered_{0};
};

} // namespace splitvk::link
