#include "corpus_recorder.h"

#include "log.h"

#include <cstdio>
#include <fstream>

namespace splitvk::agent {

CorpusRecorder::CorpusRecorder(std::string dir, uint64_t session_id)
    : prefix_(std::move(dir) + "/s" + std::to_string(session_id)) {}

CorpusRecorder::~CorpusRecorder() {
    if (!commands_.empty()) write("commands", commands_);
}

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
    if (type == protocol::to_wire(protocol::MessageType::Commands) &&
        commands_.size() + protocol::kHeaderSize + payload.size() <= kMaxStreamBytes) {
        const auto frame = protocol::encode_frame(type, ++commands_sequence_, payload);
        commands_.insert(commands_.end(), frame.begin(), frame.end());
    }
}

} // namespace splitvk::agent
