// splitvk-fuzz-message-seeds DIR
//
// Adds compressed twins to the fuzz_agent_messages seeds that `splitvk-agent --record-corpus DIR`
// wrote: for every recorded message s<session>-<NNNN>-<type> (one uncompressed frame, as the
// recorder writes them) whose payload is 64 bytes to 64 KiB, it writes <file>-zstd, the same
// message with its payload compressed (flags bit 0), as a client with compression on sends it.
// Mutating a valid compressed frame reaches the decompression checks that random bytes do not.
// The header is read and written with protocol/wire.h and the payload compressed with the
// protocol's own compressor, so the seeds follow the wire format wherever it goes. scripts/fuzz
// runs it; the seeds stay under out/fuzz, never in the repository.

#include "compression.h"
#include "wire.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <regex>
#include <string>
#include <vector>

namespace {

using namespace splitvk::protocol;

// Payloads outside this range are left alone: smaller ones compress into noise, larger ones make
// slow inputs for the fuzzer.
constexpr size_t kMinPayload = 64;
constexpr size_t kMaxPayload = 65536;

std::vector<uint8_t> read_bytes(const std::filesystem::path &path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

} // namespace

int main(int argc, char **argv) {
    if (argc != 2) {
        std::fprintf(stderr, "usage: splitvk-fuzz-message-seeds DIR\n");
        return 2;
    }
    const std::filesystem::path dir = argv[1];
    std::error_code ec;
    if (!std::filesystem::is_directory(dir, ec)) {
        std::fprintf(stderr, "splitvk-fuzz-message-seeds: %s is not a directory\n", dir.c_str());
        return 1;
    }
    // The recorder's per-message files; its -hello, its -stream and earlier -zstd twins are not.
    const std::regex message_name(R"(s[0-9]+-[0-9]{4}-[A-Za-z0-9_]+)");
    std::vector<std::filesystem::path> messages;
    for (const auto &entry : std::filesystem::directory_iterator(dir, ec))
        if (entry.is_regular_file() && std::regex_match(entry.path().filename().string(), message_name))
            messages.push_back(entry.path());
    std::sort(messages.begin(), messages.end());

    // Every payload compressed, whether or not it pays: the seed is about the compressed path. Twice
    // the payload is the compressor's output buffer, more than zstd's worst case from 64 bytes on.
    CompressionPolicy always;
    always.threshold = 0;
    always.ratio_num = 2;
    always.ratio_den = 1;
    Compressor compressor(always);
    size_t written = 0;
    for (const auto &path : messages) {
        const std::vector<uint8_t> frame = read_bytes(path);
        if (frame.size() < kHeaderSize) continue;
        const MessageHeader header =
            decode_header(std::span<const uint8_t, kHeaderSize>(frame.data(), kHeaderSize));
        const std::span<const uint8_t> payload(frame.data() + kHeaderSize, frame.size() - kHeaderSize);
        if (header.flags != 0 || header.payload_length != payload.size() || payload.size() < kMinPayload ||
            payload.size() > kMaxPayload)
            continue;
        std::vector<uint8_t> packed;
        if (!compressor.compress_if_pays(payload, packed)) {
            std::fprintf(stderr, "splitvk-fuzz-message-seeds: cannot compress %s\n", path.c_str());
            return 1;
        }
        const auto twin = encode_frame(header.type, header.sequence, packed, kFlagCompressed);
        std::ofstream out(path.string() + "-zstd", std::ios::binary | std::ios::trunc);
        out.write(reinterpret_cast<const char *>(twin.data()), static_cast<std::streamsize>(twin.size()));
        if (!out) {
            std::fprintf(stderr, "splitvk-fuzz-message-seeds: cannot write %s-zstd\n", path.c_str());
            return 1;
        }
        ++written;
    }
    std::printf("%zu compressed twins of %zu recorded messages\n", written, messages.size());
    return 0;
}
