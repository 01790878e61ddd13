#pragma once

// splitvk-link's command line. Parsing is separate from main() so it is unit-tested; the tables
// behind it (options, profiles) are the only place their names and values are written down.

#include <chrono>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace splitvk::link {

// One direction of the emulated link: a serialiser at `rate_bps` followed by `delay` of
// propagation. A rate of 0 means the serialiser is infinitely fast.
struct LinkShape {
    uint64_t rate_bps = 0;
    std::chrono::nanoseconds delay{0};

    bool shaped() const { return rate_bps != 0 || delay.count() != 0; }
    bool operator==(const LinkShape &) const = default;
};

// "400 Mbit/s + 2 ms", "unlimited + 0 ms" (0 ms with no rate: "no shaping").
std::string describe(const LinkShape &shape);

struct LinkProfile {
    const char *name;
    LinkShape shape; // each direction
    const char *stands_for;
};

// gige, wifi5, wifi6, none.
std::span<const LinkProfile> link_profiles();

struct LinkOptions {
    std::string listen_host = "127.0.0.1";
    uint16_t listen_port = 0; // 0: any free port, printed at start
    std::string connect_host;
    uint16_t connect_port = 0;
    std::string profile; // the --profile given, empty if none
    LinkShape up;        // client -> server (what arrives on --listen goes to --connect)
    LinkShape down;      // server -> client
    bool help = false;
};

struct ParsedLinkOptions {
    LinkOptions options;
    std::string error; // one line; empty when the command line is valid
};

// A profile sets both directions; --rate/--delay override both; --up-*/--down-* override one.
// The order on the command line does not matter.
ParsedLinkOptions parse_link_options(const std::vector<std::string> &arguments);

// "400M" -> 400000000 (bits per second; suffixes k, M, G are decimal). Nothing on a bad value.
bool parse_rate(const std::string &text, uint64_t &bits_per_second);
// "2ms", "150us", "0.2ms", "1s", "0". Nothing on a bad value.
bool parse_delay(const std::string &text, std::chrono::nanoseconds &delay);

std::string link_usage();

} // namespace splitvk::link
