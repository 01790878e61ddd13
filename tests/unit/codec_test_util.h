#pragma once

// Helpers for the codec tests (hand-written ones and the generated smoke test).

#include "codec.h"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <deque>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace splitvk::codec::test {

// Empty if equal, else where the two byte strings first differ.
inline std::string same_bytes(std::span<const uint8_t> a, std::span<const uint8_t> b) {
    const size_t n = std::min(a.size(), b.size());
    for (size_t i = 0; i < n; ++i) {
        if (a[i] != b[i]) {
            char text[96];
            std::snprintf(text, sizeof(text), "re-encoded bytes differ at offset %zu (0x%02x vs 0x%02x)", i,
                          a[i], b[i]);
            return text;
        }
    }
    if (a.size() != b.size())
        return "re-encoded size " + std::to_string(b.size()) + " differs from " + std::to_string(a.size());
    return {};
}

// A session in miniature: an encoder, a handle table in which every fake handle maps to itself
// (so decoded handles equal the encoded ones), an arena, and storage for test objects.
struct Smoke {
    Encoder enc;
    HandleTable table;
    Arena arena;
    uint64_t next_id = 0x1000;
    std::deque<std::unique_ptr<uint8_t[]>> storage;

    // A fake handle registered with its object type (id == agent handle).
    template <class H>
    H handle(VkObjectType type) {
        next_id += 0x10;
        table.insert(next_id, type, next_id);
        return to_handle<H>(next_id);
    }
    // A fake handle the "driver" created: not registered.
    template <class H>
    H output() {
        next_id += 0x10;
        return to_handle<H>(next_id);
    }
    // A zero-filled object that lives as long as the fixture.
    template <class T>
    T *make() {
        storage.push_back(std::make_unique<uint8_t[]>(sizeof(T)));
        std::memset(storage.back().get(), 0, sizeof(T));
        return reinterpret_cast<T *>(storage.back().get());
    }
};

// For the hand-written tests: client handles are registered twice, in `table` with an agent
// handle that differs from the id (so tests see the replacement), and in `identity` with the id
// itself (so decoded arguments re-encode to the same bytes).
struct Session {
    Encoder enc;
    HandleTable table;
    HandleTable identity;
    Arena arena;

    static constexpr uint64_t kServerOffset = 0x7000000000;
    static uint64_t server_of(uint64_t id) { return id + kServerOffset; }

    template <class H>
    H client(VkObjectType type, uint64_t id) {
        table.insert(id, type, server_of(id));
        identity.insert(id, type, id);
        return to_handle<H>(id);
    }
    // The agent handle a client handle decodes to.
    template <class H>
    static H server(H client_handle) {
        return client_handle == H{} ? H{} : to_handle<H>(server_of(handle_value(client_handle)));
    }
    std::span<const uint8_t> bytes() const { return enc.data(); }
};

// An address that faults when read: members the specification ignores point here, so a test
// fails (crashes, or ASan reports) if the encoder reads them.
template <class T>
const T *invalid_pointer() {
    return reinterpret_cast<const T *>(static_cast<uintptr_t>(0x10));
}
// A handle value no table knows: an ignored handle member holds it, so decoding fails with
// "unknown id" if the encoder sent it.
template <class H>
H garbage_handle() {
    return to_handle<H>(0xdeadbeefcafe0000ull);
}

} // namespace splitvk::codec::test
