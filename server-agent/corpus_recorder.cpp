#include "corpus_recorder.h"

#include "log.h"

#include <cstdio>

namespace splitvk::agent {

CorpusRecorder::CorpusRecorder(std::string dir, uint64_t session_id)
    : prefix_(std::move(dir) + "/s" + std::to_string(session_id)) {}

bool CorpusRecorder::write(const std::string &name, std::span<const uint8_t> bytes) {
    if (failed_) return false;
    const std::string path = prefix_ + "-" + name;
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char *>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    if (!out) {
        SPLITVK_WARN("--record-corpus: cannot write %s; recording stops", path.c_str());
        failed_ = true;
        return false;
    }
    return true;
}

void CorpusRecorder::hello(const protocol::Hello &hello) {
    protocol::Hello copy = hello;
    copy.token.clear(); // the secret never goes to disk
    const auto payload = protocol::encode_hello(copy);
    write("hello", protocol::encode_frame(protocol::to_wire(protocol::MessageType::Hello), 1, payload));
}

void CorpusRecorder::message(uint16_t type, std::span<const uint8_t> payload) {
    // Uncompressed frames: the fuzzer mutates what the decoders read, not zstd's bit stream.
    if (messages_ < kMaxMessages && protocol::kHeaderSize + payload.size() <= kMaxFileBytes) {
        char name[64];
        std::snprintf(name, sizeof(name), "%04u-%s", static_cast<unsigned>(messages_),
                      protocol::message_type_name(type));
        for (char *c = name; *c; ++c)
            if (*c == ' ') *c = '_';
        write(name, protocol::encode_frame(type, 1, payload));
    }
    ++messages_;
    if (failed_ || type == protocol::to_wire(protocol::MessageType::MemoryData) ||
        stream_bytes_ + protocol::kHeaderSize + payload.size() > kMaxStreamBytes)
        return;
    if (!stream_.is_open()) stream_.open(prefix_ + "-stream", std::ios::binary | std::ios::trunc);
    const auto frame = protocol::encode_frame(type, ++stream_sequence_, payload);
    stream_.write(reinterpret_cast<const char *>(frame.data()), static_cast<std::streamsize>(frame.size()));
    stream_.flush();
    if (!stream_) {
        SPLITVK_WARN("--record-corpus: cannot write %s-stream; recording stops", prefix_.c_str());
        failed_ = true;
    }
    stream_bytes_ += frame.size();
}

} // namespace splitvk::agent
