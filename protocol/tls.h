#pragma once

// TLS 1.3 on the link (docs/security.md "The link"). The agent has a key and a
// certificate, self-signed unless the operator brings one; the client does not trust any
// certificate authority but pins the certificate itself, by its SHA-256 fingerprint, as ssh pins
// host keys. OpenSSL stays inside tls.cpp and transport.cpp: this header is cheap to include.
//
// Only TLS 1.3 is offered or accepted (SSL_CTX_set_min_proto_version): its handshake encrypts the
// certificate, and it has no renegotiation, no static RSA and no CBC suites to configure away.

#include "result.h"

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace splitvk::protocol {

struct TlsIdentity {
    std::string certificate_pem; // the agent's own certificate first, then any chain
    std::string private_key_pem;
};

// A fresh P-256 key and a self-signed certificate for it, valid from now + `not_before` to now +
// `not_after` (negative offsets lie in the past: the tests make expired certificates this way).
Result<TlsIdentity> generate_tls_identity(const std::string &common_name, std::chrono::seconds not_before,
                                          std::chrono::seconds not_after);

struct CertificateInfo {
    std::string fingerprint; // "sha256:" and 64 lowercase hex digits, of the DER certificate
    std::string subject;     // one line, for logs
    int64_t not_before = 0;  // seconds since the epoch
    int64_t not_after = 0;
};

// The first certificate of a PEM text.
Result<CertificateInfo> describe_certificate(std::string_view certificate_pem);

// The certificate, and that the key is the certificate's.
Result<CertificateInfo> check_identity(const TlsIdentity &identity);

// normalize_fingerprint (the grammar of fingerprints) is in settings.h, which the layer's
// settings share.

// "2036-11-25 10:00:00 UTC"
std::string format_utc(int64_t seconds_since_epoch);

// Why a certificate is not valid at `now` (expired, or not yet valid); empty when it is.
std::string validity_problem(const CertificateInfo &certificate, int64_t now);

// OpenSSL's configuration for one side of many connections. Create it before forking (the agent
// loads its identity once, in the listener) and share it: connections only read it.
class TlsContext {
public:
    // The agent: presents `identity`. Fails with one line on an unusable identity.
    static Result<std::shared_ptr<TlsContext>> server(const TlsIdentity &identity);

    // The client. During each handshake the agent's certificate goes first through the validity
    // check (an expired certificate is refused whatever pins it), then to `verify`, which returns
    // an empty string to accept it or one line saying why not; the handshake then fails with
    // that line, and the agent hears a certificate alert.
    using Verifier = std::function<std::string(const CertificateInfo &certificate)>;
    static Result<std::shared_ptr<TlsContext>> client(Verifier verify);

    ~TlsContext();
    TlsContext(const TlsContext &) = delete;
    TlsContext &operator=(const TlsContext &) = delete;

    bool is_server() const;

    struct Impl; // tls_internal.h
    Impl &impl() const { return *impl_; }

private:
    explicit TlsContext(std::unique_ptr<Impl> impl);
    std::unique_ptr<Impl> impl_;
};

// One side of a TLS handshake over memory instead of a socket, for the fuzzer and its seeds: `peer`
// is everything the other side sent; what this side answers is appended to *sent, and any
// application data it could decrypt to *received. Returns "" when the handshake completed, else the
// one line a connection would have failed with (or "incomplete" when `peer` simply ran out).
std::string tls_over_memory(const TlsContext &context, const uint8_t *peer, size_t peer_size,
                            std::vector<uint8_t> *sent, std::vector<uint8_t> *received);

// What the agent's first bytes on a fresh connection are: a TLS ClientHello record, or anything
// else (a plaintext splitvk Hello starts with its length and type 0x0001, which no TLS record
// does). Waits at most `timeout` for the first 6 bytes, reading nothing (MSG_PEEK).
enum class FirstBytes { Tls, Plain };
Result<FirstBytes> sniff_first_bytes(int socket_fd, std::chrono::milliseconds timeout);
// The decision on 6 bytes, for sniff_first_bytes and the fuzzer.
FirstBytes classify_first_bytes(const uint8_t bytes[6]);

// Whether the socket's peer is on this machine's loopback (127.0.0.0/8, ::1, ::ffff:127.x).
bool peer_is_loopback(int socket_fd);
// "10.0.0.2:50112", "[fe80::1]:50112", or "?".
std::string peer_address_of(int socket_fd);

} // namespace splitvk::protocol
