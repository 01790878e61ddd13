#pragma once

// What tls.cpp shares with transport.cpp only: the Asio/OpenSSL side of TlsContext.

#include "tls.h"

#include <string>

#include <asio/error_code.hpp>
#include <asio/ssl/context.hpp>

namespace splitvk::protocol {

// One client handshake's decision on the agent's certificate, reached in OpenSSL's verify
// callback (which may run more than once for the same certificate) and read after the handshake.
struct TlsPeerCheck {
    bool decided = false;
    std::string refusal; // empty: accepted
    CertificateInfo certificate;
};

struct TlsContext::Impl {
    Impl(asio::ssl::context::method method, bool is_server) : context(method), server(is_server) {}
    asio::ssl::context context;
    bool server;
    Verifier verify; // client only
};

// The SSL ex_data slot that holds a connection's TlsPeerCheck (client side).
int tls_peer_check_index();

// One line for a failed handshake or TLS read, in words a user can act on; `server` says which
// side this is (an alert from the client means it refused the agent's certificate).
std::string describe_tls_error(const asio::error_code &ec, bool server);

} // namespace splitvk::protocol
