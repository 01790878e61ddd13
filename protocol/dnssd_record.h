#pragma once

// What an agent advertises over DNS-SD (`splitvk-agent --advertise`) and what a client browsing
// for agents (SPLITVK_SERVER=dnssd) reads back: the service type and the TXT record, one table of
// keys both sides use. The TXT record is a hint for choosing among agents, never a reason to trust
// one: the client still checks the certificate at the TLS handshake against what it pins, and the
// agent still checks the client's Hello (docs/security.md, "Agents found over DNS-SD").

#include "result.h"

#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace splitvk::protocol {

inline constexpr const char *kDnssdServiceType = "_splitvk._tcp";

struct AgentRecord {
    // What the handshake compares (protocol major version and session_fingerprint), as
    // session_text() writes it: a client skips an agent whose session it could not open.
    std::string session;
    std::string certificate; // "sha256:<hex>" as --print-fingerprint prints it; empty: no TLS identity
    std::string gpu_name;
    std::string gpu_uuid; // 32 lowercase hex digits (VkPhysicalDeviceIDProperties::deviceUUID)
    bool tls = false;     // the agent serves TLS clients
    uint32_t free_slots = 0;
    uint32_t max_slots = 0;
    bool operator==(const AgentRecord &) const = default;
};

// One row per TXT key: the key and what its value is, for the docs and the decoder's errors.
struct DnssdKey {
    const char *key;
    const char *meaning;
};
std::span<const DnssdKey> dnssd_key_table();

// "<protocol major>-<16 hex digits of session_fingerprint(codec_fingerprint)>".
std::string session_text(uint64_t codec_fingerprint);

// "key=value" strings in the table's order.
std::vector<std::string> encode_txt(const AgentRecord &record);
// A record from "key=value" strings in any order; unknown keys are ignored (a later agent may add
// some). An error names the key that is missing or malformed.
Result<AgentRecord> decode_txt(const std::vector<std::string> &entries);

} // namespace splitvk::protocol
