// splitvk-fuzz-tls-seeds DIR: writes seeds for fuzz_tls_handshake and fuzz_known_agents under
// DIR/<target>/ (scripts/fuzz). The TLS seeds are real: a ClientHello from the layer's context, the
// first flight the agent's context answers it with, and the client's whole stream (ClientHello,
// then its Finished) of a handshake run over memory; plus a plaintext Hello, as the agent's
// plaintext path sees one. Byte 0 of each picks the side, as the target expects.

#include "handshake.h"
#include "tls.h"
#include "wire.h"

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace {

using namespace splitvk::protocol;

void write(const std::filesystem::path &path, uint8_t side, const std::vector<uint8_t> &bytes) {
    std::ofstream out(path, std::ios::binary);
    out.put(static_cast<char>(side));
    out.write(reinterpret_cast<const char *>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

void write_text(const std::filesystem::path &path, const std::string &text) {
    std::ofstream(path, std::ios::binary) << text;
}

} // namespace

int main(int argc, char **argv) {
    if (argc != 2) {
        std::fprintf(stderr, "usage: splitvk-fuzz-tls-seeds DIR\n");
        return 2;
    }
    const std::filesystem::path dir = argv[1];
    const auto tls_dir = dir / "fuzz_tls_handshake";
    const auto known_dir = dir / "fuzz_known_agents";
    std::filesystem::create_directories(tls_dir);
    std::filesystem::create_directories(known_dir);

    auto identity =
        generate_tls_identity("splitvk-agent seeds", std::chrono::hours(-1), std::chrono::hours(24));
    if (!identity) {
        std::fprintf(stderr, "%s\n", identity.error().c_str());
        return 1;
    }
    auto server = TlsContext::server(*identity);
    auto client = TlsContext::client([](const CertificateInfo &) { return std::string(); });
    if (!server || !client) {
        std::fprintf(stderr, "cannot make TLS contexts\n");
        return 1;
    }
    // The client speaks first; each side then answers everything the other sent so far.
    std::vector<uint8_t> client_stream, server_stream, ignored;
    tls_over_memory(**client, nullptr, 0, &client_stream, &ignored);
    const std::vector<uint8_t> client_hello = client_stream;
    tls_over_memory(**server, client_stream.data(), client_stream.size(), &server_stream, &ignored);
    std::vector<uint8_t> client_rest;
    tls_over_memory(**client, server_stream.data(), server_stream.size(), &client_rest, &ignored);
    write(tls_dir / "server-reads-client-hello", 0, client_hello);
    write(tls_dir / "client-reads-server-flight", 1, server_stream);
    std::vector<uint8_t> whole = client_hello;
    whole.insert(whole.end(), client_rest.begin(), client_rest.end());
    write(tls_dir / "server-reads-client-stream", 0, whole);

    // A plaintext Hello with a token and a device envelope's worth of bytes, framed as sent.
    Hello hello;
    hello.token = {'s', 'e', 'c', 'r', 'e', 't'};
    hello.client_name = "splitvk-atrium";
    hello.client_gpu_name = "llvmpipe";
    const std::vector<uint8_t> payload = encode_hello(hello);
    MessageHeader header;
    header.payload_length = static_cast<uint32_t>(payload.size());
    header.type = to_wire(MessageType::Hello);
    header.sequence = 1;
    const auto head = encode_header(header);
    std::vector<uint8_t> plain(head.begin(), head.end());
    plain.insert(plain.end(), payload.begin(), payload.end());
    write(tls_dir / "server-reads-plaintext-hello", 0, plain);

    const std::string a(64, 'a'), b(64, 'b');
    write_text(known_dir / "recorded",
               "192.168.1.20:7447 sha256:" + a + "\n[fe80::1]:7447 sha256:" + b + "\n");
    write_text(known_dir / "edited",
               "# agents of the lab\n\n  10.0.0.2:7447\tSHA256:" + std::string(64, 'C') +
                   "  \nbroken line here\n10.0.0.3:70000 sha256:" + a + "\nhost:1 sha256:xyz\n");
    std::string colons;
    for (int i = 0; i < 32; ++i)
        colons += std::string(i ? ":" : "") + "AB";
    write_text(known_dir / "openssl-form", "agent.lan:7447 " + colons + "\r\n");
    std::printf("TLS and known_agents seeds in %s\n", dir.string().c_str());
    return 0;
}
