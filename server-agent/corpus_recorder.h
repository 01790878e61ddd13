#pragma once

// splitvk-agent --record-corpus DIR: a debugging aid that writes what a session receives as seed
// inputs for the fuzz targets (tests/fuzz, scripts/fuzz). Files are streams in the wire format
// fuzz_agent_messages reads, each starting at sequence 1:
//
//   s<session>-hello             the client's Hello, its token left out
//   s<session>-<n>-<type>        message n alone (the first kMaxMessages, each up to kMaxFileBytes)
//   s<session>-stream            the session's messages in order but for MemoryData (bulk bytes), up
//                                to kMaxStreamBytes: the objects created (by commands, and swapchain
//                                images) resolve in later commands, as in a session
//
// Never on by default: the files hold the application's data in the clear.

#include "handshake.h"
#include "wire.h"

#include <cstdint>
#include <fstream>
#include <span>
#include <string>

namespace splitvk::agent {

class CorpusRecorder {
public:
    static constexpr uint32_t kMaxMessages = 256;
    static constexpr size_t kMaxFileBytes = size_t{1} << 20;
    static constexpr size_t kMaxStreamBytes = size_t{4} << 20;

    // Recording stops (with one warning) at the first file that cannot be written.
    CorpusRecorder(std::string dir, uint64_t session_id);
    CorpusRecorder(const CorpusRecorder &) = delete;
    CorpusRecorder &operator=(const CorpusRecorder &) = delete;

    void hello(const protocol::Hello &hello);
    void message(uint16_t type, std::span<const uint8_t> payload);

private:
    bool write(const std::string &name, std::span<const uint8_t> bytes);

    std::string prefix_; // DIR/s<session>
    bool failed_ = false;
    uint32_t messages_ = 0;
    // Appended as messages arrive, so a session killed by SIGTERM still leaves its stream.
    std::ofstream stream_;
    size_t stream_bytes_ = 0;
    uint64_t stream_sequence_ = 0;
};

} // namespace splitvk::agent
