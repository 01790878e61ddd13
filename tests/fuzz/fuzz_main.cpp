// libFuzzer's entry point for one target; SPLITVK_FUZZ_ENTRY names it (fuzz_agent_messages,
// fuzz_tile_decoder, fuzz_tls_handshake, fuzz_known_agents) and the function after the "fuzz_" prefix does
// the work.

#include "fuzz_targets.h"

#define SPLITVK_FUZZ_CONCAT(a, b) a##b
#define SPLITVK_FUZZ_CALL(name) SPLITVK_FUZZ_CONCAT(call_, name)

namespace {
[[maybe_unused]] void call_fuzz_agent_messages(const uint8_t *data, size_t size) {
    splitvk::fuzz::agent_messages(data, size);
}
[[maybe_unused]] void call_fuzz_tile_decoder(const uint8_t *data, size_t size) {
    splitvk::fuzz::tile_decoder(data, size);
}
[[maybe_unused]] void call_fuzz_tls_handshake(const uint8_t *data, size_t size) {
    splitvk::fuzz::tls_handshake(data, size);
}
[[maybe_unused]] void call_fuzz_known_agents(const uint8_t *data, size_t size) {
    splitvk::fuzz::known_agents(data, size);
}
} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    SPLITVK_FUZZ_CALL(SPLITVK_FUZZ_ENTRY)(data, size);
    return 0;
}
