#include "link_options.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <optional>

namespace splitvk::link {
namespace {

using namespace std::chrono_literals;

// Rates are what TCP can carry, not the PHY's headline: 940 Mbit/s is gigabit Ethernet's TCP
// goodput; the WiFi figures are what a good 802.11ac/ax client sees near its access point.
// Delays are one way, each direction: a switch for Ethernet, a WiFi hop and its MAC for the rest.
constexpr LinkProfile kProfiles[] = {
    {"gige", {940'000'000, 200us}, "gigabit Ethernet: 940 Mbit/s, 0.2 ms each way"},
    {"wifi5", {400'000'000, 2ms}, "802.11ac (5 GHz, the paper's client link): 400 Mbit/s, 2 ms each way"},
    {"wifi6", {800'000'000, 1500us}, "802.11ax: 800 Mbit/s, 1.5 ms each way"},
    {"none", {0, 0ns}, "no shaping: plain forwarding, to measure the proxy itself"},
};

constexpr uint64_t kMaxRate = 1'000'000'000'000; // 1 Tbit/s: beyond it, use no rate at all
constexpr auto kMaxDelay = std::chrono::nanoseconds(10s);

// What the options set, before the precedence rules apply.
struct Given {
    LinkOptions options;
    std::optional<LinkShape> profile;
    std::optional<uint64_t> rate, up_rate, down_rate;
    std::optional<std::chrono::nanoseconds> delay, up_delay, down_delay;
    bool listen = false;
};

bool parse_number(std::string_view text, double &value, std::string_view &rest) {
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    if (ec != std::errc() || end == text.data() || !std::isfinite(value) || value < 0) return false;
    rest = text.substr(static_cast<size_t>(end - text.data()));
    return true;
}

// HOST:PORT or [IPV6]:PORT, as SPLITVK_SERVER and splitvk-agent --listen write it, except that the
// port is required (the proxy sits between two ports and no default fits both) and may be 0 for
// --listen.
bool parse_address(std::string_view text, std::string &host, uint16_t &port, bool port_zero_ok) {
    std::string_view h;
    std::string_view p;
    if (text.starts_with('[')) {
        const size_t close = text.find(']');
        if (close == std::string_view::npos || text.substr(close + 1, 1) != ":") return false;
        h = text.substr(1, close - 1);
        p = text.substr(close + 2);
    } else {
        const size_t colon = text.find(':');
        if (colon == std::string_view::npos || text.find(':', colon + 1) != std::string_view::npos)
            return false;
        h = text.substr(0, colon);
        p = text.substr(colon + 1);
    }
    unsigned value = 0;
    const auto [end, ec] = std::from_chars(p.data(), p.data() + p.size(), value);
    if (h.empty() || h.find_first_of(" \t/[]") != std::string_view::npos || p.empty() || ec != std::errc() ||
        end != p.data() + p.size() || value > 65535 || (value == 0 && !port_zero_ok))
        return false;
    host = std::string(h);
    port = static_cast<uint16_t>(value);
    return true;
}

// Each handler returns an empty string, or why the value is wrong ("expected ...").
struct OptionRow {
    const char *name;
    const char *metavar; // nullptr: a flag without a value
    const char *help;
    bool shapes; // part of the link's description (at least one is required)
    std::string (*apply)(Given &given, const std::string &value);
};

std::string rate_into(std::optional<uint64_t> &slot, const std::string &value) {
    uint64_t rate = 0;
    if (!parse_rate(value, rate)) return "expected bits per second such as 400M, 1.5G or 100k";
    slot = rate;
    return {};
}

std::string delay_into(std::optional<std::chrono::nanoseconds> &slot, const std::string &value) {
    std::chrono::nanoseconds delay{};
    if (!parse_delay(value, delay))
        return "expected a one-way delay such as 2ms, 200us, 0.2ms or 0 (at most 10s)";
    slot = delay;
    return {};
}

constexpr OptionRow kOptions[] = {
    {"--listen", "ADDR:PORT", "where the client connects (port 0: any free port, printed at start)", false,
     [](Given &g, const std::string &v) -> std::string {
         g.listen = true;
         if (!parse_address(v, g.options.listen_host, g.options.listen_port, true))
             return "expected HOST:PORT or [IPV6]:PORT";
         return {};
     }},
    {"--connect", "ADDR:PORT", "the server to forward to (splitvk-agent's --listen)", false,
     [](Given &g, const std::string &v) -> std::string {
         if (!parse_address(v, g.options.connect_host, g.options.connect_port, false))
             return "expected HOST:PORT or [IPV6]:PORT";
         return {};
     }},
    {"--profile", "NAME", "gige, wifi5, wifi6 or none (see below)", true,
     [](Given &g, const std::string &v) -> std::string {
         for (const LinkProfile &p : kProfiles) {
             if (v == p.name) {
                 g.profile = p.shape;
                 g.options.profile = p.name;
                 return {};
             }
         }
         return "expected gige, wifi5, wifi6 or none";
     }},
    {"--rate", "BITS", "rate of both directions, bits per second: 400M, 1.5G, 100k", true,
     [](Given &g, const std::string &v) { return rate_into(g.rate, v); }},
    {"--delay", "TIME", "one-way delay of both directions: 2ms, 200us, 0.2ms, 0", true,
     [](Given &g, const std::string &v) { return delay_into(g.delay, v); }},
    {"--up-rate", "BITS", "rate client -> server only", true,
     [](Given &g, const std::string &v) { return rate_into(g.up_rate, v); }},
    {"--down-rate", "BITS", "rate server -> client only", true,
     [](Given &g, const std::string &v) { return rate_into(g.down_rate, v); }},
    {"--up-delay", "TIME", "delay client -> server only", true,
     [](Given &g, const std::string &v) { return delay_into(g.up_delay, v); }},
    {"--down-delay", "TIME", "delay server -> client only", true,
     [](Given &g, const std::string &v) { return delay_into(g.down_delay, v); }},
    {"--help", nullptr, "print this help and exit", false,
     [](Given &g, const std::string &) -> std::string {
         g.options.help = true;
         return {};
     }},
};

const OptionRow *find_option(const std::string &name) {
    for (const OptionRow &row : kOptions)
        if (name == row.name) return &row;
    if (name == "-h") return &kOptions[std::size(kOptions) - 1];
    return nullptr;
}

std::string format_rate(uint64_t bps) {
    char text[32];
    if (bps % 1'000'000'000 == 0)
        std::snprintf(text, sizeof(text), "%llu Gbit/s",
                      static_cast<unsigned long long>(bps / 1'000'000'000));
    else if (bps >= 1'000'000)
        std::snprintf(text, sizeof(text), "%g Mbit/s", static_cast<double>(bps) / 1e6);
    else
        std::snprintf(text, sizeof(text), "%g kbit/s", static_cast<double>(bps) / 1e3);
    return text;
}

} // namespace

std::span<const LinkProfile> link_profiles() {
    return kProfiles;
}

std::string describe(const LinkShape &shape) {
    if (!shape.shaped()) return "no shaping";
    char delay[32];
    std::snprintf(delay, sizeof(delay), "%g ms",
                  std::chrono::duration<double, std::milli>(shape.delay).count());
    return (shape.rate_bps ? format_rate(shape.rate_bps) : std::string("unlimited")) + " + " + delay;
}

bool parse_rate(const std::string &text, uint64_t &bits_per_second) {
    double value = 0;
    std::string_view rest;
    if (!parse_number(text, value, rest)) return false;
    double scale = 1;
    if (rest == "k" || rest == "K")
        scale = 1e3;
    else if (rest == "M")
        scale = 1e6;
    else if (rest == "G")
        scale = 1e9;
    else if (!rest.empty())
        return false;
    const double bps = std::round(value * scale);
    if (bps < 1 || bps > static_cast<double>(kMaxRate)) return false;
    bits_per_second = static_cast<uint64_t>(bps);
    return true;
}

bool parse_delay(const std::string &text, std::chrono::nanoseconds &delay) {
    double value = 0;
    std::string_view rest;
    if (!parse_number(text, value, rest)) return false;
    double ns_per_unit = 0;
    if (rest == "us")
        ns_per_unit = 1e3;
    else if (rest == "ms")
        ns_per_unit = 1e6;
    else if (rest == "s")
        ns_per_unit = 1e9;
    else if (rest.empty() && value == 0)
        ns_per_unit = 1; // "0" needs no unit; anything else does (is "2" seconds or milliseconds?)
    else
        return false;
    const double ns = std::round(value * ns_per_unit);
    if (ns > static_cast<double>(kMaxDelay.count())) return false;
    delay = std::chrono::nanoseconds(static_cast<int64_t>(ns));
    return true;
}

std::string link_usage() {
    std::string text =
        "usage: splitvk-link --listen ADDR:PORT --connect ADDR:PORT --profile NAME\n"
        "       splitvk-link --listen ADDR:PORT --connect ADDR:PORT [--rate BITS] [--delay TIME]\n"
        "                    [--up-rate BITS] [--down-rate BITS] [--up-delay TIME] [--down-delay TIME]\n"
        "\n"
        "A TCP proxy that emulates a network link between a splitvk client and splitvk-agent on one\n"
        "machine. Each direction is a serialising link: bytes leave at the rate and arrive the delay\n"
        "after they left, so a message of S bytes takes delay + S/rate. Up is client -> server.\n"
        "\n";
    for (const OptionRow &row : kOptions) {
        char line[160];
        const std::string flag = row.metavar ? std::string(row.name) + " " + row.metavar : row.name;
        std::snprintf(line, sizeof(line), "  %-22s %s\n", flag.c_str(), row.help);
        text += line;
    }
    text += "\nprofiles (one-way, each direction):\n";
    for (const LinkProfile &p : kProfiles) {
        char line[160];
        std::snprintf(line, sizeof(line), "  %-7s %s\n", p.name, p.stands_for);
        text += line;
    }
    return text;
}

ParsedLinkOptions parse_link_options(const std::vector<std::string> &arguments) {
    ParsedLinkOptions parsed;
    Given given;
    bool shaping_given = false;
    for (size_t i = 0; i < arguments.size(); ++i) {
        const std::string &arg = arguments[i];
        const OptionRow *row = find_option(arg);
        if (!row) {
            parsed.error = "unknown option '" + arg + "' (see --help)";
            return parsed;
        }
        std::string value;
        if (row->metavar) {
            if (i + 1 >= arguments.size()) {
                parsed.error = arg + " needs " + row->metavar;
                return parsed;
            }
            value = arguments[++i];
        }
        if (const std::string why = row->apply(given, value); !why.empty()) {
            parsed.error = arg + " '" + value + "' is invalid: " + why;
            return parsed;
        }
        shaping_given |= row->shapes;
    }
    LinkOptions &o = given.options;
    if (o.help) {
        parsed.options = o;
        return parsed;
    }
    if (!given.listen) {
        parsed.error = "--listen ADDR:PORT is required (where the client connects)";
        return parsed;
    }
    if (o.connect_host.empty()) {
        parsed.error = "--connect ADDR:PORT is required (the server to forward to)";
        return parsed;
    }
    if (!shaping_given) {
        parsed.error = "no link given: pass --profile gige|wifi5|wifi6|none, or --rate and --delay";
        return parsed;
    }
    const LinkShape base = given.profile.value_or(LinkShape{});
    o.up = o.down = base;
    if (given.rate) o.up.rate_bps = o.down.rate_bps = *given.rate;
    if (given.delay) o.up.delay = o.down.delay = *given.delay;
    if (given.up_rate) o.up.rate_bps = *given.up_rate;
    if (given.down_rate) o.down.rate_bps = *given.down_rate;
    if (given.up_delay) o.up.delay = *given.up_delay;
    if (given.down_delay) o.down.delay = *given.down_delay;
    parsed.options = o;
    return parsed;
}

} // namespace splitvk::link
