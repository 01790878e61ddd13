#include "tls.h"

#include "settings.h"
#include "tls_internal.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <ctime>
#include <memory>
#include <mutex>

#include <arpa/inet.h>
#include <asio/ssl/error.hpp>
#include <netinet/in.h>
#include <openssl/bio.h>
#include <openssl/bn.h>
#include <openssl/err.h>
#include <openssl/evp.h>
#include <openssl/pem.h>
#include <openssl/rand.h>
#include <openssl/ssl.h>
#include <openssl/x509.h>
#include <poll.h>
#include <sys/socket.h>

namespace splitvk::protocol {
namespace {

template <class T, void (*Free)(T *)>
struct Deleter {
    void operator()(T *p) const { Free(p); }
};
using BioPtr = std::unique_ptr<BIO, Deleter<BIO, BIO_free_all>>;
using X509Ptr = std::unique_ptr<X509, Deleter<X509, X509_free>>;
using PkeyPtr = std::unique_ptr<EVP_PKEY, Deleter<EVP_PKEY, EVP_PKEY_free>>;
using BnPtr = std::unique_ptr<BIGNUM, Deleter<BIGNUM, BN_free>>;

// The most recent OpenSSL error as one line, and the queue emptied.
std::string openssl_error(const char *what) {
    std::string text = what;
    const unsigned long code = ERR_get_error();
    if (code != 0) {
        char buffer[256];
        ERR_error_string_n(code, buffer, sizeof(buffer));
        text += std::string(": ") + buffer;
    }
    ERR_clear_error();
    return text;
}

std::string pem_of(BIO *bio) {
    char *data = nullptr;
    const long length = BIO_get_mem_data(bio, &data);
    return length > 0 ? std::string(data, static_cast<size_t>(length)) : std::string();
}

int64_t seconds_of(const ASN1_TIME *time) {
    std::tm tm{};
    if (!time || ASN1_TIME_to_tm(time, &tm) != 1) return 0;
    return static_cast<int64_t>(timegm(&tm));
}

CertificateInfo info_of(X509 *certificate) {
    CertificateInfo info;
    unsigned char digest[EVP_MAX_MD_SIZE];
    unsigned int length = 0;
    if (X509_digest(certificate, EVP_sha256(), digest, &length) == 1) {
        static const char kHex[] = "0123456789abcdef";
        info.fingerprint = "sha256:";
        for (unsigned i = 0; i < length; ++i) {
            info.fingerprint += kHex[digest[i] >> 4];
            info.fingerprint += kHex[digest[i] & 15];
        }
    }
    char subject[256] = {};
    X509_NAME_oneline(X509_get_subject_name(certificate), subject, sizeof(subject));
    info.subject = subject;
    info.not_before = seconds_of(X509_get0_notBefore(certificate));
    info.not_after = seconds_of(X509_get0_notAfter(certificate));
    return info;
}

Result<X509Ptr> first_certificate(std::string_view pem) {
    BioPtr bio(BIO_new_mem_buf(pem.data(), static_cast<int>(pem.size())));
    if (!bio) return Error{openssl_error("BIO_new_mem_buf")};
    X509Ptr certificate(PEM_read_bio_X509(bio.get(), nullptr, nullptr, nullptr));
    if (!certificate) return Error{openssl_error("no PEM certificate")};
    return certificate;
}

// The SSL_CTX ex_data slot that leads from OpenSSL back to our context. (Not the app data: Asio
// keeps its own verify callback there and deletes whatever it finds in its destructor.)
int context_index() {
    static const int index = SSL_CTX_get_ex_new_index(0, nullptr, nullptr, nullptr, nullptr);
    return index;
}

// The client's verify callback: decides once, at depth 0 (the agent's own certificate), and
// ignores what OpenSSL thinks of the chain: the certificate is self-signed by design, and trust
// comes from the pin, not from a certificate authority.
int verify_agent_certificate(int /*preverified*/, X509_STORE_CTX *store) {
    if (X509_STORE_CTX_get_error_depth(store) != 0) return 1;
    SSL *ssl = static_cast<SSL *>(X509_STORE_CTX_get_ex_data(store, SSL_get_ex_data_X509_STORE_CTX_idx()));
    auto *check = ssl ? static_cast<TlsPeerCheck *>(SSL_get_ex_data(ssl, tls_peer_check_index())) : nullptr;
    const auto *context = ssl ? static_cast<const TlsContext::Impl *>(
                                    SSL_CTX_get_ex_data(SSL_get_SSL_CTX(ssl), context_index()))
                              : nullptr;
    X509 *certificate = X509_STORE_CTX_get_current_cert(store);
    if (!check || !context || !certificate) return 0;
    if (!check->decided) {
        check->decided = true;
        check->certificate = info_of(certificate);
        check->refusal = validity_problem(check->certificate, static_cast<int64_t>(std::time(nullptr)));
        if (!check->refusal.empty())
            check->refusal = "the agent's certificate " + check->refusal;
        else if (context->verify)
            check->refusal = context->verify(check->certificate);
    }
    if (check->refusal.empty()) {
        X509_STORE_CTX_set_error(store, X509_V_OK);
        return 1;
    }
    // The alert the agent hears: "certificate expired" or "bad certificate".
    const int64_t now = static_cast<int64_t>(std::time(nullptr));
    X509_STORE_CTX_set_error(store, check->certificate.not_after < now    ? X509_V_ERR_CERT_HAS_EXPIRED
                                    : check->certificate.not_before > now ? X509_V_ERR_CERT_NOT_YET_VALID
                                                                          : X509_V_ERR_CERT_REJECTED);
    return 0;
}

bool pin_tls13(asio::ssl::context &context, std::string *error) {
    SSL_CTX *native = context.native_handle();
    if (SSL_CTX_set_min_proto_version(native, TLS1_3_VERSION) != 1 ||
        SSL_CTX_set_max_proto_version(native, TLS1_3_VERSION) != 1) {
        *error = openssl_error("cannot restrict TLS to 1.3");
        return false;
    }
    // No resumption: every session is a full handshake against the pinned certificate, and the
    // agent sends no tickets nobody would use.
    SSL_CTX_set_session_cache_mode(native, SSL_SESS_CACHE_OFF);
    SSL_CTX_set_num_tickets(native, 0);
    return true;
}

} // namespace

int tls_peer_check_index() {
    static const int index = SSL_get_ex_new_index(0, nullptr, nullptr, nullptr, nullptr);
    return index;
}

std::string describe_tls_error(const asio::error_code &ec, bool server) {
    if (ec == asio::error::eof || ec == asio::ssl::error::stream_truncated)
        return server
                   ? "the client closed the connection during the TLS handshake"
                   : "the agent closed the connection during the TLS handshake (it may have no TLS identity)";
    if (ec.category() != asio::error::get_ssl_category()) return ec.message();
    const int reason = ERR_GET_REASON(static_cast<unsigned long>(ec.value()));
    std::string detail = ec.message();
    switch (reason) {
    case SSL_R_WRONG_VERSION_NUMBER:
    case SSL_R_HTTP_REQUEST:
    case SSL_R_PACKET_LENGTH_TOO_LONG:
        return (server ? std::string("the client") : std::string("the agent")) + " does not speak TLS (" +
               detail + ")";
    case SSL_R_UNSUPPORTED_PROTOCOL:
    case SSL_R_TLSV1_ALERT_PROTOCOL_VERSION:
    case SSL_R_NO_PROTOCOLS_AVAILABLE:
        return (server ? std::string("the client") : std::string("the agent")) + " does not offer TLS 1.3 (" +
               detail + ")";
    case SSL_R_SSLV3_ALERT_CERTIFICATE_EXPIRED:
        if (server) return "the client refused this agent's certificate: it has expired (" + detail + ")";
        break;
    case SSL_R_SSLV3_ALERT_BAD_CERTIFICATE:
    case SSL_R_SSLV3_ALERT_UNSUPPORTED_CERTIFICATE:
    case SSL_R_SSLV3_ALERT_CERTIFICATE_UNKNOWN:
    case SSL_R_TLSV1_ALERT_UNKNOWN_CA:
        if (server)
            return "the client refused this agent's certificate: it pins another one, or recorded another "
                   "for "
                   "this address in its known_agents (" +
                   detail + ")";
        break;
    default:
        break;
    }
    return detail;
}

Result<TlsIdentity> generate_tls_identity(const std::string &common_name, std::chrono::seconds not_before,
                                          std::chrono::seconds not_after) {
    PkeyPtr key(EVP_EC_gen("P-256"));
    if (!key) return Error{openssl_error("cannot generate a P-256 key")};
    X509Ptr certificate(X509_new());
    if (!certificate) return Error{openssl_error("X509_new")};
    X509_set_version(certificate.get(), 2);
    // A random 127-bit serial: two certificates of one agent (after a regeneration) never share one.
    unsigned char serial_bytes[16];
    if (RAND_bytes(serial_bytes, sizeof(serial_bytes)) != 1) return Error{openssl_error("RAND_bytes")};
    serial_bytes[0] &= 0x7f;
    BnPtr serial(BN_bin2bn(serial_bytes, sizeof(serial_bytes), nullptr));
    if (!serial || !BN_to_ASN1_INTEGER(serial.get(), X509_get_serialNumber(certificate.get())))
        return Error{openssl_error("certificate serial")};
    if (!X509_gmtime_adj(X509_getm_notBefore(certificate.get()), static_cast<long>(not_before.count())) ||
        !X509_gmtime_adj(X509_getm_notAfter(certificate.get()), static_cast<long>(not_after.count())))
        return Error{openssl_error("certificate validity")};
    X509_NAME *name = X509_get_subject_name(certificate.get());
    X509_NAME_add_entry_by_txt(name, "CN", MBSTRING_UTF8,
                               reinterpret_cast<const unsigned char *>(common_name.c_str()), -1, -1, 0);
    X509_set_issuer_name(certificate.get(), name);
    if (X509_set_pubkey(certificate.get(), key.get()) != 1 ||
        X509_sign(certificate.get(), key.get(), EVP_sha256()) == 0)
        return Error{openssl_error("cannot sign the certificate")};

    BioPtr cert_bio(BIO_new(BIO_s_mem()));
    BioPtr key_bio(BIO_new(BIO_s_mem()));
    if (!cert_bio || !key_bio || PEM_write_bio_X509(cert_bio.get(), certificate.get()) != 1 ||
        PEM_write_bio_PrivateKey(key_bio.get(), key.get(), nullptr, nullptr, 0, nullptr, nullptr) != 1)
        return Error{openssl_error("cannot write PEM")};
    return TlsIdentity{pem_of(cert_bio.get()), pem_of(key_bio.get())};
}

Result<CertificateInfo> describe_certificate(std::string_view certificate_pem) {
    auto certificate = first_certificate(certificate_pem);
    if (!certificate) return Error{certificate.error()};
    return info_of(certificate->get());
}

Result<CertificateInfo> check_identity(const TlsIdentity &identity) {
    auto certificate = first_certificate(identity.certificate_pem);
    if (!certificate) return Error{"certificate: " + certificate.error()};
    BioPtr bio(
        BIO_new_mem_buf(identity.private_key_pem.data(), static_cast<int>(identity.private_key_pem.size())));
    PkeyPtr key(bio ? PEM_read_bio_PrivateKey(bio.get(), nullptr, nullptr, nullptr) : nullptr);
    if (!key) return Error{openssl_error("key: no PEM private key (or one with a passphrase)")};
    if (X509_check_private_key(certificate->get(), key.get()) != 1)
        return Error{openssl_error("the key is not the certificate's")};
    return info_of(certificate->get());
}

std::string format_utc(int64_t seconds_since_epoch) {
    const std::time_t t = static_cast<std::time_t>(seconds_since_epoch);
    std::tm tm{};
    gmtime_r(&t, &tm);
    char text[40];
    std::strftime(text, sizeof(text), "%Y-%m-%d %H:%M:%S UTC", &tm);
    return text;
}

std::string validity_problem(const CertificateInfo &certificate, int64_t now) {
    if (certificate.not_after < now) return "expired on " + format_utc(certificate.not_after);
    if (certificate.not_before > now) return "is not valid until " + format_utc(certificate.not_before);
    return {};
}

TlsContext::TlsContext(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
TlsContext::~TlsContext() = default;

bool TlsContext::is_server() const {
    return impl_->server;
}

Result<std::shared_ptr<TlsContext>> TlsContext::server(const TlsIdentity &identity) {
    if (auto checked = check_identity(identity); !checked) return Error{checked.error()};
    try {
        auto impl = std::make_unique<Impl>(asio::ssl::context::tls_server, true);
        std::string error;
        if (!pin_tls13(impl->context, &error)) return Error{error};
        impl->context.use_certificate_chain(
            asio::buffer(identity.certificate_pem.data(), identity.certificate_pem.size()));
        impl->context.use_private_key(
            asio::buffer(identity.private_key_pem.data(), identity.private_key_pem.size()),
            asio::ssl::context::pem);
        return std::shared_ptr<TlsContext>(new TlsContext(std::move(impl)));
    } catch (const std::exception &e) {
        ERR_clear_error();
        return Error{std::string("cannot use the TLS identity: ") + e.what()};
    }
}

Result<std::shared_ptr<TlsContext>> TlsContext::client(Verifier verify) {
    try {
        auto impl = std::make_unique<Impl>(asio::ssl::context::tls_client, false);
        std::string error;
        if (!pin_tls13(impl->context, &error)) return Error{error};
        impl->verify = std::move(verify);
        SSL_CTX_set_ex_data(impl->context.native_handle(), context_index(), impl.get());
        SSL_CTX_set_verify(impl->context.native_handle(), SSL_VERIFY_PEER, verify_agent_certificate);
        return std::shared_ptr<TlsContext>(new TlsContext(std::move(impl)));
    } catch (const std::exception &e) {
        ERR_clear_error();
        return Error{std::string("cannot set up TLS: ") + e.what()};
    }
}

std::string tls_over_memory(const TlsContext &context, const uint8_t *peer, size_t peer_size,
                            std::vector<uint8_t> *sent, std::vector<uint8_t> *received) {
    using SslPtr = std::unique_ptr<SSL, Deleter<SSL, SSL_free>>;
    SslPtr ssl(SSL_new(context.impl().context.native_handle()));
    BIO *in = BIO_new(BIO_s_mem());
    BIO *out = BIO_new(BIO_s_mem());
    if (!ssl || !in || !out) {
        BIO_free(in);
        BIO_free(out);
        return openssl_error("SSL_new");
    }
    if (peer_size) BIO_write(in, peer, static_cast<int>(std::min<size_t>(peer_size, INT32_MAX)));
    BIO_set_mem_eof_return(in, -1); // no more bytes: "want read", as on a socket that waits
    SSL_set_bio(ssl.get(), in, out);
    TlsPeerCheck check;
    if (context.is_server()) {
        SSL_set_accept_state(ssl.get());
    } else {
        SSL_set_connect_state(ssl.get());
        SSL_set_ex_data(ssl.get(), tls_peer_check_index(), &check);
    }
    std::string outcome;
    int result = SSL_do_handshake(ssl.get());
    if (result == 1) {
        uint8_t buffer[16384];
        int n = 0;
        while ((n = SSL_read(ssl.get(), buffer, sizeof(buffer))) > 0)
            received->insert(received->end(), buffer, buffer + n);
        result = n;
    }
    const int error = SSL_get_error(ssl.get(), result);
    if (!check.refusal.empty()) {
        outcome = check.refusal;
    } else if (error == SSL_ERROR_WANT_READ) {
        outcome = SSL_is_init_finished(ssl.get()) ? "" : "incomplete";
    } else if (error == SSL_ERROR_SSL) {
        const asio::error_code ec(static_cast<int>(ERR_peek_last_error()), asio::error::get_ssl_category());
        outcome = "TLS handshake failed: " + describe_tls_error(ec, context.is_server());
    } else if (error != SSL_ERROR_NONE && error != SSL_ERROR_ZERO_RETURN) {
        outcome = "TLS error " + std::to_string(error);
    }
    ERR_clear_error();
    char *data = nullptr;
    const long length = BIO_get_mem_data(out, &data);
    if (length > 0) sent->insert(sent->end(), data, data + length);
    return outcome;
}

FirstBytes classify_first_bytes(const uint8_t bytes[6]) {
    // A TLS record of type handshake (22), major version 3, whose first message is a ClientHello
    // (1). A plaintext Hello's header has type 0x0001 at offsets 4-5 little-endian: byte 5 is 0.
    return bytes[0] == 0x16 && bytes[1] == 0x03 && bytes[5] == 0x01 ? FirstBytes::Tls : FirstBytes::Plain;
}

Result<FirstBytes> sniff_first_bytes(int socket_fd, std::chrono::milliseconds timeout) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    uint8_t bytes[6] = {};
    for (;;) {
        const ssize_t n = ::recv(socket_fd, bytes, sizeof(bytes), MSG_PEEK | MSG_DONTWAIT);
        if (n == static_cast<ssize_t>(sizeof(bytes))) return classify_first_bytes(bytes);
        if (n == 0) return Error{"the peer closed the connection before it sent anything"};
        if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)
            return Error{std::string("cannot read from the peer: ") + std::strerror(errno)};
        const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
            deadline - std::chrono::steady_clock::now());
        if (left.count() <= 0)
            return Error{"the peer sent " + std::to_string(n > 0 ? n : 0) + " bytes in " +
                         std::to_string(timeout.count()) + " ms, not a greeting"};
        // Fewer than 6 bytes so far: wait for more (poll wakes at once while any byte is unread,
        // so sleep a little instead when some have come).
        if (n > 0) {
            ::poll(nullptr, 0, static_cast<int>(std::min<int64_t>(left.count(), 10)));
            continue;
        }
        pollfd entry{socket_fd, POLLIN, 0};
        ::poll(&entry, 1, static_cast<int>(std::min<int64_t>(left.count(), 1000)));
    }
}

std::string peer_address_of(int socket_fd) {
    sockaddr_storage address{};
    socklen_t length = sizeof(address);
    if (::getpeername(socket_fd, reinterpret_cast<sockaddr *>(&address), &length) != 0) return "?";
    char text[INET6_ADDRSTRLEN] = {};
    if (address.ss_family == AF_INET) {
        const auto *v4 = reinterpret_cast<const sockaddr_in *>(&address);
        ::inet_ntop(AF_INET, &v4->sin_addr, text, sizeof(text));
        std::string result = text;
        result.append(":");
        result.append(std::to_string(ntohs(v4->sin_port)));
        return result;
    }
    if (address.ss_family == AF_INET6) {
        const auto *v6 = reinterpret_cast<const sockaddr_in6 *>(&address);
        ::inet_ntop(AF_INET6, &v6->sin6_addr, text, sizeof(text));
        std::string result = "[";
        result.append(text);
        result.append("]:");
        result.append(std::to_string(ntohs(v6->sin6_port)));
        return result;
    }
    return "?";
}

bool peer_is_loopback(int socket_fd) {
    sockaddr_storage address{};
    socklen_t length = sizeof(address);
    if (::getpeername(socket_fd, reinterpret_cast<sockaddr *>(&address), &length) != 0) return false;
    if (address.ss_family == AF_INET) {
        const auto *v4 = reinterpret_cast<const sockaddr_in *>(&address);
        return (ntohl(v4->sin_addr.s_addr) >> 24) == 127;
    }
    if (address.ss_family == AF_INET6) {
        const auto *v6 = reinterpret_cast<const sockaddr_in6 *>(&address);
        if (IN6_IS_ADDR_LOOPBACK(&v6->sin6_addr)) return true;
        return IN6_IS_ADDR_V4MAPPED(&v6->sin6_addr) && v6->sin6_addr.s6_addr[12] == 127;
    }
    return false;
}

} // namespace splitvk::protocol
