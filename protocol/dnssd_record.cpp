#include "dnssd_record.h"

#include "handshake.h"

#include <array>
#include <charconv>
#include <cstdio>
#include <map>

namespace splitvk::protocol {
namespace {

constexpr std::array kKeys{
    DnssdKey{"session",
             "protocol major and session fingerprint, <major>-<16 hex>: what the handshake compares"},
    DnssdKey{"cert",
             "the TLS certificate's fingerprint, sha256:<64 hex> (--print-fingerprint); none: no TLS"},
    DnssdKey{"gpu", "the GPU's name"},
    DnssdKey{"uuid", "the GPU's deviceUUID, 32 hex digits"},
    DnssdKey{"tls", "on: the agent serves TLS clients; off: loopback plaintext only"},
    DnssdKey{"slots", "sessions the agent can take now (--max-sessions less those running)"},
    DnssdKey{"max", "--max-sessions"},
};

bool parse_count(const std::string &text, uint32_t *out) {
    if (text.empty()) return false;
    const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), *out);
    return error == std::errc{} && end == text.data() + text.size();
}

} // namespace

std::span<const DnssdKey> dnssd_key_table() {
    return kKeys;
}

std::string session_text(uint64_t codec_fingerprint) {
    char hex[17];
    std::snprintf(hex, sizeof(hex), "%016llx",
                  static_cast<unsigned long long>(session_fingerprint(codec_fingerprint)));
    return std::to_string(kProtocolMajor) + "-" + hex;
}

std::vector<std::string> encode_txt(const AgentRecord &record) {
    return {
        std::string("session=") + record.session,
        std::string("cert=") + (record.certificate.empty() ? "none" : record.certificate),
        std::string("gpu=") + record.gpu_name,
        std::string("uuid=") + record.gpu_uuid,
        std::string("tls=") + (record.tls ? "on" : "off"),
        std::string("slots=") + std::to_string(record.free_slots),
        std::string("max=") + std::to_string(record.max_slots),
    };
}

Result<AgentRecord> decode_txt(const std::vector<std::string> &entries) {
    std::map<std::string, std::string> values;
    for (const std::string &entry : entries) {
        const size_t equals = entry.find('=');
        if (equals == std::string::npos) continue; // a boolean attribute: none of ours
        values.emplace(entry.substr(0, equals), entry.substr(equals + 1));
    }
    for (const DnssdKey &key : kKeys)
        if (!values.count(key.key))
            return Error{std::string("no TXT key '") + key.key + "' (" + key.meaning + ")"};
    AgentRecord record;
    record.session = values["session"];
    record.certificate = values["cert"] == "none" ? std::string() : values["cert"];
    if (!record.certificate.empty() && !record.certificate.starts_with("sha256:"))
        return Error{"TXT key 'cert' is '" + record.certificate + "', not sha256:<hex> or none"};
    record.gpu_name = values["gpu"];
    record.gpu_uuid = values["uuid"];
    const std::string &tls = values["tls"];
    if (tls != "on" && tls != "off") return Error{"TXT key 'tls' is '" + tls + "', not on or off"};
    record.tls = tls == "on";
    if (!parse_count(values["slots"], &record.free_slots))
        return Error{"TXT key 'slots' is '" + values["slots"] + "', not a count"};
    if (!parse_count(values["max"], &record.max_slots))
        return Error{"TXT key 'max' is '" + values["max"] + "', not a count"};
    return record;
}

} // namespace splitvk::protocol
