// Every input a fuzzer once crashed on, replayed through the same entry function in the normal
// build (and under ASan+UBSan in scripts/test's sanitizer build), so the fix stays in place
// without clang. Add a file to regressions/<target>/ with each crash you fix.

#include "fuzz_targets.h"

#include <filesystem>
#include <fstream>
#include <iterator>
#include <vector>

#include <gtest/gtest.h>

namespace splitvk::fuzz {
namespace {

namespace fs = std::filesystem;

template <class Entry>
void replay_all(const char *target, Entry entry) {
    const fs::path dir = fs::path(SPLITVK_FUZZ_REGRESSIONS) / target;
    ASSERT_TRUE(fs::is_directory(dir)) << dir;
    size_t replayed = 0;
    for (const auto &file : fs::directory_iterator(dir)) {
        if (!file.is_regular_file() || file.path().filename() == "README") continue;
        std::ifstream in(file.path(), std::ios::binary);
        const std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)),
                                         std::istreambuf_iterator<char>());
        SCOPED_TRACE(file.path().string());
        entry(bytes.data(), bytes.size()); // must return: no crash, no sanitizer report
        ++replayed;
    }
    ::testing::Test::RecordProperty("inputs", static_cast<int>(replayed));
}

TEST(FuzzRegressions, AgentMessages) {
    replay_all("fuzz_agent_messages", agent_messages);
}

TEST(FuzzRegressions, TileDecoder) {
    replay_all("fuzz_tile_decoder", tile_decoder);
}

TEST(FuzzRegressions, TlsHandshake) {
    replay_all("fuzz_tls_handshake", tls_handshake);
}

TEST(FuzzRegressions, KnownAgents) {
    replay_all("fuzz_known_agents", known_agents);
}

// The entry functions take empty and tiny inputs (libFuzzer starts with them).
TEST(FuzzRegressions, TinyInputs) {
    const uint8_t bytes[17] = {};
    for (size_t n = 0; n <= sizeof(bytes); ++n) {
        agent_messages(bytes, n);
        tile_decoder(bytes, n);
        tls_handshake(bytes, n);
        known_agents(bytes, n);
    }
}

} // namespace
} // namespace splitvk::fuzz
